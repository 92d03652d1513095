"""One measurement point, the flow of design.md §1: inject → operate → acquire → persist →
analyse → predict → verdict.

The raw capture is written to the record *before* any analysis, and the bench is made safe (drive
disabled, injections restored and read back, DAQ disarmed) at the end of every point, on the normal
path as on any failure. Test plans describe points with :class:`PointPlan` and call
:func:`measure_point`; they hold no analysis or driver code.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, fields

from hil.analysis import ANALYSES, DecisionRule, RippleResult, Verdict, decide, run_analysis
from hil.analysis.decision import with_phase
from hil.bench import Bench
from hil.errors import InputError
from hil.model import OperatingPoint, Prediction, predict
from hil.model.core import MEAN_TORQUE_BASE
from hil.outcome_kinds import MEASURED
from hil.plants import capture_timeout_s
from hil.record import RunRecord, utc_now

#: The source name of a point with nothing injected (the bench's own ripple).
BASELINE = "baseline"
#: Electrical revolutions captured per point unless a plan says otherwise.
DEFAULT_REVOLUTIONS = 8
#: Angle-grid points per period of the highest analysed order (the analysis needs >= 8).
POINTS_PER_PERIOD = 10
#: What a recorded point is for (the record contract's ``kind``).
KINDS = ("measurement", "self_check", "ripple_map", "diagnosis", "other")


@dataclass(frozen=True)
class PointPlan:
    """What one test point injects, where it operates, how it captures and how it is judged.

    ``injection`` uses the drive's knob names (``ia_offset_a``, ``dead_time_s``, …) in SI units.
    ``prediction_params`` are extra inputs of the closed form that are not injections (e.g. the
    nominal current a dead-time figure is stated at). ``expectation`` states, in words, where the
    paper's assumptions do not hold at this point and what the plan judges against instead.
    """

    source: str
    injection: dict
    speed_rpm: float
    current_a: float
    current_angle_rad: float = 0.0
    revolutions: int = DEFAULT_REVOLUTIONS
    max_order: int = 48
    named_order: int | None = None
    pk_pk_method: str = "band-limited"
    analysis: str = "torque"
    settle_s: float = 0.05
    sample_rate_hz: float | None = None
    rule: DecisionRule | None = field(default_factory=DecisionRule)
    prediction_params: dict = field(default_factory=dict)
    expectation: str | None = None
    kind: str = "measurement"
    requirements: tuple = ()
    #: ``checks(capture, result, plan, bench) -> list[dict]``: bench self-checks on this point's
    #: capture (:mod:`hil.selfcheck`); recorded as the entry's ``checks``, any failure fails it.
    checks: Callable | None = field(default=None, compare=False)
    #: ``phase(result, prediction, plan, bench) -> PhaseVerdict | None``: the order phase judged
    #: against the model's (design.md §9, :func:`hil.analysis.decision.decide_phase`); recorded
    #: in the entry's ``verdict`` as ``phase``; the verdict's decision is the worse of magnitude
    #: and phase (:func:`hil.analysis.decision.with_phase`), so a wrong phase fails the point.
    phase: Callable | None = field(default=None, compare=False)
    #: False: the drive stays disabled (gates off, no current) while the dyno turns the motor —
    #: the self-check's back-EMF angle reference (hil.selfcheck.emf_angle_reference)
    drive_enabled: bool = True
    #: DAQ channels captured besides those the analysis reads (e.g. ``vab_v``)
    extra_channels: tuple[str, ...] = ()
    #: electrical revolutions of one analysed period (``hil.analysis.analyze_capture``): > 1 for
    #: a ripple that repeats only over several (an encoder count order that is not a whole
    #: number per electrical revolution); ``revolutions`` and ``max_order`` are then per period
    period_revolutions: int = 1

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise InputError(f"kind={self.kind!r}; allowed: {', '.join(KINDS)}")
        if self.revolutions < 2:
            raise InputError(f"revolutions={self.revolutions} must be >= 2 (type A needs scatter)")
        if self.analysis not in ANALYSES:
            raise InputError(f"analysis={self.analysis!r}; allowed: {', '.join(ANALYSES)}")
        if "current_angle_rad" in self.injection:
            raise InputError("injection current_angle_rad: give the current angle as "
                             "PointPlan.current_angle_rad, not in the injection")
        if isinstance(self.period_revolutions, bool) or not isinstance(
                self.period_revolutions, int) or self.period_revolutions < 1:
            raise InputError(f"period_revolutions={self.period_revolutions!r} must be an "
                             "integer >= 1")
        if self.speed_rpm == 0:
            raise InputError("speed_rpm=0: the angle never advances; use a slow speed (e.g. 3 rpm)"
                             " for the paper's near-standstill encoder measurement")

    def electrical_frequency_hz(self, pole_pairs: int) -> float:
        return abs(self.speed_rpm) / 60.0 * pole_pairs

    def period_frequency_hz(self, pole_pairs: int) -> float:
        """How often the analysed period (``period_revolutions`` electrical revolutions) passes."""
        return self.electrical_frequency_hz(pole_pairs) / self.period_revolutions

    def capture_duration_s(self, pole_pairs: int) -> float:
        """Whole analysed periods plus a quarter, so that jitter never loses the last one."""
        return (self.revolutions + 0.25) / self.period_frequency_hz(pole_pairs)

    def capture_rate_hz(self, pole_pairs: int) -> float:
        """Sample rate: the plan's, or enough points per period of ``max_order`` (≥ 1 kHz)."""
        if self.sample_rate_hz:
            return float(self.sample_rate_hz)
        needed = self.period_frequency_hz(pole_pairs) * self.max_order * POINTS_PER_PERIOD
        return float(min(20_000.0, max(1_000.0, math.ceil(needed / 500.0) * 500.0)))

    def capture_channels(self) -> tuple[str, ...]:
        """The DAQ channels this point captures: those its analysis reads (issue 17: the
        transfer is the cost), plus the phase currents ``Bench.check_capture`` checks against
        the current limit."""
        return ("ia_a", "ib_a", "rotor_angle_mech_rad") + (
            ("torque_nm",) if self.analysis == "torque" else ()) + tuple(self.extra_channels)


