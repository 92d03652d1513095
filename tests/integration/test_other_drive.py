"""`hil run` on a simulated drive whose objects differ from ripple-hil's (tests/data/other_drive):
the plans go through its drive profile and its EDS over the real CANopen stacks; a plan whose knob
it has passes, a plan whose knob it lacks is not determinable with the knob named, a faulty
profile stops the run at connect with one line. (The full plan set: docs/drive-profile.md.)"""

import subprocess
import sys
from pathlib import Path

from hil.record import load_record

HIL = [sys.executable, "-m", "hil"]
REPO = Path(__file__).resolve().parents[2]
OTHER = REPO / "tests" / "data" / "other_drive"


def bench_file(tmp_path: Path, profile: Path) -> Path:
    text = (REPO / "hil" / "examples" / "sim-bench.toml").read_text()
    path = tmp_path / "bench.toml"
    path.write_text(text.replace("[drive]\n", f"[drive]\neds = \"{OTHER / 'eps_drive.eds'}\"\n"
                                 f"profile = \"{profile}\"\n", 1))
    return path


def run(tmp_path: Path, profile: Path, *sources: str) -> subprocess.CompletedProcess:
    selection = [arg for source in sources for arg in ("--source", source)]
    return subprocess.run(HIL + ["run", "--bench", str(bench_file(tmp_path, profile)), *selection,
                                 "--record-dir", str(tmp_path / "records"), "--no-report"],
                          capture_output=True, text=True, timeout=600, cwd=tmp_path)


def test_injection_plans_pass_where_the_drive_can_inject_and_are_refused_where_it_cannot(tmp_path):
    done = run(tmp_path, OTHER / "eps_drive_profile.toml", "gain_mismatch", "word_length")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    record = load_record(next((tmp_path / "records").iterdir()))
    gain = [t for t in record["tests"] if t["source"] == "gain_mismatch" and t.get("verdict")]
    assert len(gain) == 3 and all(t["verdict"]["decision"] == "pass" for t in gain)
    # the Q15 gain trims took the plan's values to within one count (1/32768)
    assert all(abs(t["injection"]["ia_gain_error_pu"]) in (0.01, 0.02) for t in gain)
    word = [t for t in record["tests"] if t["nodeid"].startswith("testplans/test_word_length.py"
                                                                   "::test_word_length[")]
    assert len(word) == 3 and {t["outcome"] for t in word} == {"not determinable"}
    assert {t["message"] for t in word} == {
        "not determinable here: the drive under test has no word_length_bits"}


def test_a_profile_naming_a_missing_object_fails_at_connect_with_one_line(tmp_path):
    bad = tmp_path / "bad_profile.toml"
    bad.write_text((OTHER / "eps_drive_profile.toml").read_text().replace(
        'type = "INTEGER32"', 'type = "UNSIGNED32"', 1))
    done = run(tmp_path, bad, "baseline")
    assert done.returncode != 0
    line = ("drive profile bad_profile.toml: knobs.ia_offset_a: object 0x3000:01 is INTEGER32 in "
            "the EDS eps_drive.eds, the profile says UNSIGNED32")
    assert line in done.stderr + done.stdout, done.stdout[-2000:] + done.stderr[-2000:]


def test_a_drive_with_no_injection_still_runs_the_self_check_and_the_baseline(tmp_path):
    done = run(tmp_path, OTHER / "no_injection_profile.toml", "self_check", "baseline",
               "dc_offset")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    record = load_record(next((tmp_path / "records").iterdir()))
    outcome = {t["nodeid"].split("::")[-1]: (t["outcome"], t.get("message")) for t in
               record["tests"]}
    assert outcome["test_bench_self_check"][0] == outcome["test_angle_reference"][0] == "passed"
    assert outcome["test_baseline"][0] == "passed"
    assert outcome["test_transducer_dynamics"] == (
        "not determinable", "not determinable here: transducer dynamics: the drive under test "
        "has no ia_gain_error_pu; the drive under test has no ib_gain_error_pu, which gives its "
        "known test ripple (a gain mismatch's order 2)")
    offsets = [o for name, o in outcome.items() if name.startswith("test_dc_offset[")]
    assert len(offsets) == 5 and all(o[0] == "not determinable" and "has no i" in o[1]
                                     for o in offsets)

