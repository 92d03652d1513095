"""Server-rendered SVG of one recorded point: torque ripple against rotor angle and its order
spectrum. No JavaScript library and no build step on the page.

The arrays are the report's (:func:`reports.angle_view.angle_view`): those the test stored, else
its raw capture through ``hil.analysis.run_analysis`` with the settings it recorded — the same
curves page 2 of the PDF draws, never a second analysis. The SVG is written directly (polylines,
tick labels from :func:`reports.plot.nice_ticks`, the report's tick rules) rather than through
matplotlib: drawing one point costs ~5 ms instead of 0.3–0.8 s on a loaded 2-core machine, which
is what keeps a point's plot on the page within 1 s of its analysis.
"""

from __future__ import annotations

from html import escape
from pathlib import Path

import numpy as np

from ripple_hil_reports.angle_view import angle_view
from ripple_hil_reports.plot import decimate, fmt_tick, nice_ticks

#: Revolutions drawn under the synchronous average at most (thin grey lines).
MAX_REVOLUTIONS = 30
#: Vertices per drawn line at most (min/max per bucket: peaks survive).
MAX_VERTICES = 600
WIDTH, HEIGHT = 900, 320
#: Panels: (left, top, width, height) in px of the ripple and the spectrum plot areas.
RIPPLE_BOX = (70, 40, 450, 220)
SPECTRUM_BOX = (600, 40, 280, 220)
FAMILY = "font-family='DejaVu Sans, Arial, sans-serif'"
FONT = f"{FAMILY} font-size='11'"


def point_svg(entry: dict, record_dir: Path) -> bytes:
    """Two panels (ripple vs rotor angle, order spectrum) of one test entry, as SVG bytes."""
    view = angle_view(entry, record_dir)
    title = entry["test_id"].rsplit("::", 1)[-1]
    measured = entry.get("measured") or {}
    if isinstance(measured.get("pk_pk_pu"), (int, float)):
        title += f" — pk-pk {100 * measured['pk_pk_pu']:.3g} % of mean torque"
    parts = [f"<svg xmlns='http://www.w3.org/2000/svg' width='{WIDTH}' height='{HEIGHT}' "
             f"viewBox='0 0 {WIDTH} {HEIGHT}'><rect width='100%' height='100%' fill='white'/>",
             f"<text x='{WIDTH / 2}' y='18' text-anchor='middle' {FAMILY} font-size='13'>"
             f"{escape(title)}</text>"]
    if view.problem or view.sync_average_nm is None or view.angle_grid_rad is None:
        parts.append(f"<text x='{WIDTH / 2}' y='{HEIGHT / 2}' text-anchor='middle' {FONT}>"
                     f"no plot: {escape(view.problem or 'no angle-domain curve')}</text>")
        return ("".join(parts) + "</svg>").encode()
    degrees = np.degrees(np.asarray(view.angle_grid_rad, dtype=float))
    average = np.asarray(view.sync_average_nm, dtype=float)
    mean = float(np.mean(average))
    rows = np.asarray(view.revolution_matrix_nm if view.revolution_matrix_nm is not None
                      else np.empty((0, len(degrees))), dtype=float)
    step = max(1, int(np.ceil(len(rows) / MAX_REVOLUTIONS))) if len(rows) else 1
    shown = rows[::step] - mean
    stack = np.concatenate([average - mean, shown.ravel()]) if shown.size else average - mean
    axes = _Axes(RIPPLE_BOX, (float(degrees[0]), float(degrees[-1])),
                 _padded(float(np.nanmin(stack)), float(np.nanmax(stack))))
    parts += axes.frame("rotor angle (electrical degrees)", "torque ripple (N·m)")
    for row in shown:
        parts.append(axes.polyline(degrees, row, "#bbbbbb", 0.7))
    parts.append(axes.polyline(degrees, average - mean, "#1f77b4", 2.0))
    parts.append(f"<text x='{RIPPLE_BOX[0] + RIPPLE_BOX[2] - 4}' y='{RIPPLE_BOX[1] + 14}' "
                 f"text-anchor='end' {FONT} fill='#1f77b4'>synchronous average"
                 + (f" over {len(rows)} revolutions (grey)" if len(rows) else "") + "</text>")
    if view.orders is not None and view.amplitude_nm is not None:
        orders = np.asarray(view.orders, dtype=float)
        amplitude = np.abs(np.asarray(view.amplitude_nm, dtype=float))
        keep = (orders > 0) & np.isfinite(amplitude)
        orders, amplitude = orders[keep], amplitude[keep]
        if len(orders):
            spectrum = _Axes(SPECTRUM_BOX, (0.0, float(orders.max()) + 1),
                             (0.0, float(amplitude.max()) * 1.08 or 1.0))
            parts += spectrum.frame("order (harmonic of the electrical frequency)",
                                    "amplitude (N·m)")
            parts.append(spectrum.stems(orders, amplitude, "#1f77b4"))
    return ("".join(parts) + "</svg>").encode()


