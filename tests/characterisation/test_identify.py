"""``hil.characterisation.identify`` on synthetic captures whose R, L and ψ are known exactly
(unit tests: no bench)."""

import math

import numpy as np
import pytest

from hil.capture import Capture
from hil.characterisation.identify import back_emf, winding

POLE_PAIRS = 2
PSI = 0.0325                      # peak phase EMF per mechanical rad/s, V·s/rad
R, L = 0.07, 31e-6


def _capture(current_a: float, *, speed_rpm: float = 500.0, skew_s: float = 0.0,
             angle_offset: float = 0.3, rate_hz: float = 7919.0, revolutions: int = 8):
    """Phase a/b currents I·cos(θe + α) and the terminal voltages v = R·i + L·di/dt + e, e_a =
    ψ·ω_m·sin θe; the voltage channel lagging the others by ``skew_s``."""
    omega_m = speed_rpm / 60.0 * 2 * math.pi
    omega_e = POLE_PAIRS * omega_m
    t = np.arange(int(revolutions * 2 * math.pi / abs(omega_e) * rate_hz)) / rate_hz
    theta_m = angle_offset + omega_m * t

    def phase(x, time):
        theta = POLE_PAIRS * (angle_offset + omega_m * time) - x * 2 * math.pi / 3
        i = current_a * np.sin(theta)                      # in phase with the EMF (φ = 0)
        di = current_a * omega_e * np.cos(theta)
        return R * i + L * di + PSI * omega_m * np.sin(theta), i

    va, ia = phase(0, t - skew_s)[0], phase(0, t)[1]
    vb = phase(1, t - skew_s)[0]
    return Capture({"time_s": t, "rotor_angle_mech_rad": theta_m, "vab_v": va - vb, "ia_a": ia})


def test_psi_from_the_back_emf_and_r_l_from_the_winding():
    emf = back_emf(_capture(0.0), POLE_PAIRS)
    assert emf.psi.value == pytest.approx(PSI, rel=1e-9)
    resistance, inductance = winding(_capture(20.0), emf, POLE_PAIRS, skew_bound_s=0.0)
    assert resistance.value == pytest.approx(R, rel=1e-9)
    assert inductance.value == pytest.approx(L, rel=1e-9)
    assert "Z = (V − E)/I" in resistance.method and "back EMF" in emf.psi.method


def test_reverse_rotation_gives_the_same_motor():
    emf = back_emf(_capture(0.0, speed_rpm=-700.0), POLE_PAIRS)
    assert emf.psi.value == pytest.approx(PSI, rel=1e-9)
    resistance, inductance = winding(_capture(15.0, speed_rpm=-700.0), emf, POLE_PAIRS,
                                     skew_bound_s=0.0)
    assert (resistance.value, inductance.value) == (pytest.approx(R, rel=1e-9),
                                                    pytest.approx(L, rel=1e-9))


def test_a_channel_skew_moves_l_and_the_stated_bound_covers_it():
    """A voltage channel 20 µs late in both captures turns V − E by ωe·δt: L is off by δt·R
    (4.5 %), within the U a 25 µs bound states, beyond a 0 µs bound's."""
    emf = back_emf(_capture(0.0, skew_s=20e-6), POLE_PAIRS)
    _, off = winding(_capture(20.0, skew_s=20e-6), emf, POLE_PAIRS, skew_bound_s=0.0)
    assert abs(off.value - L) == pytest.approx(20e-6 * R, rel=0.02)
    assert abs(off.value - L) > off.expanded
    _, bounded = winding(_capture(20.0, skew_s=20e-6), emf, POLE_PAIRS, skew_bound_s=25e-6)
    assert abs(bounded.value - L) <= bounded.expanded


def test_a_daq_voltage_gain_error_is_covered_by_its_stated_accuracy_class():
    """A voltage channel reading 0.4 % high makes ψ and Z 0.4 % high (E and V come through the
    same channel): beyond the U of quantisation and scatter alone, within the U once the DAQ's
    0.5 % FS accuracy class is a type-B gain term (0.5 %/√3; Z: the voltage and current
    channels' gains, √2 × it)."""
    def high(capture):
        return Capture(capture.channels | {"vab_v": capture["vab_v"] * 1.004})

    gain_u = 0.005 / math.sqrt(3.0)
    for u_rel, covered in ((0.0, False), (gain_u, True)):
        emf = back_emf(high(_capture(0.0)), POLE_PAIRS, gain_u_rel=u_rel)
        assert emf.psi.value == pytest.approx(PSI * 1.004, rel=1e-9)
        assert (abs(emf.psi.value - PSI) <= emf.psi.expanded) is covered
        resistance, inductance = winding(high(_capture(20.0)), emf, POLE_PAIRS, skew_bound_s=0.0,
                                         gain_u_rel=u_rel)
        for item, truth in ((resistance, R), (inductance, L)):
            assert item.value == pytest.approx(truth * 1.004, rel=1e-9)
            assert (abs(item.value - truth) <= item.expanded) is covered
    assert emf.u_without_gain < 0.1 * emf.psi.u          # Z takes the gain once, not via E
    assert "accuracy class" in emf.psi.method and "accuracy class" in resistance.method


def test_too_few_samples_per_revolution_is_a_clear_input_error():
    """A 24-pole motor at 2900 rpm (580 Hz electrical) sampled at 7919 Hz: 13.7 samples per
    revolution (14.1 counted over whole ones), fewer than a fit takes. The stage's error is a HilError the run
    reports in one line (exit 6), not a ValueError that ended pytest with an INTERNALERROR."""
    import numpy as np
    import pytest

    from hil.characterisation.identify import fit_per_revolution
    from hil.errors import HilError

    t = np.arange(0, 0.05, 1 / 7919.0)
    theta = 2 * np.pi * 580.0 * t
    with pytest.raises(HilError, match=r"at least 16 samples each; the capture has 28 of ~14.1 samples"):
        fit_per_revolution(np.sin(theta), theta)
    t = np.arange(0, 0.05, 1 / 47317.0)               # the same revolutions, sampled finely
    phasors, _ = fit_per_revolution(np.sin(2 * np.pi * 580.0 * t), 2 * np.pi * 580.0 * t)
    assert len(phasors) >= 2
