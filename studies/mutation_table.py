"""Mutation table: every test-only defect of the simulated drive against every plan.

For each defect (hil.sim.defects.DriveDefects) all plans run end to end on the simulated bench;
the table lists the plans that failed, and the plans that exist to catch that defect but passed
(the aim: none). Run: ``.venv/bin/python studies/mutation_table.py`` (≈ 1 min per defect);
``--only KEY`` runs the defects whose key contains KEY (and the control); ``--bench FILE`` runs
them on another simulated bench file, e.g. one whose ``[simulation.actual]`` puts the motor off
its nameplate (issue 29: ``--nameplate-off`` writes R × 1.3, L × 0.8, Ke × 0.96 of the shipped
bench's Table I motor into a copy and uses it).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parents[1] / "tests" / "mutations"))
from mutation_run import failed_sources, refused_sources, run_plans  # noqa: E402

INJECTED = ["encoder", "word_length", "dc_offset", "gain_mismatch", "pwm_resolution",
            "pwm_switching", "dead_time"]
PLANS = ["characterisation", "self_check", "baseline", *INJECTED]
#: ``--nameplate-off``: the actual motor as multiples of the bench file's nameplate (warm, saturated)
NAMEPLATE_OFF = {"phase_resistance_ohm": 1.3, "phase_inductance_h": 0.8, "ke_v_s_per_rad": 0.96}
SCALED = {"encoder", "dc_offset", "gain_mismatch", "pwm_resolution", "pwm_switching",
          "dead_time"}
#: defect → the plans that exist to catch it
DEFECTS = [
    ({"ignore_injection": "*"}, set(INJECTED)),
    ({"injection_scale": 1.5}, SCALED),
    ({"injection_scale": 0.7}, SCALED),
    ({"hidden_ia_offset_a": 0.3}, {"baseline", "dc_offset"}),
    ({"word_length_offset_bits": -2}, {"word_length"}),
    ({"word_length_offset_bits": 2}, {"word_length"}),
    ({"transducer_scale": 1.05}, {"self_check"}),
    ({"transducer_scale": 0.95}, {"self_check"}),
    ({"daq_drop_every_nth": 10}, {"characterisation"}),   # the run stops at the stage (exit 6)
    # issue 21 item 8: defects the first table could not express
    ({"sensor_injection_swapped": True}, {"dc_offset", "gain_mismatch"}),
    ({"gain_applied_inverse": True}, {"gain_mismatch"}),
    ({"encoder_index_offset_rad": 0.35}, {"self_check", "gain_mismatch"}),
    ({"dead_time_compensation_pu": 0.7}, {"dead_time"}),
    ({"transducer_extra_lag_s": 1e-3}, {"self_check"}),
    ({"current_loop_bandwidth_scale": 0.5}, {"characterisation"}),
    # issue 23 item 0: the angle channel 30° electrical off phase a's back EMF (the bench file
    # states 0): the self-check's angle-reference measurement
    ({"encoder_commutation_offset_elec_deg": 30.0}, {"self_check"}),
    # issue 30: the DAQ's sample instants jitter by ±3/8 sample (tick count nominal); its clock
    # runs 0.5 % slow (time base stamped at the stated rate); the PWM-resolution model 2× too
    # large (a model mutation: ``model_scale``, tests/mutations/model_mutation.py)
    ({"daq_sample_jitter_samples": 0.375}, {"self_check"}),
    ({"daq_clock_scale": 0.995}, {"self_check"}),
    ({"model_scale": {"pwm_resolution": 2.0}}, {"pwm_resolution"}),
]


def nameplate_off_bench(folder: Path) -> Path:
    """A copy of the shipped simulated bench whose motor runs ``NAMEPLATE_OFF`` of its [motor]."""
    import tomllib

    import tomli_w

    from hil.config import example_bench_path

    table = tomllib.loads(example_bench_path("sim-bench").read_text())
    actual = {key: table["motor"][key] * factor for key, factor in NAMEPLATE_OFF.items()}
    table.setdefault("simulation", {})["actual"] = actual
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "nameplate-off.toml"
    path.write_text(tomli_w.dumps(table))
    return path


def main(argv: list[str]) -> int:
    only = argv[argv.index("--only") + 1] if "--only" in argv else None
    bench = Path(argv[argv.index("--bench") + 1]).resolve() if "--bench" in argv else None
    chosen = [(d, m) for d, m in DEFECTS if only is None or any(only in key for key in d)]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        if "--nameplate-off" in argv:
            bench = nameplate_off_bench(Path(tmp))
            print(f"bench: the shipped one, its motor off the nameplate: {NAMEPLATE_OFF}")
        control = run_plans(PLANS, {}, Path(tmp) / "control", bench=bench)
        print(f"control (no defect): failed {sorted(failed_sources(control)) or 'none'}")
        for index, (defects, must_fail) in enumerate(chosen):
            started = time.perf_counter()
            drive = {k: v for k, v in defects.items() if k != "model_scale"}
            run = run_plans(PLANS, drive, Path(tmp) / f"d{index}", bench=bench,
                            model_scale=defects.get("model_scale"))
            failed = failed_sources(run)
            label = ", ".join(
                ", ".join(f"{s} model x{f:g}" for s, f in v.items()) if k == "model_scale"
                else f"{k}={v}" for k, v in defects.items())
            refused = refused_sources(run) & (must_fail - failed)
            rows.append((label, sorted(failed), sorted(must_fail - failed - refused),
                         sorted(refused)))
            print(f"{label}: {time.perf_counter() - started:.0f} s", file=sys.stderr)
    print("\n| defect | plans that failed | should have failed but passed | refused here "
          "(not determinable: cannot judge this bench) |")
    print("|---|---|---|---|")
    for label, failed, missed, refused in rows:
        print(f"| {label} | {', '.join(failed) or '—'} | {', '.join(missed) or 'none'} | "
              f"{', '.join(refused) or '—'} |")
    return 1 if any(missed for _, _, missed, _ in rows) else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