@dataclass
class PointOutcome:
    """Everything one point produced; ``entry`` is what went into the run record.

    ``verdict`` is the model-validation verdict (None for a point without one);
    ``requirements`` the requirement verdicts (dicts, :func:`hil.requirements.judge`).
    """

    test_id: str
    result: RippleResult
    prediction: Prediction | None
    verdict: Verdict | None
    predicted_pk_pk_pu_of_mean: float | None
    entry: dict
    requirements: list = field(default_factory=list)
    checks: list = field(default_factory=list)
    phase_verdict: object | None = None

    @property
    def failed_requirements(self) -> list[dict]:
        return [r for r in self.requirements if not r["accepted"]]

    @property
    def failed_checks(self) -> list[dict]:
        return [c for c in self.checks if not c["passed"]]

    @property
    def passed(self) -> bool:
        """The model verdict (if any) passes, every requirement is accepted, every self-check
        holds."""
        return ((self.verdict is None or self.verdict.guarded_pass)
                and (self.phase_verdict is None or self.phase_verdict.guarded_pass)
                and not self.failed_requirements and not self.failed_checks)

    def summary(self) -> str:
        text = (f"{self.test_id}: measured {self.result.pk_pk_pu:.4f} pu "
                f"(U={self.result.uncertainty.expanded_pu:.4f}, dominant order "
                f"{self.result.dominant_order})")
        if self.verdict is not None:
            text += (f" vs predicted {self.verdict.predicted_pk_pk_pu:.4f} pu of the nameplate "
                     f"torque (order {self.prediction.order}) -> {self.verdict.decision}: "
                     f"{self.verdict.reason}")
        for req in self.requirements:
            text += f"; {req['statement']}"
        for item in self.failed_checks:
            text += (f"; self-check {item['name']} FAILED: {item['measured']:.4g} vs "
                     f"{item['expected']:.4g} ± {item['tolerance']:.2g} {item['unit']}")
        return text


