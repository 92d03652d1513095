"""Plots drawn straight into the PDF with fpdf2's vector primitives (lines, rectangles, text).

No matplotlib → SVG → PDF round trip (issue 17 item 2: that parse was ~70 % of the report's
time): a plot is a frame with nice ticks on a linear or log axis, and series drawn as polylines,
markers, error bars or stems; long series are decimated to at most :data:`MAX_POINTS` vertices
(min/max per bucket, so peaks survive). Everything stays vector.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: Most vertices of one drawn polyline (min and max of each bucket are kept).
MAX_POINTS = 1200
COLOURS = {"blue": (31, 119, 180), "orange": (255, 127, 14), "red": (214, 39, 40),
           "grey": (170, 170, 170), "green": (44, 160, 44), "black": (0, 0, 0)}


def nice_ticks(lo: float, hi: float, count: int = 6) -> list[float]:
    """Round tick values covering [lo, hi] (1, 2, 2.5, 5 × 10^n steps)."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [lo]
    raw = (hi - lo) / max(1, count - 1)
    power = 10 ** math.floor(math.log10(raw))
    step = next(m * power for m in (1, 2, 2.5, 5, 10) if m * power >= raw)
    first = math.ceil(lo / step - 1e-9) * step
    ticks, value = [], first
    while value <= hi + 1e-9 * step:
        ticks.append(round(value, 12))
        value += step
    return ticks


def log_ticks(lo: float, hi: float) -> list[float]:
    """Decades covering [lo, hi] (lo > 0)."""
    return [10.0 ** e for e in range(math.floor(math.log10(lo)), math.ceil(math.log10(hi)) + 1)
            if lo * (1 - 1e-9) <= 10.0 ** e <= hi * (1 + 1e-9)]


def decimate(x: np.ndarray, y: np.ndarray, limit: int = MAX_POINTS) -> tuple:
    """At most ``limit`` vertices: the min and max of each bucket, in x order."""
    n = len(x)
    if n <= limit:
        return x, y
    buckets = limit // 2
    edges = np.linspace(0, n, buckets + 1).astype(int)
    keep = []
    for start, stop in zip(edges[:-1], edges[1:]):
        if stop <= start:
            continue
        seg = y[start:stop]
        a, b = start + int(np.argmin(seg)), start + int(np.argmax(seg))
        keep += sorted((a, b))
    keep = np.unique(np.asarray(keep))
    return x[keep], y[keep]


def fmt_tick(value: float) -> str:
    if value == 0:
        return "0"
    if abs(value) >= 1e4 or abs(value) < 1e-3:
        return f"{value:.0e}".replace("e-0", "e-").replace("e+0", "e")
    return f"{value:g}"


