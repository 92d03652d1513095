"""GUM uncertainty budget of the per-unit peak-to-peak ripple ``p = pk_pk / |mean|`` (k = 2).

Sources (each a row of the budget table: source, value, unit, distribution, divisor, sensitivity,
contribution in per unit of the mean torque):

* **Type A — revolution-to-revolution scatter.** The single revolutions (their order spectra or
  their angle bins, whichever the pk-pk is taken from) are resampled with replacement (bootstrap,
  fixed seed, in contiguous blocks when there are many revolutions) and ``p`` is recomputed for
  each draw; the standard deviation is the standard uncertainty of ``p`` of the synchronous
  average. Synchronous averaging over R revolutions leaves noise of σ/√R per bin, which still
  lifts the pk-pk of the average (the extremes pick up noise).
* **Residual noise bias.** The same draws, scaled up, estimate that lift by
  simulation-extrapolation to zero noise (see :func:`type_a`). It is not subtracted: ``p`` stays
  the pk-pk of the synchronous average as defined, and the bias is added linearly to the expanded
  uncertainty (``U = k·u_c + |bias|``), so the interval ``p ± U`` covers the noise-free value.
* **Type B — transducer accuracy class** (± class % of full scale on any reading, rectangular).
  On the mean torque it acts like an offset: sensitivity ``p/|mean|``. On the pk-pk (a span of two
  readings, whose offsets cancel) it is taken as a sensitivity error of class % of the span.
* **Type B — DAQ resolution**: a rectangular error of ±LSB/2 on each of the two readings that make
  the pk-pk, i.e. LSB/√6 on their difference, sensitivity ``1/|mean|``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Callable

import numpy as np
from numba import njit

from hil.errors import InputError

COVERAGE_FACTOR = 2.0
BOOTSTRAP_DRAWS = 400
BOOTSTRAP_MAX_BLOCKS = 200
BOOTSTRAP_SEED = 20020901       # fixed: the same capture always gives the same budget
BOOTSTRAP_CHUNK = 100
SIMEX_SCALES = (1.0, math.sqrt(2.0), math.sqrt(3.0))   # λ: added noise / measured noise


@dataclass(frozen=True)
class InstrumentUncertainty:
    """Type-B data of the torque chain, from the bench file's ``[[instrument]]`` entries.

    ``transducer_accuracy_class_pct``: the transducer's accuracy class, ± % of its full scale
    ``transducer_full_scale_nm`` (N·m). DAQ resolution: either ``daq_lsb_nm`` (one LSB in N·m) or
    ``daq_bits`` with ``daq_range_nm`` (the full input span in N·m; LSB = span / 2**bits).
    All zero/None means "no type-B data" (the budget then holds type A only).
    """

    transducer_accuracy_class_pct: float = 0.0
    transducer_full_scale_nm: float = 0.0
    daq_bits: int | None = None
    daq_range_nm: float | None = None
    daq_lsb_nm: float | None = None

    def __post_init__(self) -> None:
        _require(0.0 <= self.transducer_accuracy_class_pct <= 10.0,
                 "transducer_accuracy_class_pct", self.transducer_accuracy_class_pct, "0..10 %")
        _require(0.0 <= self.transducer_full_scale_nm <= 1e6,
                 "transducer_full_scale_nm", self.transducer_full_scale_nm, "0..1e6 N*m")
        if self.daq_bits is not None:
            _require(isinstance(self.daq_bits, int) and 1 <= self.daq_bits <= 32,
                     "daq_bits", self.daq_bits, "an integer 1..32")
            _require(self.daq_range_nm is not None and 0.0 < self.daq_range_nm <= 1e6,
                     "daq_range_nm", self.daq_range_nm, "0 < span <= 1e6 N*m (with daq_bits)")
            _require(self.daq_lsb_nm is None, "daq_lsb_nm", self.daq_lsb_nm,
                     "None when daq_bits/daq_range_nm are given")
        elif self.daq_range_nm is not None:
            _require(False, "daq_bits", None, "an integer 1..32 (with daq_range_nm)")
        if self.daq_lsb_nm is not None:
            _require(0.0 <= self.daq_lsb_nm <= 1e3, "daq_lsb_nm", self.daq_lsb_nm, "0..1e3 N*m")

    @property
    def lsb_nm(self) -> float:
        """One DAQ least-significant bit in N·m (0 if unknown)."""
        if self.daq_lsb_nm is not None:
            return float(self.daq_lsb_nm)
        if self.daq_bits is not None and self.daq_range_nm is not None:
            return float(self.daq_range_nm) / 2.0 ** self.daq_bits
        return 0.0

    @property
    def transducer_limit_nm(self) -> float:
        """Half-width of the accuracy-class error band in N·m."""
        return self.transducer_accuracy_class_pct / 100.0 * self.transducer_full_scale_nm


def _require(ok: bool, name: str, value, allowed: str) -> None:
    if not ok:
        raise InputError(f"instrument uncertainty {name}={value!r} is out of range; "
                         f"allowed: {allowed}")


@dataclass(frozen=True)
class BudgetRow:
    """One line of the budget: ``contribution_pu = value / divisor · sensitivity``.

    ``combination`` is "rss" (root-sum-square into u_c) or "linear" (added to U after k·u_c).
    """

    source: str
    value: float
    unit: str
    distribution: str
    divisor: float
    sensitivity: float
    sensitivity_unit: str
    contribution_pu: float
    combination: str = "rss"


@dataclass(frozen=True)
class UncertaintyBudget:
    """Expanded uncertainty of pk_pk_pu and its budget table."""

    rows: tuple[BudgetRow, ...]
    coverage_factor: float
    combined_standard_pu: float
    expanded_pu: float
    noise_bias_pu: float
    revolutions: int
    bootstrap_draws: int
    notes: tuple[str, ...] = field(default_factory=tuple)

    def to_dict(self) -> dict:
        data = asdict(self)
        data["rows"] = [asdict(row) for row in self.rows]
        data["notes"] = list(self.notes)
        return data

    def format_table(self) -> str:
        """The budget as a fixed-width text table (for the CLI and the report)."""
        header = (f"{'source':<46} {'value':>11} {'unit':<6} {'distribution':<22} "
                  f"{'divisor':>7} {'sens.':>10} {'contrib. pu':>11}")
        lines = [header, "-" * len(header)]
        for row in self.rows:
            lines.append(f"{row.source:<46} {row.value:>11.4g} {row.unit:<6} "
                         f"{row.distribution:<22} {row.divisor:>7.4g} {row.sensitivity:>10.4g} "
                         f"{row.contribution_pu:>11.4g}")
        lines.append("-" * len(header))
        lines.append(f"combined standard uncertainty u_c = {self.combined_standard_pu:.4g} pu; "
                     f"expanded U = k*u_c + |bias| = {self.expanded_pu:.4g} pu "
                     f"(k = {self.coverage_factor:g})")
        lines.extend(f"note: {note}" for note in self.notes)
        return "\n".join(lines)


@dataclass(frozen=True)
class TypeA:
    """Bootstrap result: standard uncertainty and noise bias of p (NaN with < 2 revolutions)."""

    standard_pu: float
    bias_pu: float
    draws: int


def type_a(per_revolution: np.ndarray,
           statistic: Callable[[np.ndarray], np.ndarray]) -> TypeA:
    """Type-A figures of ``p = statistic(synchronous average)`` from its per-revolution rows.

    ``per_revolution`` is R × D (one row per revolution: bins or order coefficients, any linear
    representation whose mean over rows is the synchronous average); ``statistic`` maps B × D
    rows to B values of p. Bootstrap draws of the average give noise realisations ``δ`` with the
    average's own noise covariance. The standard uncertainty is the spread of ``p(x̄ + δ)``. The
    noise bias is found by simulation-extrapolation (SIMEX): ``p`` is averaged over ``x̄ + λ·δ`` for
    λ² = 0, 1, 2, 3, i.e. total noise s = √(1+λ²) times that of the measurement, a straight line
    in s is fitted and its slope is the bias at s = 1 relative to s = 0 (exact when the bias grows
    in proportion to the noise — a flat-topped ripple — and an overestimate when it grows more
    slowly, so it errs on the safe side).
    """
    revolutions = per_revolution.shape[0]
    if revolutions < 2:
        return TypeA(math.nan, math.nan, 0)
    average = per_revolution.mean(axis=0)
    blocks = np.array_split(np.arange(revolutions), min(revolutions, BOOTSTRAP_MAX_BLOCKS))
    block_sums = np.stack([per_revolution[b].sum(axis=0) for b in blocks])
    # complex coefficients are summed as their (re, im) pairs: one compiled float kernel
    real_block_sums = block_sums.view(np.float64) if np.iscomplexobj(block_sums) else block_sums
    block_sizes = np.array([b.size for b in blocks], dtype=np.float64)
    n_blocks = len(blocks)
    # the bootstrap variance of a mean of G blocks is (G-1)/G of the unbiased one
    inflation = math.sqrt(n_blocks / (n_blocks - 1))
    measured = float(statistic(average[None, :])[0])
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    sums = {scale: [] for scale in SIMEX_SCALES}
    for start in range(0, BOOTSTRAP_DRAWS, BOOTSTRAP_CHUNK):
        size = min(BOOTSTRAP_CHUNK, BOOTSTRAP_DRAWS - start)
        counts = rng.multinomial(n_blocks, np.full(n_blocks, 1.0 / n_blocks), size=size)
        draw_sums, draw_sizes = _draw_sums(counts, real_block_sums, block_sizes)
        draw_sums = draw_sums.view(block_sums.dtype)
        noise = (draw_sums / draw_sizes[:, None] - average) * inflation
        for scale in SIMEX_SCALES:
            sums[scale].append(statistic(average + scale * noise))
    draws = {scale: np.concatenate(values) for scale, values in sums.items()}
    standard = float(np.std(draws[1.0], ddof=1))
    noise_multiple = np.sqrt(1.0 + np.array((0.0,) + SIMEX_SCALES) ** 2)
    mean_p = np.array([measured] + [float(np.mean(draws[scale])) for scale in SIMEX_SCALES])
    slope = float(np.polyfit(noise_multiple, mean_p, 1)[0])
    return TypeA(standard, slope, BOOTSTRAP_DRAWS)


@njit(cache=True, error_model="numpy", fastmath=False)
def _draw_sums(counts, block_sums, block_sizes):
    """``counts @ block_sums`` and ``counts @ block_sizes`` of bootstrap draws (rows of block
    counts; ``block_sums`` real) without BLAS: a product this small (draws × ≤ 200 blocks) gains nothing from BLAS
    threads and, on a shared machine, loses tens of ms waiting for them. The sums are taken in
    block order, so they differ from BLAS's by rounding only (≈1e-16 relative; the SIMEX bias,
    a small slope, moves by up to ≈3e-13 of itself in the benchmark case)."""
    draws, blocks = counts.shape
    sums = np.zeros((draws, block_sums.shape[1]))
    sizes = np.zeros(draws)
    for draw in range(draws):
        row = sums[draw]
        for block in range(blocks):
            count = counts[draw, block]
            if count:
                sizes[draw] += count * block_sizes[block]
                source = block_sums[block]
                for column in range(row.size):
                    row[column] += count * source[column]
    return sums, sizes


def amplitude_standard_uncertainty(per_revolution_coefficients: np.ndarray) -> np.ndarray:
    """Type-A standard uncertainty u(A_k) (N·m) of the synchronous average's order amplitudes.

    From the scatter of the complex coefficients between revolutions (R × (K+1)), taken as
    circular: u(A_k) = √((var Re + var Im) / 2 / R). NaN with fewer than two revolutions.
    """
    revolutions, width = per_revolution_coefficients.shape
    if revolutions < 2:
        return np.full(width, math.nan)
    real_var = per_revolution_coefficients.real.var(axis=0, ddof=1)
    imag_var = per_revolution_coefficients.imag.var(axis=0, ddof=1)
    return np.sqrt((real_var + imag_var) / 2.0 / revolutions)


def build_budget(*, pk_pk_pu: float, pk_pk_nm: float, mean_torque_nm: float, type_a_result: TypeA,
                 revolutions: int, instruments: InstrumentUncertainty | None) -> UncertaintyBudget:
    """Assemble the rows (module docstring) and the expanded uncertainty U of ``pk_pk_pu``."""
    instruments = instruments or InstrumentUncertainty()
    mean_abs = abs(mean_torque_nm)
    rows = [BudgetRow(f"type A: revolution scatter ({revolutions} revs, bootstrap)",
                      type_a_result.standard_pu, "pu", "normal", 1.0, 1.0, "1",
                      type_a_result.standard_pu),
            BudgetRow("residual noise bias of sync-average pk-pk", type_a_result.bias_pu, "pu",
                      "bias (added linearly)", 1.0, 1.0, "1", abs(type_a_result.bias_pu),
                      combination="linear")]
    notes = []
    limit = instruments.transducer_limit_nm
    if limit > 0:
        rows.append(BudgetRow("type B: transducer accuracy class, on mean", limit, "N*m",
                              "rectangular", math.sqrt(3.0), pk_pk_pu / mean_abs, "1/(N*m)",
                              limit / math.sqrt(3.0) * pk_pk_pu / mean_abs))
        class_pu = instruments.transducer_accuracy_class_pct / 100.0
        rows.append(BudgetRow("type B: transducer accuracy class, on pk-pk", class_pu * pk_pk_nm,
                              "N*m", "rectangular", math.sqrt(3.0), 1.0 / mean_abs, "1/(N*m)",
                              class_pu * pk_pk_nm / math.sqrt(3.0) / mean_abs))
    else:
        notes.append("no transducer accuracy class given: its type-B row is omitted")
    lsb = instruments.lsb_nm
    if lsb > 0:
        rows.append(BudgetRow("type B: DAQ resolution (1 LSB), on pk-pk", lsb, "N*m",
                              "rectangular, 2 readings", math.sqrt(6.0), 1.0 / mean_abs, "1/(N*m)",
                              lsb / math.sqrt(6.0) / mean_abs))
    else:
        notes.append("no DAQ resolution given: its type-B row is omitted")
    if revolutions < 2:
        notes.append("one revolution only: type A cannot be estimated, U is undefined (NaN)")
    rss = [row.contribution_pu for row in rows if row.combination == "rss"]
    combined = math.sqrt(sum(c * c for c in rss))
    expanded = COVERAGE_FACTOR * combined + abs(type_a_result.bias_pu)
    return UncertaintyBudget(rows=tuple(rows), coverage_factor=COVERAGE_FACTOR,
                             combined_standard_pu=combined, expanded_pu=expanded,
                             noise_bias_pu=type_a_result.bias_pu, revolutions=revolutions,
                             bootstrap_draws=type_a_result.draws, notes=tuple(notes))
