"""``diagnose``: from measured order spectra back to the controller faults that cause the ripple.

Steps (design.md §8; issue 15): (1) find the encoder's count line (discrete, :mod:`.encoder`) and
drop its orders; (2) fit the sensor offsets, k_a − k_b and the effective dead time together with
motor-side terms at the same orders (cogging, EMF-harmonic torque) by weighted least squares on
the complex coefficients at mechanical orders p·{1, 2, 6, 12} (:mod:`.fit`); (3) state what the
captures cannot separate (weak directions of the Jacobian) and which extra operating point would
separate it; (4) flag orders whose residual contradicts the signatures ("not explained by the
controller models"), and describe the remaining motor-side ripple per mechanical order.
Assumptions stated in the output: no motor-side torque at electrical orders 1 and 2 other than
cogging at mechanical order 2p (even EMF harmonics do not exist in a half-wave-symmetric machine);
the order-1 torque is attributed to the sensor offsets (a term fixed in the rotor angle gives the
same torque at every current, speed and direction — the torque alone cannot tell them apart).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Iterable

import numpy as np

from hil.capture import Capture
from hil.diagnosis.quantiles import chi2_ppf
from hil.diagnosis import dwell
from hil.diagnosis import encoder as enc
from hil.diagnosis import parameters as P
from hil.diagnosis import signatures as sig
from hil.diagnosis.fit import LinearProblem, SystematicTerm, fit, identifiability
from hil.diagnosis.orders import OrderSpectrum, spectrum_from_capture
from hil.diagnosis.result import Diagnosis, ParameterEstimate
from hil.errors import InputError
from hil.model.encoder import DRIVE_COUNTS_PER_REV

#: Electrical orders of the controller signatures fitted (offset 1, gain 2, dead time 6 and 12).
CONTROLLER_ELEC_ORDERS = (1, 2, 6, 12)
#: Electrical orders where motor-side terms are fitted beside the controller's.
COGGING_ELEC_ORDERS = (2, 6, 12)
EMF_ELEC_ORDERS = (6, 12)
#: A fitted order whose residual χ² exceeds this quantile is "not explained".
UNEXPLAINED_QUANTILE = 0.999
#: A free order is listed as motor-side residual when its amplitude exceeds this many σ.
RESIDUAL_Z = 5.0
EXPANSION_K = 2.0
#: Standard deviation of a dwell's leg-voltage error per unit of its bound ε: the dwell current
#: (−T·offset) has a sign, and the leg's dead-time error is set by it (eqs 32-37): ±ε, two-point.
DWELL_SD_PER_BOUND = 1.0
ENCODER_HIDES_DEAD_TIME = (
    "dead time not stated: with a count line in band the current reference is a staircase "
    "that dwells at zero for a whole count at each zero crossing, and the average-voltage model "
    "(continuous reference, sign(i) everywhere defined) no longer describes the order-6/12 torque "
    "(on the twin it reads 25 % low at 10° and 65 % low at 20° electrical per count); it is "
    "fitted as a nuisance term (model uncertainty 100 %) so that the order-6/12 torque does not "
    "bias the other estimates. The dwell also breaks the dead-time distortion's half-wave "
    "symmetry: an order-1 torque that the offsets absorb; it is bounded, not modelled (see the "
    "dwell note)")


def diagnose(inputs: Iterable, *, setup: sig.DriveSetup | None = None,
             transducer_class_pct: float = 0.0, encoder_counts_per_rev: int | None = None,
             dead_time: bool = True, max_mech_order: int = 128) -> Diagnosis:
    """Diagnose the drive from order spectra, or from (capture, operating point) pairs (turned
    into spectra up to ``max_mech_order`` by :func:`spectra_from_captures`).

    ``setup``: the drive's current loop, PWM frequency and the transducer's bandwidth (module
    :mod:`.signatures`); ``transducer_class_pct``: accuracy class in % of reading used as a model
    uncertainty; ``encoder_counts_per_rev``: the drive's encoder (default: the captures' meta,
    else the drive contract's 7200).
    """
    spectra = _as_spectra(list(inputs), max_mech_order)
    if not spectra:
        raise InputError("diagnose needs at least one capture or spectrum")
    setup = setup or sig.DriveSetup()
    pole_pairs = {s.pole_pairs for s in spectra}
    if len(pole_pairs) != 1:
        raise InputError(f"captures disagree on pole pairs: {sorted(pole_pairs)}")
    p = pole_pairs.pop()
    max_mech = min(s.max_mech_order for s in spectra)
    if max_mech < 12 * p:
        raise InputError(f"spectra must reach mechanical order {12 * p} (electrical 12); "
                         f"they reach {max_mech}")
    cpr = encoder_counts_per_rev or spectra[0].meta.get("encoder_counts_per_rev")
    if not cpr:
        cpr = DRIVE_COUNTS_PER_REV
        notes_cpr = [f"encoder counts per revolution not in the captures: the drive contract's "
                     f"{DRIVE_COUNTS_PER_REV} assumed"]
    else:
        notes_cpr = []
    encoder = enc.detect(spectra, setup, int(cpr) if cpr else None)
    excluded = set(encoder.get("excluded_mech_orders", []))
    notes = list(notes_cpr)
    model_spectra = spectra
    if encoder.get("detected"):
        # θ_d = θ − γ with γ uniform over a count: the currents lag by half a count on average
        shift = math.radians(encoder["resolution_elec_deg"]) / 2.0
        model_spectra = [dataclasses.replace(s, current_angle_rad=s.current_angle_rad + shift)
                         for s in spectra]
        notes.append(f"signatures evaluated at φ + {math.degrees(shift):.3g}° electrical: the "
                     "truncated firmware angle lags the rotor by half a count on average (eq 7)")

    nuisance = set()
    if dead_time and encoder.get("detected"):
        nuisance.add("dead_time_us")
        notes.append(ENCODER_HIDES_DEAD_TIME)
    params = P.controller_parameters(transducer_class_pct, dead_time=dead_time,
                                     dead_time_nuisance="dead_time_us" in nuisance)
    use_currents = (setup.current_channel_u_a is not None
                    and all(s.current_dc_a is not None for s in spectra))
    if use_currents:
        notes.append("phase-current dc fitted with the torque (DAQ channel dc uncertainty "
                     f"{setup.current_channel_u_a:g} A): a torque fixed in the rotor angle at "
                     "electrical order 1 is fitted as cogging, separated from the offsets")
    elif all(s.current_dc_a is not None for s in spectra):
        notes.append("the captures hold phase currents, unused: state the DAQ current channels' "
                     "dc uncertainty (current_channel_u_a) to separate offsets from a "
                     "rotor-fixed order-1 torque")
    for k in ((1,) if use_currents else ()) + COGGING_ELEC_ORDERS:
        params += P.cogging_parameters(p * k, transducer_class_pct)
    for k in EMF_ELEC_ORDERS:
        params += P.emf_parameters(p * k, transducer_class_pct)
    fit_orders = [p * k for k in CONTROLLER_ELEC_ORDERS if p * k not in excluded]
    signatures = [[param.signature(s, setup, max_mech) for param in params]
                  for s in model_spectra]
    if encoder.get("detected"):
        signatures = _encoder_angle_uncertainty(signatures, params, encoder, notes)
    currents = _current_signatures(model_spectra, params, setup) if use_currents else None
    problem = _problem(model_spectra, params, signatures, fit_orders, currents, setup)
    problem.alternatives = _loop_alternatives(model_spectra, params, setup, max_mech,
                                              fit_orders, use_currents, problem, notes)
    result = fit(problem)
    if dead_time and encoder.get("detected"):
        problem.systematic = _dwell_terms(model_spectra, params, problem, result, encoder,
                                          setup, max_mech, notes)
        result = fit(problem)

    estimates = _estimates(params, result, nuisance)
    aliases = [] if use_currents else _alias_probe(model_spectra, params, signatures, fit_orders,
                                                   setup, transducer_class_pct, p, max_mech)
    weak = [_explain(w, params) for w in result.weak_directions]
    unexplained = _unexplained(problem, result, spectra, fit_orders, p)
    contributions = _contributions(spectra, params, signatures, result, encoder, excluded)
    motor_residual = _motor_residual(spectra, contributions, set(fit_orders) | excluded, p,
                                     setup)
    for index, parts in enumerate(contributions):
        _add_motor_other(parts, motor_residual, index, spectra[index].coefficients_nm.size)
    return Diagnosis(
        spectra=spectra, setup=setup, parameters=estimates, params=params, fit=result,
        encoder=encoder, fit_orders=fit_orders, weak=weak, aliases=aliases,
        unexplained=unexplained, motor_residual=motor_residual, contributions=contributions,
        expansion_k=EXPANSION_K, notes=notes)


def spectra_from_captures(captures: Iterable[tuple[Capture, dict]], *,
                          max_mech_order: int = 128) -> list[OrderSpectrum]:
    """Order spectra of (capture, operating point) pairs; the operating point gives
    ``current_a`` (peak phase current commanded) and optionally ``current_angle_rad``,
    ``speed_rpm`` (default: measured from the capture) and ``label``."""
    out = []
    for capture, op in captures:
        if "current_a" not in op:
            raise InputError(f"operating point of capture {op.get('label', '?')!r} lacks "
                             "current_a (peak phase current, A)")
        out.append(spectrum_from_capture(
            capture, current_a=op["current_a"], current_angle_rad=op.get("current_angle_rad", 0.0),
            speed_rpm=op.get("speed_rpm"), max_mech_order=max_mech_order,
            label=str(op.get("label", f"point {len(out) + 1}"))))
    return out


# ------------------------------------------------------------------------------ building blocks
def _as_spectra(items: list, max_mech_order: int) -> list[OrderSpectrum]:
    out = []
    for item in items:
        if isinstance(item, OrderSpectrum):
            out.append(item)
        elif (isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], Capture)
              and isinstance(item[1], dict)):
            out += spectra_from_captures([item], max_mech_order=max_mech_order)
        else:
            raise InputError(f"diagnose takes OrderSpectrum objects or (Capture, operating point "
                             f"dict) pairs, got {type(item).__name__}")
    return out


def _current_signatures(spectra, params, setup) -> list[list[tuple[complex, float]]]:
    """Per point and parameter: (dc_a + j·dc_b of the actual currents per unit, relative model
    uncertainty); only the offsets move the dc (eqs 15-17 through the loop)."""
    out = []
    for spectrum in spectra:
        op = sig.operating_point(spectrum.speed_rpm, spectrum.current_a,
                                 spectrum.current_angle_rad, setup)
        row = []
        for param in params:
            if param.name in ("ia_offset_a", "ib_offset_a"):
                phase = param.name[1]
                value = sig.offset_current_dc(op, setup, phase)
                ideal = -1.0 if phase == "a" else -1j
                row.append((value, P.LOOP_CORRECTION_REL_UNCERTAINTY * abs(value - ideal)))
            else:
                row.append((0j, 0.0))
        out.append(row)
    return out


def _problem(spectra, params, signatures, fit_orders, currents=None,
             setup=None) -> LinearProblem:
    """Rows (point, mechanical order) of torque coefficients; with ``currents``, one more row per
    point (order 0) holding the phase currents' dc as dc_a + j·dc_b."""
    y, sigma, jac, rel, rows = [], [], [], [], []
    for s_index, spectrum in enumerate(spectra):
        for m in fit_orders:
            rows.append((s_index, m))
            y.append(spectrum.coefficients_nm[m])
            sigma.append(spectrum.sigma_nm[m])
            jac.append([signatures[s_index][j][0].get(m, 0j) for j in range(len(params))])
            rel.append([_rel_at(signatures[s_index][j][1], m) for j in range(len(params))])
        if currents is not None:
            rows.append((s_index, 0))
            y.append(complex(*spectrum.current_dc_a))
            sigma.append(math.hypot(spectrum.current_dc_sigma_a, setup.current_channel_u_a))
            jac.append([currents[s_index][j][0] for j in range(len(params))])
            rel.append([currents[s_index][j][1] for j in range(len(params))])
    return LinearProblem(names=[param.name for param in params], y=np.array(y),
                         sigma=np.array(sigma), jacobian=np.array(jac, dtype=complex),
                         model_rel=np.array(rel), rows=rows)


