"""The validity floor derived from the bench's resolution and noise (issue 30 item 4).

The hole: at Table I 180 rpm / 8 A the encoder 2.5°/5° points and the dead time 2-3 µs were
refused by a fixed two-count floor (0.001 N·m, 0.26 % of 0.39 N·m) although their predicted
ripple is 4-9 counts; a synchronous average over thousands of samples with the stated noise
(0.4 count) dithering the quantiser resolves far less than two counts. The floor now follows
from the resolution q, the noise σ and the point's own capture (hil.validity
``resolvable_floor_nm``); it still refuses what a noisy bench cannot resolve, and a bench file
that states no noise keeps the two counts.
"""

from __future__ import annotations

import pytest

from hil.config import default_sim_bench
from hil.validity import dithered_quantiser_error_nm, problems, resolvable_floor_nm
from ripple_hil_testplans import conditions as c
from ripple_hil_testplans import test_dead_time, test_encoder

LSB = 0.0005


def test_the_dithered_quantiser():
    assert dithered_quantiser_error_nm(LSB, 0.0) == LSB / 2
    assert dithered_quantiser_error_nm(LSB, 0.4 * LSB) == pytest.approx(0.0135 * LSB, rel=0.01)
    errors = [dithered_quantiser_error_nm(LSB, s * LSB) for s in (0.05, 0.1, 0.2, 0.3, 0.5)]
    assert errors == sorted(errors, reverse=True)


def bench(noise_rms_nm=None, speed_rpm=180.0, current_a=8.0):
    overrides = {"operating_point": {"speed_rpm": speed_rpm, "current_a": current_a,
                                     "current_angle_deg": 0.0}}
    config = default_sim_bench().with_overrides(overrides)
    if noise_rms_nm != "default":
        config = config.with_overrides({"torque": {"noise_rms_nm": noise_rms_nm}})
    return config


POINTS = [(test_encoder, {"encoder_decimation": 25}), (test_encoder, {"encoder_decimation": 50}),
          (test_dead_time, {"dead_time_s": 2e-6}), (test_dead_time, {"dead_time_s": 3e-6})]


@pytest.mark.parametrize("module, injection", POINTS, ids=lambda v: str(v)[-30:])
def test_points_of_several_counts_are_judged_with_the_stated_noise(module, injection):
    config = bench("default")
    assert config.torque.noise_rms_nm == pytest.approx(2e-4)   # the shipped simulated bench
    plan = module.plan(config, injection)
    assert not problems(plan, config), problems(plan, config)
    assert resolvable_floor_nm(plan, config) < 0.5e-3             # below the old two counts


@pytest.mark.parametrize("module, injection", POINTS, ids=lambda v: str(v)[-30:])
def test_a_noisy_bench_and_one_without_a_stated_noise_still_refuse(module, injection):
    noisy = bench(2e-2)                                           # 40 counts of noise
    assert any(r.startswith("ripple not resolvable") for r in
               problems(module.plan(noisy, injection), noisy))
    unstated = bench(None)
    plan = module.plan(unstated, injection)
    assert resolvable_floor_nm(plan, unstated) == pytest.approx(2 * LSB)
    assert any(r.startswith("ripple not resolvable") for r in problems(plan, unstated))
