"""The regression grid's file format (hil/campaign/grid_spec.py) and its one-write store."""

import io
import json
import tarfile
from pathlib import Path

import pytest

from hil.campaign.grid import done_keys, store_result, summary_table, grid_row
from hil.campaign.grid_spec import GridRun, apply_overrides, load_grid, run_key
from hil.errors import InputError

EXAMPLE = Path(__file__).resolve().parents[2] / "hil" / "examples" / "grid.toml"


def write(tmp_path, text):
    path = tmp_path / "grid.toml"
    path.write_text(text)
    return path


def test_example_grid_is_the_product_of_its_axes_and_plans():
    runs = load_grid(EXAMPLE)
    assert len(runs) == 2 * 2 * 2 * 2
    assert len({r.key for r in runs}) == len(runs)
    p8 = next(r for r in runs if r.labels == {"motor": "p8_48v", "point": "reverse",
                                               "defect": "hidden_offset"})
    assert p8.bench["motor"]["pole_count"] == 8
    assert p8.bench["operating_point"]["speed_rpm"] == -500.0
    assert p8.bench["simulation"]["defects"]["hidden_ia_offset_a"] == 0.3
    assert p8.bench["drive"]["node_id"] == 1          # the base bench's other keys stay


def test_any_table_by_dotted_keys_nested_or_quoted(tmp_path):
    runs = load_grid(write(tmp_path, """
plans = [[]]
[axes.loop]
slow = {"drive.current_loop_bandwidth_hz" = 800.0}
[axes.loop.fast]
drive.current_loop_bandwidth_hz = 2400.0
"""))
    assert [r.bench["drive"]["current_loop_bandwidth_hz"] for r in runs] == [800.0, 2400.0]
    assert all(r.sources == () for r in runs)


def test_key_is_the_resolved_bench_plans_and_seed():
    bench = {"motor": {"pole_count": 4}}
    assert run_key(bench, ("a", "b"), 0) == run_key(bench, ("b", "a"), 0)
    assert run_key(bench, ("a",), 0) != run_key(bench, ("a",), 1)
    assert run_key(bench, ("a",), 0) != run_key({"motor": {"pole_count": 8}}, ("a",), 0)
    # the same run written as another variant name is the same run
    assert GridRun({"x": "one"}, bench).key == GridRun({"y": "two"}, bench).key


@pytest.mark.parametrize("text, words", [
    ('[axes.m]\nbad = {"motor.pole_count" = 5}', "pole_count"),        # odd pole count
    ('[axes.m]\nbad = {"motor.no_such_key" = 1}', "no_such_key"),
    ('[axes.m]\nbad = {"motor" = 1}', "dotted key"),
    ('colour = 1', "unknown key"),
    ('plans = "baseline"', "plans must be"),
    ('[axes.m]\na = {}\nb = {"operating_point.speed_rpm" = 500.0}', "same run"),
])
def test_a_wrong_grid_is_refused_naming_what(tmp_path, text, words):
    with pytest.raises(InputError, match=words):
        load_grid(write(tmp_path, text))


def test_overrides_do_not_touch_the_base():
    base = {"motor": {"pole_count": 4}}
    changed = apply_overrides(base, {"motor.pole_count": 8, "simulation.actual.r_ohm": 1.0}, "x")
    assert base == {"motor": {"pole_count": 4}}
    assert changed == {"motor": {"pole_count": 8}, "simulation": {"actual": {"r_ohm": 1.0}}}


def _result(run, record_bytes=b'{"tests": []}'):
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w") as tar:
        info = tarfile.TarInfo("record/record.json")
        info.size = len(record_bytes)
        tar.addfile(info, io.BytesIO(record_bytes))
    return {"key": run.key, "exit_status": 0, "seconds": 1.0, "worker_pid": 1,
            "record_tar": buffer.getvalue(), "output": None}


def test_a_result_is_written_once_and_a_missing_record_is_retried(tmp_path):
    run = GridRun({"p": "a"}, {"motor": {}})
    assert store_result(tmp_path, run, _result(run)) is True
    assert store_result(tmp_path, run, _result(run, b"{}")) is False     # a late duplicate
    assert json.loads((tmp_path / "runs" / run.key / "record" / "record.json").read_text()) \
        == {"tests": []}
    assert done_keys(tmp_path) == {run.key}
    other = GridRun({"p": "b"}, {"motor": {"x": 1}})
    lost = _result(other) | {"record_tar": None, "exit_status": 6, "output": "no SDO answer"}
    assert store_result(tmp_path, other, lost) is False
    assert done_keys(tmp_path) == {run.key}                              # not done: rerun
    row = grid_row(tmp_path, other)
    assert row["state"] == "no record" and "no SDO answer" in row["output"]
    assert "0/1 done" in summary_table([row])
