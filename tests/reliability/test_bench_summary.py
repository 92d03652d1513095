"""``python -m benchmarks``: each script's printed figures are found and named (unit tests on
outputs the scripts printed on this machine), and a figure that is missing is an error in the
summary, never a silent gap. No benchmark runs here (``make bench`` runs them)."""

from __future__ import annotations

import pytest

from benchmarks.__main__ import (BENCHMARKS, Benchmark, load_before, missing_figures,
                                 parse_figures, run_benchmark, table)

OUTPUTS = {
    "simulation": """first calls (compile or cache load): 0.41 s
cores: 2, numba threads: 2, load average: 5.46
one drive, one core, Table I motor           : 0.0226 wall s per simulated s (44x real time; target <= 0.02)
one drive, one core, + EMF harmonics, cogging: 0.0282 wall s per simulated s (35x real time; target <= 0.02)
batch of 16, all cores: 1.3693 wall s per simulated s of the batch, 0.0856 per drive-second
""",
    "analysis": """samples: 10000000, revolutions: 6669, max_order: 64, grid: 512 bins/rev
analysis chain: 4.810 s (best of 3) = 2,078,985 samples/s
capture of the same samples at 100,000 S/s: 100.0 s; analysis is 21x faster than capturing
""",
    "canopen": """virtual (in-process):
  sdo_uploads_per_s                     6151.69
  rpdo_frames_lost_fraction                0.00
remote (TCP 127.0.0.1):
  sdo_uploads_per_s                     3867.39
""",
    "modbus": """Modbus TCP loopback: buffer paging 98,544 registers/s (1,577 transactions/s, 120000 registers in 960 pages, x3)
Modbus TCP loopback: whole capture of 20000 samples x 7 channels in 0.727 s (27,496 samples/s end to end)
Modbus RTU pty (unpaced): buffer paging 13,652 registers/s (218 transactions/s, 30000 registers in 240 pages, x1)
""",
    "transducer": """magtrol unpaced pty: polled read(): 3,514 samples/s (1000 in 0.285 s)
himmelstein pty paced at 115200 baud: stream(500): 478 samples/s (500 in 1.045 s)
""",
    "hil_run": """hil run (all plans, simulated bench): 22 points in 8.06 wall s = 2.731 points/s (exit 0, record complete; 22 passed)
hil report on that record: 7.53 wall s (exit 0)
pytest start-up and collection of one plan: 2.20 s with every installed plugin, 1.28 s with hil run's
""",
    "hil_run_issue17": """hil run (baseline, dc_offset, gain_mismatch, encoder, word_length, pwm_resolution, pwm_switching, dead_time, simulated bench): 33 points in 7.06 wall s = 4.677 points/s (exit 0, record complete; 33 passed; PDF written by the run; median of 3: 6.75, 7.06, 7.21)
""",
    "yield": """cores: 2, load average: 3.10
closed form, one core: 412,000 drives/s (3 operating points, 100,000 drives)
hil yield closed form, 10,000 drives + Sobol' (9,216 evaluations), 2 workers: 4.20 wall s (+ 1.10 s LocalCluster start); yield 97.40 %
twin on 1 worker(s): 3.50 drive-s per wall s (32 drives x 0.071 simulated s in 0.65 wall s; compute 18.0 ms per drive on a worker)
dask overhead per task, 1 worker(s): 2.1 ms (chunks of 16 drives); empty-task round trip 1.5 ms
twin on 2 worker(s): 6.20 drive-s per wall s (32 drives x 0.071 simulated s in 0.37 wall s; compute 18.5 ms per drive on a worker)
dask overhead per task, 2 worker(s): 3.4 ms (chunks of 16 drives); empty-task round trip 1.8 ms
projection (extrapolated from 1 worker, not measured): 10^6-drive twin campaign at 500 rpm, chunks of 16: N=1: 5.04 h, N=2: 2.52 h
""",
    "results_db": """ingest of a 53-test run, sqlite: 0.009 s (median of 2, warm engine; min 0.009, max 0.009)
bulk load of 500 synthetic runs (2500 points), sqlite: 0.05 s
hil history (newest 50 of 500 runs), sqlite: 0.000 s
hil history --dut (one of 2000 DUTs), sqlite: 0.000 s
hil trend --requirement over 503 runs, sqlite: 0.007 s (Cpk 0.91)
hil trend --source over 500 runs, sqlite: 0.005 s
ingest of a 53-test run, postgresql: 0.013 s (median of 2, warm engine; min 0.013, max 0.014)
hil history (newest 50 of 500 runs), postgresql: 0.001 s
hil trend --requirement over 503 runs, postgresql: 0.009 s (Cpk 0.91)
hil trend --source over 500 runs, postgresql: 0.007 s
""",
}
EXPECTED = {
    "simulation": {"one_drive_one_core_Table_I_motor_wall_s_per_sim_s": 0.0226,
                   "one_drive_one_core_+_EMF_harmonics_cogging_wall_s_per_sim_s": 0.0282,
                   "batch_of_16_wall_s_per_sim_s": 1.3693,
                   "batch_of_16_wall_s_per_drive_s": 0.0856, "first_call_compile_s": 0.41},
    "analysis": {"analysis_samples_per_s": 2078985.0, "analysis_over_capture_rate": 21.0},
    "canopen": {"virtual.sdo_uploads_per_s": 6151.69, "virtual.rpdo_frames_lost_fraction": 0.0,
                "remote.sdo_uploads_per_s": 3867.39},
    "modbus": {"TCP_loopback_registers_per_s": 98544.0,
               "TCP_loopback_capture_samples_per_s": 27496.0,
               "RTU_pty_(unpaced)_registers_per_s": 13652.0},
    "transducer": {"magtrol_unpaced_pty_polled_read()_samples_per_s": 3514.0,
                   "himmelstein_pty_paced_at_115200_baud_stream(500)_samples_per_s": 478.0},
    "hil_run": {"points": 22.0, "wall_s": 8.06, "points_per_s": 2.731, "report_wall_s": 7.53,
                "startup_all_plugins_s": 2.2, "startup_hil_run_plugins_s": 1.28},
    "hil_run_issue17": {"points": 33.0, "wall_s": 7.06, "fastest_of_3_wall_s": 6.75},
    "yield": {"closed_form_drives_per_s": 412000.0, "closed_form_campaign_wall_s": 4.2,
              "twin_1_workers_drive_s_per_wall_s": 3.5, "twin_2_workers_drive_s_per_wall_s": 6.2,
              "dask_overhead_per_task_1_workers_ms": 2.1,
              "dask_overhead_per_task_2_workers_ms": 3.4,
              "projected_1e6_twin_drives_N1_h": 5.04, "projected_1e6_twin_drives_N2_h": 2.52},
    "results_db": {"ingest_53_tests_sqlite_s": 0.009, "history_sqlite_s": 0.0,
                   "trend_requirement_sqlite_s": 0.007, "trend_source_sqlite_s": 0.005,
                   "ingest_53_tests_postgresql_s": 0.013, "history_postgresql_s": 0.001,
                   "trend_requirement_postgresql_s": 0.009, "trend_source_postgresql_s": 0.007},
}