def measure_point(bench: Bench, record: RunRecord, test_id: str, plan: PointPlan, *,
                  nodeid: str | None = None, requirements=()) -> PointOutcome:
    """Run one point on ``bench`` and record it; raises after recording if anything fails.

    A point that nothing judges — no model rule (``plan.rule`` None), no requirement that
    applies, no self-check — is recorded "measured, no verdict" (``hil.outcome_kinds.MEASURED``,
    design.md §9), never "passed"; the plugin keeps that outcome when the test passes.

    The model verdict compares pk-pk per unit of the *nameplate* mean torque K_t·I·cos φ (the
    paper's base, :attr:`hil.model.OperatingPoint.mean_torque_nm`) on both sides, so that a weak
    drive or a transducer scale error cannot move the prediction; the variant per unit of the
    measured mean torque is recorded beside it. ``requirements`` (the run's) and
    ``plan.requirements`` are judged when they apply to this point.
    """
    from hil.requirements import applicable, check_unique, judge

    started = utc_now()
    entry = {"test_id": test_id, "nodeid": nodeid or test_id, "source": plan.source,
             "kind": plan.kind, "started_utc": started, "injection": dict(plan.injection),
             "operating_point": {"speed_rpm": plan.speed_rpm, "current_a": plan.current_a,
                                 "current_angle_rad": plan.current_angle_rad,
                                 "dc_bus_v": bench.config.motor.dc_bus_v},
             "notes": [plan.expectation] if plan.expectation else []}
    pole_pairs = bench.config.motor.pole_pairs
    chosen = applicable(tuple(requirements) + tuple(plan.requirements), source=plan.source,
                        speed_rpm=plan.speed_rpm, current_a=plan.current_a,
                        injection=plan.injection)
    prediction = verdict = predicted_pu = nameplate_nm = phase_verdict = None
    try:
        check_unique(chosen)
        entry["operating_point"].update(carrier_fields(plan, bench, pole_pairs))
        dyno_rpm = entry["operating_point"]["dyno_speed_setpoint_rpm"]
        bench.check_command(current_a=plan.current_a, speed_rpm=dyno_rpm)
        capture = _acquire(bench, record, test_id, plan, pole_pairs, dyno_rpm,
                           written_before_return=False)
        settings = analysis_settings(plan, bench)
        result = run_analysis(capture, settings, instruments=bench.config.instrument_uncertainty())
        if plan.rule is not None:
            op = bench.config.model_point(plan.speed_rpm, plan.current_a, plan.current_angle_rad)
            prediction = _predict(plan, op)
            nameplate_nm = op.mean_torque_nm
            predicted_pu = judged_prediction_pu(prediction, plan.rule) * (
                prediction.base_nm / nameplate_nm)
            order = analysed_order(prediction.order, plan, test_id)
            if order is not None and order > plan.max_order:
                raise InputError(f"{test_id}: predicted order {order} is above max_order "
                                 f"{plan.max_order}; raise the plan's max_order")
            expected_range = (None if prediction.expected_range_pu is None else
                              tuple(v * prediction.base_nm / nameplate_nm
                                    for v in prediction.expected_range_pu))
            verdict = decide(result, predicted_pu, order, plan.rule,
                             base_scale=abs(result.mean_torque_nm) / nameplate_nm,
                             expected_range_pu=expected_range)
            if plan.phase is not None:
                phase_verdict = plan.phase(result, prediction, plan, bench)
                verdict = with_phase(verdict, phase_verdict)
        judged = [judge(req, result, torque_accuracy_nm=_torque_accuracy_nm(bench))
                  for req in chosen]
        checks = plan.checks(capture, result, plan, bench) if plan.checks else None
        record.capture_written(test_id)     # its storage fault fails the point
    except BaseException as exc:
        # a storage fault of this point's raw data outranks whatever else failed meanwhile:
        # it is what stops the run (as when the capture was written before anything else)
        storage = record.capture_fault(test_id)
        failure = storage if storage is not None and storage is not exc else exc
        entry.update(outcome="error", error=f"{type(failure).__name__}: {failure}")
        _add_safely(record, entry)
        if failure is not exc:
            raise failure from exc
        raise
    accepted = ((verdict is None or verdict.guarded_pass)
                and (phase_verdict is None or phase_verdict.guarded_pass)
                and all(r["accepted"] for r in judged)
                and all(c["passed"] for c in checks or ()))
    if checks is not None:
        entry["checks"] = checks
    entry.update(
        outcome=(MEASURED if verdict is None and not judged and checks is None else
                 "passed" if accepted else "failed"),
        measured=result.to_dict() | {"analysis_settings": settings},
        uncertainty=result.uncertainty.to_dict(),
        requirements=judged,
        verdict=verdict.to_dict() if verdict is not None else None,
    )
    if phase_verdict is not None:
        entry["verdict"]["phase"] = phase_verdict.to_dict()
    if prediction is not None:
        entry["prediction"] = _thinned(prediction.to_dict()) | {
            "pk_pk_pu_of_nameplate_mean": predicted_pu,
            "nameplate_mean_torque_nm": nameplate_nm,
            "pk_pk_pu_of_measured_mean": prediction.pk_pk_nm / abs(result.mean_torque_nm),
            "motor_used": motor_used(bench.config)}
    record.add_test(entry)
    return PointOutcome(test_id, result, prediction, verdict, predicted_pu, entry, judged,
                        checks or [], phase_verdict)


