"""A stated 2-DOF loop whose integrator is updated from the realised (delayed) voltage
(DriveSetup.current_loop_integrator_realised; issue 23's motulator offset misses): its
correction T − 1 at the offset's frequency is 1 + (α + jω_e)·τ times the computed-update
form's; the stated loop's variants include that form, so the offsets stay inside U, and
without that variant they miss."""

import math
from dataclasses import replace

import numpy as np
import pytest

from hil.diagnosis import OrderSpectrum, diagnose
from hil.diagnosis import signatures as sig
from hil.motor import TABLE_I
from ripple_hil_testplans import diagnosis_design as design

MAX_MECH = 128
SIGMA_NM = 1e-6
LOOP_2K = sig.DriveSetup(current_loop_bandwidth_hz=2200.0, current_loop_delay_s=37.5e-6,
                         current_loop_design="2dof", current_loop_angle_compensation=True)
#: another motor: 4 pole pairs, 48 V (the study's p8_48v)
P8 = replace(TABLE_I, pole_count=8, dc_bus_v=48.0, phase_resistance_ohm=0.12,
             phase_inductance_h=3e-4, max_reactance_ohm=1.0,
             ke_v_s_per_rad=0.08485281374238571, ke_definition="peak_phase")


def _spectra(real_setup, offsets, direction):
    """Spectra of a drive with only sensor offsets, through ``real_setup``'s loop."""
    p = real_setup.motor.pole_count // 2
    out = []
    for index, point in enumerate(design.design_points()):
        speed = direction * abs(point.speed_rpm)
        op = sig.operating_point(speed, point.current_a, point.current_angle_rad, real_setup)
        elec = (offsets[0] * sig.offset_orders(op, real_setup, "a")
                + offsets[1] * sig.offset_orders(op, real_setup, "b"))
        c = np.zeros(MAX_MECH + 1, dtype=complex)
        c[0] = op.mean_torque_nm
        c[p] = elec[1]
        rng = np.random.default_rng(index)
        c[1:] += rng.normal(0, SIGMA_NM, MAX_MECH) + 1j * rng.normal(0, SIGMA_NM, MAX_MECH)
        out.append(OrderSpectrum(label=point.label, speed_rpm=speed, current_a=point.current_a,
                                 current_angle_rad=point.current_angle_rad, pole_pairs=p,
                                 coefficients_nm=c, sigma_nm=np.full(MAX_MECH + 1, SIGMA_NM),
                                 revolutions=8, meta={"encoder_counts_per_rev": 7200}))
    return out


def _errors(spectra, setup, offsets):
    result = diagnose(spectra, setup=setup)
    out = []
    for name, truth in zip(("ia_offset_a", "ib_offset_a"), offsets):
        value, u = result.value(name)
        out.append((abs(value - truth), 2 * u))
    return out


def test_realised_update_scales_the_correction_by_one_plus_alpha_tau():
    op = sig.operating_point(1000.0, 20.0, 0.0, LOOP_2K)
    w = -op.elec_speed_rad_s                 # a dc sensor error, in the rotor frame
    computed = sig.loop_tracking(w, op, LOOP_2K) - 1.0
    realised = sig.loop_tracking(
        w, op, replace(LOOP_2K, current_loop_integrator_realised=True)) - 1.0
    factor = 1.0 + (2 * math.pi * 2200.0 + 1j * op.elec_speed_rad_s) * 37.5e-6
    assert abs(realised / computed) == pytest.approx(abs(factor), rel=0.05)
    assert abs(realised / computed) > 1.4


@pytest.mark.parametrize("motor, offsets, direction", [
    (TABLE_I, (0.18, -0.016), 1), (P8, (0.175, 0.177), -1)])
def test_realised_update_is_inside_u_and_missed_without_its_variant(
        motor, offsets, direction, monkeypatch):
    stated = replace(LOOP_2K, motor=motor)
    spectra = _spectra(replace(stated, current_loop_integrator_realised=True), offsets,
                       direction)
    with_variant = _errors(spectra, stated, offsets)
    assert all(err <= big_u for err, big_u in with_variant), with_variant
    # U stays useful: within 20× the error it has to cover
    assert max(big_u / err for err, big_u in with_variant) < 20, with_variant
    computed_only = sig.DriveSetup.loop_variants
    monkeypatch.setattr(sig.DriveSetup, "loop_variants", lambda self: [
        v for v in computed_only(self) if not v.current_loop_integrator_realised])
    without = _errors(spectra, stated, offsets)
    assert any(err > big_u for err, big_u in without), without
    # the drive as stated (computed update) is covered and tight
    right = _errors(_spectra(stated, offsets, direction), stated, offsets)
    assert all(err <= big_u for err, big_u in right), right


def test_variants_of_a_stated_pi_do_not_change():
    pi = replace(LOOP_2K, current_loop_design="continuous")
    assert not any(v.current_loop_integrator_realised for v in pi.loop_variants())
    assert sum(v.current_loop_integrator_realised for v in LOOP_2K.loop_variants()) == 1