def _loop_alternatives(spectra, params, setup, max_mech, fit_orders, use_currents, problem,
                       notes) -> list[np.ndarray]:
    """The current loop's model uncertainty, propagated by evaluating the forward model over the
    loops the bench's statement allows (``DriveSetup.loop_variants``): the fit is re-solved
    with each variant's Jacobian (fit.LinearProblem.alternatives; not linearised, so a loop
    that rejects the dead-time voltage five times better moves T_d five times) and
    Σ_v δ_v·δ_vᵀ/k² of the shifts is added to the covariance: the drive has one of these loops,
    not known which, so each variant's shift is kept within U (k = 2). The spread of each
    signature's complex transfer over the variants (magnitude in %, phase in degrees) is
    stated in the notes."""
    variants = setup.loop_variants()
    if not variants:
        return []
    out, spread = [], {}
    for variant in variants:
        signatures = [[param.signature(s, variant, max_mech) for param in params]
                      for s in spectra]
        currents = _current_signatures(spectra, params, variant) if use_currents else None
        jacobian = _problem(spectra, params, signatures, fit_orders, currents, setup).jacobian
        out.append(jacobian)
        for j, param in enumerate(params):
            if not param.controller:
                continue
            nominal = problem.jacobian[:, j]
            big = np.abs(nominal) > 1e-3 * np.max(np.abs(nominal), initial=0.0)
            if not big.any():
                continue
            ratio = jacobian[big, j] / nominal[big]
            mag, phase = spread.get(param.name, (0.0, 0.0))
            spread[param.name] = (max(mag, float(np.max(np.abs(np.abs(ratio) - 1.0)))),
                                  max(phase, float(np.max(np.abs(np.degrees(np.angle(ratio)))))))
    text = "; ".join(f"{name} ±{100 * mag:.2g} % / ±{phase:.2g}°"
                     for name, (mag, phase) in spread.items())
    notes.append(f"current loop: {setup.loop_text()}; its model uncertainty is the spread of "
                 f"the signatures over {len(variants)} loops the statement allows (largest "
                 f"deviation from the nominal, magnitude / phase, over the points and orders: "
                 f"{text}), propagated into every parameter's U by re-solving the fit through "
                 "each (hil.diagnosis.core._loop_alternatives)")
    return out