def motor_used(config) -> dict:
    """The motor parameters a prediction read (the bench as characterised when the run measured
    it, ``hil.characterisation``; else the bench file's nameplate)."""
    from hil.characterisation.result import MOTOR_KEYS

    return {name: getattr(config.motor, name) for name in MOTOR_KEYS}


def _torque_accuracy_nm(bench: Bench) -> float | None:
    """The torque transducer's accuracy class in N·m (``% FS`` × full scale), if stated."""
    entry = bench.config.instrument("torque")
    pct = entry.accuracy_pct_fs() if entry is not None else None
    return None if pct is None else pct / 100.0 * bench.config.torque.full_scale_nm


def analysis_settings(plan: PointPlan, bench: Bench) -> dict:
    """The settings of ``hil.analysis.run_analysis`` for this point; recorded with the result."""
    settings = {"analysis": plan.analysis, "max_order": plan.max_order,
                "pole_pairs": bench.config.motor.pole_pairs}
    if plan.analysis == "switching":
        motor = bench.config.motor
        return settings | {"pwm_frequency_hz": plan.injection.get("pwm_frequency_hz",
                                                                  DEFAULT_PWM_FREQUENCY_HZ),
                           "motor": {f.name: getattr(motor, f.name) for f in fields(motor)}}
    named = plan.named_order
    if named is None and plan.rule is not None:
        named = _order_of(plan, bench)
    settings = settings | {"named_order": named, "pk_pk_method": plan.pk_pk_method}
    if plan.period_revolutions != 1:
        settings["period_revolutions"] = plan.period_revolutions
    return settings


#: The drive's PWM frequency when a plan does not inject one (the EDS default), Hz.
DEFAULT_PWM_FREQUENCY_HZ = 20_000.0


