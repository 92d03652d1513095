"""The paper's closed-form torque-ripple predictions, one module per source, plus the budget.

Must not import ``hil.sim`` or ``hil.drivers`` (design.md, section 2). See README.md here for the
equations, the per-unit base of each source and the typos found in the paper.
"""

from hil.model.core import OperatingPoint, Prediction
from hil.model.sources import INJECTION_KNOBS, SOURCES, predict, source_parameters

__all__ = ["INJECTION_KNOBS", "OperatingPoint", "Prediction", "SOURCES", "predict",
           "source_parameters"]
