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


#: A piece that continues the previous one without a space (a long token split in two).
_JOINED = "\u2060"


def _pieces(word: str, width_mm: float, measure) -> list[str]:
    """``word`` as it may be placed on lines: whole if it fits, else split after break
    characters, else (no break character) by characters; continuation pieces carry
    :data:`_JOINED` so that no space is put before them (removed when drawn)."""
    if measure(word) <= width_mm or len(word) <= 1:
        return [word]
    parts = [p for p in breakable(word, always=True).split(ZERO_WIDTH_SPACE) if p]
    out = []
    for part in parts:
        while measure(part) > width_mm and len(part) > 1:
            cut = max(1, next((n for n in range(len(part), 0, -1)
                               if measure(part[:n]) <= width_mm), 1))
            out.append(part[:cut])
            part = part[cut:]
        out.append(part)
    return [out[0]] + [_JOINED + piece for piece in out[1:]]


def breakable(text: str, *, always: bool = False) -> str:
    """``text`` with a zero-width space after each break opportunity inside long tokens (every
    token with ``always``)."""
    return re.sub(r"\S{%d,}" % (1 if always else LONG_TOKEN + 1),
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
        self.lines(text, size, "B", size * 0.5)
        self.ln(1)
        self.set_font("sans", "", 8.5)

    def para(self, text: str, size: float = 8.5, style: str = "") -> None:
        self.lines(text, size, style, size * 0.47)
        self.ln(1)
        self.set_font("sans", "", 8.5)

    def bullets(self, items: list[str], size: float = 8.0) -> None:
        indent = 3.5
        for item in items:
            self.lines(item, size, "", size * 0.47, indent=indent, bullet="•")
            self.ln(0.6)
        self.ln(1)
        self.set_font("sans", "", 8.5)

    def lines(self, text: str, size: float, style: str, line_h: float, indent: float = 0.0,
              bullet: str | None = None) -> None:
        """``text`` wrapped to the text width (less ``indent``), drawn line by line with page
        breaks; ``bullet`` is drawn in the indent of the first line."""
        width = self.w - self.l_margin - self.r_margin - indent
        wrapped = self.wrap(text, width, "sans", style, size)
        self.set_font("sans", style, size)
        for number, line in enumerate(wrapped):
            if self.get_y() + line_h > self.h - self.b_margin:
                self.add_page()
                self.set_font("sans", style, size)
            y = self.get_y()
            if bullet and number == 0:
                self.text(self.l_margin + 0.5, y + 0.8 * line_h, bullet)
            self.text(self.l_margin + indent, y + 0.8 * line_h, line)
            self.set_y(y + line_h)

    def key_values(self, rows: list[tuple[str, str]], key_width: float = 48) -> None:
        self.grid(["", ""], [[k, v] for k, v in rows], widths=(key_width, 0), header=False)

    def grid(self, headings: list[str], rows: list[list[str]], widths: tuple = (),
             header: bool = True, size: float = 7.5, mono_columns: tuple[int, ...] = ()) -> None:
        """A table; ``widths`` in mm (0 = share the rest); mono columns for hashes and ids.

        Laid out here (not with fpdf2's table, whose per-character line breaking was most of the
        report's time): each cell wraps at spaces, a long token after ``_ / = , [ - :``, and
        only a token with none of those mid-word; a row that does not fit starts a new page
        with the header repeated."""
        if not rows:
            self.para("(none)", size)
            return
        usable = self.w - self.l_margin - self.r_margin
        widths = list(widths) or [0] * len(rows[0])
        rest = usable - sum(widths)
        zeros = widths.count(0) or 1
        widths = [w or rest / zeros for w in widths]
        pad, line_h = 0.8, size * 0.5
        fonts = [("mono", "", size - 0.8) if i in mono_columns else ("sans", "", size)
                 for i in range(len(widths))]

        def layout(values, bold=False):
            cells = []
            for index, text in enumerate(values):
                family, style, points = fonts[index] if not bold else ("sans", "B", size)
                cells.append(((family, style, points),
                              self.wrap(str(text), widths[index] - 2 * pad, family, style,
                                        points)))
            return cells, max(len(lines) for _, lines in cells) * line_h + 2 * pad

        def draw(cells, height, rule_below):
            x, y = self.l_margin, self.get_y()
            for (font, lines), width in zip(cells, widths):
                self.set_font(*font)
                for number, line in enumerate(lines):
                    self.text(x + pad, y + pad + (number + 0.78) * line_h, line)
                x += width
            if rule_below:
                self.set_draw_color(90 if bold_rule[0] else 190)
                self.set_line_width(0.2)
                self.line(self.l_margin, y + height, self.l_margin + usable, y + height)
                self.set_draw_color(0)
            self.set_y(y + height)

        bold_rule = [False]
        head = layout(headings, bold=True) if header else None
        limit = self.h - self.b_margin

        def draw_head():
            bold_rule[0] = True
            draw(*head, rule_below=True)
            bold_rule[0] = False

        if head is not None:
            if self.get_y() + head[1] + layout(rows[0])[1] > limit:
                self.add_page()
            draw_head()
        for values in rows:
            cells, height = layout(values)
            if self.get_y() + height > limit:
                self.add_page()
                if head is not None:
                    draw_head()
            draw(cells, height, rule_below=header)
        self.set_font("sans", "", 8.5)
        self.ln(2)

    def wrap(self, text: str, width_mm: float, family: str = "sans", style: str = "",
             size: float = 8.5) -> list[str]:
        """``text`` in lines no wider than ``width_mm`` (explicit newlines kept)."""
        measure = self._measure(family, style, size)
        space = measure(" ")
        out = []
        for paragraph in text.replace(ZERO_WIDTH_SPACE, "").split("\n"):
            line, used = "", 0.0
            for word in paragraph.split(" "):
                for piece in _pieces(word, width_mm, measure):
                    joined = piece.startswith(_JOINED)
                    piece = piece.removeprefix(_JOINED)
                    glue = "" if not line or joined else " "
                    width = measure(piece)
                    if line and used + (space if glue else 0.0) + width > width_mm:
                        out.append(line)
                        line, used = piece, width
                    else:
                        line += glue + piece
                        used += (space if glue else 0.0) + width
            out.append(line)
        return out or [""]

    def _measure(self, family: str, style: str, size: float):
        """A cached width function (mm) for one font and size."""
        key = (family, style, size)
        cached = self._measures.get(key) if hasattr(self, "_measures") else None
        if cached is not None:
            return cached
        if not hasattr(self, "_measures"):
            self._measures = {}
        self.set_font(family, style, size)
        widths = self.current_font.cw
        scale = size * 0.001 / self.k
        words: dict[str, float] = {}

        def char(c: str) -> float:
            try:
                return widths[ord(c)] or 0
            except (IndexError, KeyError):
                return 600               # a glyph the font lacks: about one digit wide

        def measure(text: str) -> float:
            value = words.get(text)
            if value is None:
                value = words[text] = scale * sum(char(c) for c in text)
            return value

        self._measures[key] = measure
        return measure

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
