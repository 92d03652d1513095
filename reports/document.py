"""The PDF layout (fpdf2): header and footer on every page, sections, tables and vector plots.

fpdf2 rather than ReportLab: it is installed already, pure Python, imports matplotlib's SVG as
vector paths, embeds files as PDF/A-3 associated files, replaces the total page count alias, and
lets us fix the creation date and file ID, so one record always gives the same PDF.
"""

from __future__ import annotations

import io
import logging
from datetime import datetime
from pathlib import Path

import matplotlib
from fpdf import FPDF
from fpdf.enums import XPos, YPos

TITLE = "Controller-induced torque ripple: test report"
_FONT_DIR = Path(matplotlib.get_data_path()) / "fonts" / "ttf"
_FONTS = {("sans", ""): "DejaVuSans.ttf", ("sans", "B"): "DejaVuSans-Bold.ttf",
          ("sans", "I"): "DejaVuSans-Oblique.ttf", ("mono", ""): "DejaVuSansMono.ttf"}
logging.getLogger("fpdf.svg").setLevel(logging.ERROR)


class ReportPDF(FPDF):
    """A4 pages with the title, report ID and "Page x of y" on each."""

    def __init__(self, report_id: str, created: datetime, partial: bool) -> None:
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
        self.cell(0, 4, f"Report ID: {self.report_id}"
                        + ("    PARTIAL RECORD - run not complete" if self.partial else ""))
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
                        row.cell(str(text))
        self.ln(2)

    def svg(self, data: bytes | None, caption: str = "") -> None:
        if data is None:
            return
        width = self.w - self.l_margin - self.r_margin
        self.image(io.BytesIO(data), w=width)
        if caption:
            self.para(caption, size=7, style="I")


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
