"""``diagnose`` on synthetic spectra built from the forward signatures plus noise (no twin): what
it recovers, what it says it cannot separate, what it flags as unexplained, the encoder line."""

import math

import numpy as np
import pytest

from hil.diagnosis import OrderSpectrum, diagnose
from hil.diagnosis import encoder as enc
from hil.diagnosis import signatures as sig
from ripple_hil_testplans import diagnosis_design as design

SETUP = sig.DriveSetup(current_loop_bandwidth_hz=1600.0, current_loop_delay_s=75e-6,
                       transducer_bandwidth_hz=1000.0)
MAX_MECH = 128
SIGMA_NM = 2e-5


def _spectra(points, *, offsets=(0.0, 0.0), k_diff=0.0, dead_time_us=0.0, cogging=None,
             extra=None, seed=0, decimation=None, setup=SETUP):
    """Spectra of a drive whose torque is exactly the signatures through ``setup``'s loop (plus
    noise and ``extra``); also used by test_loop_designs."""
    rng = np.random.default_rng(seed)
    out = []
    for point in points:
        op = sig.operating_point(point.speed_rpm, point.current_a, point.current_angle_rad, setup)
        elec = (offsets[0] * sig.offset_orders(op, setup, "a")
                + offsets[1] * sig.offset_orders(op, setup, "b")
                + k_diff * sig.gain_difference_orders(op, setup)
                + dead_time_us * sig.dead_time_orders(op, setup))
        c = np.zeros(MAX_MECH + 1, dtype=complex)
        c[0] = op.mean_torque_nm
        for m, value in sig.to_mech(elec, 2, MAX_MECH).items():
            c[m] += value * sig.transducer_response(m, point.speed_rpm, setup)
        for m, value in (cogging or {}).items():
            c[m] += value * sig.transducer_response(m, point.speed_rpm, setup)
        spectrum = OrderSpectrum(label=point.label, speed_rpm=point.speed_rpm,
                                 current_a=point.current_a,
                                 current_angle_rad=point.current_angle_rad, pole_pairs=2,
                                 coefficients_nm=c, sigma_nm=np.full(MAX_MECH + 1, SIGMA_NM),
                                 revolutions=8, meta={"encoder_counts_per_rev": 7200})
        if decimation:
            for m, value in enc.staircase_lines(spectrum, setup, 7200, decimation,
                                                MAX_MECH).items():
                c[m] += value
        if extra:
            for m, value in extra(point).items():
                c[m] += value
        c[1:] += rng.normal(0, SIGMA_NM, MAX_MECH) + 1j * rng.normal(0, SIGMA_NM, MAX_MECH)
        out.append(spectrum)
    return out


def test_recovers_every_controller_parameter_at_the_designed_points():
    spectra = _spectra(design.design_points(), offsets=(0.12, -0.07), k_diff=0.015,
                       dead_time_us=1.8, cogging={12: 0.004 - 0.002j, 4: 0.003j})
    result = diagnose(spectra, setup=SETUP)
    for name, truth in (("ia_offset_a", 0.12), ("ib_offset_a", -0.07), ("gain_k_diff", 0.015),
                        ("dead_time_us", 1.8)):
        value, u = result.value(name)
        assert abs(value - truth) <= 2 * u, (name, value, u)
        # and the estimate is informative (the dead time's U carries the stated loop's
        # bandwidth ± 10 % and delay ± half a PWM period: ≈ 11 % of T_d here)
        assert u < (0.15 if name == "dead_time_us" else 0.1) * abs(truth), (name, u)
    terms = {t["name"]: t for t in result.motor_terms()}
    assert terms["cogging_m12_nm"]["amplitude"] == pytest.approx(abs(0.004 - 0.002j),
                                                                 abs=terms["cogging_m12_nm"][
                                                                     "expanded_uncertainty"])
    assert not result.weak and not result.unexplained
    assert result.encoder["detected"] is False


