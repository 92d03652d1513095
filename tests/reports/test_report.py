"""The PDF report built from a recorded run: content by text extraction, determinism, rendering,
attachments, partial records, tampered captures and the ``hil report`` command."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pypdf
import pypdfium2
import pytest

from hil.cli import main
from hil.record import load_record
from record_factory import EXPECTED_DECISIONS, POINTS, write_record
from ripple_hil_reports import build_report, render_report
from ripple_hil_reports.content import knob_display, swept_knobs
from ripple_hil_reports.document import ZERO_WIDTH_SPACE, breakable


@pytest.fixture(scope="module")
def full_record(tmp_path_factory) -> Path:
    return write_record(tmp_path_factory.mktemp("records"), name="full")


@pytest.fixture(scope="module")
def partial_record(tmp_path_factory) -> Path:
    return write_record(tmp_path_factory.mktemp("records"), partial=True, name="partial")


@pytest.fixture(scope="module")
def full_pdf(full_record, tmp_path_factory) -> Path:
    return build_report(full_record, tmp_path_factory.mktemp("pdf") / "report.pdf")


def unissued(folder: Path) -> None:
    """A copied record as before any report was issued: the signed revision lines of
    record.sig cut off (its seal line kept), so that the test starts at Rev. 1."""
    sig = folder / "record.sig"
    sig.write_text(sig.read_text().splitlines(keepends=True)[0])


def page_texts(pdf: Path) -> list[str]:
    """Each page's text, without the zero-width spaces that mark break opportunities."""
    return [page.extract_text().replace(ZERO_WIDTH_SPACE, "")
            for page in pypdf.PdfReader(pdf).pages]


def flat(text: str) -> str:
    """Extracted text with line breaks removed (table cells wrap long ids)."""
    return re.sub(r"\s+", "", text)


def test_the_record_under_test_has_every_decision(full_record):
    decisions = [(t.get("verdict") or {}).get("decision") for t in load_record(full_record)["tests"]]
    assert decisions[:len(POINTS)] == EXPECTED_DECISIONS


def test_every_page_has_report_id_and_page_x_of_y(full_record, full_pdf):
    record = load_record(full_record)
    pages = page_texts(full_pdf)
    assert len(pages) >= 6
    report_ids = set()
    for number, text in enumerate(pages, start=1):
        assert f"Page {number} of {len(pages)}" in text
        found = re.findall(r"RHR-\d{8}T\d{6}Z-[0-9a-f]{6}-[0-9a-f]{8}-R1", text)
        assert found, f"page {number} has no report ID"
        report_ids.update(found)
    assert len(report_ids) == 1
    assert report_ids.pop().startswith(f"RHR-{record['record_id']}-")
    assert "End of report" in pages[-1]
    assert all("End of report" not in text for text in pages[:-1])


def test_page_one_states_the_four_verdicts_apart(full_pdf):
    first = flat_lines(page_texts(full_pdf)[0])
    assert "1. Requirements conformity no requirements given" in first
    # every source of the record, with its worst state: the skipped encoder test and the
    # errored word-length test make those sources NOT DETERMINED (page 1 = the record)
    # the dc-offset point inside its guard band failed its test (guarded rule): FAIL, as the
    # summary table and the exit status say
    assert ("2. Model validation (vs the paper) dc_offset: FAIL (2 pass, 1 fail); dead_time: FAIL (1 conditional fail, 1 fail); encoder: NOT "
            "DETERMINED (1 not determined); word_length: NOT DETERMINED (1 not determined)") \
        in first
    assert "3. Bench self-check not run" in first
    assert "4. Run status and integrity complete" in first and "every hash verifies" in first
    assert ("Overall: FAIL (4 test(s) failed or errored; the rest is not stated (not "
            "determined: encoder, word_length))") in first   # never PASS with failures
    assert "SIM-MOTOR-1" in first and "ripple-fw 1.4.2" in first   # item tested, firmware
    assert "results relate only to the item tested" in first
    assert "Signature:" in first and "Date:" in first and "Rev. 1" in first


