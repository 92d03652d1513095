"""``hil diagnose`` on a run's captures models the bench that run's plans judged: the motor, loop
and transducer its characterisation stage measured, the drive's PI gains from the nameplate it
was configured from (``hil.commands.diagnose.as_characterised``), not the bench file as stated."""

import json
from pathlib import Path

import pytest

from hil.cli import main
from hil.commands.diagnose import as_characterised
from hil.config import example_bench_path

#: a warm (R +30 %), saturated (L −20 %) motor whose EMF is 4 % below its nameplate's, a loop
#: 25 % faster and a transducer 40 % faster than documented
ACTUAL = {"phase_resistance_ohm": 0.055 * 1.3, "phase_inductance_h": 38.5e-6 * 0.8,
          "ke_v_s_per_rad": 0.023 * 0.96, "current_loop_bandwidth_hz": 2000.0,
          "bandwidth_hz": 1400.0}


def test_the_values_the_plans_used_replace_the_stated_ones():
    stated = {"motor": {"phase_resistance_ohm": 0.055, "ke_v_s_per_rad": 0.023, "pole_count": 4},
              "drive": {"current_loop_bandwidth_hz": 1600.0}, "torque": {"bandwidth_hz": 1000.0}}
    rows = [{"name": "phase_resistance_ohm", "measured": 0.07, "predictions_use": "measured"},
            {"name": "ke_v_s_per_rad", "measured": 0.02301,
             "predictions_use": "stated (the measurement confirms it within U)"},
            {"name": "bandwidth_hz", "measured": 1390.0, "predictions_use": "measured"}]
    bench = as_characterised(stated, {"stated_vs_measured": rows})
    assert bench["motor"] == {"phase_resistance_ohm": 0.07, "ke_v_s_per_rad": 0.023,
                              "pole_count": 4}
    assert bench["loop_tuning"] == stated["motor"]          # the gains: the nameplate's
    assert bench["torque"]["bandwidth_hz"] == 1390.0
    assert bench["drive"]["current_loop_bandwidth_hz"] == 1600.0
    assert stated["motor"]["phase_resistance_ohm"] == 0.055           # the record is not changed
    assert as_characterised(stated, None) is stated
    only_transducer = as_characterised(stated, {"stated_vs_measured": rows[2:]})
    assert "loop_tuning" not in only_transducer


@pytest.fixture(scope="module")
def deviated_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("deviated")
    text = example_bench_path("sim-bench").read_text()
    assert "[simulation" not in text
    bench = folder / "bench.toml"
    bench.write_text(text + "\n[simulation.actual]\n"
                     + "".join(f"{k} = {v!r}\n" for k, v in ACTUAL.items()))
    main(["run", "--bench", str(bench), "--source", "diagnosis", "--no-report",
          "--record-dir", str(folder / "records")])
    (record,) = (folder / "records").glob("*/record.json")
    return record.parent


def test_hil_diagnose_models_the_bench_the_plan_judged(deviated_run, capsys):
    from hil.record import load_record

    record = load_record(deviated_run)
    plan_setup = record["diagnosis"]["setup"]
    base = {Path(t["capture"]["file"]).name for t in record["tests"]
            if t.get("kind") == "diagnosis" and t.get("capture") and t["injection"] == {}
            and "repeated" not in t["test_id"]}
    captures = sorted(str(p) for p in (deviated_run / "captures").glob("*test_diagnosis*.npz")
                      if p.name in base)
    assert len(captures) == 8
    capsys.readouterr()
    assert main(["diagnose", *captures, "--json"]) == 0
    setup = json.loads(capsys.readouterr().out)["setup"]
    for name in ("phase_resistance_ohm", "phase_inductance_h", "ke_v_s_per_rad"):
        assert setup["motor"][name] == pytest.approx(plan_setup["motor"][name], rel=1e-12)
        assert setup["motor"][name] != pytest.approx(0.055 if name == "phase_resistance_ohm"
                                                     else 38.5e-6 if name == "phase_inductance_h"
                                                     else 0.023, rel=0.02)   # not the nameplate
    assert setup["loop_tuning"]["phase_resistance_ohm"] == 0.055
    assert setup["current_loop_bandwidth_hz"] == pytest.approx(
        plan_setup["current_loop_bandwidth_hz"])
    assert setup["transducer_bandwidth_hz"] == pytest.approx(plan_setup["transducer_bandwidth_hz"])
    assert setup["transducer_bandwidth_hz"] == pytest.approx(1400.0, rel=0.05)


def test_captures_of_runs_characterised_differently_are_refused():
    from types import SimpleNamespace

    from hil.commands.diagnose import _bench_dict
    from hil.errors import InputError

    loaded = {"motor": {"phase_resistance_ohm": 0.055}, "drive": {}, "torque": {}}

    def record(measured_r):
        rows = [{"name": "phase_resistance_ohm", "measured": measured_r,
                 "predictions_use": "measured"}]
        return {"bench": {"loaded": loaded}, "characterisation": {"stated_vs_measured": rows}}

    args = SimpleNamespace(bench=None)
    assert _bench_dict(args, [record(0.07), None, record(0.07)])["motor"] == {
        "phase_resistance_ohm": 0.07}
    with pytest.raises(InputError, match="differ"):
        _bench_dict(args, [record(0.07), record(0.06)])