def _padded(lo: float, hi: float) -> tuple[float, float]:
    span = (hi - lo) or abs(hi) * 0.01 or 1.0
    return lo - 0.05 * span, hi + 0.15 * span


class _Axes:
    """A linear x-y plot area in SVG pixels."""

    def __init__(self, box, xlim, ylim) -> None:
        self.left, self.top, self.width, self.height = box
        self.xlim, self.ylim = xlim, ylim

    def px(self, x):
        return self.left + (np.asarray(x, dtype=float) - self.xlim[0]) \
            / ((self.xlim[1] - self.xlim[0]) or 1.0) * self.width

    def py(self, y):
        return self.top + self.height - (np.asarray(y, dtype=float) - self.ylim[0]) \
            / ((self.ylim[1] - self.ylim[0]) or 1.0) * self.height

    def frame(self, xlabel: str, ylabel: str) -> list[str]:
        left, top, width, height = self.left, self.top, self.width, self.height
        out = [f"<rect x='{left}' y='{top}' width='{width}' height='{height}' fill='none' "
               f"stroke='#333'/>"]
        for tick in nice_ticks(*self.xlim):
            x = float(self.px(tick))
            out.append(f"<line x1='{x:.1f}' y1='{top}' x2='{x:.1f}' y2='{top + height}' "
                       f"stroke='#e4e4e4'/><text x='{x:.1f}' y='{top + height + 15}' "
                       f"text-anchor='middle' {FONT}>{fmt_tick(tick)}</text>")
        for tick in nice_ticks(*self.ylim):
            y = float(self.py(tick))
            out.append(f"<line x1='{left}' y1='{y:.1f}' x2='{left + width}' y2='{y:.1f}' "
                       f"stroke='#e4e4e4'/><text x='{left - 5}' y='{y + 4:.1f}' "
                       f"text-anchor='end' {FONT}>{fmt_tick(tick)}</text>")
        out.append(f"<text x='{left + width / 2}' y='{top + height + 32}' text-anchor='middle' "
                   f"{FONT}>{escape(xlabel)}</text>")
        out.append(f"<text transform='translate({left - 55},{top + height / 2}) rotate(-90)' "
                   f"text-anchor='middle' {FONT}>{escape(ylabel)}</text>")
        return out

    def polyline(self, x, y, colour: str, width: float) -> str:
        x, y = decimate(np.asarray(x, dtype=float), np.asarray(y, dtype=float), MAX_VERTICES)
        points = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(self.px(x), self.py(y)))
        return (f"<polyline points='{points}' fill='none' stroke='{colour}' "
                f"stroke-width='{width}'/>")

    def stems(self, x, y, colour: str) -> str:
        base = float(self.py(0.0))
        path = " ".join(f"M{a:.1f} {base:.1f}V{b:.1f}" for a, b in zip(self.px(x), self.py(y)))
        return f"<path d='{path}' stroke='{colour}' stroke-width='2' fill='none'/>"


def warm_up() -> None:
    """Import the analysis and analyse one synthetic capture (loads the compiled analysis
    kernels), so that the first point of a run is not plotted seconds late by start-up costs.
    Best effort: a failure only costs that time."""
    from hil.analysis import run_analysis
    from hil.capture import Capture

    rate_hz, speed_rad_s, pole_pairs = 8000.0, 500 * 2 * np.pi / 60, 2
    time_s = np.arange(int(0.5 * rate_hz)) / rate_hz
    angle = speed_rad_s * time_s
    capture = Capture(channels={
        "time_s": time_s, "rotor_angle_mech_rad": angle % (2 * np.pi),
        "torque_nm": 1 + 0.01 * np.sin(6 * pole_pairs * angle),
        "ia_a": np.cos(pole_pairs * angle), "ib_a": np.cos(pole_pairs * angle - 2.094),
        "encoder_counts": np.floor(angle / (2 * np.pi) * 7200) % 7200,
        "sample_counter": np.arange(len(time_s), dtype=float)},
        meta={"pole_pairs": pole_pairs, "sample_rate_hz": rate_hz})
    try:
        run_analysis(capture, {"analysis": "torque", "pole_pairs": pole_pairs, "max_order": 48})
    except Exception:           # noqa: BLE001 - warm-up only
        pass