def _encoder_angle_uncertainty(signatures, params, encoder, notes):
    """The firmware angle's error within a count is uniform over θ_res (standard deviation
    θ_res/√12 about the half-count mean already applied); it moves the reference current that a
    gain error scales, and is added to the gain signature's relative model uncertainty (an
    offset's torque does not depend on the reference, eq 19)."""
    u = math.radians(encoder["resolution_elec_deg"]) / math.sqrt(12.0)
    sensors = [j for j, param in enumerate(params) if param.source == "gain_mismatch"]
    notes.append(f"gain-mismatch signature given a further {100 * u:.3g} % relative model "
                 "uncertainty: the firmware angle's error within a count (θ_res/√12) moves the "
                 "reference current it scales")
    out = []
    for row in signatures:
        row = list(row)
        for j in sensors:
            orders, rel = row[j]
            row[j] = (orders, {m: math.hypot(_rel_at(rel, m), u) for m in orders})
        out.append(row)
    return out


def _dwell_terms(spectra, params, problem, result, encoder, setup, max_mech,
                 notes) -> list[SystematicTerm]:
    """The six dwells of a coarse encoder's command at zero, each an unknown leg-voltage error
    within ±ε (rectangular), as bounded terms of the fit (module :mod:`.dwell`); the bound's
    inputs are written into ``encoder['offset_dwell_bound']`` and the notes."""
    if setup.dead_time_bound_s is not None:
        bound_s, origin = setup.dead_time_bound_s, "the drive's stated dead-time bound"
    else:
        j = [param.name for param in params].index("dead_time_us")
        estimate = float(result.estimate[j])
        u = float(np.sqrt(result.covariance[j, j]))
        if not (math.isfinite(estimate) and math.isfinite(u)):
            notes.append("dwell term: the nuisance dead time is not determined and no "
                         "dead_time_bound_s is stated: the offsets' uncertainty lacks the "
                         "dwell term (state the drive's dead-time bound)")
            encoder["offset_dwell_bound"] = {"applied": False}
            return []
        factor = 1.0 + EXPANSION_K * P.NUISANCE_REL_UNCERTAINTY
        # the larger of the model-uncertainty expansion and the fit's own k = 2 interval
        bound_us = max(max(estimate, 0.0) * factor, estimate + EXPANSION_K * u)
        if not bound_us > 0.0:
            notes.append(f"dwell term: the nuisance dead time {estimate:.3g} ± "
                         f"{EXPANSION_K * u:.2g} µs bounds nothing above zero and no "
                         "dead_time_bound_s is stated: the offsets' uncertainty lacks the dwell "
                         "term (state the drive's dead-time bound)")
            encoder["offset_dwell_bound"] = {"applied": False}
            return []
        bound_s = bound_us * 1e-6
        origin = (f"the larger of the nuisance dead time {estimate:.3g} µs × {factor:g} (its "
                  "100 % model uncertainty at k = 2) and its fit interval "
                  f"{estimate:.3g} + {EXPANSION_K * u:.2g} µs (k = 2); the average model reads "
                  "low with a coarse encoder: state the drive's dead-time bound, "
                  "DriveSetup.dead_time_bound_s)")
    width = math.radians(encoder["resolution_elec_deg"])
    eps = dwell.leg_loss_v(bound_s, setup.pwm_frequency_hz, setup.motor.dc_bus_v)
    terms = []
    for leg in "abc":
        for dwell_index in (0, 1):
            for direction in (1.0, -1.0):
                per_point = []
                for spectrum in spectra:
                    if math.copysign(1.0, spectrum.speed_rpm) != direction:
                        per_point.append(({}, 0j))
                        continue
                    op = sig.operating_point(spectrum.speed_rpm, spectrum.current_a,
                                             spectrum.current_angle_rad, setup)
                    start = dwell.dwell_starts_rad(op, leg, width)[dwell_index]
                    torque, current_dc = dwell.dwell_pulse_orders(op, setup, leg, start, width)
                    orders = sig.to_mech(torque, spectrum.pole_pairs, max_mech)
                    per_point.append(({m: c * sig.transducer_response(m, spectrum.speed_rpm,
                                                                      setup)
                                       for m, c in orders.items()}, current_dc))
                rows = [per_point[s][1] if m == 0 else per_point[s][0].get(m, 0j)
                        for s, m in problem.rows]
                if not np.any(rows):
                    continue
                terms.append(SystematicTerm(
                    name=f"dwell_{leg}{dwell_index}_{'fwd' if direction > 0 else 'rev'}",
                    rows=np.array(rows), standard_uncertainty=eps * DWELL_SD_PER_BOUND,
                    common=True))
    encoder["offset_dwell_bound"] = {
        "applied": True, "dead_time_bound_us": bound_s * 1e6, "dead_time_bound_from": origin,
        "leg_error_bound_v": eps,
        "dwell_width_elec_deg": encoder["resolution_elec_deg"],
        "kind": "stated bound (not a model): each leg's dwell voltage error ±ε, standard "
                "uncertainty ε, common to all points"}
    notes.append(
        "offsets (and k_a − k_b) given a further uncertainty — a stated bound, not a model: for "
        f"the count ({encoder['resolution_elec_deg']:.3g}° electrical) after each zero crossing "
        "the current command is zero and the dead-time voltage of that leg lies anywhere in "
        f"±ε = ±T_d·f_pwm·V_dc (T_d ≤ {bound_s * 1e6:.3g} µs from {origin}); per leg ±ε "
        "(standard uncertainty ε, the same at every point) propagated through the loop and the "
        "fit (hil.diagnosis.dwell)")
    return terms


