"""The typed characterisation result: what was measured beside what the bench file states
(motulator keeps ``par`` and ``est_par``; design.md §12.5), and the bench as measured that the
predictions read."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from hil.characterisation.identify import Identified
from hil.motor import KE_DEFINITIONS

#: The ``[motor]`` keys the characterisation identifies.
MOTOR_KEYS = ("phase_resistance_ohm", "phase_inductance_h", "ke_v_s_per_rad")


@dataclass(frozen=True)
class Characterisation:
    """Identified motor parameters (``hil.characterisation.identify.Identified``, in the bench
    file's key names and units) and what the stage could not identify, with the reason."""

    identified: tuple[Identified, ...] = ()
    not_identified: dict = field(default_factory=dict)     # key -> reason

    def get(self, name: str) -> Identified | None:
        return next((item for item in self.identified if item.name == name), None)

    def used(self, stated) -> dict:
        """Per motor parameter, the value the predictions use: the measured one where it
        disagrees with the stated beyond its U (k = 2); the stated one where the measurement
        confirms it (|stated − measured| ≤ U: the bench is as stated, and every prediction stays
        what it was); the stated one where nothing was measured."""
        return {row["name"]: row["measured"] if row["disagrees"] else row["stated"]
                for row in self.stated_vs_measured(stated) if row["name"] in MOTOR_KEYS}

    def measured_config(self, stated):
        """``stated`` (a ``hil.config.BenchConfig``) with :meth:`used`'s motor parameters in
        ``[motor]`` and the measured loop bandwidth in ``[drive]`` (where it disagrees beyond
        U): the bench as measured, which every plan's prediction, band and validity region then
        read (the record keeps the stated file)."""
        changes = {name: value for name, value in self.used(stated).items()
                   if value != getattr(stated.motor, name)}
        measured = replace(stated, motor=replace(stated.motor, **changes)) if changes else stated
        loop = self.loop_row(stated)
        if loop is not None and loop["disagrees"]:
            measured = replace(measured, drive=replace(
                measured.drive, current_loop_bandwidth_hz=loop["measured"]))
        return measured

    def loop_row(self, stated) -> dict | None:
        """The current loop's bandwidth: documented, measured (g × documented), U, or None."""
        gain = self.get("current_loop_gain_pu")
        documented = stated.drive.current_loop_bandwidth_hz
        if gain is None or documented is None:
            return None
        return {"name": "current_loop_bandwidth_hz", "stated": documented,
                "measured": gain.value * documented, "U_k2": gain.expanded * documented,
                "unit": "Hz", "disagrees": abs(gain.value - 1.0) > gain.expanded,
                "predictions_use": "measured" if abs(gain.value - 1.0) > gain.expanded
                else "stated (the measurement confirms it within U)"}

    def stated_vs_measured(self, stated) -> list[dict]:
        """Per identified parameter: stated, measured, U (k = 2), and whether they disagree
        beyond U (a note about the motor: it is not the drive under test)."""
        rows = []
        for item in self.identified:
            value = getattr(stated.motor, item.name, None)
            if value is None:
                continue
            disagrees = abs(item.value - value) > item.expanded
            rows.append({"name": item.name, "stated": value, "measured": item.value,
                         "U_k2": item.expanded, "unit": item.unit, "disagrees": disagrees,
                         "predictions_use": "measured" if disagrees else
                         "stated (the measurement confirms it within U)"})
        return rows

    def to_dict(self, stated=None) -> dict:
        out = {"identified": [item.to_dict() for item in self.identified],
               "not_identified": dict(self.not_identified)}
        if stated is not None:
            loop = self.loop_row(stated)
            out["stated_vs_measured"] = self.stated_vs_measured(stated) + ([loop] if loop else [])
        return out


def ke_from_psi(psi: Identified, ke_definition: str) -> Identified:
    """ψ (peak phase EMF per mechanical rad/s) as the bench file's Ke (read as ``ke_definition``)."""
    factor = KE_DEFINITIONS[ke_definition]
    return Identified("ke_v_s_per_rad", psi.value / factor, psi.u / factor, "V*s/rad",
                      psi.method + f"; stated as Ke read as {ke_definition} (÷{factor:.6g})")


def torque_scale_tolerance_pu(bench, expected_nm: float) -> tuple[float, str] | None:
    """The self-check's torque-scale tolerance (per unit of ``expected_nm``) when the bench's
    K_t was measured electrically (from ψ): U (k = 2) of the combination of ψ's relative u and the
    transducer's accuracy class (% of full scale, rectangular: /√3), with a description; None
    when nothing was measured (the caller keeps its nameplate tolerance)."""
    result = getattr(bench, "characterisation", None)
    ke = result.get("ke_v_s_per_rad") if result is not None else None
    if ke is None:
        return None
    inputs = bench.config.uncertainty_inputs()
    class_nm = inputs["transducer_accuracy_class_pct"] / 100.0 * inputs["transducer_full_scale_nm"]
    u_class = class_nm / 3.0 ** 0.5 / abs(expected_nm)
    u_psi = ke.u / ke.value
    tolerance = 2.0 * (u_class ** 2 + u_psi ** 2) ** 0.5
    return tolerance, (f"K_t from ψ measured on this bench (u {u_psi:.2%}) and the transducer's "
                       f"class (u {u_class:.2%} of this torque): U (k = 2) {tolerance:.2%}")
