"""The report's plots, drawn straight into the PDF (``reports.plot``): sweep, torque against
angle, order spectrum (dB) and the ripple map's heat map.

Readability (issue 11 item 7): a sweep whose values span more than a decade (the encoder sweep
beside its Hall point) gets a log axis; the spectrum is in dB relative to its largest order, so
the small orders are visible beside the dominant one.
"""

from __future__ import annotations

import math

import numpy as np

from ripple_hil_reports.content import SourceSection, knob_display
from ripple_hil_reports.plot import Plot

WIDTH_MM = 170.0
#: Decades of spread above which a sweep's ripple axis is logarithmic.
LOG_SPAN = 10.0
#: Lowest level drawn in the order spectrum, dB below its largest order.
SPECTRUM_FLOOR_DB = -80.0


def sweep(pdf, section: SourceSection) -> bool:
    """Measured (±U, k = 2) and predicted ripple against the swept knob, the tolerance limits of
    the decision rule as red bars at each point. When several knobs vary together the axis lists
    the points. Returns False if there is nothing to draw."""
    points = [p for p in section.points if p.measured_pu is not None or p.predicted_pu is not None]
    if not points:
        return False
    numeric = len(section.swept) == 1 and all(p.x is not None for p in points)
    label, scale = knob_display(section.swept[0] if numeric else None,
                                [p.x or 0.0 for p in points])
    xs = np.array([p.x * scale if numeric else i for i, p in enumerate(points)], dtype=float)
    values = [100 * v for p in points for v in (p.measured_pu, p.predicted_pu, p.upper_pu)
              if v is not None]
    errors = [100 * ((p.measured_pu or 0) + (p.u_pu or 0)) for p in points]
    positive = [v for v in values if v > 0]
    log = bool(positive) and max(positive) / min(positive) > LOG_SPAN
    top = max(values + errors + [1e-3]) * (1.6 if log else 1.12)
    low = min(positive) / 1.6 if log else 0.0
    pad = (xs.max() - xs.min()) * 0.06 or 0.5
    ticks = None if numeric else [(x, p.label.replace(", ", "\n")) for x, p in zip(xs, points)]
    plot = Plot(pdf, WIDTH_MM, 62 if numeric else 70,
                title=f"{section.name}: measured and predicted ripple"
                      + (" (log axis)" if log else ""),
                xlabel=label if numeric else "test point (injected values)",
                ylabel="ripple pk-pk (% of mean)", xlim=(xs.min() - pad, xs.max() + pad),
                ylim=(low, top), ylog=log, xticks=ticks)
    plot.frame()
    for attr, name in (("upper_pu", "tolerance limits"), ("lower_pu", None)):
        limit = [(x, 100 * getattr(p, attr)) for x, p in zip(xs, points)
                 if getattr(p, attr) is not None and (not log or getattr(p, attr) > 0)]
        if limit:
            plot.markers([x for x, _ in limit], [v for _, v in limit], "red", "_", name)
    predicted = [(x, 100 * p.predicted_pu) for x, p in zip(xs, points)
                 if p.predicted_pu is not None and (not log or p.predicted_pu > 0)]
    if predicted:
        if numeric and len(predicted) > 1:
            plot.line(*zip(*predicted), colour="orange", dash=True, width=0.25)
        plot.markers(*zip(*predicted), colour="orange", shape="s", label="predicted")
    measured = [(x, 100 * p.measured_pu, 100 * (p.u_pu or 0.0)) for x, p in zip(xs, points)
                if p.measured_pu is not None and (not log or p.measured_pu > 0)]
    if measured:
        x, y, err = (np.array(v) for v in zip(*measured))
        if log:
            err = np.minimum(err, 0.999 * y)             # a log axis cannot show y − U ≤ 0
        plot.errorbars(x, y, err)
        plot.markers(x, y, label="measured ± U (k = 2)")
    plot.finish()
    return True


def angle(pdf, angle_rad, revolutions_nm, sync_average_nm, title: str,
          ylabel: str = "torque (N·m)") -> None:
    """Torque against electrical angle: revolutions (thin grey) under their synchronous average."""
    degrees = np.degrees(np.asarray(angle_rad, dtype=float))
    average = np.asarray(sync_average_nm, dtype=float)
    rows = np.asarray(revolutions_nm, dtype=float) if revolutions_nm is not None else None
    stack = [average] + ([rows.ravel()] if rows is not None and rows.size else [])
    lo = min(float(np.nanmin(a)) for a in stack)
    hi = max(float(np.nanmax(a)) for a in stack)
    span = (hi - lo) or abs(hi) * 0.01 or 1.0
    plot = Plot(pdf, WIDTH_MM, 58, title=title, xlabel="rotor angle (electrical degrees)",
                ylabel=ylabel, xlim=(float(degrees[0]), float(degrees[-1])),
                ylim=(lo - 0.08 * span, hi + 0.25 * span))
    plot.frame()
    if rows is not None and rows.size:
        step = max(1, math.ceil(len(rows) / 40))
        for row in rows[::step]:
            plot.line(degrees, row, colour="grey", width=0.15)
        drawn = "" if step == 1 else f", every {step}th drawn"
        plot.legend.append(("line", "grey", f"revolutions ({len(rows)}{drawn})"))
    plot.line(degrees, average, colour="blue", width=0.45, label="synchronous average")
    plot.finish()


