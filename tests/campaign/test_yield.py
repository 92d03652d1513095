"""Yield statistics, the closed-form combiner, Sobol' ranking and the inverse design, each on a
case whose answer is known independently."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.special import erf
from scipy.stats import binom, binomtest, norm

from hil.commands.yield_cmd import format_summary
from hil.model import predict
from hil.model.core import PHASE_OFFSETS_RAD, OperatingPoint
from hil.tolerance.combiner import CombinerSettings, ripple_pu
from hil.tolerance.design import inverse_design
from hil.tolerance.run import YieldOptions, run_yield
from hil.tolerance.sobol import sobol_indices, sobol_sample_unit
from hil.tolerance.spec import parse_tolerances
from hil.tolerance.stats import QUANTILES, drives_needed, quantiles, yield_interval

EXAMPLE = Path(__file__).resolve().parents[2] / "hil" / "examples" / "tolerances.toml"
NO_BOUNDS = CombinerSettings(bounds=False)


def one_offset_spec(sigma_a, limit_pct=3.0, drives=40_000):
    return parse_tolerances({
        "drives": drives, "seed": 4,
        "requirement": {"id": "R", "name": "ripple", "quantity": "pk_pk_pct", "limit": {"max": limit_pct}},
        "operating_point": [{"speed_rpm": 500, "current_a": 20}],
        "parameters": {"ia_offset_a": {"distribution": "normal", "sigma": sigma_a}}})


def offset_pass_probability(sigma_a, limit_pct=3.0, current_a=20.0):
    """Eq 19 with one sensor: pk-pk = (4/√3)|Δa|, so a drive passes iff
    |offset| ≤ limit·√3/4·I; for a zero-mean normal offset P = erf(x/(σ√2))."""
    threshold_a = limit_pct / 100 * math.sqrt(3) / 4 * current_a
    return erf(threshold_a / (sigma_a * math.sqrt(2))), threshold_a


def test_yield_interval_is_clopper_pearson_with_at_least_nominal_coverage():
    assert yield_interval(0, 10) == pytest.approx((0.0, 1 - 0.025 ** 0.1))  # x = 0 closed form
    assert yield_interval(8, 8) == pytest.approx((0.025 ** (1 / 8), 1.0))   # x = n: 63.1 %
    # the defining tails: P(X >= 81 | low) = 2.5 % = P(X <= 81 | high)
    low, high = yield_interval(81, 263)
    assert binom.sf(80, 263, low) == pytest.approx(0.025, rel=1e-6)
    assert binom.cdf(81, 263, high) == pytest.approx(0.025, rel=1e-6)
    # exact coverage over every outcome, on a grid of true yields: never below 95 % (Wilson's
    # interval, scipy's, dips below it near an all-pass sample: why it is not used)
    for n in (8, 50):
        k = np.arange(n + 1)
        ours = np.array([yield_interval(int(x), n) for x in k])
        wilson = np.array([tuple(binomtest(int(x), n).proportion_ci(0.95, method="wilson"))
                           for x in k])
        p_true = np.linspace(0.5, 0.999, 400)
        pmf = binom.pmf(k[None, :], n, p_true[:, None])
        cover = lambda ci: (pmf * ((ci[:, 0] <= p_true[:, None])  # noqa: E731
                                   & (p_true[:, None] <= ci[:, 1]))).sum(axis=1)
        assert cover(ours).min() >= 0.95 - 1e-9
        assert cover(wilson).min() < 0.93


def test_quantiles_are_stated_only_where_the_sample_supports_them():
    """n ≥ 10/(1 − q): q99.9 needs 10,000 drives; a stated quantile's order-statistic interval
    covers the true quantile about 95 % of the time (|N(0, 1)|, whose quantiles are known)."""
    assert [drives_needed(q) for q in QUANTILES] == [20, 100, 200, 1000, 10_000]
    table = quantiles(np.arange(999.0))
    assert table["q99"] == {"value": None, "needs_drives": 1000}
    assert table["q99.9"] == {"value": None, "needs_drives": 10_000}
    assert table["q95"]["value"] == pytest.approx(np.quantile(np.arange(999.0), 0.95))
    rng = np.random.default_rng(7)
    hits = []
    for _ in range(400):
        ci = quantiles(np.abs(rng.normal(size=200)), (0.9,))["q90"]["ci95"]
        hits.append(ci[0] <= norm.ppf(0.95) <= ci[1])
    assert 0.93 <= np.mean(hits) <= 0.995


def test_small_campaign_states_no_tail_and_yields_carry_their_interval(tmp_path):
    """8 drives: no quantile is printed or written, every yield (overall, per point) carries its
    Clopper-Pearson interval, in the text, the --json output and yield.json alike."""
    done = subprocess.run([sys.executable, "-m", "hil", "yield", str(EXAMPLE), "--drives", "8",
                           "--sobol-n", "0", "--scheduler", "inline", "--out", str(tmp_path),
                           "--json"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    printed = json.loads(done.stdout)
    written = json.loads((tmp_path / "yield.json").read_text())
    text = "\n".join(format_summary(printed))  # what `hil yield` prints without --json
    assert "q99.9 not stated (needs >= 10,000 drives)" in text
    assert "q50 not stated (needs >= 20 drives)" in text
    for summary in (printed, written):
        assert summary["ci_method"].startswith("Clopper-Pearson")
        assert all(q["value"] is None for q in summary["worst_ripple_pct_quantiles"].values())
        low, high = yield_interval(summary["passed"], 8)
        assert summary["yield_ci95"] == [low, high]
        for point in summary["per_point"]:
            assert point["yield_ci95"][0] <= point["yield"] <= point["yield_ci95"][1]
            assert all(q["value"] is None for q in point["ripple_pct_quantiles"].values())
    ci = printed["yield_ci95"]           # rounded outwards: the printed interval contains it
    assert f"(95 % CI {math.floor(100 * ci[0]):.0f} .. {math.ceil(100 * ci[1]):.0f} %)" in text
    assert text.count("95 % CI") == 1 + len(printed["per_point"])


def test_yield_ci_contains_known_answer(tmp_path):
    truth, _ = offset_pass_probability(0.2)
    summary = run_yield(one_offset_spec(0.2), tmp_path,
                        YieldOptions(scheduler="inline", combiner=NO_BOUNDS, progress=False,
                                     sobol_n=0, plots=False))
    low, high = summary["yield_ci95"]
    assert low <= truth <= high
    assert high - low < 0.01  # 40 000 drives: the interval is tight, the check is not vacuous
    # eq 19, one sensor: ripple % = 100·(4/√3)·|offset|/I, a half-normal: known quantiles
    for label, entry in summary["worst_ripple_pct_quantiles"].items():
        q = float(label[1:]) / 100
        true_pct = 100 * 4 / math.sqrt(3) / 20.0 * 0.2 * norm.ppf((1 + q) / 2)
        assert entry["ci95"][0] <= true_pct <= entry["ci95"][1], label
    assert json.loads((tmp_path / "yield.json").read_text())["passed"] == summary["passed"]


def test_combination_by_phase_matches_direct_torque_sum():
    """Offsets (order 1) and a gain mismatch (order 2) at once: the combiner against
    Σ e_x·i_x/ω_m (eq 7) of regulated currents i = (i_meas − offset)/(1 + g), i_c = −i_a − i_b."""
    op = OperatingPoint(500.0, 20.0, math.radians(20.0))
    off_a, off_b, g_a, g_b = 0.15, -0.05, 0.008, -0.006
    theta = np.linspace(0, 2 * math.pi, 20000, endpoint=False)
    measured = op.current_a * np.sin(theta[None, :] - op.current_angle_rad
                                     - PHASE_OFFSETS_RAD[:, None])
    i_a = (measured[0] - off_a) / (1 + g_a)
    i_b = (measured[1] - off_b) / (1 + g_b)
    currents = np.stack([i_a, i_b, -i_a - i_b])
    emf = op.emf_peak_v * np.sin(theta[None, :] - PHASE_OFFSETS_RAD[:, None])
    torque = np.sum(emf * currents, axis=0) / op.mech_speed_rad_s
    direct = np.ptp(torque) / torque.mean()
    params = {"ia_offset_a": [off_a], "ib_offset_a": [off_b], "ia_gain_error_pu": [g_a],
              "ib_gain_error_pu": [g_b]}
    combined = ripple_pu(op, {k: np.array(v) for k, v in params.items()}, 1, NO_BOUNDS)[0]
    assert combined == pytest.approx(direct, rel=0.01)  # second-order (offset × gain) dropped
    separate = (predict("dc_offset", op, ia_offset_a=off_a, ib_offset_a=off_b).pk_pk_pu
                + predict("gain_mismatch", op, ia_gain_error_pu=g_a,
                          ib_gain_error_pu=g_b).pk_pk_pu)
    assert separate > 1.15 * direct  # adding pk-pk values instead would be far off


def test_combiner_reproduces_single_source_models():
    op = OperatingPoint(1000.0, 15.0, 0.1)
    one = lambda **p: ripple_pu(op, {k: np.array([v]) for k, v in p.items()}, 1, NO_BOUNDS)[0]
    assert one(ia_offset_a=0.1, ib_offset_a=0.2) == pytest.approx(
        predict("dc_offset", op, ia_offset_a=0.1, ib_offset_a=0.2).pk_pk_pu, rel=1e-3)
    assert one(ia_gain_error_pu=0.01) == pytest.approx(
        predict("gain_mismatch", op, ia_gain_error_pu=0.01).pk_pk_pu, rel=1e-3)
    full_band = predict("dead_time", op, dead_time_s=2e-6, model="average_voltage",
                        current_loop_bandwidth_hz=1600.0, current_loop_delay_s=1.5 / 20000)
    spectrum = np.fft.rfft(full_band.waveform_pu)  # the model's waveform, orders 1..64 kept
    spectrum[65:] = 0.0
    band_limited = np.ptp(np.fft.irfft(spectrum, n=full_band.waveform_pu.size))
    assert one(dead_time_s=2e-6) == pytest.approx(band_limited, rel=0.01)
    assert band_limited < 0.95 * full_band.pk_pk_pu  # the band limit matters here
    for knobs in ({"hall_mode": True}, {"encoder_decimation": 100}):  # count orders 6 and 36
        staircase = predict("encoder", op, **knobs)
        spectrum = np.fft.rfft(staircase.waveform_pu)
        spectrum[65:] = 0.0
        expected = np.ptp(np.fft.irfft(spectrum, n=staircase.waveform_pu.size))
        assert one(**{k: float(v) for k, v in knobs.items()}) == pytest.approx(expected, rel=0.02)
    assert one(encoder_counts_per_rev=7200) == 0.0  # count order 3600: outside the band


def test_sobol_ranks_the_dominant_tolerance_first(tmp_path):
    doc = {"drives": 2000, "seed": 3,
           "requirement": {"id": "R", "name": "ripple", "quantity": "pk_pk_pct", "limit": {"max": 1.0}},
           "operating_point": [{"speed_rpm": 800, "current_a": 15}],
           "parameters": {
               "ia_gain_error_pu": {"distribution": "normal", "sigma": 0.0005},
               "ia_offset_a": {"distribution": "normal", "sigma": 0.005},
               "dead_time_s": {"distribution": "uniform", "mean": 2e-6, "half_width": 2e-6}}}
    options = YieldOptions(scheduler="inline", combiner=NO_BOUNDS, progress=False, sobol_n=256,
                           plots=False)
    sobol = run_yield(parse_tolerances(doc), tmp_path / "a", options)["sobol"]
    assert sobol["ranking"][0] == "dead_time_s" and sobol["ranked_by"] == "ST of failure"
    assert sobol["indices"]["failure"]["dead_time_s"]["ST"] > 0.8
    doc["parameters"]["ia_offset_a"]["sigma"] = 0.3  # now the offset dominates
    doc["parameters"]["dead_time_s"]["half_width"] = 0.1e-6
    sobol = run_yield(parse_tolerances(doc), tmp_path / "b", options)["sobol"]
    assert sobol["ranking"][0] == "ia_offset_a"


def test_sobol_order_is_stated_resolved_only_when_the_intervals_separate():
    """y = x1 + x2 + 0.2·x3: x1 and x2 are equally important (their order is not resolved),
    both clearly above x3 (resolved)."""
    names = ["x1", "x2", "x3"]
    unit = sobol_sample_unit(names, 512, seed=1)
    y = unit[:, 0] + unit[:, 1] + 0.2 * unit[:, 2]
    out = sobol_indices(names, {"ripple": y}, seed=1)
    assert out["ranking"][2] == "x3"
    assert out["unresolved"] == [out["ranking"][:2]]


def test_inverse_design_one_tolerance_has_a_known_answer():
    """One normal offset, target 99 %: σ ≤ threshold/2.576; the design is the loosest ladder
    step (2^(k/4)) under it."""
    target = 0.99
    _, threshold = offset_pass_probability(1.0)
    sigma_max = threshold / 2.5758293035489
    design = inverse_design(one_offset_spec(0.3), target, drives=20_000, check_drives=50_000,
                            settings=NO_BOUNDS)
    sigma = design["parameters"]["ia_offset_a"]["design_spread"]
    assert sigma_max / 2 ** 0.25 * 0.97 <= sigma <= sigma_max * 1.03
    assert design["alone"]["ia_offset_a"]["spread"] == pytest.approx(sigma)
    assert design["check"]["yield_ci95"][1] >= target - 0.002
    unreachable = parse_tolerances({
        "requirement": {"id": "R", "name": "ripple", "quantity": "pk_pk_pct", "limit": {"max": 1.0}},
        "operating_point": [{"speed_rpm": 500, "current_a": 20}],
        "parameters": {"ia_offset_a": {"distribution": "normal", "sigma": 0.01},
                       "ib_offset_a": {"distribution": "fixed", "value": 0.5}}})
    assert inverse_design(unreachable, target, drives=2000, check_drives=2000,
                          settings=NO_BOUNDS)["feasible"] is False


def test_hil_yield_cli_on_the_example(tmp_path):
    done = subprocess.run([sys.executable, "-m", "hil", "yield", str(EXAMPLE), "--drives", "20000",
                           "--sobol-n", "64", "--scheduler", "inline", "--out", str(tmp_path),
                           "--json"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert summary["drives"] == 20000 and 0.0 < summary["yield"] < 1.0
    assert summary["yield_ci95"][0] <= summary["yield"] <= summary["yield_ci95"][1]
    assert len(summary["sobol"]["ranking"]) == 6
    assert (tmp_path / "histogram.png").stat().st_size > 1000
    assert (tmp_path / "histogram.svg").read_text().lstrip().startswith("<?xml")


def test_coarse_encoder_combined_with_offset_matches_direct_torque_sum():
    """Hall sensors (60°, eqs 7-9) and a sensor offset at once: the combiner against
    Σ e_x·i_x/ω_m with currents regulated to the truncated angle, computed here on another grid,
    both band-limited to orders 1..64 (the ripple definition)."""
    op = OperatingPoint(500.0, 20.0, math.radians(10.0))
    offset_a = 0.6
    theta = np.linspace(0, 2 * math.pi, 7200, endpoint=False)
    theta_d = np.floor(theta / (math.pi / 3) + 1e-9) * (math.pi / 3)
    measured = op.current_a * np.sin(theta_d[None, :] - op.current_angle_rad
                                     - PHASE_OFFSETS_RAD[:, None])
    i_a, i_b = measured[0] - offset_a, measured[1]
    currents = np.stack([i_a, i_b, -i_a - i_b])
    emf = op.emf_peak_v * np.sin(theta[None, :] - PHASE_OFFSETS_RAD[:, None])
    torque = np.sum(emf * currents, axis=0) / op.mech_speed_rad_s
    spectrum = np.fft.rfft(torque)
    spectrum[65:] = 0.0
    limited = np.fft.irfft(spectrum, n=torque.size)
    direct = np.ptp(limited) / limited.mean()
    combined = ripple_pu(op, {"hall_mode": np.array([1.0]), "ia_offset_a": np.array([offset_a])},
                         1, NO_BOUNDS)[0]
    hall_alone = ripple_pu(op, {"hall_mode": np.array([1.0])}, 1, NO_BOUNDS)[0]
    # within a tenth of what the offset adds to the Hall ripple (a product of the two waveforms
    # would miss it by 40 %: the offset × staircase term is as large as the offset's own ripple)
    assert abs(combined - direct) < 0.1 * (direct - hall_alone)


@pytest.mark.parametrize("passed, drives, printed", [
    (1, 1, "yield 100 % (95 % CI 2 .. 100 %)"),            # 2.50 %: never printed as 3
    (8, 9, "yield 89 % (95 % CI 51 .. 100 %)"),            # 51.75 % .. 99.72 %
    (0, 30, "yield 0 % (95 % CI 0 .. 12 %)"),              # upper 11.57 %
    (1999, 2000, "yield 99.95 % (95 % CI 99.72 .. 100.00 %)"),
    (999_999, 1_000_000, "yield 99.999 % (95 % CI 99.999 .. 100.000 %)"),   # not 100.000 %
    (1, 1_000_000, "yield 0.001 % (95 % CI 0.000 .. 0.001 %)"),              # not 0.000 %
])
def test_printed_yield_interval_is_rounded_outwards(passed, drives, printed):
    """A confidence bound is never printed tighter than computed: the lower one rounds down,
    the upper one up (the yield itself to nearest, but never to 0 or 100 % unless exact)."""
    from hil.commands.yield_cmd import _yield

    low, high = yield_interval(passed, drives)
    assert _yield(passed / drives, [low, high], drives) == printed