def _rel_at(rel, mech_order: int) -> float:
    return float(rel.get(mech_order, 0.0)) if isinstance(rel, dict) else float(rel)


def _estimates(params, result, nuisance: set[str]) -> list[ParameterEstimate]:
    """Estimates; a ``nuisance`` parameter is fitted (its torque is accounted for) but its value
    is not stated, because its model does not hold for these captures."""
    u = result.standard_uncertainty()
    return [ParameterEstimate(name=param.name, unit=param.unit, source=param.source,
                              description=param.description + (" — fitted as a nuisance term, "
                                                               "value not stated (see notes)"
                                                               if param.name in nuisance else ""),
                              estimate=float(result.estimate[j]),
                              standard_uncertainty=float(u[j]),
                              identifiable=bool(result.identifiable[j])
                              and param.name not in nuisance)
            for j, param in enumerate(params)]


def _separate_by(names: list[str], params) -> str:
    """Which extra operating point would separate the parameters of a weak combination."""
    by_name = {param.name: param for param in params}
    sources = {by_name[n].source for n in names if n in by_name}
    if "dc_offset" in sources and "motor_cogging" in sources:
        return ("the torque cannot separate them at any operating point (both are fixed in the "
                "rotor angle and independent of current): capture the phase currents with the "
                "gates off (the sensor reading is the offset) or trust the motor's cogging data")
    if sources == {"dc_offset"}:
        return "add a second current angle φ or a phase-current capture"
    if "gain_mismatch" in sources and "motor_cogging" in sources:
        return "add a second current (gain ripple scales with current, cogging does not)"
    if "dead_time" in sources and sources & {"dc_offset", "gain_mismatch"}:
        return ("add a second speed and the reverse direction, or a standard addition (a known "
                "dead-time step, or a known offset/gain step on one sensor: hil run --source "
                "diagnosis with additions)")
    if "gain_mismatch" in sources and "motor_emf" in sources:
        return ("a standard addition (a known gain step on one sensor): gain and EMF torque "
                "both scale with current")
    if "dead_time" in sources and ("motor_cogging" in sources or "motor_emf" in sources):
        return ("add a second speed and the reverse direction (the loop rejects the dead-time "
                "harmonics differently at each speed; a motor term keeps its angle)")
    if "motor_cogging" in sources and "motor_emf" in sources:
        return "add a second current (cogging is independent of current, EMF torque is not)"
    return "add operating points that differ in current, speed and direction"


