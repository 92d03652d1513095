"""The capture's angle reference: where, in the capture's own electrical angle, phase a's back EMF
crosses zero going positive (``emf_a_rising_zero_elec_deg``; convention in
hil/diagnosis/README.md).

The forward models (paper eqs 4, 7: e_a = +E·sin θ_e, i_a = I·sin(θ_e − φ)) put that crossing at
θ_e = 0. A capture whose angle zero lies elsewhere (an encoder's commutation offset, another
simulator's convention) shows every controller signature rotated: an order-k electrical line by
k times the reference. Rotating the spectra by −reference before the fit (hil.diagnosis.orders)
gives the twin's convention. The reference is

* **stated** (a manifest's ``emf_a_rising_zero_elec_deg``, ``hil diagnose --emf-a-zero-elec-deg``),
* **recorded** (the capture's meta, written by the bench from its self-check's back-EMF
  measurement, :mod:`hil.selfcheck`),
* **measured** from the capture's phase currents (the phase of phase a's fundamental against the
  commanded current angle φ; it assumes the drive commutates correctly, i.e. puts its current at
  φ from the back EMF), or
* **unknown**: which sensor carries an offset and the signs of Δa, Δb, k_a − k_b are then not
  identifiable, and no signed calibration is printed (hil.diagnosis.result).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hil.capture import Capture

#: Meta keys a capture carries its recorded reference (degrees electrical) and its standard
#: uncertainty (degrees) under.
META_KEY = "emf_a_rising_zero_elec_deg"
META_U_KEY = "emf_a_rising_zero_u_elec_deg"
META_SOURCE_KEY = "emf_a_rising_zero_source"


@dataclass(frozen=True)
class AngleReference:
    """``elec_deg`` None: unknown. ``u_elec_deg``: standard uncertainty (degrees electrical)."""

    elec_deg: float | None
    u_elec_deg: float
    source: str

    @property
    def known(self) -> bool:
        return self.elec_deg is not None

    def to_meta(self) -> dict:
        return {META_KEY: self.elec_deg, META_U_KEY: self.u_elec_deg, META_SOURCE_KEY: self.source}

    def describe(self) -> str:
        if not self.known:
            return f"unknown ({self.source})"
        return f"{self.elec_deg:.4g}° ± {self.u_elec_deg:.2g}° electrical ({self.source})"


UNKNOWN = AngleReference(None, math.inf, "not stated, not recorded, no phase currents")


def wrap_deg(angle_deg: float) -> float:
    """An angle in (−180, 180] degrees."""
    wrapped = math.remainder(angle_deg, 360.0)
    return 180.0 if wrapped == -180.0 else wrapped


def recorded(capture: Capture) -> AngleReference | None:
    """The reference a capture's meta records (None when it records none)."""
    if META_KEY not in capture.meta:
        return None
    value = capture.meta[META_KEY]
    if value is None:
        return AngleReference(None, math.inf, str(capture.meta.get(META_SOURCE_KEY, "recorded "
                                                                   "as unknown")))
    u = capture.meta.get(META_U_KEY)
    return AngleReference(float(value), float(u) if u is not None else 0.0,
                          str(capture.meta.get(META_SOURCE_KEY, "recorded in the capture")))


def measure_from_currents(capture: Capture, *, pole_pairs: int,
                          current_angle_rad: float) -> AngleReference | None:
    """The reference from phase a's current: i_a = I·sin(θ_c − ref − φ) (eq 4 with the capture's
    angle θ_c = θ_e + ref), fitted per electrical revolution by least squares on
    {cos θ_c, sin θ_c, 1}. Standard uncertainty: the scatter of the per-revolution values (type A).
    A current loop with integral action in the rotor frame tracks the dc reference without a
    steady-state phase error, so the loop adds none; a sensor gain mismatch g shifts phase a's
    fundamental by up to about |g|/2 rad (0.4° at 1.5 %), not included. None when the capture has
    no phase current a, no angle, or less than two electrical revolutions.
    """
    if "ia_a" not in capture or "rotor_angle_mech_rad" not in capture:
        return None
    theta = np.unwrap(np.asarray(capture["rotor_angle_mech_rad"], dtype=float)) * pole_pairs
    current = np.asarray(capture["ia_a"], dtype=float)
    ok = np.isfinite(theta) & np.isfinite(current)
    theta, current = theta[ok], current[ok]
    if theta.size < 16:
        return None
    turns = np.floor((theta - theta[0]) / (2 * math.pi) * np.sign(theta[-1] - theta[0] or 1.0))
    values = []
    for turn in np.unique(turns)[:-1] if np.unique(turns).size > 1 else []:
        pick = turns == turn
        if pick.sum() < 16:
            continue
        basis = np.column_stack([np.cos(theta[pick]), np.sin(theta[pick]), np.ones(pick.sum())])
        (a, b, _), *_ = np.linalg.lstsq(basis, current[pick], rcond=None)
        if math.hypot(a, b) > 0:
            values.append(math.atan2(-a, b))
    if len(values) < 2:
        return None
    phasors = np.exp(1j * np.array(values))
    mean = np.angle(phasors.mean())
    spread = np.angle(phasors * np.exp(-1j * mean))
    u_a = float(np.std(spread, ddof=1) / math.sqrt(spread.size))
    u_deg = math.degrees(u_a)
    ref = wrap_deg(math.degrees(mean - current_angle_rad))
    return AngleReference(ref, u_deg, "measured from phase a's current against the commanded "
                                      "current angle (assumes the drive commutates correctly)")


def resolve(capture: Capture, *, stated: AngleReference | None, pole_pairs: int,
            current_angle_rad: float) -> AngleReference:
    """Stated, else recorded, else measured from the phase currents, else :data:`UNKNOWN`."""
    for candidate in (stated, recorded(capture)):
        if candidate is not None:
            return candidate
    measured = measure_from_currents(capture, pole_pairs=pole_pairs,
                                     current_angle_rad=current_angle_rad)
    return measured or UNKNOWN
