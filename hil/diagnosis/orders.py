"""Order spectra for diagnosis: complex torque coefficients per *mechanical* order, with their
type-A standard uncertainty, and the operating point they were measured at.

The diagnosis needs mechanical orders (cogging is fixed in the mechanical angle; with p pole pairs
electrical order k is mechanical order p·k) and phases referred to the rotor's angle zero.
:func:`hil.analysis.analyze_capture` gives both when called with ``pole_pairs=1`` (its
"electrical" angle is then the mechanical one): ``τ(θ_m) = c₀ + Σ Re(c_m·e^{i·m·θ_m})``,
``c_m = A_m·e^{iφ_m}`` (hil.analysis.spectrum convention). The scatter of the per-revolution
coefficients gives a standard uncertainty per real/imaginary component, pooled over neighbouring
orders (the in-band noise varies slowly with order) so that it has enough degrees of freedom.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hil.analysis import analyze_capture
from hil.analysis.spectrum import order_coefficients, peak_to_peak
from hil.capture import Capture
from hil.errors import InputError

#: Neighbouring orders on each side pooled into one order's noise estimate.
POOL_HALF_WIDTH = 3


@dataclass(frozen=True)
class OrderSpectrum:
    """Complex torque coefficients of one capture per mechanical order 0..M (N·m).

    ``speed_rpm`` is signed (negative: rotor turning backwards), ``current_a`` the peak phase
    current amplitude commanded, ``current_angle_rad`` φ (paper eq 4). ``sigma_nm[m]`` is the
    standard uncertainty of each of Re c_m and Im c_m (type A, pooled; index 0 unused).
    """

    label: str
    speed_rpm: float
    current_a: float
    current_angle_rad: float
    pole_pairs: int
    coefficients_nm: np.ndarray
    sigma_nm: np.ndarray
    revolutions: int
    meta: dict = field(default_factory=dict)
    #: dc of the actual phase currents a, b over whole electrical revolutions (A), from the DAQ's
    #: current channels when the capture has them, and its type-A standard uncertainty
    current_dc_a: tuple[float, float] | None = None
    current_dc_sigma_a: float | None = None
    #: the capture's angle reference (hil.diagnosis.angle_reference): the capture's electrical
    #: angle (degrees) at which phase a's back EMF crosses zero going positive; the coefficients
    #: above are already rotated to the twin's convention (0). None: unknown (not rotated; which
    #: sensor and which sign are then not identifiable). Its standard uncertainty (degrees) and
    #: where it came from.
    emf_a_rising_zero_elec_deg: float | None = 0.0
    angle_reference_u_elec_deg: float = 0.0
    angle_reference_source: str = "the twin's convention (not stated)"

    @property
    def max_mech_order(self) -> int:
        return self.coefficients_nm.size - 1

    @property
    def mean_torque_nm(self) -> float:
        return float(self.coefficients_nm[0].real)

    def pk_pk_nm(self, coefficients: np.ndarray | None = None) -> float:
        """Pk-pk of the band-limited torque of ``coefficients`` (default: the measured ones)."""
        c = self.coefficients_nm if coefficients is None else coefficients
        return float(peak_to_peak(np.asarray(c)[None, :])[0])

    def describe(self) -> dict:
        return {"label": self.label, "speed_rpm": self.speed_rpm, "current_a": self.current_a,
                "current_angle_rad": self.current_angle_rad, "pole_pairs": self.pole_pairs,
                "mean_torque_nm": self.mean_torque_nm, "pk_pk_nm": self.pk_pk_nm(),
                "mech_revolutions": self.revolutions, "max_mech_order": self.max_mech_order,
                "emf_a_rising_zero_elec_deg": self.emf_a_rising_zero_elec_deg,
                "angle_reference_u_elec_deg": self.angle_reference_u_elec_deg,
                "angle_reference_source": self.angle_reference_source}


def rotate_to_emf_reference(coefficients: np.ndarray, emf_a_rising_zero_elec_deg: float,
                            pole_pairs: int) -> np.ndarray:
    """Coefficients per mechanical order m referred to the twin's angle (θ_e = 0 where phase a's
    back EMF rises through zero): with the capture's angle θ_c = θ + ref (ref = the reference in
    electrical rad, ref/p mechanical), c_m·e^{i·m·θ_c} = (c_m·e^{i·m·ref/p})·e^{i·m·θ}."""
    m = np.arange(np.asarray(coefficients).shape[-1])
    shift_mech_rad = math.radians(emf_a_rising_zero_elec_deg) / pole_pairs
    return np.asarray(coefficients) * np.exp(1j * m * shift_mech_rad)


def pooled_sigma(per_rev: np.ndarray, half_width: int = POOL_HALF_WIDTH) -> np.ndarray:
    """Standard uncertainty of the mean coefficient's Re and Im parts, per order (index 0..M).

    ``per_rev``: complex coefficients, one row per revolution. The variance of Re and Im across
    revolutions (divided by the number of revolutions) is averaged over orders m±half_width.
    """
    revolutions = per_rev.shape[0]
    if revolutions < 2:
        raise InputError("diagnosis needs at least 2 whole mechanical revolutions per capture "
                         "for a type-A uncertainty")
    variance = 0.5 * (np.var(per_rev.real, axis=0, ddof=1) + np.var(per_rev.imag, axis=0, ddof=1))
    variance /= revolutions
    pooled = np.empty_like(variance)
    top = variance.size - 1
    for m in range(variance.size):
        low, high = max(1, m - half_width), min(top, m + half_width)
        pooled[m] = variance[low:high + 1].mean() if high >= low else variance[m]
    return np.sqrt(pooled)


def measured_speed_rpm(capture: Capture) -> float:
    """Mean mechanical speed (signed, rpm) from the capture's angle channel."""
    time_s = np.asarray(capture["time_s"], dtype=float)
    if "rotor_angle_mech_rad" in capture:
        angle = np.unwrap(np.asarray(capture["rotor_angle_mech_rad"], dtype=float))
    elif "encoder_counts" in capture:
        cpr = capture.meta.get("encoder_counts_per_rev")
        if not isinstance(cpr, (int, float)) or cpr <= 0:
            raise InputError("capture channel 'encoder_counts' needs meta 'encoder_counts_per_rev'")
        angle = np.asarray(capture["encoder_counts"], dtype=float) * (2 * math.pi / cpr)
    elif "speed_rpm" in capture:
        return float(np.mean(capture["speed_rpm"]))
    else:
        raise InputError("capture has no rotor angle or speed channel; the diagnosis needs one")
    span = time_s[-1] - time_s[0]
    if not span > 0:
        raise InputError("capture spans no time")
    return float((angle[-1] - angle[0]) / span * 60.0 / (2 * math.pi))


