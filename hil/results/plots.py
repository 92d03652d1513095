"""PNG figures of ``hil compare`` and ``hil trend`` (matplotlib, Agg backend)."""

from __future__ import annotations

from pathlib import Path

from hil.results.reproduction import off_scale


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def compare_plot(result: dict, out: str | Path) -> None:
    """Each matched point's pk-pk difference b − a (% of the nameplate torque) with ±U_d;
    points off that scale (``hil.results.reproduction.OFF_SCALE_PU``) listed below the axes
    instead."""
    plt = _pyplot()
    compared = [p for p in result["points"] if p["pk_pk_pu"]["difference"] is not None]
    rows = [p for p in compared if not off_scale(p)]
    listed = [p for p in compared if off_scale(p)]
    fig, ax = plt.subplots(figsize=(10, 0.35 * len(rows) + 1.8 + 0.2 * len(listed)))
    for i, p in enumerate(rows):
        d = p["pk_pk_pu"]
        color = ("tab:gray" if d["changed"] is None
                 else "tab:red" if d["changed"] else "tab:green")
        ax.errorbar(100 * d["difference"], i, xerr=100 * d["u_difference"], fmt="o",
                    color=color, capsize=3)
    ax.axvline(0.0, color="black", lw=0.8)
    ax.set_yticks(range(len(rows)), [p["test_id"].split("::")[-1] for p in rows], fontsize=7)
    ax.set_xlabel("pk-pk difference B − A, % of the nameplate torque (bars: ±U_d)")
    ax.set_title(f"B {result['run_b']} − A {result['run_a']}\nred: changed beyond U_d, "
                 "green: not, grey: another operating point (not judged)", fontsize=8)
    if listed:
        text = "not plotted (off the scale of a torque ripple, beyond ±100 %):\n" + "\n".join(
            f"  {p['test_id'].split('::')[-1]}: d = {100 * p['pk_pk_pu']['difference']:.3g} % "
            f"± {100 * (p['pk_pk_pu']['u_difference'] or 0.0):.3g} %" for p in listed)
        fig.text(0.01, 0.0, text, fontsize=7, va="top", family="monospace")
    fig.tight_layout()
    fig.savefig(out, dpi=110, bbox_inches="tight")
    plt.close(fig)


def control_chart_plot(result: dict, out: str | Path) -> None:
    """Individuals chart: the observations, centre line, 3σ̂ limits and the spec limits."""
    plt = _pyplot()
    obs = result["observations"]
    chart = result["control_chart"]
    x = range(len(obs))
    fig, ax = plt.subplots(figsize=(9, 4))
    colors = ["tab:blue" if o["accepted"] else "tab:red" for o in obs]
    ax.plot(x, [o["value"] for o in obs], color="tab:blue", lw=0.6)
    ax.scatter(x, [o["value"] for o in obs], c=colors, s=8, zorder=3)
    ax.axhline(chart["centre"], color="black", lw=1, label="centre")
    if chart["ucl"] is not None and chart.get("stated", True):
        ax.axhline(chart["ucl"], color="tab:orange", ls="--", label="±3σ̂ (moving range)")
        if chart["lcl"] is not None:
            ax.axhline(chart["lcl"], color="tab:orange", ls="--")
    for limit, text in ((result["upper_limit"], "USL"), (result["lower_limit"], "LSL")):
        if limit is not None:
            ax.axhline(limit, color="tab:red", lw=1.2, label=text)
    cap = result["capability"]
    title = result["what"]
    if cap["cpk"] is not None and cap.get("stated", True):
        title += f"; Cpk {cap['cpk']:.2f} [{cap['cpk_ci'][0]:.2f}, {cap['cpk_ci'][1]:.2f}]"
    elif cap.get("reason"):
        title += f"; Cpk not stated: {cap['reason']}"
    if not chart.get("stated", True):
        title += f"; control limits not stated: {chart['reason']}"
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("run (oldest first; red: not accepted)")
    ax.set_ylabel(result["unit"])
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(out, dpi=110, bbox_inches="tight")
    plt.close(fig)
