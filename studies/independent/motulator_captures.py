"""Captures of a PMSM drive simulated by motulator 0.18 (an independent simulator), with hidden
current-sensor and inverter faults, for the issue-23 coverage study of ``hil diagnose``.

Runs INSIDE ``.venv-motulator`` (``.ci/setup-motulator``): stdlib + numpy + motulator only; it
never imports ``hil``. Usage::

    .venv-motulator/bin/python studies/independent/motulator_captures.py SPEC.json OUT_DIR
    ... | .venv-motulator/bin/python studies/independent/motulator_captures.py - OUT_DIR
    ... motulator_captures.py --jobs 3 SPEC.json OUT_DIR     # the points in 3 processes at once

Spec (JSON; every key optional, defaults in :data:`DEFAULT_SPEC`)::

    {"motor":  {"name": "table_i", "pole_pairs": 2, "R_s_ohm": 0.055, "L_d_h": 38.5e-6,
                "L_q_h": 38.5e-6, "psi_f_vs": 0.01626, "u_dc_v": 12.0, "J_kgm2": null},
     "loop":   {"bandwidth_hz": 1000, "design": "continuous" | "discrete",
                "pwm_frequency_hz": 20000, "pwm_model": "carrier" | "zoh"},
     "faults": {"ia_offset_a": 0.3, "ib_offset_a": -0.1, "ia_gain_error_pu": 0.015,
                "ib_gain_error_pu": 0.0, "dead_time_s": 1e-6},
     "points": [{"speed_rpm": 500, "current_a": 20, "current_angle_deg": 0,
                 "mech_revolutions": 3}, ...],
     "settle_s": 0.02}

What is motulator's and what is added here
-----------------------------------------
* Machine: ``motulator.drive.model.SynchronousMachine`` (``SynchronousMachinePars``: n_p, R_s,
  L_d, L_q, ψ_f). Mechanics: ``ExternalRotorSpeed`` (a dyno holding the speed exactly), or with
  ``J_kgm2`` a ``MechanicalSystem`` of that inertia loaded by a speed-holding dyno (the expected
  mean torque plus k·(ω − ω_ref), k = J·2π·20 Hz; settling then ≥ 10 of its time constants,
  80 ms; see :func:`_mechanics`).
* Inverter: ``VoltageSourceConverter(u_dc, t_d)`` — motulator's own dead time (each leg blanked for
  ``t_d`` after its switching instant, the leg state during blanking set by the current sign;
  ``_converter.py``, class docstring). ``pwm_model = "carrier"``: ``Drive(pwm=True)``, its
  carrier comparison (``CarrierComparison``, switching instants and blanking intervals resolved);
  ``"zoh"``: ``Drive(pwm=False)``, its switching-cycle averaged model (``ZOH`` with
  ``averaged_gate_signals``, dead time as an average duty-ratio loss). No dead-time compensation
  in the controller (``PWM(d_err=None)``): the hidden dead time is uncompensated.
* Current sensors: motulator's ``Sensor`` (``y = gain·x + offset``), wrapped in
  :class:`TwoPhaseCurrentSensors`: phases a and b are measured (sensor a reads (1 + g_a)·i_a + Δa,
  sensor b (1 + g_b)·i_b + Δb; shared23.md's hidden-fault convention) and phase c is computed
  as −a − b, as the paper's two-sensor drive does (motulator's own default would be three
  ideal/erroneous sensors, whose zero sequence the Clarke transform drops).
* Control: motulator's ``CurrentVectorController`` (sensored, ``sensorless=False``; the speed/
  position observer locked to the measured rotor angle) with its own current controller: the
  continuous-time 2-DOF complex-vector PI (``CurrentController``, k_t = α_c, k_p = 2·α_c,
  k_i = α_c² on the flux linkage, angle advance 1.5·T_s) or its direct discrete-time design
  (``DiscreteCurrentController``); α_c = 2π·bandwidth_hz. Sampling twice per carrier period
  (T_s = 1/(2·f_pwm)) with motulator's default one-sample computational delay; SVPWM duty ratios
  (``PWM``: min/max zero-sequence injection). The only part replaced is the *reference*
  generation: :class:`FixedCurrentReference` commands the operating point's current vector
  (amplitude, angle φ: i_d = −I·sin φ, i_q = I·cos φ, the current lagging the EMF by φ as in
  paper eq 4) instead of motulator's torque-to-current MTPA generator. The manifest states the
  loop in the bench file's vocabulary (:data:`STATED_DESIGN`): the continuous design as "2dof"
  with angle compensation, the discrete one as "unknown"; bandwidth and delay 1.5·T_s as built.

Output per operating point (``OUT_DIR/<label>.csv``): one row per PWM (carrier) period —
``time_s`` (the period's centre), ``torque_nm`` (motulator's electromagnetic torque ``tau_M``
AVERAGED over the period: the trapezoidal integral of the solver's solution points, which include
every switching and sampling instant, divided by the period), ``motulator_theta_M_mech_rad``
(motulator's mechanical rotor angle ``mechanics.theta_M``, unwrapped, at the period's centre; the
machine's electrical angle is ``theta_m = n_p·theta_M`` exactly, both start at 0) and the actual
phase currents ``ia_a``, ``ib_a``, ``ic_a`` (period averages, A). Plus ``manifest.toml``
(shared23.md) and ``truth.json`` (hidden values; also motulator's conventions as measured).

Angle reference (measured, :func:`measure_emf_a_rising_zero_elec_deg`): motulator's machine
works in rotor coordinates with the PM flux on the d axis, ψ_s = ψ_f at zero current, and maps to
stator coordinates by ``i_s_ab = i_s_dq * exp_j_theta_m`` (``drive/model/_machine.py``,
``SynchronousMachine.compute_outputs``); its open-circuit EMF is ``e_dq = R_s*i_s_dq +
1j*w_m*psi_s_dq - …`` (``compute_ac_port``), phase a is the real part (``complex2abc``). So
e_a = Re(j·ω·ψ_f·e^{jθ}) = −ω·ψ_f·sin θ: phase a's EMF rises through zero at θ = 180°. The
function MEASURES it (it calls ``compute_ac_port`` of a motulator machine at zero current over a
sweep of rotor angles and fits e_a = E·sin(θ − θ₀)); the manifest states the measured θ₀.

Start-up transient: each point starts from zero current, the controller's integrators at zero
and the observer at the true angle but zero speed. The slowest dynamics are the observer's speed
estimate (poles at 2π·400 rad/s, motulator's sensored default) and the current loop's integral
action (α_c ≥ 2π·500 rad/s): time constants ≤ 0.4 ms. ``settle_s`` (default 20 ms, ≥ 50 time
constants) is simulated and discarded; the output then holds the revolutions asked for (+ 2 %).
``truth.json`` records the steady-state check: the mean torque of the first and the last kept
revolution (they agree to the solver's accuracy when the transient is gone).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

import motulator
from motulator.common.model import Sensor
from motulator.common.utils import complex2abc
from motulator.drive import model
import motulator.drive.control.sm as control

#: Table I of the paper (Chen, Namuduri, Mir 2002): 4 poles, 12 V bus, R = 55 mΩ, L = 38.5 µH,
#: Ke = 0.023 V/(rad/s) rms phase per mechanical rad/s → ψ_f = √2·0.023/2 V·s (peak phase flux
#: per electrical rad).
TABLE_I = {"name": "table_i", "pole_pairs": 2, "R_s_ohm": 55e-3, "L_d_h": 38.5e-6,
           "L_q_h": 38.5e-6, "psi_f_vs": math.sqrt(2.0) * 0.023 / 2, "u_dc_v": 12.0,
           "J_kgm2": None}

DEFAULT_SPEC = {
    "motor": TABLE_I,
    "loop": {"bandwidth_hz": 1000.0, "design": "continuous", "pwm_frequency_hz": 20_000.0,
             "pwm_model": "carrier"},
    "faults": {"ia_offset_a": 0.0, "ib_offset_a": 0.0, "ia_gain_error_pu": 0.0,
               "ib_gain_error_pu": 0.0, "dead_time_s": 0.0},
    "points": [{"speed_rpm": 500.0, "current_a": 20.0, "current_angle_deg": 0.0,
                "mech_revolutions": 3}],
    "settle_s": 0.02,
    "state_angle_reference": True,
}


class TwoPhaseCurrentSensors:
    """Two motulator ``Sensor`` channels on phases a and b; phase c computed as −a − b."""

    def __init__(self, *, ia_offset_a: float, ib_offset_a: float, ia_gain_error_pu: float,
                 ib_gain_error_pu: float) -> None:
        self.sensor = Sensor(gain=[1.0 + ia_gain_error_pu, 1.0 + ib_gain_error_pu],
                             offset=[ia_offset_a, ib_offset_a])

    def __call__(self, i_abc):
        a, b = self.sensor(np.asarray(i_abc)[:2])
        return np.array([a, b, -a - b])


class FixedCurrentReference:
    """Reference generator of a current-commanded drive: the rotor-frame current vector
    i_d + j·i_q = I·(−sin φ + j·cos φ), whatever the torque reference (motulator's
    ``ReferenceGenerator`` interface: compute_flux_and_torque_refs, compute_current_ref, update)."""

    def __init__(self, par, current_a: float, current_angle_rad: float) -> None:
        self.par = par
        self.i_s_ref = current_a * complex(-math.sin(current_angle_rad),
                                           math.cos(current_angle_rad))

    def compute_flux_and_torque_refs(self, tau_M_ref, w_m, u_dc):
        psi = complex(self.par.psi_s_dq(self.i_s_ref))
        tau = 1.5 * self.par.n_p * (psi.conjugate() * self.i_s_ref).imag
        return abs(psi), tau

    def compute_current_ref(self, tau_M_ref):
        return self.i_s_ref

    def update(self, T_s):
        pass


def _merge(spec: dict) -> dict:
    out = json.loads(json.dumps(DEFAULT_SPEC))
    for key, value in spec.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = {**out[key], **value}
        else:
            out[key] = value
    return out


def _pars(motor: dict):
    return model.SynchronousMachinePars(n_p=int(motor["pole_pairs"]), R_s=motor["R_s_ohm"],
                                        L_d=motor["L_d_h"], L_q=motor["L_q_h"],
                                        psi_f=motor["psi_f_vs"])


def measure_emf_a_rising_zero_elec_deg(motor: dict, n: int = 720) -> float:
    """θ₀ (electrical degrees of motulator's rotor angle ``theta_m``) at which phase a's
    open-circuit EMF crosses zero going positive, measured on a motulator machine: the EMF
    vector is ``SynchronousMachine.compute_ac_port().e`` at zero current (ψ_s = ψ_f), phase a
    its ``complex2abc`` part, swept over θ and fitted as E·sin(θ − θ₀)."""
    par = _pars(motor)
    machine = model.SynchronousMachine(par)
    machine.inp.w_M = 2 * math.pi * 10.0           # any positive speed (rad/s mechanical)
    theta = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    e_a = np.empty(n)
    for k, th in enumerate(theta):
        machine.state.psi_s_dq = complex(par.psi_f)
        machine.state.theta_m = complex(th)
        machine.set_outputs(0.0)
        e_a[k] = complex2abc(machine.compute_ac_port().e)[0]
    # e_a = E·(sin θ·cos θ₀ − cos θ·sin θ₀)
    s, c = 2 * np.mean(e_a * np.sin(theta)), 2 * np.mean(e_a * np.cos(theta))
    return float(math.degrees(math.atan2(-c, s)) % 360.0)


#: Bandwidth (Hz) of the speed-holding dyno of a drive with inertia: its viscous torque
#: k·(ω − ω_ref) with k = J·2π·this; the mechanical time constant is 1/(2π·this).
DYNO_BANDWIDTH_HZ = 20.0


def _mechanics(motor: dict, w_M: float, load_torque_nm: float):
    """motulator's ``ExternalRotorSpeed`` (speed held exactly) or, with ``J_kgm2``, its
    ``MechanicalSystem`` of that inertia loaded by a dyno: the expected mean motor torque
    (feed-forward, ``load_torque_nm``) plus a stiff viscous term k·(ω − ω_ref) (the rotor's
    speed then ripples with the torque, as on a real shaft)."""
    if motor.get("J_kgm2") is None:
        mech = model.ExternalRotorSpeed()
        mech.set_external_rotor_speed(w_M)
        return mech
    J = float(motor["J_kgm2"])
    k = J * 2 * math.pi * DYNO_BANDWIDTH_HZ
    mech = model.MechanicalSystem(J=J, B_L=lambda w: k * (w - w_M) / w if w else 0.0)
    mech.set_external_load_torque(load_torque_nm)
    mech.state.w_M = complex(w_M)
    return mech


#: A point's known additions (shared23.md, standard additions of issue 23 item 1) → the hidden
#: fault they add to: offsets add, sensor a's gain multiplies by (1 + addition), dead time adds.
ADDITIONS = ("addition_ia_offset_a", "addition_ib_offset_a", "addition_gain_a_pu",
             "addition_dead_time_s")


def with_additions(faults: dict, point: dict) -> dict:
    out = dict(faults)
    out["ia_offset_a"] = float(out["ia_offset_a"]) + float(point.get("addition_ia_offset_a", 0.0))
    out["ib_offset_a"] = float(out["ib_offset_a"]) + float(point.get("addition_ib_offset_a", 0.0))
    out["ia_gain_error_pu"] = ((1.0 + float(out["ia_gain_error_pu"]))
                               * (1.0 + float(point.get("addition_gain_a_pu", 0.0))) - 1.0)
    out["dead_time_s"] = float(out["dead_time_s"]) + float(point.get("addition_dead_time_s", 0.0))
    return out


def simulate_point(spec: dict, point: dict) -> dict:
    """One operating point: period-averaged columns of the kept (steady-state) window."""
    motor, loop, faults = spec["motor"], spec["loop"], spec["faults"]
    par = _pars(motor)
    f_pwm = float(loop["pwm_frequency_hz"])
    T_pwm, T_s = 1.0 / f_pwm, 0.5 / f_pwm
    w_M = float(point["speed_rpm"]) * 2 * math.pi / 60.0
    faults = with_additions(faults, point)
    sensors = TwoPhaseCurrentSensors(**{k: float(faults[k]) for k in (
        "ia_offset_a", "ib_offset_a", "ia_gain_error_pu", "ib_gain_error_pu")})
    machine = model.SynchronousMachine(par, i_s_sensor=sensors)
    phi = math.radians(float(point.get("current_angle_deg", 0.0)))
    i_dq = float(point["current_a"]) * complex(-math.sin(phi), math.cos(phi))
    tau_expected = 1.5 * par.n_p * (complex(par.psi_s_dq(i_dq)).conjugate() * i_dq).imag
    mech = _mechanics(motor, w_M, tau_expected)
    converter = model.VoltageSourceConverter(u_dc=float(motor["u_dc_v"]),
                                             t_d=float(faults["dead_time_s"]))
    mdl = model.Drive(machine, mech, converter, pwm=loop["pwm_model"] == "carrier")
    current = float(point["current_a"])
    cfg = control.CurrentVectorControllerCfg(
        i_s_max=2.0 * current, alpha_c=2 * math.pi * float(loop["bandwidth_hz"]),
        sensorless=False, T_s=T_s, discrete=loop["design"] == "discrete")
    vector = control.CurrentVectorController(par, cfg)
    vector.reference_gen = FixedCurrentReference(
        par, current, math.radians(float(point.get("current_angle_deg", 0.0))))
    ctrl = control.VectorControlSystem(vector)
    ctrl.set_torque_ref(0.0)                       # unused by the fixed current reference
    revolutions = int(point.get("mech_revolutions", 3))
    settle = float(spec["settle_s"])
    if motor.get("J_kgm2") is not None:     # ≥ 10 mechanical time constants of the dyno
        settle = max(settle, 10.0 / (2 * math.pi * DYNO_BANDWIDTH_HZ))
    t_rev = 2 * math.pi / abs(w_M)
    periods_settle = math.ceil(settle / T_pwm)
    periods_keep = math.ceil((revolutions + 0.02) * t_rev / T_pwm) + 2
    t_stop = (periods_settle + periods_keep) * T_pwm
    sim = model.Simulation(mdl, ctrl, show_progress=False)
    res = sim.simulate(t_stop=t_stop, N_eval=2)
    if not res.success:
        raise RuntimeError(f"motulator stopped early at point {point}")
    t = np.asarray(res.mdl.t, dtype=float)
    order = np.argsort(t, kind="stable")
    t = t[order]
    tau = np.asarray(res.mdl.machine.tau_M, dtype=float)[order]
    i_abc = np.real(complex2abc(np.asarray(res.mdl.machine.i_s_ab)[order]))
    theta = np.unwrap(np.asarray(res.mdl.mechanics.theta_M, dtype=float)[order])

    def period_average(y: np.ndarray, edges: np.ndarray) -> np.ndarray:
        cum = np.concatenate(([0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))))
        at = np.interp(edges, t, cum)
        return np.diff(at) / np.diff(edges)

    edges = (periods_settle + np.arange(periods_keep + 1)) * T_pwm
    edges = edges[edges <= t[-1] + 1e-12]
    centre = 0.5 * (edges[1:] + edges[:-1])
    columns = {"time_s": centre, "torque_nm": period_average(tau, edges),
               "motulator_theta_M_mech_rad": period_average(theta, edges)}
    for name, row in zip(("ia_a", "ib_a", "ic_a"), i_abc):
        columns[name] = period_average(row, edges)
    # the kept window: whole mechanical revolutions of travel from the first sample, plus 2 %
    turned = np.abs(columns["motulator_theta_M_mech_rad"]
                    - columns["motulator_theta_M_mech_rad"][0])
    per_rev = [columns["torque_nm"][(turned >= 2 * math.pi * r)
                                    & (turned < 2 * math.pi * (r + 1))].mean()
               for r in range(revolutions)]
    return {"columns": columns, "mean_torque_first_rev_nm": float(per_rev[0]),
            "mean_torque_last_rev_nm": float(per_rev[-1])}


def _label(point: dict) -> str:
    angle = float(point.get("current_angle_deg", 0.0))
    text = f"p{float(point['speed_rpm']):+g}rpm_{float(point['current_a']):g}A"
    text += f"_{angle:g}deg" if angle else ""
    for key in ADDITIONS:
        if float(point.get(key, 0.0)):
            text += f"_{key[len('addition_'):]}{float(point[key]):+g}"
    return text


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    return repr(float(value)) if isinstance(value, float) else str(value)


#: What the manifest states for each of motulator's current controllers, in the vocabulary of
#: shared23.md / the bench file: its continuous design IS the complex-vector 2-DOF PI
#: (feedback L·(2α + (α² + jω_e·α)/s), "2dof"); its direct discrete-time design (Awan 2019) has no
#: name there, so it is stated "unknown" (the diagnosis then propagates a family of loops).
#: ``loop.state_design`` in the spec overrides (e.g. to state a wrong design on purpose).
STATED_DESIGN = {"continuous": "2dof", "discrete": "unknown"}


def manifest_text(spec: dict, files: list[tuple[str, dict]], emf_deg: float) -> str:
    """manifest.toml (shared23.md) for the captures: drive, motor and one [[capture]] each."""
    motor, loop = spec["motor"], spec["loop"]
    f_pwm = float(loop["pwm_frequency_hz"])
    discrete = loop["design"] == "discrete"
    drive = {"pole_pairs": int(motor["pole_pairs"])}
    if spec.get("state_angle_reference", True):
        drive["emf_a_rising_zero_elec_deg"] = round(emf_deg, 6)
    drive |= {"pwm_frequency_hz": f_pwm,
              "current_loop_bandwidth_hz": float(loop["bandwidth_hz"]),
              # one sampling period (T_s = 1/(2 f_pwm)) of computation + half of it for the ZOH
              "current_loop_delay_s": 1.5 * 0.5 / f_pwm,
              "current_loop_design": loop.get("state_design") or STATED_DESIGN[loop["design"]],
              "current_loop_decoupling": False,
              "current_loop_emf_feedforward": False,
              # continuous design: voltage angle advanced by 1.5·T_s·ω (k_comp = 1.5); the
              # discrete design includes the delay in its own design (k_comp = 0)
              "current_loop_angle_compensation": not discrete}
    ke_peak = int(motor["pole_pairs"]) * float(motor["psi_f_vs"])
    motor_table = {"pole_count": 2 * int(motor["pole_pairs"]), "dc_bus_v": float(motor["u_dc_v"]),
                   "phase_resistance_ohm": float(motor["R_s_ohm"]),
                   "phase_inductance_h": 0.5 * (float(motor["L_d_h"]) + float(motor["L_q_h"])),
                   "ke_v_s_per_rad": ke_peak, "ke_definition": "peak_phase"}
    lines = [f"# captures of motulator {motulator_version()} (studies/independent/"
             "motulator_captures.py); controller: motulator's "
             f"{'direct discrete-time' if discrete else 'continuous-time 2-DOF complex-vector'} "
             f"current controller, {loop['bandwidth_hz']:g} Hz, PWM model {loop['pwm_model']}",
             "[drive]"]
    lines += [f"{k} = {_toml_value(v)}" for k, v in drive.items()]
    lines += ["", "[motor]"] + [f"{k} = {_toml_value(v)}" for k, v in motor_table.items()]
    for name, point in files:
        lines += ["", "[[capture]]", f"file = {json.dumps(name)}",
                  f"current_a = {_toml_value(float(point['current_a']))}",
                  f"current_angle_deg = {_toml_value(float(point.get('current_angle_deg', 0.0)))}",
                  'torque_column = "torque_nm"', 'angle_column = "motulator_theta_M_mech_rad"',
                  'angle_kind = "mech"']
        lines += [f"{key} = {_toml_value(float(point[key]))}" for key in ADDITIONS
                  if float(point.get(key, 0.0))]
    return "\n".join(lines) + "\n"


def motulator_version() -> str:
    from importlib.metadata import version
    return version("motulator")


def simulated_points(spec: dict, points: list[dict], jobs: int = 1) -> list[dict]:
    """``simulate_point`` of each point, in ``jobs`` processes at once: each point is its own
    simulation from rest, and motulator is deterministic, so the results are those of the
    points simulated one after another."""
    jobs = min(jobs, len(points))
    if jobs <= 1:
        return [simulate_point(spec, point) for point in points]
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max_workers=jobs) as pool:
        return list(pool.map(simulate_point, [spec] * len(points), points))


def generate(spec: dict, out_dir: Path, *, jobs: int = 1) -> Path:
    spec = _merge(spec)
    out_dir.mkdir(parents=True, exist_ok=True)
    emf_deg = measure_emf_a_rising_zero_elec_deg(spec["motor"])
    files = [(_label(point) + ".csv", point) for point in spec["points"]]
    reused = {name for name, _ in files
              if spec.get("reuse_existing") and (out_dir / name).is_file()}   # same spec → same capture
    new = [(name, point) for name, point in files if name not in reused]
    results = dict(zip((name for name, _ in new),
                       simulated_points(spec, [point for _, point in new], jobs)))
    checks = []
    for name, _ in files:
        if name in reused:
            checks.append({"file": name, "reused": True})
            continue
        result = results[name]
        columns = result["columns"]
        header = ",".join(columns)
        data = np.column_stack(list(columns.values()))
        np.savetxt(out_dir / name, data, delimiter=",", header=header, comments="",
                   fmt="%.10g")
        checks.append({"file": name, "mean_torque_first_rev_nm":
                       result["mean_torque_first_rev_nm"],
                       "mean_torque_last_rev_nm": result["mean_torque_last_rev_nm"],
                       "rows": int(data.shape[0])})
    (out_dir / "manifest.toml").write_text(manifest_text(spec, files, emf_deg))
    f = spec["faults"]
    g_a, g_b = float(f["ia_gain_error_pu"]), float(f["ib_gain_error_pu"])
    truth = {"simulator": f"motulator {motulator_version()}", "spec": spec,
             "hidden": {k: float(v) for k, v in f.items()},
             # the paper's k (1 + k = 1/(1 + g)); k_a − k_b ≈ −(g_a − g_b) to first order
             "k_diff": 1.0 / (1.0 + g_a) - 1.0 / (1.0 + g_b),
             "motulator_emf_a_rising_zero_elec_deg": emf_deg,
             "angle_reference_stated": bool(spec.get("state_angle_reference", True)),
             "steady_state_check": checks}
    (out_dir / "truth.json").write_text(json.dumps(truth, indent=1))
    return out_dir / "manifest.toml"


def restate(out_dir: Path) -> Path:
    """Rewrite ``out_dir/manifest.toml`` from its ``truth.json`` with this version's statement
    (no simulation: the captures stay as they are)."""
    truth = json.loads((out_dir / "truth.json").read_text())
    spec = _merge(truth["spec"])
    files = [(_label(point) + ".csv", point) for point in spec["points"]]
    missing = [name for name, _ in files if not (out_dir / name).is_file()]
    if missing:
        raise FileNotFoundError(f"{out_dir}: captures {missing} missing")
    (out_dir / "manifest.toml").write_text(
        manifest_text(spec, files, truth["motulator_emf_a_rising_zero_elec_deg"]))
    return out_dir / "manifest.toml"


def main(argv: list[str]) -> int:
    if len(argv) == 2 and argv[0] == "--restate":
        print(restate(Path(argv[1])))
        return 0
    jobs = 1
    if len(argv) == 4 and argv[0] == "--jobs" and argv[1].isdigit():
        jobs, argv = int(argv[1]), argv[2:]
    if len(argv) != 2:
        print("usage: motulator_captures.py [--jobs N] SPEC.json|- OUT_DIR\n"
              "       motulator_captures.py --restate OUT_DIR", file=sys.stderr)
        return 2
    text = sys.stdin.read() if argv[0] == "-" else Path(argv[0]).read_text()
    print(generate(json.loads(text), Path(argv[1]), jobs=jobs))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
