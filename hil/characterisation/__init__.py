"""Characterisation: the bench is measured, not believed (design.md §11, issue 29).

``identify`` turns captures into parameters with their GUM uncertainty; ``result`` holds them
beside what the bench file states; ``stage`` runs the captures on a bench (the set-up stage of
``hil run`` and ``hil characterize``).
"""

from hil.characterisation.identify import Identified
from hil.characterisation.result import Characterisation

__all__ = ["Characterisation", "Identified"]
