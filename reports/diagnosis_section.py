"""The report's "Ripple attribution" section, drawn from the record's ``diagnosis`` section
(written by the diagnosis plan from :meth:`hil.diagnosis.Diagnosis.to_dict`). It draws only what
the record holds; it never re-runs the diagnosis."""

from __future__ import annotations


def _num(value, digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}g}"


def _pct(value) -> str:
    return "-" if value is None else f"{100.0 * value:.1f} %"


def add_diagnosis_section(doc, diagnosis: dict) -> None:
    """Draw the "Ripple attribution" section on ``doc`` (a ``reports.document.ReportPDF``)."""
    doc.heading("Ripple attribution (diagnosis)", 1)
    k = diagnosis.get("coverage_factor", 2)
    points = diagnosis.get("operating_points", [])
    doc.para(f"The drive was measured as it is (nothing injected) at {len(points)} operating "
             "points; the forward models of each ripple source (hil.model and the derived "
             "closed-loop forms) were fitted to the complex order coefficients of all of them by "
             f"weighted least squares. Uncertainties are expanded, k = {k:g}.")
    rows = [[row.get("title", row.get("source", "")), row.get("estimate_text", ""),
             _pct(row.get("share_of_pk_pk")), _num(row.get("pk_pk_pct"), 3) + " %"]
            for row in diagnosis.get("attribution", [])]
    doc.heading("Sources ranked by their share of the pk-pk ripple", 2)
    doc.grid(["source", "estimate ± U", "share of pk-pk", "alone, pk-pk of mean"], rows,
             widths=(48, 0, 22, 26))
    doc.caption("Share: the pk-pk of the source's modelled torque alone over the measured pk-pk, "
                "averaged over the points (waveforms add by phase, so shares need not sum to "
                "100 %). 'Not attributed' is the measured torque minus every modelled source.")

    doc.heading("Calibration to apply", 2)
    cal = diagnosis.get("calibration", {}) or {}
    cal_rows = []
    for key, label, unit in (("ia_offset_correction_a", "offset correction, sensor a", "A"),
                             ("ib_offset_correction_a", "offset correction, sensor b", "A"),
                             ("gain_trim_a_pct", "gain trim of sensor a relative to b", "%")):
        item = cal.get(key)
        if item is None:
            cal_rows.append([label, "not identifiable from these points", ""])
        else:
            cal_rows.append([label, f"{item['value']:+.4g} ± {item['expanded_uncertainty']:.2g} "
                                    f"{unit}", "apply" if item.get("significant")
                             else "not significant"])
    doc.grid(["correction", "value ± U", ""], cal_rows, widths=(60, 0, 30))
    doc.caption("Offset corrections are added to each sensor's reading; the gain trim multiplies "
                "sensor a's reading by (1 + trim).")
    after = diagnosis.get("predicted_after_correction", [])
    if after:
        doc.grid(["operating point", "pk-pk now", "pk-pk after the correction (predicted)"],
                 [[row["label"], f"{row['pk_pk_pct_before']:.3f} %",
                   f"{row['pk_pk_pct_after']:.3f} %"] for row in after], widths=(60, 30, 0))

    ident = diagnosis.get("identifiability", {}) or {}
    lines = []
    for weak in ident.get("weak_combinations", []):
        lines.append(f"Not separable from these points: {', '.join(weak.get('parameters', []))}"
                     f" — {weak.get('separate_by', '')}")
    for alias in ident.get("assumptions", []):
        lines.append(f"Assumed absent: {alias['assumed_absent']} ({alias['consequence']}); to "
                     f"check: {alias['separate_by']}")
    for item in diagnosis.get("unexplained", []):
        lines.append(f"Mechanical order {item['mech_order']} (electrical {item['elec_order']:g}): "
                     f"{item['note']}; largest residual "
                     f"{_num(item.get('largest_residual_pct_of_mean'))} % of the mean torque "
                     f"at {item.get('at', '')}")
    encoder = diagnosis.get("encoder", {}) or {}
    if encoder.get("note"):
        lines.append(f"Encoder: {encoder['note']}")
    for residual in diagnosis.get("motor_residual", [])[:5]:
        text = (f"Motor-side ripple at mechanical order {residual['mech_order']}: "
                f"{1e3 * residual['constant_nm']:.3g} mN·m independent of current")
        if residual.get("per_ampere_nm") is not None:
            text += f", {1e3 * residual['per_ampere_nm']:.3g} mN·m per A"
        lines.append(text)
    lines += [str(note) for note in diagnosis.get("notes", [])]
    quality = diagnosis.get("fit_quality", {}) or {}
    if quality.get("birge_ratio") is not None:
        lines.append(f"Fit: χ² = {_num(quality.get('chi2'))} for {quality.get('dof')} degrees of "
                     f"freedom (Birge ratio {_num(quality.get('birge_ratio'))}; uncertainties "
                     "are scaled up by it when it exceeds 1).")
    if lines:
        doc.heading("What the diagnosis cannot say, and what it assumed", 2)
        doc.bullets(lines)