def dyno_speed_setpoint_rpm(plan: PointPlan, pole_pairs: int, pwm_frequency_hz: float) -> float:
    """The speed the dyno is given for ``plan``: its own, moved by at most 0.5 % where the drive's
    PWM carrier (``pwm_frequency_hz``) would be locked to the rotor (``hil.carrier_lock``); its
    own with the drive disabled (no carrier). Checks against the dyno's setpoint read this
    (capture meta and the entry's ``operating_point.dyno_speed_setpoint_rpm``)."""
    from hil.carrier_lock import unlocked_speed_rpm

    if not plan.drive_enabled:
        return plan.speed_rpm
    return unlocked_speed_rpm(plan.speed_rpm, pole_pairs, pwm_frequency_hz, plan.revolutions,
                              plan.period_revolutions)


def carrier_fields(plan: PointPlan, bench: Bench, pole_pairs: int) -> dict:
    """The entry's ``operating_point`` fields of the carrier lock: the dyno's setpoint and, where
    no move within 0.5 % unlocks the carrier, ``carrier_locked`` True."""
    from hil.carrier_lock import carrier_locked
    from hil.validity import injected_or_default

    pwm_hz = injected_or_default(plan, bench.config, "pwm_frequency_hz")
    setpoint = dyno_speed_setpoint_rpm(plan, pole_pairs, pwm_hz)
    fields = {"dyno_speed_setpoint_rpm": setpoint}
    if plan.drive_enabled and carrier_locked(setpoint, pole_pairs, pwm_hz, plan.revolutions,
                                             plan.period_revolutions):
        fields["carrier_locked"] = True
    return fields


def _acquire(bench: Bench, record: RunRecord, test_id: str, plan: PointPlan, pole_pairs: int,
             dyno_rpm: float | None = None, *, written_before_return: bool = True):
    """Inject, operate (the dyno at ``dyno_rpm``, default the plan's own speed: the
    characterisation's captures, whose fits read it), capture and persist the raw data, inside
    the safety guard. With ``written_before_return`` False the raw data is still being written
    when this returns: the caller waits with ``record.capture_written(test_id)``."""
    if record.write_error is not None:      # the record cannot keep raw data: drive nothing
        raise record.write_error
    dyno_rpm = plan.speed_rpm if dyno_rpm is None else dyno_rpm
    duration_s = plan.capture_duration_s(pole_pairs)
    rate_hz = plan.capture_rate_hz(pole_pairs)
    with bench.guard(f"{test_id}: acquire"):
        bench.drive.set_injection(**plan.injection, current_angle_rad=plan.current_angle_rad)
        bench.daq.set_dyno_speed_rpm(dyno_rpm)
        bench.drive.set_current_command_a(plan.current_a)
        if plan.drive_enabled:
            bench.drive.enable()
        bench.check_health()
        failure = None
        try:
            capture = bench.acquisition.capture(duration_s, rate_hz, settle_s=plan.settle_s,
                                                timeout_s=capture_timeout_s(
                                                    bench.config, duration_s, plan.settle_s),
                                                channels=plan.capture_channels())
        except Exception as exc:
            # a capture that failed its integrity check carries the data as received
            # (ripple_hil_drivers.modbus_daq.CaptureIntegrityError): record it, then fail the point
            if getattr(exc, "capture", None) is None:
                raise
            capture, failure = exc.capture, exc
        capture.meta.update(test_id=test_id, source=plan.source,
                            dyno_speed_setpoint_rpm=dyno_rpm,
                            injection=dict(plan.injection), captured_utc=utc_now(),
                            wall_time_unix_s=time.time(),
                            **getattr(bench, "angle_reference_meta", {}))
        # raw data first, before any check: written in the record's writer thread while the
        # point goes on (RunRecord.save_capture_later); its test entry waits for it
        saving = record.save_capture_later(test_id, capture)
        if written_before_return:
            saving.result()
        if failure is not None:
            raise failure
        bench.check_health(synchronise=True)    # a fault sent as the capture ended fails it
        bench.check_capture(capture)
        bench.make_safe(f"{test_id}: point finished")
    return capture