def test_one_current_cannot_separate_gain_from_cogging_and_says_which_point_would():
    points = [p for p in design.design_points() if p.current_a == 20.0]
    result = diagnose(_spectra(points, k_diff=0.01), setup=SETUP)
    assert result.value("gain_k_diff") is None
    weak = [w for w in result.weak if "gain_k_diff" in w["parameters"]]
    assert weak and any(n.startswith("cogging_m4_") for n in weak[0]["parameters"])
    assert "second current" in weak[0]["separate_by"]
    # the offsets are still identified
    assert result.value("ia_offset_a") is not None


def test_offsets_and_a_rotor_fixed_order_1_term_are_stated_as_not_separable():
    result = diagnose(_spectra(design.design_points(), offsets=(0.1, 0.0)), setup=SETUP)
    assert result.aliases
    assert "phase currents" in result.aliases[0]["separate_by"]
    assert "cogging_m2_re_nm" in result.aliases[0]["parameters"]


def test_order_2_that_grows_with_current_squared_is_not_explained():
    def extra(point):            # no controller source scales like I², at a phase of its own
        return {4: 2e-5 * point.current_a ** 2 * np.exp(0.7j)}

    result = diagnose(_spectra(design.design_points(), extra=extra), setup=SETUP)
    assert [u["mech_order"] for u in result.unexplained] == [4]


def test_gain_signature_at_the_wrong_phase_is_not_explained():
    """Order 2 scaling with current (like gain mismatch) but rotated 90° from eq 24's phase."""
    def extra(point):
        op = sig.operating_point(point.speed_rpm, point.current_a, 0.0, SETUP)
        c = 0.02 * sig.gain_difference_orders(op, SETUP)[2]
        return {4: 1j * c * sig.transducer_response(4, point.speed_rpm, SETUP)}

    result = diagnose(_spectra(design.design_points(), extra=extra), setup=SETUP)
    assert 4 in [u["mech_order"] for u in result.unexplained]


@pytest.mark.parametrize("decimation", [100, 150])
def test_encoder_count_line_is_found(decimation):
    spectra = _spectra(design.design_points(), offsets=(0.05, 0.0), decimation=decimation)
    result = diagnose(spectra, setup=SETUP)
    assert result.encoder["decimation"] == decimation
    assert result.encoder["line_mech_order"] == 7200 // decimation
    value, u = result.value("ia_offset_a")
    assert abs(value - 0.05) <= 2 * u


def test_a_cogging_line_alone_is_not_an_encoder():
    """A strong line at a possible count order but without the staircase's harmonic is not
    taken for the encoder (mech 48 = decimation 150 would also put a line at 96)."""
    spectra = _spectra(design.design_points(), cogging={48: 0.02})
    assert enc.detect(spectra, SETUP, 7200)["detected"] is False


def test_input_errors_are_one_line():
    from hil.errors import InputError

    with pytest.raises(InputError, match="at least one"):
        diagnose([], setup=SETUP)
    short = _spectra(design.design_points()[:1])[0]
    cut = OrderSpectrum(**{**short.__dict__, "coefficients_nm": short.coefficients_nm[:10],
                           "sigma_nm": short.sigma_nm[:10]})
    with pytest.raises(InputError, match="mechanical order 24"):
        diagnose([cut], setup=SETUP)


def test_to_dict_is_json_ready_and_complete():
    import json

    result = diagnose(_spectra(design.design_points(), offsets=(0.1, 0.05), k_diff=-0.01,
                               dead_time_us=1.0), setup=SETUP)
    data = json.loads(json.dumps(result.to_dict(), allow_nan=False))
    assert data["format"] == "ripple-hil-diagnosis/1"
    names = {p["name"] for p in data["parameters"]}
    assert {"ia_offset_a", "ib_offset_a", "gain_k_diff", "dead_time_us"} <= names
    ranked = [row["source"] for row in data["attribution"]]
    assert ranked[0] == "dc_offset" and ranked[-1] == "unattributed"
    cal = data["calibration"]
    assert cal["ia_offset_correction_a"]["value"] == pytest.approx(-0.1, abs=1e-3)
    assert cal["gain_trim_a_pct"]["value"] == pytest.approx(-1.0, abs=0.02)
    after = data["predicted_after_correction"]
    assert all(row["pk_pk_pct_after"] < 0.5 * row["pk_pk_pct_before"] for row in after)
    assert math.isfinite(data["identifiability"]["condition_number"])
