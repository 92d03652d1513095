"""Study: how much larger the current loop's correction T − 1 at a sensor offset's frequency is in
motulator than in the diagnosis' forward model (the cause of issue 23's offset misses).

Run: ``PYTHONPATH=. .venv/bin/python studies/offset_loop_ratio.py --captures-from /tmp/mot/final``
(captures of ``studies/motulator_coverage.py``). For each capture the order-1 torque (electrical,
twin's angle convention) is solved for (Δa, Δb) twice: with the stated loop's signatures and with
ideal regulation (T = 1); r = e_ideal/(e_ideal − e_model) of the larger error component is the
measured correction over the model's (1 when the model is right). Printed beside it: the
prediction 1 + α·τ of an integrator updated from the realised voltage
(``DriveSetup.current_loop_integrator_realised``). r is ill-conditioned where the loop's
correction is small against the capture's other errors (slow loops, the p8 motor at 400 rpm).
"""

from __future__ import annotations

import argparse
import inspect
import json
import math
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np

from hil.diagnosis import signatures as sig
from hil.motor import MotorParameters


def capture_ratio(folder: Path, manifest: dict, capture: dict, truth: tuple, setup) -> float:
    data = np.genfromtxt(folder / capture["file"], delimiter=",", names=True)
    theta = data["motulator_theta_M_mech_rad"]
    keep = np.abs(theta - theta[0]) < 2 * math.pi * 3          # three whole revolutions
    p = manifest["drive"]["pole_pairs"]
    elec = p * theta[keep] - math.radians(manifest["drive"]["emf_a_rising_zero_elec_deg"])
    weights = np.abs(np.gradient(theta[keep]))
    weights /= weights.sum()
    order1 = 2 * np.sum(data["torque_nm"][keep] * np.exp(-1j * elec) * weights)
    speed = float(capture["file"].split("rpm")[0][1:])
    op = sig.operating_point(speed, capture["current_a"], 0.0, setup)

    def solve(s):
        a, b = sig.offset_orders(op, s, "a")[1], sig.offset_orders(op, s, "b")[1]
        matrix = np.array([[a.real, b.real], [a.imag, b.imag]])
        return np.linalg.solve(matrix, [order1.real, order1.imag]) - np.array(truth)

    e_model, e_ideal = solve(setup), solve(replace(setup, current_loop_bandwidth_hz=None))
    k = int(np.argmax(np.abs(e_ideal)))
    return e_ideal[k] / (e_ideal[k] - e_model[k])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--captures-from", required=True, metavar="WORK")
    args = parser.parse_args()
    print("drive  design      bw_Hz  T_d_us  capture              r_measured  1+alpha*tau")
    for folder in sorted(Path(args.captures_from).glob("drive*")):
        manifest = tomllib.load(open(folder / "manifest.toml", "rb"))
        record = json.loads((folder / "truth.json").read_text())
        hidden = record["hidden"]
        truth = (hidden["ia_offset_a"] / (1 + hidden["ia_gain_error_pu"]),
                 hidden["ib_offset_a"] / (1 + hidden["ib_gain_error_pu"]))
        fields = inspect.signature(MotorParameters).parameters
        motor = MotorParameters(**{k: v for k, v in manifest["motor"].items() if k in fields})
        drive = manifest["drive"]
        setup = sig.DriveSetup(
            motor=motor, pwm_frequency_hz=drive["pwm_frequency_hz"],
            current_loop_bandwidth_hz=drive["current_loop_bandwidth_hz"],
            current_loop_delay_s=drive["current_loop_delay_s"],
            current_loop_design=drive["current_loop_design"],
            current_loop_decoupling=drive["current_loop_decoupling"],
            current_loop_angle_compensation=drive["current_loop_angle_compensation"])
        predicted = 1 + 2 * math.pi * drive["current_loop_bandwidth_hz"] \
            * drive["current_loop_delay_s"]
        for capture in manifest["capture"]:
            r = capture_ratio(folder, manifest, capture, truth, setup)
            print(f"{folder.name}  {record['spec']['loop']['design']:10s} "
                  f"{drive['current_loop_bandwidth_hz']:6.0f}  "
                  f"{hidden['dead_time_s'] * 1e6:5.2f}   {capture['file']:20s} {r:10.3f}  "
                  f"{predicted:10.3f}")


if __name__ == "__main__":
    main()
