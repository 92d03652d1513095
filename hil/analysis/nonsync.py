"""Non-synchronous torque RMS: what is left of a capture once the synchronous average is removed.

A ripple that does not repeat every electrical revolution (PWM duty quantisation under a closed
loop, transducer noise) averages out of the synchronous average, and the pk-pk of what remains
is a poor statistic (its uncertainty is of the order of its value). Its RMS is not: estimated
from N_eff independent stretches its relative standard uncertainty falls as 1/(2·√N_eff).

Definition, over the whole electrical revolutions R of the capture (travel angle from the first
sample): the Fourier series of orders 0..``max_order`` in the electrical angle is fitted to the
torque samples by least squares (the synchronous average as a series), and
``rms_nm = sqrt(mean(residual²))``. No degrees-of-freedom correction: the fit also removes the
non-synchronous part that falls on those orders, about 1/R of its power there, and a model of
the statistic states that share (``hil.model.pwm_noise``). Type-A standard uncertainty: the
residual's mean square per block (``blocks_per_revolution`` equal stretches of angle per
revolution), its scatter over the blocks → u(mean square) = s/√n_blocks → u(rms) = u/(2·rms).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from hil.analysis.angle import TWO_PI, check_finite, check_time, travel_angle
from hil.errors import InputError

#: Largest condition number of the fit's normal equations: beyond it the samples' angles do not
#: pin the series down (fewer samples than unknowns, or orders aliased onto each other by too
#: few samples per revolution) and the residual would be meaningless.
MAX_NORMAL_CONDITION = 1e10
#: Blocks per revolution for the type-A scatter; each must be far longer than the residual's
#: correlation time (1/4 electrical revolution is 15 ms at 500 rpm with 2 pole pairs).
DEFAULT_BLOCKS_PER_REVOLUTION = 4


@dataclass(frozen=True)
class NonSyncResult:
    """RMS of the non-synchronous torque and its standard uncertainty (module docstring)."""

    rms_nm: float
    rms_u_nm: float           # type-A standard uncertainty (k = 1)
    mean_torque_nm: float
    revolutions: int
    samples: int
    max_order: int
    blocks: int

    def to_dict(self) -> dict:
        return asdict(self)


def nonsynchronous_rms(time_s, torque_nm, angle_elec_rad, *, max_order: int,
                       blocks_per_revolution: int = DEFAULT_BLOCKS_PER_REVOLUTION
                       ) -> NonSyncResult:
    """RMS of the torque after its synchronous average (orders 0..``max_order``) is removed.

    InputError for non-finite or mismatched channels, fewer than 2 whole revolutions, too few
    samples per revolution for the fitted orders, or out-of-range options.
    """
    time_s = check_time(time_s)
    torque_nm = check_finite("torque_nm", torque_nm)
    if not time_s.size == torque_nm.size == np.asarray(angle_elec_rad).size:
        raise InputError(f"time ({time_s.size}), torque ({torque_nm.size}) and angle "
                         f"({np.asarray(angle_elec_rad).size}) must have the same number of "
                         "samples")
    if isinstance(max_order, bool) or not isinstance(max_order, int) or not 1 <= max_order <= 4096:
        raise InputError(f"max_order must be an integer in 1..4096, got {max_order!r}")
    if isinstance(blocks_per_revolution, bool) or not isinstance(blocks_per_revolution, int) \
            or not 1 <= blocks_per_revolution <= 64:
        raise InputError(f"blocks_per_revolution must be an integer in 1..64, "
                         f"got {blocks_per_revolution!r}")
    travel = travel_angle(time_s, angle_elec_rad).travel_rad
    travel = travel - travel[0]
    revolutions = int(travel[-1] // TWO_PI)
    if revolutions < 2:
        raise InputError(f"the capture spans {travel[-1] / TWO_PI:.2f} electrical revolutions; "
                         "the non-synchronous RMS needs at least 2 whole ones")
    keep = travel < revolutions * TWO_PI
    angle, torque = travel[keep], torque_nm[keep]
    if angle.size < 4 * (2 * max_order + 1):
        raise InputError(f"{angle.size} samples over {revolutions} revolutions cannot fit orders "
                         f"0..{max_order}; sample faster or lower max_order")
    residual, mean_nm = synchronous_residual(angle, torque, max_order)
    mean_square = float(np.mean(residual ** 2))
    rms = math.sqrt(mean_square)
    blocks = revolutions * blocks_per_revolution
    index = np.minimum((angle / (TWO_PI / blocks_per_revolution)).astype(int), blocks - 1)
    counts = np.bincount(index, minlength=blocks)
    if counts.min() < 2:
        raise InputError(f"a block of 1/{blocks_per_revolution} revolution holds "
                         f"{int(counts.min())} sample(s); sample faster or use fewer blocks")
    block_ms = np.bincount(index, residual ** 2, minlength=blocks) / counts
    u_ms = float(np.std(block_ms, ddof=1) / math.sqrt(blocks))
    return NonSyncResult(rms_nm=rms, rms_u_nm=u_ms / (2.0 * rms) if rms > 0 else 0.0,
                         mean_torque_nm=float(mean_nm), revolutions=revolutions,
                         samples=int(angle.size), max_order=max_order, blocks=blocks)


def synchronous_residual(angle_rad: np.ndarray, torque: np.ndarray, max_order: int
                         ) -> tuple[np.ndarray, np.ndarray]:
    """(torque less its least-squares Fourier series of orders 0..``max_order`` in the angle,
    the series' mean); ``torque`` one row per record (rows × samples) or one record.

    The normal equations are built from the sample angles' power sums S(m) = Σ e^{jmθ},
    m = 0..2K, by the product formulas (cos aθ·cos bθ = ½[cos (a−b)θ + cos (a+b)θ], …) instead of
    a samples × (2K+1) design matrix and its Gram product, and the powers e^{jkθ} by running
    products instead of sines and cosines: the same least squares (rounding apart, ~1e-13), 5–10×
    faster (issue 33: 1 s of the default run). The Fourier basis over whole revolutions is well
    conditioned, so the normal equations lose nothing."""
    angle_rad = np.asarray(angle_rad, dtype=np.float64)
    y = np.asarray(torque, dtype=np.float64)
    k = int(max_order)
    unit = np.exp(1j * angle_rad)
    powers = np.empty((angle_rad.size, 2 * k + 1), dtype=np.complex128)   # e^{jmθ}, m = 0..2K
    powers[:, 0] = 1.0
    if k:
        np.cumprod(np.broadcast_to(unit[:, None], (angle_rad.size, 2 * k)), axis=1,
                   out=powers[:, 1:])
    sums = powers.sum(axis=0)                                            # S(m), m = 0..2K
    orders = np.arange(1, k + 1)
    diff = np.subtract.outer(orders, orders)
    total = np.add.outer(orders, orders)
    s_diff = np.where(diff >= 0, sums[np.abs(diff)], np.conj(sums[np.abs(diff)]))
    s_total = sums[total]
    gram = np.empty((2 * k + 1, 2 * k + 1))
    gram[0, 0] = angle_rad.size
    gram[0, 1:k + 1] = gram[1:k + 1, 0] = sums[1:k + 1].real
    gram[0, k + 1:] = gram[k + 1:, 0] = sums[1:k + 1].imag
    gram[1:k + 1, 1:k + 1] = 0.5 * (s_diff.real + s_total.real)      # Σ cos aθ cos bθ
    gram[k + 1:, k + 1:] = 0.5 * (s_diff.real - s_total.real)        # Σ sin aθ sin bθ
    cos_sin = 0.5 * (s_total.imag - s_diff.imag)                     # Σ cos aθ sin bθ
    gram[1:k + 1, k + 1:] = cos_sin
    gram[k + 1:, 1:k + 1] = cos_sin.T
    if angle_rad.size < 2 * k + 1 or np.linalg.cond(gram) > MAX_NORMAL_CONDITION:
        raise InputError(f"{angle_rad.size} samples at these angles cannot resolve the Fourier "
                         f"series to order {k} (2K+1 = {2 * k + 1} unknowns; normal equations "
                         f"condition {np.linalg.cond(gram):.3g}): sample faster or lower "
                         "max_order")
    basis = powers[:, 1:k + 1]
    projected = y @ basis                                            # Σ y e^{jkθ}, per record
    right = np.concatenate([y.sum(axis=-1)[..., None], projected.real, projected.imag],
                           axis=-1)
    coefficients = np.linalg.solve(gram, right.T)                    # (2K+1) × records
    mean = coefficients[0]
    phasors = coefficients[1:k + 1] - 1j * coefficients[k + 1:]      # a_k − j b_k
    fitted = (basis @ phasors).real.T + np.asarray(mean)[..., None]
    return y - fitted, mean


def nonsynchronous_rms_of_capture(capture, *, pole_pairs: int, max_order: int,
                                  blocks_per_revolution: int = DEFAULT_BLOCKS_PER_REVOLUTION
                                  ) -> NonSyncResult:
    """:func:`nonsynchronous_rms` of a :class:`~hil.capture.Capture`'s ``torque_nm`` against
    ``pole_pairs`` × its ``rotor_angle_mech_rad`` (InputError if either channel is missing)."""
    missing = [name for name in ("time_s", "torque_nm", "rotor_angle_mech_rad")
               if name not in capture]
    if missing:
        raise InputError(f"the non-synchronous RMS needs capture channel(s) {missing}; the "
                         f"capture has {sorted(capture.channels)}")
    if isinstance(pole_pairs, bool) or not isinstance(pole_pairs, int) or pole_pairs < 1:
        raise InputError(f"pole_pairs must be an integer >= 1, got {pole_pairs!r}")
    mech = check_finite("rotor_angle_mech_rad", capture["rotor_angle_mech_rad"])
    return nonsynchronous_rms(capture["time_s"], capture["torque_nm"],
                              pole_pairs * np.unwrap(mech, period=TWO_PI), max_order=max_order,
                              blocks_per_revolution=blocks_per_revolution)


def floor_removed(raw: float, raw_u: float, reference: float, reference_u: float,
                  reference_model: float, *, k: float = 2.0) -> tuple[float, float]:
    """(value, expanded uncertainty U at coverage ``k``) of a point's non-synchronous RMS with the
    bench's floor removed in quadrature: value = sqrt(max(raw² − floor², 0)), floor² =
    max(reference² − reference_model², 0) (the reference point's RMS less its modelled share;
    all in one unit, e.g. per unit of the mean torque; the model value taken as exact).

    U of value² = k·2·sqrt((raw·u_raw)² + (reference·u_ref)²), the reference term only where a
    floor is removed. value = sqrt(value²) is not linear near 0, so U is the larger half-width of
    sqrt over [value² − U², value² + U²] (clipped at 0): the linear U²/(2·value) where value ≫ U,
    finite (≤ sqrt(U of value²)) when the floor is as large as the point's RMS."""
    for name, number in (("raw", raw), ("raw_u", raw_u), ("reference", reference),
                         ("reference_u", reference_u), ("reference_model", reference_model)):
        if not (math.isfinite(number) and number >= 0):
            raise InputError(f"{name}={number!r} must be a finite number >= 0")
    floor2 = max(reference ** 2 - reference_model ** 2, 0.0)
    square = max(raw ** 2 - floor2, 0.0)
    value = math.sqrt(square)
    u_square = 2.0 * math.hypot(raw * raw_u, reference * reference_u if floor2 > 0 else 0.0)
    spread = k * u_square
    upper = math.sqrt(square + spread) - value
    lower = value - math.sqrt(max(square - spread, 0.0))
    return value, max(upper, lower)
