"""The report's plots as SVG (vector) bytes, drawn with matplotlib, reproducible byte for byte."""

from __future__ import annotations

import io
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (backend first)
import numpy as np  # noqa: E402

from reports.content import SourceSection, knob_display  # noqa: E402

_STYLE = {"svg.hashsalt": "ripple-hil-report", "svg.fonttype": "path", "font.size": 8,
          "axes.grid": True, "grid.alpha": 0.35, "figure.dpi": 100}
WIDTH_IN = 6.7
#: Most revolutions drawn behind a synchronous average (keeps the vector plot small).
MAX_REVOLUTION_LINES = 40


def sweep_svg(section: SourceSection) -> bytes | None:
    """Measured (±U, k = 2) and predicted ripple against the swept knob, with the tolerance
    limits of the decision rule drawn as red bars at each point. When several knobs vary
    together the axis lists the points (no line joins them)."""
    points = [p for p in section.points if p.measured_pu is not None or p.predicted_pu is not None]
    if not points:
        return None
    numeric = len(section.swept) == 1 and all(p.x is not None for p in points)
    label, scale = knob_display(section.swept[0] if numeric else None,
                                [p.x or 0.0 for p in points])
    xs = np.array([p.x * scale if numeric else i for i, p in enumerate(points)], dtype=float)
    joined = "--" if numeric else ""
    with plt.rc_context(_STYLE):
        fig, ax = plt.subplots(figsize=(WIDTH_IN, 3.1 if numeric else 3.4))
        for attr, name in (("upper_pu", "tolerance limits"), ("lower_pu", None)):
            limit = [(x, getattr(p, attr)) for x, p in zip(xs, points)
                     if getattr(p, attr) is not None]
            if limit:
                ax.plot([x for x, _ in limit], [100 * v for _, v in limit], "_", color="tab:red",
                        markersize=14, markeredgewidth=1.6, label=name)
        predicted = [(x, p) for x, p in zip(xs, points) if p.predicted_pu is not None]
        if predicted:
            ax.plot([x for x, _ in predicted], [100 * p.predicted_pu for _, p in predicted],
                    f"s{joined}", color="tab:orange", markersize=7, markerfacecolor="none",
                    markeredgewidth=1.3, zorder=5, label="predicted (paper)")
        measured = [(x, p) for x, p in zip(xs, points) if p.measured_pu is not None]
        if measured:
            ax.errorbar([x for x, _ in measured], [100 * p.measured_pu for _, p in measured],
                        yerr=[100 * (p.u_pu or 0.0) for _, p in measured], fmt="o", capsize=3,
                        color="tab:blue", label="measured ± U (k = 2)")
        if numeric:
            ax.set_xlabel(label)
        else:
            ax.set_xticks(xs, [p.label.replace(", ", "\n") for p in points], fontsize=6)
            ax.set_xlabel("test point (injected values)")
        ax.set_ylabel("torque ripple pk-pk (% of mean)")
        ax.set_ylim(bottom=0)
        ax.set_title(f"{section.name}: measured and predicted ripple")
        ax.legend(loc="best", fontsize=7)
        return _svg(fig)


def angle_svg(angle_rad: np.ndarray, revolutions_nm: np.ndarray | None,
              sync_average_nm: np.ndarray, title: str, ylabel: str = "torque (N·m)") -> bytes:
    """Torque against electrical angle: revolutions (thin) overlaid on their synchronous average."""
    degrees = np.degrees(np.asarray(angle_rad, dtype=float))
    with plt.rc_context(_STYLE):
        fig, ax = plt.subplots(figsize=(WIDTH_IN, 2.7))
        if revolutions_nm is not None and len(revolutions_nm):
            rows = np.asarray(revolutions_nm, dtype=float)
            step = max(1, math.ceil(len(rows) / MAX_REVOLUTION_LINES))
            for row in rows[::step]:
                ax.plot(degrees, row, color="0.7", linewidth=0.4)
            drawn = "" if step == 1 else f", every {step}th drawn"
            ax.plot([], [], color="0.7", linewidth=0.6, label=f"revolutions ({len(rows)}{drawn})")
        ax.plot(degrees, sync_average_nm, color="tab:blue", linewidth=1.4,
                label="synchronous average")
        ax.set_xlim(degrees[0], degrees[-1])
        ax.set_xlabel("rotor angle (electrical degrees)")
        ax.set_ylabel(ylabel)
        ax.set_title(title)
        ax.legend(loc="best", fontsize=7)
        return _svg(fig)


def spectrum_svg(orders: np.ndarray, amplitude_nm: np.ndarray, predicted_order: float | None,
                 title: str) -> bytes:
    """Single-sided order spectrum (amplitude per electrical order), predicted order marked."""
    orders = np.asarray(orders, dtype=float)
    amplitude = np.asarray(amplitude_nm, dtype=float)
    keep = orders > 0
    with plt.rc_context(_STYLE):
        fig, ax = plt.subplots(figsize=(WIDTH_IN, 2.4))
        ax.vlines(orders[keep], 0, amplitude[keep], color="tab:blue", linewidth=1.2)
        ax.plot(orders[keep], amplitude[keep], "o", color="tab:blue", markersize=2.5)
        if predicted_order is not None:
            ax.axvline(predicted_order, color="tab:orange", linestyle="--", linewidth=1,
                       label=f"predicted order {predicted_order:g}")
            ax.legend(loc="best", fontsize=7)
        ax.set_xlabel("order (harmonic of the electrical frequency)")
        ax.set_ylabel("amplitude (N·m)")
        ax.set_title(title)
        ax.set_ylim(bottom=0)
        return _svg(fig)


def _svg(fig) -> bytes:
    buffer = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buffer, format="svg", metadata={"Date": None, "Creator": None})
    plt.close(fig)
    text = buffer.getvalue()
    start, end = text.find(b"<metadata"), text.find(b"</metadata>")
    if start >= 0 and end > start:  # fpdf2 ignores it, noisily
        text = text[:start] + text[end + len(b"</metadata>"):]
    return text
