"""Server-rendered PNG of one recorded point: torque ripple against rotor angle and its order
spectrum (matplotlib's Agg backend: no JavaScript plotting library, no build step; PNG because Agg
rasterises these few hundred line segments ~3x faster than the SVG writer, which keeps a
point's capture → plot on the page within 1 s on a loaded machine).

The arrays are the report's (:func:`reports.angle_view.angle_view`): those the test stored, else
its raw capture through ``hil.analysis.run_analysis`` with the settings it recorded — the same
curves page 2 of the PDF draws, never a second analysis.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ripple_hil_reports.angle_view import angle_view

#: Revolutions drawn under the synchronous average at most (thin grey lines).
MAX_REVOLUTIONS = 30
#: Resolution of the PNG (pixels per inch of a 9 x 3.3 in figure).
DPI = 90


def point_png(entry: dict, record_dir: Path) -> bytes:
    """Two panels (ripple vs rotor angle, order spectrum) of one test entry, as PNG bytes."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    view = angle_view(entry, record_dir)
    figure = Figure(figsize=(9.0, 3.3), dpi=DPI)
    title = entry["test_id"].rsplit("::", 1)[-1]
    measured = entry.get("measured") or {}
    if isinstance(measured.get("pk_pk_pu"), (int, float)):
        title += f"   pk-pk {100 * measured['pk_pk_pu']:.3g} % of mean torque"
    if view.problem or view.sync_average_nm is None or view.angle_grid_rad is None:
        axis = figure.add_subplot(1, 1, 1)
        axis.axis("off")
        axis.text(0.5, 0.5, f"{title}\nno plot: {view.problem or 'no angle-domain curve'}",
                  ha="center", va="center", wrap=True)
        return _png(figure)
    ripple, spectrum = figure.subplots(1, 2, gridspec_kw={"width_ratios": [3, 2]})
    degrees = np.degrees(np.asarray(view.angle_grid_rad, dtype=float))
    average = np.asarray(view.sync_average_nm, dtype=float)
    mean = float(np.mean(average))
    rows = view.revolution_matrix_nm
    if rows is not None and np.size(rows):
        step = max(1, int(np.ceil(len(rows) / MAX_REVOLUTIONS)))
        for row in np.asarray(rows, dtype=float)[::step]:
            ripple.plot(degrees, row - mean, color="0.75", linewidth=0.5)
    ripple.plot(degrees, average - mean, color="tab:blue", linewidth=1.6,
                label="synchronous average")
    ripple.set_xlabel("rotor angle (electrical degrees)")
    ripple.set_ylabel("torque ripple (N·m)")
    ripple.set_xlim(float(degrees[0]), float(degrees[-1]))
    ripple.legend(loc="upper right", fontsize=7)
    ripple.grid(alpha=0.3)
    if view.orders is not None and view.amplitude_nm is not None:
        orders = np.asarray(view.orders, dtype=float)
        amplitude = np.abs(np.asarray(view.amplitude_nm, dtype=float))
        keep = (orders > 0) & np.isfinite(amplitude)
        spectrum.vlines(orders[keep], 0, amplitude[keep], color="tab:blue")
        spectrum.set_xlabel("order (harmonic of the electrical frequency)")
        spectrum.set_ylabel("amplitude (N·m)")
        spectrum.grid(alpha=0.3)
    figure.suptitle(title, fontsize=9)
    figure.subplots_adjust(left=0.1, right=0.98, bottom=0.16, top=0.88, wspace=0.3)
    return _png(figure)


def _png(figure) -> bytes:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    return buffer.getvalue()


def warm_up() -> None:
    """Import matplotlib and the analysis, analyse one synthetic capture (loads the compiled
    analysis kernels) and draw one throw-away figure, so that the first point of a run is not
    plotted seconds late by start-up costs. Best effort: a failure only costs that time."""
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
    grid = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    entry = {"test_id": "warm-up", "measured": {
        "angle_grid_rad": grid, "sync_average_nm": 1 + 0.01 * np.sin(6 * grid),
        "revolution_matrix_nm": [1 + 0.01 * np.sin(6 * grid)], "orders": [1.0, 6.0],
        "amplitude_nm": [0.0, 0.01]}}
    point_png(entry, Path("."))
