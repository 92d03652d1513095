"""Study: the diagnosis on the twin with each of its current-loop designs (issue 23 items 2-4).

One drive (Δa +0.30 A, Δb −0.10 A, g_a +1.5 %, dead time 1 µs by default), simulated at the
diagnosis plan's designed points with each firmware loop (hil.sim.FirmwareModel), diagnosed three
ways: the loop stated as it is (``twin_setup``), stated as the default continuous PI (what a
DriveSetup without the design took), and stated "unknown". Per parameter: error / U (k = 2),
MISS when outside.

    PYTHONPATH=. .venv/bin/python studies/diagnosis_loop_designs.py [--dead-time-s 1e-6]
"""

from __future__ import annotations

import argparse
from dataclasses import replace

from hil.diagnosis.core import diagnose
from hil.diagnosis.twin_proof import (HiddenFaults, check_estimates, simulate_points,
                                      twin_config, twin_setup)
from hil.sim import FirmwareModel
from ripple_hil_testplans import diagnosis_design as design

VARIANTS = {
    "default (continuous)": FirmwareModel(),
    "discrete": FirmwareModel(design="discrete"),
    "discrete + decoupling": FirmwareModel(design="discrete", decoupling=True),
    "EMF feed-forward": FirmwareModel(emf_feedforward=True),
    "delay 1.5 + angle comp.": FirmwareModel(delay_periods=1.5, angle_compensation=True),
    "all feed-forwards": FirmwareModel(decoupling=True, emf_feedforward=True,
                                       angle_compensation=True),
    "bandwidth 0.025 f_pwm": FirmwareModel(bandwidth_per_pwm=0.025),
    "bandwidth 0.15 f_pwm, delay 0.5": FirmwareModel(bandwidth_per_pwm=0.15, delay_periods=0.5),
}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dead-time-s", type=float, default=1e-6)
    args = parser.parse_args(argv)
    faults = HiddenFaults(ia_offset_a=0.3, ib_offset_a=-0.1, ia_gain_error_pu=0.015,
                          dead_time_s=args.dead_time_s)
    settings = dict(revolutions_elec=design.REVOLUTIONS_ELEC,
                    sample_rate_hz=design.SAMPLE_RATE_HZ, max_mech_order=design.MAX_MECH_ORDER)
    print("loop (twin)                      stated as    | error / U (k = 2) per parameter")
    for name, firmware in VARIANTS.items():
        config = replace(twin_config(faults), firmware=firmware)
        spectra = simulate_points(config, design.design_points(), **settings)
        stated = twin_setup(config)
        for label, setup in (("stated", stated),
                             ("default PI", twin_setup(twin_config(faults))),
                             ("unknown", replace(stated, current_loop_design="unknown"))):
            result = diagnose(spectra, setup=setup,
                              transducer_class_pct=config.transducer.accuracy_class_pct)
            cells = []
            for check in check_estimates(result, faults)[:4]:
                if not check["identifiable"]:
                    cells.append(f"{check['name']} n/i")
                    continue
                cells.append(f"{check['name']} {check['estimate'] - check['hidden']:+.2e} / "
                             f"{check['expanded_uncertainty']:.2e}"
                             + ("" if check["covered"] else " MISS"))
            print(f"{name:32s} {label:12s} | " + " | ".join(cells), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
