"""python-can without its MDF4 logger's import of asammdf.

``import can`` imports ``can.io.mf4``, which imports asammdf when it is installed, and asammdf
imports pandas and canmatrix: about 0.7 s of every process's start (``python -X importtime -c
"import can"``: 1.8 s of 2.3 s under load). ripple-hil never logs CAN traffic to MDF4 through
python-can (it writes its own MDF4 files with asammdf, ``hil.capture_mdf``), so while python-can
itself is being imported, asammdf is made to look absent; python-can then leaves its MF4 reader
and writer unset, as it does on a machine without asammdf. Importing asammdf afterwards works as
usual. :func:`install` (called by the ``hil`` and ``ripple_hil_drivers`` packages) puts the
import hook in place; it acts once, on the first ``import can``, and does nothing if python-can
or asammdf is already imported.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import sys


class _WithoutAsammdf(importlib.abc.Loader):
    def __init__(self, loader) -> None:
        self._loader = loader

    def create_module(self, spec):
        return self._loader.create_module(spec)

    def exec_module(self, module) -> None:
        sys.modules["asammdf"] = None          # `import asammdf` raises ImportError
        try:
            self._loader.exec_module(module)
        finally:
            if sys.modules.get("asammdf", 0) is None:
                del sys.modules["asammdf"]


class _CanFinder(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name != "can":
            return None
        uninstall()
        if "asammdf" in sys.modules:
            return None                          # already paid for: nothing to save
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is not None and spec.loader is not None:
            spec.loader = _WithoutAsammdf(spec.loader)
        return spec


_FINDER = _CanFinder()


def install() -> None:
    """Put the hook first on ``sys.meta_path`` unless python-can is already imported."""
    if "can" not in sys.modules and _FINDER not in sys.meta_path:
        sys.meta_path.insert(0, _FINDER)


def uninstall() -> None:
    if _FINDER in sys.meta_path:
        sys.meta_path.remove(_FINDER)
