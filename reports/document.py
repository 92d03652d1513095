"""The PDF layout (fpdf2): header and footer on every page, sections, tables; plots are drawn
with fpdf2's primitives (``reports.plot``).

fpdf2 rather than ReportLab: it is installed already, pure Python, embeds files as PDF/A-3
associated files, replaces the total page count alias, and lets us fix the creation date and
file ID, so one record always gives the same PDF. Table cells may break after ``_ / = , [ ( -``
(a zero-width space is inserted there), never in the middle of a word.
"""

from __future__ import annotations

import importlib.util
import re
from datetime import datetime
from pathlib import Path

from fpdf import FPDF
from fpdf.enums import XPos, YPos

TITLE = "Controller-induced torque ripple: test report"
# matplotlib's DejaVu fonts, found without importing matplotlib (~0.3 s)
_FONT_DIR = (Path(importlib.util.find_spec("matplotlib").submodule_search_locations[0])
             / "mpl-data" / "fonts" / "ttf")
#: Characters after which a table cell may break a long token (ids, knob names, paths).
_BREAK_AFTER = re.compile(r"([_/=,\[\-:])(?=\S)")
#: Tokens longer than this get break opportunities (shorter ones wrap as whole words).
LONG_TOKEN = 18
ZERO_WIDTH_SPACE = "\u200b"


def breakable(text: str) -> str:
    """``text`` with a zero-width space after each break opportunity inside long tokens."""
    return re.sub(r"\S{%d,}" % (LONG_TOKEN + 1),
                  lambda m: _BREAK_AFTER.sub(lambda b: b.group(1) + ZERO_WIDTH_SPACE, m.group(0)),
                  text)
_FONTS = {("sans", ""): "DejaVuSans.ttf", ("sans", "B"): "DejaVuSans-Bold.ttf",
          ("sans", "I"): "DejaVuSans-Oblique.ttf", ("mono", ""): "DejaVuSansMono.ttf"}


