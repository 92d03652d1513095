"""python-can, imported without its MF4 log format: ``from hil.python_can import can``.

``import can`` imports python-can's MF4 logger, which imports asammdf and, through it, pandas:
0.35 s of the ~0.5 s ``import can`` takes, paid at the start of every command that reads a bench
file (``python -X importtime``, issue 33). ripple-hil never logs CAN traffic to MF4 and imports
asammdf itself only where it reads or writes MDF captures (``hil/capture_mdf.py``,
``hil/record_export.py``). So python-can is imported here with asammdf hidden from it, and
asammdf is importable again right after; in this process python-can's own MF4 reader and writer
then say asammdf is missing. A process that imported can or asammdf before is left as it is.
The hiding holds for the whole process while ``import can`` runs: another thread importing
asammdf at that moment would be refused (ripple-hil reads its bench file before it starts
threads).
"""

from __future__ import annotations

import sys


def _import_can():
    if "can" in sys.modules or "asammdf" in sys.modules:
        import can
        return can
    sys.modules["asammdf"] = None           # "import asammdf" raises ImportError meanwhile
    try:
        import can
    finally:
        if "asammdf" in sys.modules and sys.modules["asammdf"] is None:
            del sys.modules["asammdf"]
    return can


can = _import_can()