def spectrum_from_capture(capture: Capture, *, current_a: float, current_angle_rad: float = 0.0,
                          speed_rpm: float | None = None, max_mech_order: int = 64,
                          pole_pairs: int | None = None, label: str = "") -> OrderSpectrum:
    """Mechanical-order spectrum of a torque capture (hil.analysis with ``pole_pairs=1``).

    ``speed_rpm`` defaults to the speed measured from the capture's angle channel.
    """
    if not (isinstance(current_a, (int, float)) and 0 < current_a <= 100):
        raise InputError(f"current_a={current_a!r} must be a peak phase current in (0, 100] A")
    pp = pole_pairs if pole_pairs is not None else capture.meta.get("pole_pairs")
    if isinstance(pp, float) and pp.is_integer():
        pp = int(pp)
    if not isinstance(pp, int) or not 1 <= pp <= 100:
        raise InputError(f"pole pairs must be an integer 1..100 (capture meta 'pole_pairs' or "
                         f"the option), got {pp!r}")
    result = analyze_capture(capture, max_order=max_mech_order, pole_pairs=1)
    per_rev = order_coefficients(result.revolution_matrix_nm, max_mech_order)
    coefficients = np.concatenate(([complex(result.mean_torque_nm)],
                                   result.amplitude_nm * np.exp(1j * result.phase_rad)))
    speed = measured_speed_rpm(capture) if speed_rpm is None else float(speed_rpm)
    if speed == 0:
        raise InputError("speed_rpm=0: the diagnosis needs a turning rotor")
    dc, dc_sigma = current_dc(capture, pp)
    reference = _angle_reference(capture)
    if reference.known:
        coefficients = rotate_to_emf_reference(coefficients, reference.elec_deg, pp)
    return OrderSpectrum(label=label, speed_rpm=speed, current_a=float(current_a),
                         current_angle_rad=float(current_angle_rad), pole_pairs=pp,
                         coefficients_nm=coefficients, sigma_nm=pooled_sigma(per_rev),
                         revolutions=result.revolutions, meta=dict(capture.meta),
                         current_dc_a=dc, current_dc_sigma_a=dc_sigma,
                         emf_a_rising_zero_elec_deg=reference.elec_deg,
                         angle_reference_u_elec_deg=reference.u_elec_deg,
                         angle_reference_source=reference.source)


def _angle_reference(capture: Capture):
    """The reference the capture's meta records (``hil diagnose`` writes the stated or measured
    one there); a ripple-hil capture that records none: the twin's convention, said so; an
    imported one: unknown."""
    from hil.diagnosis import angle_reference as ref

    recorded = ref.recorded(capture)
    if recorded is not None:
        return recorded
    if "imported" in capture.meta:
        return ref.UNKNOWN
    return ref.AngleReference(0.0, 0.0, "the twin's convention (the capture records none)")


def current_dc(capture: Capture, pole_pairs: int) -> tuple[tuple[float, float] | None,
                                                             float | None]:
    """Angle-averaged dc of the phase currents ``ia_a``, ``ib_a`` over whole electrical
    revolutions (the same resampling as the torque, hil.analysis), and the larger of the two
    type-A standard uncertainties; (None, None) when the capture has no current channels."""
    if "ia_a" not in capture or "ib_a" not in capture:
        return None, None
    means, sigmas = [], []
    for name in ("ia_a", "ib_a"):
        view = Capture(channels={key: capture[key] for key in capture.channels
                                 if key != "torque_nm"} | {"torque_nm": capture[name]},
                       meta=dict(capture.meta))
        result = analyze_capture(view, max_order=8, pole_pairs=pole_pairs)
        per_rev = result.revolution_matrix_nm.mean(axis=1)
        means.append(float(result.mean_torque_nm))
        sigmas.append(float(np.std(per_rev, ddof=1) / math.sqrt(per_rev.size))
                      if per_rev.size > 1 else float("nan"))
    return (means[0], means[1]), max(sigmas)