class ReportPDF(FPDF):
    """A4 pages with the title, report ID and "Page x of y" on each."""

    def __init__(self, report_id: str, created: datetime, partial: bool | str) -> None:
        super().__init__(orientation="P", unit="mm", format="A4",
                         enforce_compliance="PDF/A-3B")
        self.report_id = report_id
        self.partial = partial
        for (family, style), file in _FONTS.items():
            self.add_font(family, style, str(_FONT_DIR / file))
        self.set_creation_date(created)
        self.set_xmp_metadata(_xmp(report_id, created))
        self.set_title(f"{TITLE} {report_id}")
        self.set_subject("Torque ripple measured against the closed-form predictions of Chen, "
                         "Namuduri and Mir, IEEE TIA 38(5), 2002")
        self.set_creator("ripple-hil")
        self.set_producer("ripple-hil with fpdf2")
        self.set_lang("en")
        self.alias_nb_pages()
        self.set_auto_page_break(auto=True, margin=18)
        self.set_margins(16, 20, 16)

    def header(self) -> None:
        self.set_font("sans", "", 7.5)
        self.set_text_color(80)
        self.set_xy(self.l_margin, 8)
        self.cell(0, 4, TITLE, new_x=XPos.LMARGIN, new_y=YPos.NEXT)
        banner = self.partial if isinstance(self.partial, str) else \
            "PARTIAL RECORD - run not complete" if self.partial else ""
        self.cell(0, 4, f"Report ID: {self.report_id}" + (f"    {banner}" if banner else ""))
        self.set_draw_color(160)
        self.line(self.l_margin, 17, self.w - self.r_margin, 17)
        self.set_text_color(0)
        self.set_y(20)

    def footer(self) -> None:
        self.set_y(-12)
        self.set_font("sans", "", 7.5)
        self.set_text_color(80)
        self.cell(0, 5, f"{self.report_id}    Page {self.page_no()} of {{nb}}", align="C")
        self.set_text_color(0)

    # ------------------------------------------------------------------ building blocks
    def heading(self, text: str, level: int = 1, keep_with_mm: float = 30) -> None:
        """A heading, moved to a new page unless ``keep_with_mm`` of what follows fits."""
        size = {1: 13, 2: 11, 3: 9.5}[level]
        if self.get_y() > self.h - self.b_margin - 15 - keep_with_mm:
            self.add_page()
        self.ln(2 if level > 1 else 3)
        self.set_font("sans", "B", size)
        self.multi_cell(0, size * 0.5, text, align="L", new_x=XPos.LMARGIN, new_y=YPos.NEXT)
        self.ln(1)
        self.set_font("sans", "", 8.5)

    def para(self, text: str, size: float = 8.5, style: str = "") -> None:
        self.set_font("sans", style, size)
        self.multi_cell(0, size * 0.47, text, align="L", new_x=XPos.LMARGIN, new_y=YPos.NEXT)
        self.ln(1)
        self.set_font("sans", "", 8.5)

    def bullets(self, items: list[str], size: float = 8.0) -> None:
        self.set_font("sans", "", size)
        for item in items:
            self.multi_cell(0, size * 0.47, f"•  {item}", align="L", new_x=XPos.LMARGIN,
                            new_y=YPos.NEXT)
            self.ln(0.6)
        self.ln(1)

    def key_values(self, rows: list[tuple[str, str]], key_width: float = 48) -> None:
        self.grid(["", ""], [[k, v] for k, v in rows], widths=(key_width, 0), header=False)

    def grid(self, headings: list[str], rows: list[list[str]], widths: tuple = (),
             header: bool = True, size: float = 7.5, mono_columns: tuple[int, ...] = ()) -> None:
        """A table; ``widths`` in mm (0 = share the rest); mono columns for hashes and ids."""
        if not rows:
            self.para("(none)", size)
            return
        usable = self.w - self.l_margin - self.r_margin
        widths = list(widths) or [0] * len(rows[0])
        rest = usable - sum(widths)
        zeros = widths.count(0) or 1
        widths = [w or rest / zeros for w in widths]
        self.set_font("sans", "", size)
        with self.table(col_widths=widths, width=usable, first_row_as_headings=header,
                        line_height=size * 0.5, text_align="LEFT", padding=0.8,
                        borders_layout="HORIZONTAL_LINES" if header else "NONE") as table:
            if header:
                row = table.row()
                for text in headings:
                    row.cell(text)
            for values in rows:
                row = table.row()
                for index, text in enumerate(values):
                    if index in mono_columns:
                        self.set_font("mono", "", size - 0.8)
                        row.cell(str(text))
                        self.set_font("sans", "", size)
                    else:
                        row.cell(breakable(str(text)))
        self.ln(2)

    def caption(self, text: str) -> None:
        self.para(text, size=7, style="I")

    def signature_line(self, label: str) -> None:
        """``label`` then a line to sign on and a date line."""
        self.ln(6)
        self.set_font("sans", "", 8.5)
        y = self.get_y()
        self.text(self.l_margin, y, label)
        self.line(self.l_margin + 60, y + 0.5, self.l_margin + 120, y + 0.5)
        self.text(self.l_margin + 124, y, "Date:")
        self.line(self.l_margin + 134, y + 0.5, self.w - self.r_margin, y + 0.5)
        self.ln(4)


def _xmp(report_id: str, created: datetime) -> str:
    """XMP with the PDF/A-3B identification and the record's date (fpdf2's uses 'now')."""
    stamp = created.isoformat(timespec="seconds")
    return (
        '<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF '
        'xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#" '
        'xmlns:dc="http://purl.org/dc/elements/1.1/" xmlns:xmp="http://ns.adobe.com/xap/1.0/" '
        'xmlns:pdf="http://ns.adobe.com/pdf/1.3/" xmlns:pdfaid="http://www.aiim.org/pdfa/ns/id/">'
        f'<rdf:Description rdf:about="" xmp:CreatorTool="ripple-hil" xmp:CreateDate="{stamp}" '
        f'xmp:ModifyDate="{stamp}" xmp:MetadataDate="{stamp}" pdf:Producer="ripple-hil with fpdf2">'
        '<pdfaid:part>3</pdfaid:part><pdfaid:conformance>B</pdfaid:conformance>'
        f'<dc:title><rdf:Alt><rdf:li xml:lang="x-default">{TITLE} {report_id}</rdf:li>'
        '</rdf:Alt></dc:title></rdf:Description></rdf:RDF></x:xmpmeta>')
