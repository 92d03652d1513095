"""The order-phase verdict of a plan point (design.md §9; issue 21 item 4): the phase the model
predicts (``prediction.extras["order_phase_rad"]``, from eqs 19 / 25), moved by the bench's
stated transducer response and judged with the model's phase bounds (``hil.model.order_phase``)
and the measured phase's own U (``hil.analysis.decision.decide_phase``).

Tolerance zone: T = asin(rel_tol) + U_model. asin(rel_tol) is the closed form's own magnitude
tolerance read on the phasor (a phasor within rel_tol·|c| of the prediction lies within
asin(rel_tol) of its phase: 0.20 → 0.201 rad, 11.5°); U_model adds the chain's bounds.

A bench file without ``[torque] bandwidth_hz`` gets no phase verdict (the transducer's phase is
then unknown; the self-check's dynamics test says "not determinable here" for the same reason).

Angle reference (issue 30): the models' phases are on the electrical angle whose zero is phase
a's back-EMF rising zero crossing; the analysis' phases are on the DAQ's angle channel. The
prediction is moved by −k·θ₀, θ₀ the channel's angle at that crossing: measured by the
self-check's ``test_angle_reference`` in this run, else the bench file's ``[daq]
emf_a_rising_zero_elec_deg``; with neither there is no phase verdict. (Found on motulator's
drive, whose encoder zero is its d axis, θ₀ = 180°: a correct drive's order-1 phase was
rejected by π.)
"""

from __future__ import annotations

import math

from hil.analysis.decision import decide_phase
from hil.model.order_phase import chain_phase, wrap_rad

#: The angle channel's resolution: the drive's encoder, 7200 counts per mechanical revolution
#: (the simulated bench; a bench file states none yet).
ANGLE_COUNTS_PER_REV = 7200


def phase_judge(rel_tol: float):
    """A ``PointPlan.phase`` callable judging the order phase the prediction names."""
    def judge(result, prediction, plan, bench):
        predicted = prediction.extras.get("order_phase_rad")
        if (predicted is None or prediction.order is None
                or bench.config.torque.bandwidth_hz is None):
            return None
        reference = angle_reference_rad(bench)
        if reference is None:
            return None
        theta0_rad, theta0_u_rad = reference
        order = int(round(prediction.order))
        drive = bench.config.drive
        loop_hz = (drive.current_loop_equivalent_bandwidth_hz()
                   if drive.current_loop_bandwidth_hz is not None else None)
        tuned = bench.config.loop_tuning
        if loop_hz is not None and tuned is not None:    # gains Kp = ωc·L_tuned on the plant's L:
            loop_hz *= tuned.phase_inductance_h / bench.config.motor.phase_inductance_h  # crossover
        chain = chain_phase(order, plan.speed_rpm, bench.config.motor.pole_pairs,
                            transducer_bandwidth_hz=bench.config.torque.bandwidth_hz,
                            loop_bandwidth_hz=loop_hz, loop_delay_s=drive.current_loop_delay_s,
                            angle_counts_per_rev=ANGLE_COUNTS_PER_REV)
        tolerance = math.asin(rel_tol) + chain.model_u_rad + order * theta0_u_rad
        return decide_phase(result, order,
                            wrap_rad(predicted + chain.correction_rad - order * theta0_rad),
                            tolerance_rad=tolerance)
    return judge


def angle_reference_rad(bench) -> tuple[float, float] | None:
    """(θ₀, its U) in electrical rad: the angle channel's angle at phase a's back-EMF rising
    zero, as measured in this run (``bench.angle_reference_meta``) or stated by the bench file
    (U 0); None when neither knows it."""
    meta = getattr(bench, "angle_reference_meta", None) or {}
    if meta.get("emf_a_rising_zero_elec_deg") is not None:
        return (math.radians(meta["emf_a_rising_zero_elec_deg"]),
                math.radians(meta.get("emf_a_rising_zero_u_elec_deg", 0.0)))
    stated = bench.config.daq.emf_a_rising_zero_elec_deg
    return None if stated is None else (math.radians(stated), 0.0)
