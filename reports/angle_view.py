"""Torque against rotor angle and the order spectrum of one recorded test, for the plots.

The numbers come from the record, never from a different analysis: arrays the test stored in
its ``measured`` entry are used as they are; otherwise the raw capture is run through
``hil.analysis.run_analysis`` with the settings stored in ``measured`` (the same analysis the
test plan ran: torque against angle, or the PWM-switching envelope). If neither is possible the report says why instead of plotting something else.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hil.capture import Capture
from hil.errors import HilError
from hil.record import capture_path

ARRAY_NAMES = ("angle_grid_rad", "revolution_matrix_nm", "sync_average_nm", "orders",
               "amplitude_nm")


@dataclass
class AngleView:
    angle_grid_rad: np.ndarray | None = None
    revolution_matrix_nm: np.ndarray | None = None
    sync_average_nm: np.ndarray | None = None
    orders: np.ndarray | None = None
    amplitude_nm: np.ndarray | None = None
    how: str = ""             # where the arrays came from, printed under the plots
    analysis: str = "torque"  # which analysis the curves are from (hil.analysis.ANALYSES)
    problem: str | None = None
    mismatch: str | None = None  # the re-analysis disagrees with the recorded figures


def angle_view(entry: dict, record_dir: Path) -> AngleView:
    measured = entry.get("measured") or {}
    if measured.get("angle_grid_rad") is not None and measured.get("sync_average_nm") is not None:
        return AngleView(**{name: _array(measured.get(name)) for name in ARRAY_NAMES},
                         how="arrays stored by the test in the record")
    capture_info = entry.get("capture") or {}
    path = capture_path(record_dir, capture_info.get("file"))
    if path is None:
        return AngleView(problem="no raw capture inside the record for this test")
    from hil.analysis import run_analysis

    settings = _settings(measured)
    try:
        capture = Capture.load(path)
        result = run_analysis(capture, settings)
    except (HilError, ValueError) as exc:
        return AngleView(problem=f"the raw capture could not be analysed again: {exc}")
    shown = ", ".join(f"{k}={v}" for k, v in sorted(settings.items())) or "defaults"
    return AngleView(mismatch=_mismatch(measured.get("pk_pk_pu"), result), **_arrays(result),
                     analysis=settings.get("analysis", "torque"),
                     how=f"raw capture {capture_info['file']} through "
                         f"hil.analysis.run_analysis({shown}), the settings in the record")


def _arrays(result) -> dict:
    return {name: _array(getattr(result, name, None)) for name in ARRAY_NAMES}


def _mismatch(recorded, result) -> str | None:
    """Say so if analysing the raw capture again does not give the recorded pk-pk."""
    again = getattr(result, "pk_pk_pu", None)
    if not isinstance(recorded, (int, float)) or not isinstance(again, (int, float)):
        return None
    if np.isclose(again, recorded, rtol=1e-6, atol=1e-12):
        return None
    return (f"analysing the raw capture again gives pk-pk {again:.6g} pu, the record says "
            f"{recorded:.6g} pu; the curves may come from a different analysis version than "
            f"the recorded figures")


#: Settings a torque analysis also reports among its results (used where none were recorded).
RESULT_SETTING_KEYS = ("max_order", "named_order", "rated_torque_nm", "pk_pk_method", "pole_pairs")


def _settings(measured: dict) -> dict:
    """The recorded analysis settings (``analysis_settings``; older records: ``settings``),
    completed by the settings the result itself reports."""
    nested = next((measured[key] for key in ("analysis_settings", "settings")
                   if isinstance(measured.get(key), dict)), {})
    settings = {key: measured.get(key) for key in RESULT_SETTING_KEYS} | nested
    return {key: value for key, value in settings.items() if value is not None}


def _array(value) -> np.ndarray | None:
    if value is None:
        return None
    array = np.asarray(value, dtype=float)
    return array if array.size else None