def spectrum(pdf, orders, amplitude_nm, predicted_order: float | None, title: str) -> None:
    """Order spectrum of the synchronous average in dB relative to its largest order (stems),
    the predicted order marked."""
    orders = np.asarray(orders, dtype=float)
    amplitude = np.abs(np.asarray(amplitude_nm, dtype=float))
    keep = (orders > 0) & np.isfinite(amplitude)
    orders, amplitude = orders[keep], amplitude[keep]
    if not len(orders):
        return
    peak = float(amplitude.max()) or 1.0
    level = np.maximum(20 * np.log10(np.maximum(amplitude, 1e-300) / peak), SPECTRUM_FLOOR_DB)
    plot = Plot(pdf, WIDTH_MM, 52, title=f"{title} (dB re the largest order, {peak:.3g} N·m)",
                xlabel="order (harmonic of the electrical frequency)",
                ylabel="amplitude (dB)", xlim=(0, float(orders.max()) + 1),
                ylim=(SPECTRUM_FLOOR_DB, 5.0))
    plot.frame()
    plot.stems(orders, level)
    plot.markers(orders, level, size=0.5)
    if predicted_order is not None:
        plot.vline(predicted_order, label=f"predicted order {predicted_order:g}")
    plot.finish()


def heat_map(pdf, cells: list[dict], title: str) -> bool:
    """Speed × current grid, each cell coloured by its pk-pk ripple (% of mean) and labelled with
    it and the dominant order. ``cells``: ``{speed_rpm, current_a, pk_pk_pct, order}``."""
    if not cells:
        return False
    speeds = sorted({c["speed_rpm"] for c in cells})
    currents = sorted({c["current_a"] for c in cells})
    values = [c["pk_pk_pct"] for c in cells if c["pk_pk_pct"] is not None]
    hi = max(values) if values else 1.0
    lo = min(values) if values else 0.0
    left, label_w = pdf.l_margin + 18, 12
    width = min(24.0, (WIDTH_MM - 30) / len(speeds))
    height = min(12.0, 80.0 / len(currents))
    pdf.set_font("sans", "B", 7.5)
    pdf.text(left, pdf.get_y() + 3, title)
    top = pdf.get_y() + 6
    pdf.set_font("sans", "", 6.5)
    by_key = {(c["speed_rpm"], c["current_a"]): c for c in cells}
    for row, current in enumerate(reversed(currents)):
        y = top + row * height
        pdf.text(left - label_w, y + height / 2 + 1, f"{current:g} A")
        for col, speed in enumerate(speeds):
            x = left + col * width
            cell = by_key.get((speed, current))
            value = None if cell is None else cell["pk_pk_pct"]
            shade = 1.0 if value is None else 1.0 - 0.75 * (value - lo) / ((hi - lo) or 1.0)
            pdf.set_fill_color(int(255 * shade), int(255 * (0.55 + 0.45 * shade)), 255)
            pdf.set_draw_color(120)
            pdf.rect(x, y, width, height, style="FD")
            pdf.set_text_color(0 if shade > 0.45 else 255)
            text = "—" if value is None else f"{value:.2f} %"
            pdf.text(x + (width - pdf.get_string_width(text)) / 2, y + height / 2, text)
            if cell is not None and cell.get("order") is not None:
                order = f"order {cell['order']}"
                pdf.text(x + (width - pdf.get_string_width(order)) / 2, y + height / 2 + 2.8,
                         order)
            pdf.set_text_color(0)
    bottom = top + len(currents) * height
    for col, speed in enumerate(speeds):
        label = f"{speed:g}"
        pdf.text(left + col * width + (width - pdf.get_string_width(label)) / 2, bottom + 3,
                 label)
    pdf.set_font("sans", "", 7)
    pdf.text(left, bottom + 7, "speed (rpm) →; rows: peak phase current; cell: pk-pk ripple "
                               "(% of mean torque) and the dominant electrical order")
    pdf.set_fill_color(255)
    pdf.set_draw_color(0)
    pdf.set_y(bottom + 10)
    return True
