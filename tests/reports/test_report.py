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
from reports import build_report, render_report
from reports.content import knob_display, swept_knobs, worst_decision


@pytest.fixture(scope="module")
def full_record(tmp_path_factory) -> Path:
    return write_record(tmp_path_factory.mktemp("records"), name="full")


@pytest.fixture(scope="module")
def partial_record(tmp_path_factory) -> Path:
    return write_record(tmp_path_factory.mktemp("records"), partial=True, name="partial")


@pytest.fixture(scope="module")
def full_pdf(full_record, tmp_path_factory) -> Path:
    return build_report(full_record, tmp_path_factory.mktemp("pdf") / "report.pdf")


def page_texts(pdf: Path) -> list[str]:
    return [page.extract_text() for page in pypdf.PdfReader(pdf).pages]


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
        found = re.findall(r"RHR-\d{8}T\d{6}Z-[0-9a-f]{6}-[0-9a-f]{8}", text)
        assert found, f"page {number} has no report ID"
        report_ids.update(found)
    assert len(report_ids) == 1
    assert report_ids.pop().startswith(f"RHR-{record['record_id']}-")
    assert "End of report" in pages[-1]
    assert all("End of report" not in text for text in pages[:-1])


def test_summary_states_conformity_per_source_and_overall(full_pdf):
    first = page_texts(full_pdf)[0]
    assert "Statement of conformity" in first
    for source, statement in (("dc_offset", "CONDITIONAL PASS"), ("dead_time", "FAIL"),
                              ("encoder", "NOT DETERMINED"), ("word_length", "NOT DETERMINED")):
        assert re.search(rf"{source}\s+\d+\s+.*{statement}", first), source
    assert "Overall: NOT DETERMINED" in first          # an error and a skip leave it open
    assert "SIM-MOTOR-1" in first and "ripple-fw 1.4.2" in first   # item tested, firmware


def test_instruments_verdicts_and_hashes_are_printed(full_record, full_pdf):
    record = load_record(full_record)
    text = "\n".join(page_texts(full_pdf))
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
    assert "every capture named in the record is present and its SHA-256 matches" in text
    assert "SDO abort 0x06090030" in text                # the errored test's reason
    assert "ideal current regulation" in text.lower()     # the paper's assumption, stated
    assert "Uncertainty budget" in text and "contrib.(pu)" in squeezed
    assert "throughhil.analysis.run_analysis(" in squeezed  # dead_time: capture re-analysed
    assert "Warning: analysing the raw capture again" not in text


def test_same_record_gives_the_same_pdf(full_record, full_pdf, tmp_path):
    again = build_report(full_record, tmp_path / "again.pdf")
    assert page_texts(again) == page_texts(full_pdf)
    assert again.read_bytes() == full_pdf.read_bytes()


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


def test_partial_record_says_so(partial_record, tmp_path):
    record = load_record(partial_record)
    assert record["status"] == "running"
    pdf = build_report(partial_record, tmp_path / "partial.pdf")
    pages = page_texts(pdf)
    assert all("PARTIAL RECORD" in text for text in pages)
    text = "\n".join(pages)
    assert "no overall statement of conformity" in text
    assert "Overall: NOT DETERMINED" in text
    pending = record["pending_captures"][0]
    assert pending["sha256"] in flat(text)
    assert "captured, not analysed" in text and "End of report" in pages[-1]


def test_altered_capture_and_disagreeing_reanalysis_are_reported(full_record, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(full_record, copy)
    data = json.loads((copy / "record.json").read_text())
    target = copy / data["tests"][0]["capture"]["file"]
    raw = bytearray(target.read_bytes())
    raw[len(raw) // 2] ^= 0xFF                       # a flipped byte in one raw capture
    target.write_bytes(bytes(raw))
    worst = max((t for t in data["tests"] if t["source"] == "dead_time"),
                key=lambda t: t["verdict"]["measured_pk_pk_pu"])
    worst["measured"]["pk_pk_pu"] *= 1.5            # as if another analysis version wrote it
    (copy / "record.json").write_text(json.dumps(data))
    rendered = render_report(copy)
    assert len(rendered.content.capture_problems) == 1
    text = "\n".join(page_texts(rendered.save(tmp_path / "altered.pdf")))
    assert "Capture check found problems" in text
    assert "Warning: analysing the raw capture again gives pk-pk" in text


def test_cli_writes_the_report(full_record, tmp_path, capsys):
    out = tmp_path / "cli.pdf"
    assert main(["report", str(full_record), "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["pdf"] == str(out) and out.is_file()
    assert summary["sources"] == {"dc_offset": "conditional pass", "dead_time": "fail",
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
    assert worst_decision(["pass", "conditional fail", "conditional pass"]) == "conditional fail"
    assert worst_decision(["pass", "not determined"]) == "not determined"
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
    assert "PARTIAL RECORD" in text and "status 'failed'" in text.replace("\n", " ")
    assert f"Page {len(pages)} of {len(pages)}" in pages[-1] and "End of report" in pages[-1]