def _explain(weak: dict, params) -> dict:
    names = list(weak["combination"])
    return weak | {"parameters": names, "separate_by": _separate_by(names, params)}


def _alias_probe(spectra, params, signatures, fit_orders, setup, class_pct, p, max_mech) -> list:
    """Terms the fit assumes absent, and whether these captures could tell them from the
    controller's: a motor-side term fixed in the rotor angle at electrical order 1."""
    probe = P.cogging_parameters(p, class_pct)
    extra = [[param.signature(s, setup, max_mech) for param in probe] for s in spectra]
    all_params = params + probe
    all_sigs = [row + extra[i] for i, row in enumerate(signatures)]
    problem = _problem(spectra, all_params, all_sigs, fit_orders)
    a = np.concatenate([problem.jacobian.real, problem.jacobian.imag]) / \
        np.concatenate([problem.sigma, problem.sigma])[:, None]
    _, weak, _, _, _ = identifiability(a, problem.names)
    names = sorted({n for w in weak for n in w["combination"]
                    if any(m.startswith(f"cogging_m{p}_") for m in w["combination"])},
                   key=problem.names.index)
    if not names:
        return []
    return [{"assumed_absent": f"motor-side torque fixed in the rotor angle at mechanical order "
                               f"{p} (electrical 1), e.g. cogging",
             "parameters": names,
             "consequence": "the order-1 torque is attributed to the sensor offsets",
             "separate_by": _separate_by(names, all_params)}]


