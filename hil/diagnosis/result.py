"""The result of a diagnosis: estimates with uncertainties and correlations, identifiability, the
ripple attribution per source, the calibration to apply and the ripple predicted after it."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hil.analysis.spectrum import peak_to_peak

FORMAT = "ripple-hil-diagnosis/1"
#: Sources the calibration removes (sensor offsets and gain mismatch).
CALIBRATED_SOURCES = ("dc_offset", "gain_mismatch")
SOURCE_TITLES = {
    "dc_offset": "current-sensor dc offset", "gain_mismatch": "current-sensor gain mismatch",
    "dead_time": "inverter dead time", "encoder": "encoder resolution",
    "motor_cogging": "motor: cogging (fixed in mech. angle)",
    "motor_emf": "motor: EMF-harmonic torque (∝ current)",
    "motor_other": "other orders (motor or unmodelled)",
    "unattributed": "not attributed (rest of the ripple)",
}


@dataclass(frozen=True)
class ParameterEstimate:
    name: str
    unit: str
    source: str
    description: str
    estimate: float
    standard_uncertainty: float
    identifiable: bool

    def to_dict(self, k: float) -> dict:
        ok = self.identifiable and math.isfinite(self.estimate)
        return {"name": self.name, "unit": self.unit, "source": self.source,
                "description": self.description,
                "estimate": self.estimate if ok else None,
                "standard_uncertainty": self.standard_uncertainty if ok else None,
                "expanded_uncertainty": k * self.standard_uncertainty if ok else None,
                "coverage_factor": k, "identifiable": self.identifiable}


def _pk_pk(coefficients: np.ndarray) -> float:
    c = np.array(coefficients, dtype=complex)
    c[0] = 0.0
    return float(peak_to_peak(c[None, :])[0])


def _fmt(value: float, u: float, unit: str, scale: float = 1.0, digits: int = 3) -> str:
    return f"{value * scale:+.{digits}g} ± {u * scale:.2g} {unit}"


@dataclass
class Diagnosis:
    """Everything :func:`hil.diagnosis.diagnose` found (see :meth:`to_dict`)."""

    spectra: list
    setup: object
    parameters: list[ParameterEstimate]
    params: list
    fit: object
    encoder: dict
    fit_orders: list[int]
    weak: list[dict]
    aliases: list[dict]
    unexplained: list[dict]
    motor_residual: list[dict]
    contributions: list[dict]
    expansion_k: float = 2.0
    notes: list[str] = field(default_factory=list)

    # ---------------------------------------------------------------- angle reference
    def angle_reference(self) -> dict:
        """Each capture's angle reference (hil.diagnosis.angle_reference) and whether all are
        known: with one unknown, the signs of Δa, Δb and k_a − k_b and which sensor carries the
        offset are not identifiable (the order-k signatures turn by k times the reference)."""
        points = [{"label": s.label, "emf_a_rising_zero_elec_deg": s.emf_a_rising_zero_elec_deg,
                   "standard_uncertainty_elec_deg": s.angle_reference_u_elec_deg
                   if s.emf_a_rising_zero_elec_deg is not None else None,
                   "source": s.angle_reference_source} for s in self.spectra]
        return {"known": all(p["emf_a_rising_zero_elec_deg"] is not None for p in points),
                "points": points}

    def offset_magnitude(self) -> tuple[float, float] | None:
        """(|n|, standard uncertainty) of the sensor offsets' error space vector, A: with
        Clarke's two-sensor transform n = (Δa, (Δa + 2Δb)/√3). An angle reference turned by ψ
        turns n by ψ, so |n| is what the torque fixes without a reference, and each of |Δa|,
        |Δb| is at most |n| (its components along a and along b)."""
        a, b = self.value("ia_offset_a"), self.value("ib_offset_a")
        if a is None or b is None:
            return None
        names = [p.name for p in self.parameters]
        i, j = names.index("ia_offset_a"), names.index("ib_offset_a")
        cov = self.fit.covariance[np.ix_([i, j], [i, j])]
        beta = (a[0] + 2.0 * b[0]) / math.sqrt(3.0)
        magnitude = math.hypot(a[0], beta)
        if magnitude == 0.0:
            return 0.0, math.sqrt(max(cov[0, 0], cov[1, 1]))
        grad = np.array([a[0] + beta / math.sqrt(3.0), 2.0 * beta / math.sqrt(3.0)]) / magnitude
        return magnitude, float(math.sqrt(max(grad @ cov @ grad, 0.0)))

    # ---------------------------------------------------------------- parameters
    def estimate(self, name: str) -> ParameterEstimate:
        for item in self.parameters:
            if item.name == name:
                return item
        raise KeyError(name)

    def value(self, name: str) -> tuple[float, float] | None:
        """(estimate, standard uncertainty) of an identifiable parameter, else None (also when
        the parameter was not fitted)."""
        try:
            item = self.estimate(name)
        except KeyError:
            return None
        if not item.identifiable or not math.isfinite(item.estimate):
            return None
        return item.estimate, item.standard_uncertainty

    def motor_terms(self) -> list[dict]:
        """Cogging and EMF terms as amplitude ± U and phase, from their re/im estimates."""
        names = [p.name for p in self.parameters]
        cov = self.fit.covariance
        out = []
        for index, item in enumerate(self.parameters):
            if item.source not in ("motor_cogging", "motor_emf") or "_re_" not in item.name:
                continue
            j = names.index(item.name.replace("_re_", "_im_"))
            if not (item.identifiable and self.parameters[j].identifiable):
                out.append({"name": item.name.replace("_re_", "_"), "source": item.source,
                            "identifiable": False})
                continue
            z = complex(item.estimate, self.parameters[j].estimate)
            amplitude = abs(z)
            grad = np.array([z.real, z.imag]) / amplitude if amplitude > 0 else np.array([1.0, 0.0])
            sub = cov[np.ix_([index, j], [index, j])]
            u = float(math.sqrt(max(grad @ sub @ grad, 0.0)))
            out.append({"name": item.name.replace("_re_", "_"), "source": item.source,
                        "mech_order": int(item.name.split("_")[1][1:]), "unit": item.unit,
                        "amplitude": amplitude, "standard_uncertainty": u,
                        "expanded_uncertainty": self.expansion_k * u,
                        "phase_rad": float(np.angle(z)), "identifiable": True})
        return out

    # ---------------------------------------------------------------- attribution
    def attribution(self) -> list[dict]:
        """Sources ranked by their mean share of the measured pk-pk ripple over the points."""
        rows: dict[str, list[dict]] = {}
        for spectrum, parts in zip(self.spectra, self.contributions):
            measured = _pk_pk(spectrum.coefficients_nm)
            mean = abs(spectrum.mean_torque_nm)
            modelled = np.zeros_like(spectrum.coefficients_nm)
            for source, coefficients in parts.items():
                modelled = modelled + coefficients
                rows.setdefault(source, []).append(self._share(spectrum, coefficients, measured,
                                                               mean))
            rest = spectrum.coefficients_nm - modelled
            rows.setdefault("unattributed", []).append(self._share(spectrum, rest, measured, mean))
        ranked = []
        for source, points in rows.items():
            ranked.append({"source": source, "title": SOURCE_TITLES.get(source, source),
                           "estimate_text": self.estimate_text(source),
                           "share_of_pk_pk": float(np.mean([p["share_of_pk_pk"] for p in points])),
                           "pk_pk_pct": float(np.mean([p["pk_pk_pct"] for p in points])),
                           "per_point": points})
        ranked.sort(key=lambda r: (r["source"] == "unattributed", -r["share_of_pk_pk"]))
        return ranked

    @staticmethod
    def _share(spectrum, coefficients, measured_pk_pk, mean) -> dict:
        alone = _pk_pk(coefficients)
        return {"label": spectrum.label, "pk_pk_nm": alone,
                "pk_pk_pct": 100.0 * alone / mean if mean else None,
                "share_of_pk_pk": alone / measured_pk_pk if measured_pk_pk else 0.0}

    def estimate_text(self, source: str) -> str:
        k = self.expansion_k
        if source == "dc_offset" and not self.angle_reference()["known"]:
            bound = self.offset_magnitude()
            return ("which sensor and which sign: not identifiable (angle reference unknown)"
                    + (f"; |Δa|, |Δb| ≤ {bound[0] + k * bound[1]:.3g} A" if bound else ""))
        if source == "gain_mismatch" and not self.angle_reference()["known"]:
            return "k_a − k_b: sign not identifiable (angle reference unknown)"
        if source == "dc_offset":
            parts = []
            for name, label in (("ia_offset_a", "Δa"), ("ib_offset_a", "Δb")):
                v = self.value(name)
                text = _fmt(v[0], k * v[1], "A") if v else "not identifiable"
                parts.append(f"{label} = {text}")
            return ", ".join(parts)
        if source == "gain_mismatch":
            v = self.value("gain_k_diff")
            return "k_a − k_b = " + (_fmt(v[0], k * v[1], "%", 100.0) if v else "not identifiable")
        if source == "dead_time":
            v = self.value("dead_time_us")
            return "T_d = " + (_fmt(v[0], k * v[1], "µs") if v else "not identifiable")
        if source == "encoder":
            return self.encoder.get("note", "")
        if source == "motor_other":
            parts = [f"mech {r['mech_order']}: {1e3 * r['constant_nm']:.3g} mN·m"
                     + (f" + {1e3 * r['per_ampere_nm']:.3g} mN·m/A" if "per_ampere_nm" in r
                        else "") for r in self.motor_residual[:4]]
            return "; ".join(parts) + (" …" if len(self.motor_residual) > 4 else "")
        if source in ("motor_cogging", "motor_emf"):
            terms = [t for t in self.motor_terms() if t["source"] == source and t["identifiable"]]
            unit = "mN·m" if source == "motor_cogging" else "mN·m/A"
            return "; ".join(f"mech {t['mech_order']}: {1e3 * t['amplitude']:.3g} ± "
                             f"{1e3 * t['expanded_uncertainty']:.2g} {unit}" for t in terms)
        return "measured minus every modelled source"

    # ---------------------------------------------------------------- calibration
    def calibration(self) -> dict:
        """Offset corrections (A, to add to each sensor reading) and the gain trim of sensor a
        relative to b (%: multiply reading a by 1 + trim). None for each when not identifiable,
        all None when a capture's angle reference is unknown (the signs are not known then)."""
        k = self.expansion_k
        if not self.angle_reference()["known"]:
            return {"ia_offset_correction_a": None, "ib_offset_correction_a": None,
                    "gain_trim_a_pct": None}
        out = {}
        for name, key in (("ia_offset_a", "ia_offset_correction_a"),
                          ("ib_offset_a", "ib_offset_correction_a")):
            v = self.value(name)
            out[key] = None if v is None else {"value": -v[0], "expanded_uncertainty": k * v[1],
                                               "significant": abs(v[0]) > k * v[1]}
        v = self.value("gain_k_diff")
        # reading a × (1 + k_a)/(1 + k_b) equalises the sensors; ≈ 1 + (k_a − k_b)
        out["gain_trim_a_pct"] = None if v is None else {
            "value": 100.0 * v[0], "expanded_uncertainty": 100.0 * k * v[1],
            "significant": abs(v[0]) > k * v[1]}
        return out

    def corrected_coefficients(self, index: int) -> np.ndarray:
        """Point ``index``'s coefficients with the calibrated sources removed (the prediction)."""
        c = np.array(self.spectra[index].coefficients_nm, dtype=complex)
        for source in CALIBRATED_SOURCES:
            if source in self.contributions[index]:
                c = c - self.contributions[index][source]
        return c

    def predicted_after_correction(self) -> list[dict]:
        out = []
        for index, spectrum in enumerate(self.spectra):
            mean = abs(spectrum.mean_torque_nm)
            before = _pk_pk(spectrum.coefficients_nm)
            after = _pk_pk(self.corrected_coefficients(index))
            out.append({"label": spectrum.label, "pk_pk_pct_before": 100.0 * before / mean,
                        "pk_pk_pct_after": 100.0 * after / mean})
        return out

    # ---------------------------------------------------------------- output
    def to_dict(self) -> dict:
        k = self.expansion_k
        corr = self.fit.correlation()
        names = [p.name for p in self.parameters]
        keep = [i for i, p in enumerate(self.parameters) if p.identifiable]
        return _clean({
            "format": FORMAT, "coverage_factor": k,
            "setup": self.setup.to_dict(),
            "operating_points": [s.describe() for s in self.spectra],
            "fit_mech_orders": self.fit_orders,
            "parameters": [self._signed(p.to_dict(k)) for p in self.parameters],
            "motor_terms": self.motor_terms(),
            "correlation": {"names": [names[i] for i in keep],
                            "matrix": corr[np.ix_(keep, keep)].tolist()},
            "identifiability": {
                "identifiable": [names[i] for i in keep],
                "not_identifiable": [n for i, n in enumerate(names) if i not in keep],
                "condition_number": self.fit.condition_number,
                "weak_combinations": self.weak, "assumptions": self.aliases},
            "fit_quality": {"chi2": self.fit.chi2, "dof": self.fit.dof,
                            "birge_ratio": self.fit.birge_ratio},
            "encoder": self.encoder,
            "attribution": [{key: value for key, value in row.items()}
                            for row in self.attribution()],
            "calibration": self.calibration(),
            "angle_reference": self.angle_reference(),
            "offset_magnitude_a": (None if self.offset_magnitude() is None else dict(zip(
                ("value", "standard_uncertainty"), self.offset_magnitude()))),
            "predicted_after_correction": self.predicted_after_correction(),
            "unexplained": self.unexplained,
            "motor_residual": [{k: v for k, v in r.items() if k != "fitted_nm"}
                               for r in self.motor_residual],
            "notes": self.notes,
        })

    def _signed(self, entry: dict) -> dict:
        """A parameter's record entry; the sensor offsets and k_a − k_b say whether their sign
        (and which sensor) is identifiable: not without an angle reference."""
        if entry["name"] in ("ia_offset_a", "ib_offset_a", "gain_k_diff"):
            entry["sign_identifiable"] = bool(entry["identifiable"]
                                              and self.angle_reference()["known"])
        return entry

    def table(self) -> str:
        """The attribution table and calibration as text (the CLI prints it)."""
        lines = [f"{'source':40s} {'share of pk-pk':>14s}  estimate ± U (k = 2)"]
        for row in self.attribution():
            lines.append(f"{row['title'][:40]:40s} {100 * row['share_of_pk_pk']:13.1f}%  "
                         f"{row['estimate_text']}")
        cal = self.calibration()
        reference = self.angle_reference()
        lines.append("")
        if reference["known"]:
            lines.append("calibration to apply:")
        else:
            lines.append("calibration to apply: none signed — the angle reference (where phase "
                         "a's back EMF rises through zero in the capture's angle) is unknown; "
                         "state emf_a_rising_zero_elec_deg (manifest, --emf-a-zero-elec-deg) or "
                         "give phase currents")
        for key, label, unit in (("ia_offset_correction_a", "sensor a offset correction", "A"),
                                 ("ib_offset_correction_a", "sensor b offset correction", "A"),
                                 ("gain_trim_a_pct", "gain trim of sensor a vs b", "%")):
            item = cal.get(key)
            lines.append(f"  {label:30s} " + ("not identifiable" if item is None else
                         f"{item['value']:+.4g} ± {item['expanded_uncertainty']:.2g} {unit}"
                         + ("" if item["significant"] else " (not significant)")))
        lines.append("")
        lines.append(f"{'point':28s} {'pk-pk before':>12s} {'after (predicted)':>18s}"
                     + ("" if reference["known"] else
                        "  (after a calibration that needs the angle reference)"))
        for row in self.predicted_after_correction():
            lines.append(f"{row['label'][:28]:28s} {row['pk_pk_pct_before']:11.3f}% "
                         f"{row['pk_pk_pct_after']:17.3f}%")
        for point in reference["points"]:
            value = point["emf_a_rising_zero_elec_deg"]
            lines.append(f"angle reference of {point['label'][:28]}: " + (
                "unknown" if value is None else
                f"{value:.4g}° ± {point['standard_uncertainty_elec_deg']:.2g}° electrical")
                + f" ({point['source']})")
        for weak in self.weak:
            lines.append(f"not separable: {', '.join(weak['parameters'])} — {weak['separate_by']}")
        for alias in self.aliases:
            lines.append(f"assumed: no {alias['assumed_absent']} ({alias['consequence']}); "
                         f"to check: {alias['separate_by']}")
        for item in self.unexplained:
            lines.append(f"mech order {item['mech_order']} (elec {item['elec_order']:g}): "
                         f"{item['note']} (χ² {item['chi2']:.3g} > {item['limit_chi2']:.3g}; "
                         f"largest residual {item['largest_residual_pct_of_mean']:.3g} % of the "
                         f"mean torque at {item['at']})")
        return "\n".join(lines)


def _clean(value):
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return _clean(value.tolist())
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.bool_,)):
        return bool(value)
    if isinstance(value, complex):
        return {"re": value.real, "im": value.imag}
    return value
