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
    note: str = ""                                         # e.g. where it was characterised
    #: what a recheck of the winding needs (``hil.characterisation.recheck``): the back EMF
    #: measured with the drive disabled and the operating point the winding was measured at
    emf: object | None = field(default=None, compare=False, repr=False)
    point: object | None = field(default=None, compare=False, repr=False)

    def with_winding(self, resistance: Identified, inductance: Identified) -> "Characterisation":
        """This result with R and L measured again (a winding that warmed, ``recheck``)."""
        fresh = {resistance.name: resistance, inductance.name: inductance}
        return replace(self, identified=tuple(fresh.get(item.name, item)
                                              for item in self.identified))

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
        U): the bench as measured, which every plan's prediction and band then read (the record
        keeps the stated file). The validity regions are decided on it too: the pre-flight's
        refusals at collection, on the stated file, are decided again after the stage
        (fixtures/preflight.py ``refusal_on_bench``). Where the motor changes, ``loop_tuning`` keeps
        the stated one: the drive's PI gains were set from it."""
        changes = {name: value for name, value in self.used(stated).items()
                   if value != getattr(stated.motor, name)}
        measured = stated if not changes else replace(
            stated, motor=replace(stated.motor, **changes),
            loop_tuning=stated.loop_tuning or stated.motor)    # the drive's gains: its nameplate
        loop = self.loop_row(stated)
        if loop is not None and loop["disagrees"]:
            measured = replace(measured, drive=replace(
                measured.drive, current_loop_bandwidth_hz=loop["measured"]))
        transducer = self.transducer_row(stated)
        if transducer is not None and transducer["disagrees"]:
            measured = replace(measured, torque=replace(
                measured.torque, bandwidth_hz=transducer["measured"]))
        return measured

    def transducer_row(self, stated) -> dict | None:
        """The torque transducer's bandwidth: stated (``[torque] bandwidth_hz``), measured, U, or
        None (not measured, or nothing stated)."""
        item = self.get("bandwidth_hz")
        if item is None or stated.torque.bandwidth_hz is None:
            return None
        return _row("bandwidth_hz", stated.torque.bandwidth_hz, item)

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

    def motor_bounds(self, stated) -> dict:
        """Per identified motor parameter, (low, high): where its truth may lie — the measured
        value ± U (k = 2), widened to take in the value the predictions use (a stated value the
        measurement confirms may sit anywhere within U of it). The validity regions' guard
        (``hil.validity.guarded_voltage_problems``) decides at these bounds."""
        bounds = {}
        for name, used in self.used(stated).items():
            item = self.get(name)
            if item is None:
                continue
            bounds[name] = (min(used, item.value - item.expanded),
                            max(used, item.value + item.expanded))
        return bounds

    def stated_vs_measured(self, stated) -> list[dict]:
        """Per identified parameter: stated, measured, U (k = 2), and whether they disagree
        beyond U (a note about the motor: it is not the drive under test)."""
        return [_row(item.name, getattr(stated.motor, item.name), item)
                for item in self.identified if item.name in MOTOR_KEYS]

    def to_dict(self, stated=None) -> dict:
        out = {"identified": [item.to_dict() for item in self.identified],
               "not_identified": dict(self.not_identified)}
        if self.note:
            out["note"] = self.note
        if stated is not None:
            extra = [self.loop_row(stated), self.transducer_row(stated)]
            out["stated_vs_measured"] = self.stated_vs_measured(stated) + [
                row for row in extra if row is not None]
            tuned = self.measured_config(stated).loop_tuning
            if tuned is not None:
                out["loop_tuning"] = {
                    "phase_resistance_ohm": tuned.phase_resistance_ohm,
                    "phase_inductance_h": tuned.phase_inductance_h,
                    "basis": "the models' PI gains (Kp = L·ωc, Ki = R·ωc) from the stated "
                             "[motor] the drive was configured from; the plant is the measured "
                             "motor"}
        return out


def _row(name: str, stated: float, item: Identified) -> dict:
    """One stated-vs-measured row: the measured value is what the predictions use where it
    disagrees with the stated one beyond its U (k = 2)."""
    disagrees = abs(item.value - stated) > item.expanded
    return {"name": name, "stated": stated, "measured": item.value, "U_k2": item.expanded,
            "unit": item.unit, "disagrees": disagrees,
            "predictions_use": "measured" if disagrees else
            "stated (the measurement confirms it within U)"}


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