def _unexplained(problem, result, spectra, fit_orders, p) -> list[dict]:
    """Fitted orders whose residual is beyond the stated uncertainties (χ² test per order)."""
    out = []
    rows = np.array(problem.rows)
    for m in fit_orders:
        mask = rows[:, 1] == m
        r = result.residual[mask]
        s = result.sigma_total[mask]
        chi2 = float(np.sum((r.real / s) ** 2 + (r.imag / s) ** 2))
        dof = 2 * int(mask.sum())
        limit = float(chi2_ppf(UNEXPLAINED_QUANTILE, dof))
        if chi2 > limit:
            worst = int(np.argmax(np.abs(r)))
            at = spectra[int(rows[mask][worst, 0])]
            out.append({"mech_order": m, "elec_order": m / p, "chi2": chi2, "dof": dof,
                        "limit_chi2": limit, "largest_residual_nm": float(np.abs(r[worst])),
                        "largest_residual_pct_of_mean":
                            100.0 * float(np.abs(r[worst])) / abs(at.mean_torque_nm),
                        "at": at.label,
                        "note": "not explained by the controller models: the amplitude, phase or "
                                "scaling across the points contradicts the sources' signatures"})
    return out


def _motor_residual(spectra, contributions, skip: set[int], p: int, setup) -> list[dict]:
    """Free orders that stand out once the fitted sources' torque is removed (e.g. dead time at
    orders 18, 24, …): split into a constant (cogging-like) and a current-proportional (EMF-like)
    part by least squares across the points, at the shaft (the transducer's response removed)."""
    max_mech = min(s.max_mech_order for s in spectra)
    currents = np.array([s.current_a for s in spectra])
    two_terms = np.ptp(currents) > 0.1 * currents.max()
    out = []
    for m in range(1, max_mech + 1):
        if m in skip:
            continue
        c = np.array([s.coefficients_nm[m] - sum(part[m] for part in parts.values())
                      for s, parts in zip(spectra, contributions)])
        sigma = np.array([s.sigma_nm[m] for s in spectra])
        if not np.any(np.abs(c) > RESIDUAL_Z * sigma):
            continue
        response = np.array([sig.transducer_response(m, s.speed_rpm, setup) for s in spectra])
        basis = np.column_stack([np.ones_like(currents), currents]) if two_terms \
            else np.ones((len(spectra), 1))
        basis = basis.astype(complex) * response[:, None]
        coef, *_ = np.linalg.lstsq(basis, c, rcond=None)
        entry = {"mech_order": m, "elec_order": m / p,
                 "fitted_nm": [complex(v) for v in basis @ coef],
                 "amplitude_nm_max": float(np.max(np.abs(c))),
                 "constant_nm": float(abs(coef[0])),
                 "constant_phase_rad": float(np.angle(coef[0]))}
        if two_terms:
            entry.update(per_ampere_nm=float(abs(coef[1])),
                         per_ampere_phase_rad=float(np.angle(coef[1])))
        out.append(entry)
    out.sort(key=lambda e: -e["amplitude_nm_max"])
    return out