def test_page_one_dates_the_report_by_its_issue_and_names_the_seal(full_record, full_pdf):
    """Issue 22 item 8: the report date is the date of issue (the revision's), not the record's
    last date; the seal line names the signing key or says there was none."""
    from ripple_hil_reports.revisions import issued

    first = flat_lines(page_texts(full_pdf)[0])
    printed = re.search(r"Report date (\d{4}-\d{2}-\d{2}) \(date of issue", first)
    assert printed, first
    logged = [entry for entry in issued(full_record) if entry.get("revision") == 1]
    assert logged and printed.group(1) == logged[0]["issued_utc"][:10]
    assert printed.group(1) != "2026-11-21"          # the record's own (test) dates
    assert "Seal Ed25519, key " in first


def flat_lines(text: str) -> str:
    return re.sub(r"\s+", " ", text)


def test_instruments_verdicts_and_hashes_are_printed(full_record, full_pdf):
    record = load_record(full_record)
    text = flat_lines("\n".join(page_texts(full_pdf)))
    for row in record["instruments"]:
        assert row["serial_number"] in text and row["model"] in text
    assert "0.1 % FS" in text
    for decision in ("pass", "conditional pass", "conditional fail", "fail"):
        assert re.search(rf"\b{decision}\b", text)
    squeezed = flat(text)
    for test in record["tests"]:
        if test["capture"]:
            assert test["capture"]["sha256"] in squeezed
    assert record["bench"]["sha256"] in squeezed
    assert record["software"]["packages"]["numpy"] in text
    assert "every capture named in the record is present and its SHA-256 matches" in \
        flat_lines(text)
    assert "SDO abort 0x06090030" in text                # the errored test's reason
    assert "ideal current regulation" in text.lower()     # the paper's assumption, stated
    assert "Uncertainty budget" in text and "contrib.(pu)" in squeezed
    assert "throughhil.analysis.run_analysis(" in squeezed  # dead_time: capture re-analysed
    assert "Warning: analysing the raw capture again" not in text


def test_same_record_and_revision_give_the_same_pdf(full_record, full_pdf):
    assert render_report(full_record).pdf == full_pdf.read_bytes()


def test_page_one_renders(full_pdf, tmp_path):
    document = pypdfium2.PdfDocument(str(full_pdf))
    image = document[0].render(scale=1.0).to_pil().convert("L")
    image.save(tmp_path / "page1.png")
    pixels = np.asarray(image)
    assert abs(pixels.shape[0] - 842) <= 1 and abs(pixels.shape[1] - 595) <= 1  # A4, 72 dpi
    assert (pixels < 128).mean() > 0.01                   # text is drawn, not a blank page
    document.close()


def test_plots_are_vector(full_pdf):
    reader = pypdf.PdfReader(full_pdf)
    for page in reader.pages:
        resources = page.get("/Resources") or {}
        xobjects = resources.get("/XObject") or {}
        for name in xobjects:
            assert xobjects[name].get_object().get("/Subtype") != "/Image"


def test_record_and_captures_are_attached(full_record, full_pdf):
    attachments = pypdf.PdfReader(full_pdf).attachments
    assert attachments["record.json"][0] == (full_record / "record.json").read_bytes()
    record = load_record(full_record)
    for test in record["tests"]:
        if test["capture"]:
            name = test["capture"]["file"].replace("/", "_")
            assert attachments[name][0] == (full_record / test["capture"]["file"]).read_bytes()


def test_partial_record_says_so(partial_record, tmp_path, capsys):
    record = load_record(partial_record)
    assert record["status"] == "running"
    assert main(["verify", str(partial_record)]) == 1            # never sealed: not intact
    out = capsys.readouterr().out
    assert "not sealed (the run never finished" in out and "intact" not in out
    assert "capture(s) match their SHA-256" in out
    pdf = build_report(partial_record, tmp_path / "partial.pdf")
    pages = page_texts(pdf)
    assert all("INCOMPLETE RUN (running)" in text for text in pages)
    assert "NOT SEALED: the run never finished" in flat_lines(pages[0])
    text = flat_lines("\n".join(pages))
    assert "no overall statement of conformity" in text
    # a failure that happened is stated in any run status; the rest is not
    assert "Overall: FAIL (1 test(s) failed or errored; the rest is not stated (never finished" \
        in text
    pending = record["pending_captures"][0]
    assert pending["sha256"] in flat(text)
    assert "captured, not analysed" in text and "End of report" in pages[-1]