@dataclass
class Plot:
    """One framed plot at the PDF's current position, ``width_mm`` × ``height_mm``."""

    pdf: object
    width_mm: float
    height_mm: float
    title: str = ""
    xlabel: str = ""
    ylabel: str = ""
    xlim: tuple[float, float] = (0.0, 1.0)
    ylim: tuple[float, float] = (0.0, 1.0)
    ylog: bool = False
    xticks: list | None = None              # [(value, label)] for categorical axes
    legend: list = field(default_factory=list)

    def __post_init__(self) -> None:
        pdf = self.pdf
        self.x0 = pdf.l_margin + 14
        self.top = pdf.get_y() + (5 if self.title else 1)
        self.w = self.width_mm - 18
        self.h = self.height_mm - (5 if self.title else 1) - 11
        if self.ylog:
            lo, hi = self.ylim
            self.ylim = (math.log10(lo), math.log10(hi))

    # ------------------------------------------------------------------ coordinates
    def px(self, x):
        lo, hi = self.xlim
        return self.x0 + (np.asarray(x, dtype=float) - lo) / ((hi - lo) or 1.0) * self.w

    def py(self, y):
        y = np.asarray(y, dtype=float)
        if self.ylog:
            y = np.log10(np.clip(y, 10 ** self.ylim[0], None))
        lo, hi = self.ylim
        return self.top + self.h - (y - lo) / ((hi - lo) or 1.0) * self.h

    # ------------------------------------------------------------------ frame
    def frame(self) -> None:
        pdf = self.pdf
        pdf.set_draw_color(0)
        pdf.set_line_width(0.2)
        if self.title:
            pdf.set_font("sans", "B", 7.5)
            pdf.text(self.x0, self.top - 1.5, self.title)
        pdf.set_font("sans", "", 6.5)
        if self.ylog:
            ticks = log_ticks(10 ** self.ylim[0], 10 ** self.ylim[1])
        else:
            ticks = nice_ticks(*self.ylim)
        pdf.set_draw_color(225)
        for value in ticks:
            y = float(self.py(value))
            pdf.line(self.x0, y, self.x0 + self.w, y)
            label = fmt_tick(value)
            pdf.text(self.x0 - 1.2 - pdf.get_string_width(label), y + 1.0, label)
        xticks = self.xticks if self.xticks is not None else [
            (v, fmt_tick(v)) for v in nice_ticks(*self.xlim)]
        for value, label in xticks:
            x = float(self.px(value))
            pdf.line(x, self.top, x, self.top + self.h)
            for row, part in enumerate(str(label).split("\n")[:3]):
                pdf.text(x - pdf.get_string_width(part) / 2, self.top + self.h + 3 + 2.4 * row,
                         part)
        pdf.set_draw_color(0)
        pdf.rect(self.x0, self.top, self.w, self.h)
        pdf.set_font("sans", "", 7)
        if self.xlabel:
            width = pdf.get_string_width(self.xlabel)
            pdf.text(self.x0 + (self.w - width) / 2, self.top + self.h + 9.5, self.xlabel)
        if self.ylabel:
            with pdf.rotation(90, self.x0 - 11, self.top + self.h / 2):
                width = pdf.get_string_width(self.ylabel)
                pdf.text(self.x0 - 11 - width / 2, self.top + self.h / 2, self.ylabel)

    # ------------------------------------------------------------------ series
    def line(self, x, y, colour: str = "blue", width: float = 0.35, label: str | None = None,
             dash: bool = False) -> None:
        x, y = decimate(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        if len(x) < 2:
            return
        pdf = self.pdf
        pdf.set_draw_color(*COLOURS[colour])
        pdf.set_line_width(width)
        if dash:
            pdf.set_dash_pattern(dash=1.2, gap=0.8)
        pdf.polyline(list(zip(self.px(x).tolist(), self.py(y).tolist())))
        if dash:
            pdf.set_dash_pattern()
        if label:
            self.legend.append(("line", colour, label))

    def markers(self, x, y, colour: str = "blue", shape: str = "o", label: str | None = None,
                size: float = 1.1) -> None:
        pdf = self.pdf
        pdf.set_draw_color(*COLOURS[colour])
        pdf.set_fill_color(*COLOURS[colour])
        pdf.set_line_width(0.3)
        for px, py in zip(self.px(x).tolist(), self.py(y).tolist()):
            _marker(pdf, px, py, shape, size)
        if label:
            self.legend.append((shape, colour, label))

    def errorbars(self, x, y, err, colour: str = "blue") -> None:
        pdf = self.pdf
        pdf.set_draw_color(*COLOURS[colour])
        pdf.set_line_width(0.25)
        y, err = np.asarray(y, dtype=float), np.asarray(err, dtype=float)
        for px, low, high in zip(self.px(x).tolist(), self.py(y - err).tolist(),
                                 self.py(y + err).tolist()):
            pdf.line(px, low, px, high)
            pdf.line(px - 0.8, low, px + 0.8, low)
            pdf.line(px - 0.8, high, px + 0.8, high)

    def stems(self, x, y, colour: str = "blue", label: str | None = None) -> None:
        pdf = self.pdf
        pdf.set_draw_color(*COLOURS[colour])
        pdf.set_line_width(0.35)
        base = self.top + self.h
        for px, py in zip(self.px(x).tolist(), self.py(y).tolist()):
            pdf.line(px, base, px, py)
        if label:
            self.legend.append(("line", colour, label))

    def vline(self, x: float, colour: str = "orange", label: str | None = None) -> None:
        pdf = self.pdf
        pdf.set_draw_color(*COLOURS[colour])
        pdf.set_line_width(0.3)
        pdf.set_dash_pattern(dash=1.2, gap=0.8)
        px = float(self.px(x))
        pdf.line(px, self.top, px, self.top + self.h)
        pdf.set_dash_pattern()
        if label:
            self.legend.append(("dash", colour, label))

    def finish(self) -> None:
        """Draw the legend in one row under the plot (never over the data) and move below."""
        pdf = self.pdf
        y = self.top + self.h + (13 if self.xlabel else 8)
        if self.legend:
            pdf.set_font("sans", "", 6.5)
            x = self.x0
            for kind, colour, text in self.legend:
                pdf.set_draw_color(*COLOURS[colour])
                pdf.set_fill_color(*COLOURS[colour])
                pdf.set_line_width(0.35)
                if kind in ("line", "dash"):
                    if kind == "dash":
                        pdf.set_dash_pattern(dash=1.0, gap=0.6)
                    pdf.line(x, y, x + 5, y)
                    pdf.set_dash_pattern()
                else:
                    _marker(pdf, x + 2.5, y, kind, 1.0)
                pdf.text(x + 6.5, y + 1.0, text)
                x += 10 + pdf.get_string_width(text)
            y += 4
        pdf.set_draw_color(0)
        pdf.set_fill_color(255)
        pdf.set_line_width(0.2)
        pdf.set_y(y)


def _marker(pdf, x: float, y: float, shape: str, size: float) -> None:
    if shape == "s":
        pdf.rect(x - size, y - size, 2 * size, 2 * size)
    elif shape == "_":
        pdf.set_line_width(0.5)
        pdf.line(x - 2.2 * size, y, x + 2.2 * size, y)
    else:
        pdf.circle(x=x, y=y, radius=size, style="F")