def _add_motor_other(parts: dict, motor_residual: list[dict], index: int, size: int) -> None:
    """The motor-side residual at free orders (constant + current-proportional fit) of point
    ``index`` as the source 'motor_other'."""
    other = np.zeros(size, dtype=complex)
    for entry in motor_residual:
        if entry["mech_order"] < size:
            other[entry["mech_order"]] = entry["fitted_nm"][index]
    if np.any(other):
        parts["motor_other"] = other


def _contributions(spectra, params, signatures, result, encoder, excluded) -> list[dict]:
    """Per point: the complex coefficients each source group adds (all its orders in band)."""
    groups = {}
    for j, param in enumerate(params):
        groups.setdefault(param.source, []).append(j)
    out = []
    for s_index, spectrum in enumerate(spectra):
        size = spectrum.coefficients_nm.size
        per_source = {}
        for source, indices in groups.items():
            total = np.zeros(size, dtype=complex)
            for j in indices:
                if not result.identifiable[j]:
                    continue
                for m, value in signatures[s_index][j][0].items():
                    if m < size:
                        total[m] += value * result.estimate[j]
            if np.any(total):
                per_source[source] = total
        if encoder.get("detected"):
            line = np.zeros(size, dtype=complex)
            for m in excluded:
                if m < size:
                    line[m] = spectrum.coefficients_nm[m]
            per_source["encoder"] = line
        out.append(per_source)
    return out