def _predict(plan: PointPlan, op: OperatingPoint) -> Prediction:
    """The closed form of ``plan.source``; for the baseline, the ideal drive's zero ripple."""
    if plan.source == BASELINE:
        if plan.injection:
            raise InputError(f"the baseline injects nothing, got {plan.injection}")
        return Prediction(source=BASELINE, pk_pk_pu=0.0, base=MEAN_TORQUE_BASE,
                          base_nm=op.mean_torque_nm, order=None, inputs={},
                          equations="eq 7 with γ = 0: T = (3/2)·E·I·cos φ/ω_m, constant",
                          assumptions=["ideal sinusoidal PMSM and ideal controller: no ripple; "
                                       "what is measured is the bench's own floor"])
    return predict(plan.source, op, **plan.injection, **plan.prediction_params)


def judged_prediction_pu(prediction: Prediction, rule: DecisionRule) -> float:
    """The predicted value ``rule`` judges, per unit of ``prediction.base_nm``: the pk-pk, or
    for a rule judging the named order's pk-pk (``hil.analysis.decision``) the prediction's
    ``extras["order_pk_pk_pu"]`` (2·A_N of its waveform)."""
    if rule.quantity == "named_order_pk_pk":
        if "order_pk_pk_pu" not in prediction.extras:
            raise InputError(f"the {prediction.source} prediction states no order_pk_pk_pu; its "
                             "rule cannot judge the named order's pk-pk")
        return float(prediction.extras["order_pk_pk_pu"])
    return prediction.pk_pk_pu


#: How far from a whole number an order over the analysed period may be (float rounding only).
ORDER_INTEGER_TOLERANCE = 1e-6


def analysed_order(order: float | None, plan: PointPlan, what: str = "point") -> int | None:
    """The predicted order (per electrical revolution) as the analysis numbers it: × the plan's
    ``period_revolutions``. It must then be a whole number: an order of 57.6 judged at 58 is a
    smeared line (its power split over 57 and 58 and scattered between revolutions), never the
    predicted one — InputError names the period it needs (``hil.validity`` refuses such a point
    before the bench is touched)."""
    if order is None:
        return None
    over_period = order * plan.period_revolutions
    whole = round(over_period)
    if abs(over_period - whole) > ORDER_INTEGER_TOLERANCE * max(1.0, abs(over_period)):
        raise InputError(f"{what}: predicted order {order:.6g} per electrical revolution is not "
                         f"a whole order over the analysed period of {plan.period_revolutions} "
                         f"electrical revolution(s) ({over_period:.6g}); analyse over a common "
                         "period (PointPlan.period_revolutions)")
    return int(whole)


def predicted_order(plan: PointPlan, config) -> int | None:
    """The order the plan's closed form predicts on the bench ``config`` (a
    ``hil.config.BenchConfig``), numbered over the analysed period (None: no single order);
    InputError where it is not whole (:func:`analysed_order`)."""
    op = config.model_point(plan.speed_rpm, plan.current_a, plan.current_angle_rad)
    return analysed_order(_predict(plan, op).order, plan)


def _order_of(plan: PointPlan, bench: Bench) -> int | None:
    order = predicted_order(plan, bench.config)
    return None if order is None or order > plan.max_order else order


#: Most points of a predicted waveform kept in the record (0.5° electrical over a revolution).
RECORDED_WAVEFORM_POINTS = 720


def _thinned(prediction: dict) -> dict:
    """The prediction with its waveform thinned for the record (plots only; pk-pk is kept)."""
    angle, wave = prediction.get("angle_rad"), prediction.get("waveform_pu")
    if angle is None or wave is None or len(angle) <= RECORDED_WAVEFORM_POINTS:
        return prediction
    step = -(-len(angle) // RECORDED_WAVEFORM_POINTS)
    return prediction | {"angle_rad": list(angle[::step]), "waveform_pu": list(wave[::step])}


def _add_safely(record: RunRecord, entry: dict) -> None:
    """Record a failed point without masking the original error."""
    try:
        record.add_test(entry)
    except Exception:  # noqa: BLE001 - the original exception is what the user must see
        pass
