"""motulator's current loop alone, driven by a known voltage disturbance: the disturbance
voltage → current transfer of its ``CurrentVectorController`` as ``hil.plants.motulator_drive``
builds it (issue 30, finding 5: the dead time's order-6 disturbance on a 2-DOF loop).

Runs INSIDE ``.venv-motulator`` (``.ci/setup-motulator``): stdlib + numpy + motulator only; it
never imports ``hil``. Usage::

    echo '{"motor": {...}, "speed_rpm": -800, "current_a": 15,
           "frequencies_rad_s": [-2010.6, 2010.6]}' \
        | .venv-motulator/bin/python studies/independent/motulator_loop_response.py

What is motulator's: the machine (``SynchronousMachine``), the dyno (``ExternalRotorSpeed``),
the inverter (``VoltageSourceConverter``, no dead time) with its switching-cycle averaged model
(``Drive(pwm=False)``: the duty ratios held over each sampling period after its one-sample
computational delay), the controller (``CurrentVectorController``: its continuous 2-DOF
complex-vector PI, or ``"design": "discrete"`` its direct discrete-time design; α_c =
2π·bandwidth_hz, sensored, T_s = 1/(2·f_pwm), the voltage angle advanced by 1.5·T_s·ω), its
SVPWM and realised-voltage feedback. What is added: the fixed current reference (as the plant
does) and the disturbance — the machine's rotor-frame voltage equation gets
d(t) = D·e^{jω_d·t} (V, ω_d signed, rad/s) added to the converter's voltage, as an inverter's
voltage error would be; one run per frequency.

Output (JSON on stdout): per frequency the response i(ω_d)/D (A/V, complex as [re, im]): the
rotor-frame current's Fourier coefficient at ω_d over whole disturbance periods after the loop
has settled, less the same run's coefficient with D = 0 (the loop's own content at that
frequency, e.g. the rounding of the sampled angle).
"""

from __future__ import annotations

import json
import math
import sys

import numpy as np

from motulator.drive import model
import motulator.drive.control.sm as control

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from motulator_captures import FixedCurrentReference, _pars  # noqa: E402

#: disturbance amplitude, V: small against the bus and the loop's output (a linear response),
#: large against the solver's error
DEFAULT_AMPLITUDE_V = 0.05
#: settling before the kept window, s (≥ 30 time constants of the 2-DOF loop at ≥ 500 Hz)
DEFAULT_SETTLE_S = 0.01
#: disturbance periods kept
DEFAULT_PERIODS = 4


class DisturbedMachine(model.SynchronousMachine):
    """motulator's machine with a rotor-frame voltage D·e^{jω_d·t} added to its stator
    voltage (the only change: its ``rhs``'s voltage)."""

    amplitude_v = 0.0
    frequency_rad_s = 0.0

    def rhs(self, t: float) -> list[complex]:
        state, inp, out, par = self.state, self.inp, self.out, self.par
        u_s_dq = inp.u_s_ab * np.exp(-1j * state.theta_m.real)
        u_s_dq = u_s_dq + self.amplitude_v * np.exp(1j * self.frequency_rad_s * t)
        w_m = par.n_p * inp.w_M
        return [u_s_dq - par.R_s * out.i_s_dq - 1j * w_m * state.psi_s_dq, w_m]


def simulate(spec: dict, frequency_rad_s: float, amplitude_v: float) -> complex:
    """The rotor-frame current's coefficient at ``frequency_rad_s`` (A) in one run."""
    motor = spec["motor"]
    par = _pars(motor)
    f_pwm = float(spec.get("pwm_frequency_hz", 20_000.0))
    T_s = 0.5 / f_pwm
    machine = DisturbedMachine(par)
    machine.amplitude_v, machine.frequency_rad_s = amplitude_v, frequency_rad_s
    w_M = float(spec["speed_rpm"]) * 2 * math.pi / 60.0
    mech = model.ExternalRotorSpeed()
    mech.set_external_rotor_speed(w_M)
    converter = model.VoltageSourceConverter(u_dc=float(motor["u_dc_v"]))
    mdl = model.Drive(machine, mech, converter, pwm=False)
    current = float(spec["current_a"])
    cfg = control.CurrentVectorControllerCfg(
        i_s_max=2.0 * current, alpha_c=2 * math.pi * float(spec.get("bandwidth_hz", 1000.0)),
        sensorless=False, T_s=T_s, discrete=spec.get("design", "continuous") == "discrete")
    vector = control.CurrentVectorController(par, cfg)
    vector.reference_gen = FixedCurrentReference(par, current, 0.0)
    ctrl = control.VectorControlSystem(vector)
    ctrl.set_torque_ref(0.0)
    period = 2 * math.pi / abs(frequency_rad_s)
    settle = float(spec.get("settle_s", DEFAULT_SETTLE_S))
    kept = int(spec.get("periods", DEFAULT_PERIODS)) * period
    res = model.Simulation(mdl, ctrl, show_progress=False).simulate(t_stop=settle + kept,
                                                                    N_eval=4)
    if not res.success:
        raise RuntimeError(f"motulator stopped early at {frequency_rad_s} rad/s")
    t = np.asarray(res.mdl.t, dtype=float)
    order = np.argsort(t, kind="stable")
    t, i_dq = t[order], np.asarray(res.mdl.machine.i_s_dq)[order]
    t, keep = np.unique(t, return_index=True)
    i_dq = i_dq[keep]
    grid = settle + np.linspace(0.0, kept, 4096, endpoint=False)
    samples = np.interp(grid, t, i_dq.real) + 1j * np.interp(grid, t, i_dq.imag)
    return complex(np.mean(samples * np.exp(-1j * frequency_rad_s * grid)))


def responses(spec: dict) -> list[dict]:
    amplitude = float(spec.get("amplitude_v", DEFAULT_AMPLITUDE_V))
    out = []
    for w in spec["frequencies_rad_s"]:
        driven = simulate(spec, float(w), amplitude)
        quiet = simulate(spec, float(w), 0.0)
        ratio = (driven - quiet) / amplitude
        out.append({"frequency_rad_s": float(w), "response_a_per_v": [ratio.real, ratio.imag]})
    return out


def main() -> int:
    spec = json.loads(sys.stdin.read())
    json.dump({"responses": responses(spec)}, sys.stdout)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
