"""One entry point from recorded analysis settings to the analysis they name.

A test records its ``analysis_settings``; the test plan's measurement and the PDF report both call
:func:`run_analysis` with them, so the report can never analyse a capture differently from the
test that judged it.

Settings: ``analysis`` = ``"torque"`` (transducer torque against rotor angle,
:func:`analyze_capture`: ``max_order``, ``named_order``, ``pole_pairs``, ``pk_pk_method``,
``rated_torque_nm``, ``period_revolutions``: orders then per period of that many electrical
revolutions) or ``"switching"`` (within-PWM-period ripple from the phase currents,
:func:`hil.analysis.switching.analyze_switching`: ``pwm_frequency_hz``, ``max_order`` and the
motor nameplate ``motor`` as a dict of :class:`hil.motor.MotorParameters` fields).
"""

from __future__ import annotations

from hil.analysis.metrics import RippleResult, analyze_capture
from hil.capture import Capture
from hil.errors import InputError
from hil.motor import MotorParameters

ANALYSES = ("torque", "switching")
_TORQUE_KEYS = ("max_order", "named_order", "pole_pairs", "pk_pk_method", "rated_torque_nm",
                "period_revolutions")


def run_analysis(capture: Capture, settings: dict, *, instruments=None) -> RippleResult:
    """Analyse ``capture`` as ``settings`` say (see the module docstring)."""
    kind = settings.get("analysis", "torque")
    if kind == "torque":
        options = {key: settings[key] for key in _TORQUE_KEYS if settings.get(key) is not None}
        return analyze_capture(capture, instruments=instruments, **options)
    if kind == "switching":
        from hil.analysis.switching import analyze_switching

        try:
            motor = MotorParameters(**settings["motor"])
            return analyze_switching(capture, pwm_frequency_hz=settings["pwm_frequency_hz"],
                                     motor=motor, max_order=settings.get("max_order", 48),
                                     instruments=instruments)
        except (KeyError, TypeError) as exc:
            raise InputError(f"switching analysis settings incomplete or wrong: {exc}") from None
    raise InputError(f"analysis={kind!r}; allowed: {', '.join(ANALYSES)}")