def test_tampered_record_is_invalid_on_page_one(full_record, tmp_path, capsys):
    """One byte flipped in a capture, another capture deleted, a verdict edited in record.json:
    page 1 says INVALID and names the files; hil report and hil verify exit 1."""
    copy = tmp_path / "copy"
    shutil.copytree(full_record, copy)
    unissued(copy)
    data = json.loads((copy / "record.json").read_text())
    flipped = copy / data["tests"][0]["capture"]["file"]
    raw = bytearray(flipped.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    flipped.write_bytes(bytes(raw))
    deleted = copy / data["tests"][1]["capture"]["file"]
    deleted.unlink()
    rendered = render_report(copy)
    assert rendered.content.overall == "INVALID"
    first = flat_lines(page_texts(rendered.save(tmp_path / "tampered.pdf"))[0])
    assert "Overall: INVALID" in first and "INVALID - a hash does not verify" in first
    assert flipped.name in flat(first) and deleted.name in flat(first)
    assert main(["verify", str(copy)]) == 1
    out = capsys.readouterr().out
    assert "INVALID (2 problem(s))" in out and deleted.name in out
    assert main(["report", str(copy), "-o", str(tmp_path / "cli.pdf")]) == 1
    assert "INVALID record" in capsys.readouterr().err
    # an edited verdict breaks the seal of record.json itself
    text = (copy / "record.json").read_text().replace('"conditional fail"', '"pass"')
    (copy / "record.json").write_text(text)
    assert "changed after the run finished" in render_report(copy).content.capture_problems[0]


def test_disagreeing_reanalysis_is_reported(full_record, tmp_path):
    from hil.record import SEAL_FILE, _sha256_file

    copy = tmp_path / "copy"
    shutil.copytree(full_record, copy)
    data = json.loads((copy / "record.json").read_text())
    worst = max((t for t in data["tests"] if t["source"] == "dead_time"),
                key=lambda t: t["verdict"]["measured_pk_pk_pu"])
    worst["measured"]["pk_pk_pu"] *= 1.5            # as if another analysis version wrote it
    (copy / "record.json").write_text(json.dumps(data))
    (copy / SEAL_FILE).write_text(f"{_sha256_file(copy / 'record.json')}  record.json\n")
    text = "\n".join(page_texts(render_report(copy).save(tmp_path / "altered.pdf")))
    assert "Warning: analysing the raw capture again gives pk-pk" in text


def test_a_second_report_is_a_new_revision(full_record, tmp_path, capsys):
    copy = tmp_path / "copy"
    shutil.copytree(full_record, copy)
    unissued(copy)
    assert main(["report", str(copy)]) == 0
    first = page_texts(copy / "report.pdf")[0]
    assert main(["report", str(copy)]) == 2                      # no reason: refused
    assert "give --reason TEXT to issue Rev. 2" in capsys.readouterr().err
    assert main(["report", str(copy), "-o", str(copy / "report.pdf"), "--reason", "x"]) == 2
    assert "never overwritten" in capsys.readouterr().err
    assert main(["report", str(copy), "--reason", "customer address corrected", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["revision"] == 2 and summary["report_id"].endswith("-R2")
    second = flat_lines(page_texts(Path(summary["pdf"]))[0])
    assert "Rev. 2" in second and "customer address corrected" in second
    assert re.search(r"RHR-\S+-R1", first) and "supersedes RHR-" in second


def test_cli_writes_the_report(full_record, tmp_path, capsys):
    out = tmp_path / "cli.pdf"
    copy = tmp_path / "copy"
    shutil.copytree(full_record, copy)
    unissued(copy)
    assert main(["report", str(copy), "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["pdf"] == str(out) and out.is_file() and summary["overall"] == "FAIL"
    assert summary["sources"] == {"dc_offset": "fail", "dead_time": "fail",
                                  "encoder": "not determined", "word_length": "not determined"}
    assert summary["pages"] == len(page_texts(out))
    assert main(["report", str(tmp_path / "missing")]) == 2
    assert "cannot read record.json" in capsys.readouterr().err


def test_content_helpers():
    assert swept_knobs([{"ia_offset_a": 0.1, "ib_offset_a": 0.0},
                        {"ia_offset_a": 0.2, "ib_offset_a": 0.0}]) == ["ia_offset_a"]
    assert swept_knobs([{"ia_offset_a": 0.1, "ib_offset_a": 0.0},
                        {"ia_offset_a": 0.0, "ib_offset_a": 0.1}]) == ["ia_offset_a",
                                                                       "ib_offset_a"]
    assert swept_knobs([{"dead_time_s": 2e-6}]) == ["dead_time_s"]
    assert swept_knobs([{}]) == []
    assert swept_knobs([{"encoder_decimation": 100, "hall_mode": False},
                        {"encoder_decimation": 1, "hall_mode": True}]) == ["encoder_decimation",
                                                                           "hall_mode"]
    assert knob_display("dead_time_s", [1e-6, 2e-6]) == ("dead_time (µs)", 1e6)
    assert knob_display("ia_gain_error_pu", [0.01]) == ("ia_gain_error (%)", 100.0)
    assert knob_display("word_length_bits", [8]) == ("word_length (bits)", 1.0)


def test_a_record_without_any_test_still_gives_a_report(tmp_path):
    from hil.config import default_sim_bench
    from hil.record import RunRecord
    record = RunRecord.create(tmp_path, default_sim_bench(), [], name="empty")
    record.finish("failed")
    pages = page_texts(build_report(record.path, tmp_path / "empty.pdf"))
    text = "\n".join(pages)
    assert "INCOMPLETE RUN (failed)" in text and "internal error" in flat_lines(text)
    assert f"Page {len(pages)} of {len(pages)}" in pages[-1] and "End of report" in pages[-1]


@pytest.fixture(scope="module")
def extras_pdf(tmp_path_factory) -> Path:
    record = write_record(tmp_path_factory.mktemp("records"), name="extras", extras=True)
    return build_report(record, tmp_path_factory.mktemp("pdf") / "extras.pdf")


def test_page_one_carries_the_17025_content_and_every_statement(extras_pdf):
    first = flat_lines(page_texts(extras_pdf)[0])
    assert "SIMULATED DRIVE WITH TEST-ONLY DEFECTS: hidden_ia_offset_a = 0.5" in first
    assert "Customer ACME Drives GmbH" in first
    assert "Item received 2026-11-20" in first and "Environment 23 °C, 45 % RH" in first
    assert "Operator A. Tester (given on the command line)" in first
    assert "Authorized by: Dr. B. Signer, head of laboratory" in first
    assert "1. Requirements conformity FAIL: REQ-9" in first and "demonstration" in first
    assert "3. Bench self-check PASS" in first
    assert "Command line hil run --requirements spec.toml" in first


def test_requirements_map_and_self_check_sections(extras_pdf):
    text = flat_lines("\n".join(page_texts(extras_pdf)))
    assert re.search(r"REQ-1 total ripple ≤ 30.0 %.*PASS", text)
    assert "FAIL (demonstration)" in text
    assert "torque scale" in text and "pk-pk torque ripple over speed × current" in text
    assert "3.10 %" in text and "order 12" in text          # a heat-map cell and its order


def test_a_failed_self_check_voids_the_other_statements(tmp_path):
    record = write_record(tmp_path, name="bad-bench", extras=True, self_check_passes=False)
    pages = [flat_lines(text) for text in page_texts(build_report(record, tmp_path / "r.pdf"))]
    first = pages[0]
    assert "3. Bench self-check FAILED: the other verdicts of this run are not stated" in first
    assert ("1. Requirements conformity NOT STATED (voided by the failed bench self-check)"
            in first)
    assert ("2. Model validation (vs the paper) NOT STATED (voided by the failed bench "
            "self-check)" in first)
    assert "PASS" not in first.split("Statements", 1)[1].split("Overall")[0]
    assert "Overall: NOT STATED (bench self-check FAILED" in first
    later = " ".join(pages[1:])
    assert "every point meets its acceptance limits" not in later
    assert later.count("NOT STATED: the bench self-check failed or did not complete") >= 2


def test_long_tokens_break_only_after_separators():
    assert breakable("short words stay whole") == "short words stay whole"
    marked = breakable("test_dc_offset[ia_offset_a=0.2]")
    assert marked.replace(ZERO_WIDTH_SPACE, "") == "test_dc_offset[ia_offset_a=0.2]"
    for piece in marked.split(ZERO_WIDTH_SPACE)[:-1]:
        assert piece[-1] in "_/=,[-:"


def test_wide_sweeps_get_a_log_axis_and_spectra_are_in_db(tmp_path):
    from datetime import datetime, timezone

    from ripple_hil_reports import figures
    from ripple_hil_reports.content import Point, SourceSection
    from ripple_hil_reports.document import ReportPDF

    def point(x, measured):
        return Point(test_id=f"t{x}", outcome="passed", x=x, label=f"d = {x}",
                     measured_pu=measured, u_pu=measured / 10, predicted_pu=measured,
                     predicted_order=None, lower_pu=None, upper_pu=None, decision="pass")

    pdf = ReportPDF("RHR-test", datetime(2026, 1, 1, tzinfo=timezone.utc), False)
    pdf.add_page()
    hall_beside_encoder = SourceSection("encoder", ["encoder_decimation"],
                                        [point(1, 0.002), point(10, 0.01), point(100, 0.3)],
                                        "pass", None)
    narrow = SourceSection("dc_offset", ["ia_offset_a"], [point(1, 0.02), point(2, 0.04)],
                           "pass", None)
    assert figures.sweep(pdf, hall_beside_encoder) and figures.sweep(pdf, narrow)
    figures.spectrum(pdf, np.arange(0, 13), np.r_[0.0, 1e-4, 0.05, np.full(10, 1e-5)], 2.0,
                     "spectrum")
    (tmp_path / "plots.pdf").write_bytes(bytes(pdf.output()))
    text = page_texts(tmp_path / "plots.pdf")[0]
    assert text.count("(log axis)") == 1
    assert "dB re the largest order" in text and "-80" in text


def test_environment_from_the_lab_or_a_daq_channel():
    from ripple_hil_reports.build import environment_text

    assert environment_text({"tests": []}, {"environment": "23 °C, 45 % RH"}) == "23 °C, 45 % RH"
    measured = {"tests": [{"operating_point": {"temperature_c": 24.0}},
                          {"measured": {"temperature_c": 26.5}}, {"operating_point": {}}]}
    assert environment_text(measured, {}).startswith("temperature 24.0 to 26.5 °C")
    assert environment_text({"tests": [{}]}, {}) == "not recorded"


def test_a_test_without_a_model_verdict_does_not_make_its_source_undetermined():
    from hil.outcome_kinds import MEASURED
    from ripple_hil_reports.content import NO_VERDICT, _section

    judged = {"test_id": "a", "outcome": "passed", "injection": {"x_a": 1.0},
              "verdict": {"decision": "pass", "measured_pk_pk_pu": 0.01}}
    sensitivity = {"test_id": "b", "outcome": "passed", "injection": {}}
    reference = {"test_id": "r", "outcome": MEASURED, "injection": {}}
    errored = {"test_id": "c", "outcome": "error", "injection": {}}
    assert _section("s", [judged, sensitivity, reference]).statement == "pass"
    assert _section("s", [reference]).statement == MEASURED
    assert [p.decision for p in _section("s", [reference]).points] == [NO_VERDICT]
    assert _section("s", [judged, sensitivity, errored]).statement == "not determined"