@pytest.mark.parametrize("benchmark", BENCHMARKS, ids=[b.name for b in BENCHMARKS])
def test_every_printed_figure_is_found(benchmark):
    figures = parse_figures(benchmark, OUTPUTS[benchmark.name])
    assert {name: item["value"] for name, item in figures.items()} == EXPECTED[benchmark.name]
    assert all(item["unit"] for item in figures.values())


def test_changed_wording_is_reported_not_hidden(tmp_path):
    script = tmp_path / "quiet.py"
    script.write_text("print('the figures moved elsewhere: 12 things/s')\n")
    quiet = Benchmark("quiet", str(script), (), (), BENCHMARKS[0].patterns, "nothing")
    result = run_benchmark(quiet, quick=False, timeout_s=60)
    assert result["returncode"] == 0 and result["figures"] == {}
    assert "not found in the output" in result["error"]
    assert "one_drive_one_core" in result["error"]
    assert "ERROR" in table({"quiet": result})


def test_one_missing_figure_is_an_error_even_if_others_are_found():
    simulation = next(b for b in BENCHMARKS if b.name == "simulation")
    text = OUTPUTS["simulation"].replace("one drive, one core", "a single drive")
    assert "batch_of_16_wall_s_per_sim_s" in parse_figures(simulation, text)
    assert missing_figures(simulation, text) == ["one_drive_one_core{label}_wall_s_per_sim_s"]
    assert missing_figures(simulation, OUTPUTS["simulation"]) == []


def test_a_failing_script_is_reported(tmp_path):
    script = tmp_path / "broken.py"
    script.write_text("raise SystemExit('bus off')\n")
    broken = Benchmark("broken", str(script), (), (), BENCHMARKS[0].patterns, "nothing")
    result = run_benchmark(broken, quick=False, timeout_s=60)
    assert result["returncode"] == 1 and "bus off" in result["error"]


def test_recorded_before_figures_name_figures_the_benchmarks_print():
    """Every before-figure is one a benchmark's patterns produce (else the column stays empty)."""
    before = load_before()
    assert before, "benchmarks/before_issue17.json is missing"
    for name, figures in before.items():
        benchmark = next(b for b in BENCHMARKS if b.name == name)
        printed = parse_figures(benchmark, OUTPUTS[name])
        assert set(figures) <= set(printed), (name, set(figures) - set(printed))


def test_table_puts_the_before_figure_beside_the_new_one():
    run = next(b for b in BENCHMARKS if b.name == "hil_run_issue17")
    result = {"figures": parse_figures(run, OUTPUTS["hil_run_issue17"])}
    line = next(row for row in table({"hil_run_issue17": result}, load_before()).splitlines()
                if " wall_s " in row)
    assert line.split()[-3:] == ["7.06", "s", "23.65"]
