"""Channel-selective runs (issue 17 item 4): only the asked channels are computed, and those are
the same numbers, bit for bit, as in a run that computes every channel; the drive's state (and so
every later sample) does not depend on what was asked."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.motor import MotorParameters
from hil.sim import DriveConfig, DriveTwin, Injection, MotorModel, simulate, simulate_batch
from hil.sim.results import STANDARD_CHANNELS

#: dead time, EMF harmonics and cogging: every per-sample path of the engine (clamped phases,
#: recurrences over harmonics, cogging torque) is exercised
CONFIG = DriveConfig(
    motor=MotorModel(parameters=MotorParameters(ke_definition="rms_phase"),
                     emf_harmonics=((5, 0.02, 0.3), (7, 0.01, -0.2)),
                     cogging=((24, 0.01, 0.1),)),
    current_command_a=12.0, speed_rpm=700.0,
    injection=Injection(dead_time_s=2e-6, current_angle_rad=0.3, encoder_decimation=4))
RATE_HZ = 170_000.0           # several samples per sub-segment (recurrences), not period-locked
SELECTIONS = (
    ("time_s", "rotor_angle_mech_rad", "torque_nm"),
    ("ia_a", "iq_a", "va_v", "encoder_counts"),
    ("torque_em_nm", "id_a", "ib_sensed_a", "vc_v", "dc_bus_v", "speed_rpm"),
    ("torque_shaft_nm",),
)


def assert_same_bits(selected, full, names):
    assert list(selected) == [name for name in STANDARD_CHANNELS if name in names]
    for name in names:
        assert selected[name].dtype == full[name].dtype, name
        assert np.array_equal(selected[name], full[name]), name


@pytest.mark.parametrize("names", SELECTIONS, ids=lambda names: "+".join(names))
def test_selected_channels_are_the_full_runs_bits(names):
    full = simulate(CONFIG, 0.004, RATE_HZ, seed=3, settle_s=0.002)
    selected = simulate(CONFIG, 0.004, RATE_HZ, seed=3, settle_s=0.002, channels=names)
    assert_same_bits(selected, full, names)
    assert len(selected) == len(full) > 0


def test_batch_selection_is_the_full_batchs_bits():
    configs = [CONFIG, DriveConfig(speed_rpm=300.0, current_command_a=5.0)]
    names = ("torque_nm", "iq_a", "encoder_counts")
    full = simulate_batch(configs, 0.003, RATE_HZ, seed=5)
    selected = simulate_batch(configs, 0.003, RATE_HZ, seed=5, channels=names)
    for one, reference in zip(selected, full):
        assert_same_bits(one, reference, names)
    assert full[0]["encoder_counts"].dtype == np.int64


def test_twin_continues_identically_after_a_selected_run():
    """The same drive advanced with a selection, then with every channel, equals one advanced
    with every channel twice: the state (currents, firmware, transducer filter, time) and the
    transducer's noise stream are the same."""
    names = ("time_s", "rotor_angle_mech_rad", "torque_nm")
    reference, selective = DriveTwin(CONFIG, seed=7), DriveTwin(CONFIG, seed=7)
    first_full = reference.advance(0.003, RATE_HZ, settle_s=0.002)
    first = selective.advance(0.003, RATE_HZ, settle_s=0.002, channels=names)
    assert_same_bits(first, first_full, names)
    assert np.array_equal(selective._state, reference._state)
    second_full = reference.advance(0.002, RATE_HZ)
    second = selective.advance(0.002, RATE_HZ)
    assert_same_bits(second, second_full, STANDARD_CHANNELS)


def test_state_does_not_depend_on_the_channels_asked():
    """Without ``torque_nm`` no noise is drawn (the noise stream then differs), but the drive's
    own state and every engine channel of the next run are the same bits."""
    reference, selective = DriveTwin(CONFIG, seed=7), DriveTwin(CONFIG, seed=7)
    reference.advance(0.003, RATE_HZ, settle_s=0.001)
    selective.advance(0.003, RATE_HZ, settle_s=0.001, channels=("speed_rpm",))
    assert np.array_equal(selective._state, reference._state)
    engine = [name for name in STANDARD_CHANNELS if name != "torque_nm"]
    assert_same_bits(selective.advance(0.002, RATE_HZ, channels=engine),
                     reference.advance(0.002, RATE_HZ), engine)


@pytest.mark.parametrize("names", [("torque_nm",), ()], ids=["torque only", "nothing"])
def test_status_stays_truthful_after_a_selected_run(names):
    """``status()`` reports the last sample's values whatever was asked: channels not asked for
    come from the exact solution at that instant (within rounding of the recorded ones)."""
    reference, selective = DriveTwin(CONFIG, seed=2), DriveTwin(CONFIG, seed=2)
    full = reference.advance(0.0031, RATE_HZ, settle_s=0.001)
    selective.advance(0.0031, RATE_HZ, settle_s=0.001, channels=names)
    status, expected = selective.status(), reference.status()
    if "torque_nm" not in names:
        del expected["torque_nm"]                 # noise-free there: checked below
    assert {name: status[name] for name in expected} == pytest.approx(expected, rel=0, abs=1e-9)
    for name in ("torque_em_nm", "speed_rpm", "ia_a", "ib_a"):
        assert status[name] == pytest.approx(full[name][-1], rel=0, abs=1e-9), name
    assert status["position_counts"] == full["encoder_counts"][-1]
    if "torque_nm" in names:                      # the recorded reading, noise included
        assert status["torque_nm"] == full["torque_nm"][-1]
    else:                                         # noise-free: within the noise of the reading
        noise = CONFIG.transducer.noise_rms_nm
        assert abs(status["torque_nm"] - full["torque_nm"][-1]) < 6 * noise


def test_status_equals_the_last_recorded_sample():
    twin = DriveTwin(CONFIG, seed=4)
    data = twin.advance(0.002, RATE_HZ, settle_s=0.001)
    status = twin.status()
    for name in ("torque_nm", "torque_em_nm", "speed_rpm", "ia_a", "ib_a", "dc_bus_v"):
        assert status[name] == data[name][-1], name
    assert status["position_counts"] == data["encoder_counts"][-1]
    assert status["speed_rpm"] == pytest.approx(CONFIG.speed_rpm, rel=1e-12)
    assert not math.isnan(status["torque_em_nm"])


@pytest.mark.parametrize("run", [
    lambda names: simulate(CONFIG, 1e-3, RATE_HZ, channels=names),
    lambda names: simulate_batch([CONFIG], 1e-3, RATE_HZ, channels=names),
    lambda names: DriveTwin(CONFIG).advance(1e-3, RATE_HZ, channels=names),
], ids=["simulate", "simulate_batch", "DriveTwin.advance"])
def test_unknown_channel_is_refused_by_name(run):
    with pytest.raises(ValueError, match=r"unknown channel 'torque_Nm'; valid channels: time_s"):
        run(("time_s", "torque_Nm"))
    with pytest.raises(ValueError, match="not the string 'torque_nm'"):
        run("torque_nm")
    with pytest.raises(ValueError, match="channels must be None or an iterable of channel "
                                         "names, not 5"):
        run(5)
