"""Input validation of the Python API: errors name the parameter and the allowed range."""

import functools
import math

import pytest

from hil.errors import InputError
from hil.model import INJECTION_KNOBS, OperatingPoint, Prediction, SOURCES, predict

OP = OperatingPoint(speed_rpm=1000, current_a=20.0)


@pytest.mark.parametrize("kwargs,name", [
    (dict(speed_rpm=4000, current_a=10), "speed_rpm"),
    (dict(speed_rpm=100, current_a=0), "current_a"),
    (dict(speed_rpm=100, current_a=150), "current_a"),
    (dict(speed_rpm=100, current_a=10, current_angle_rad=2.0), "current_angle_rad"),
    (dict(speed_rpm=100, current_a=10, dc_bus_v=-12), "dc_bus_v"),
])
def test_operating_point_validation(kwargs, name):
    with pytest.raises(InputError, match=name) as info:
        OperatingPoint(**kwargs)
    assert "allowed" in str(info.value)


@pytest.mark.parametrize("source,params,name", [
    ("encoder", dict(resolution_elec_rad=-0.1), "resolution_elec_rad"),
    ("encoder", dict(encoder_decimation=0), "encoder_decimation"),
    ("encoder", dict(encoder_decimation=2.5), "encoder_decimation"),
    ("word_length", dict(word_length_bits=0), "word_length_bits"),
    ("word_length", dict(word_length_bits=40), "word_length_bits"),
    ("dc_offset", dict(offset_a_pu=2.0), "offset_a_pu"),
    ("dc_offset", dict(ia_offset_a=30.0), "ia_offset_a"),
    ("dc_offset", dict(ia_offset_a=0.1, offset_a_pu=0.01), "ia_offset_a"),
    ("gain_mismatch", dict(ia_gain_error_pu=0.5), "ia_gain_error_pu"),
    ("pwm_resolution", dict(pwm_period_counts=4), "pwm_period_counts"),
    ("pwm_resolution", dict(pwm_bits=8, pwm_period_counts=128), "pwm_bits"),
    ("pwm_switching", dict(pwm_frequency_hz=100.0), "pwm_frequency_hz"),
    ("pwm_switching", dict(model="exact"), "model"),
    ("dead_time", dict(dead_time_s=20e-6), "dead_time_s"),
    ("dead_time", dict(dead_time_s=1e-6, model="magic"), "model"),
    ("dead_time", {}, "dead_time_s"),
    ("dc_offset", dict(offset_pu=0.01), "offset_pu"),
    ("cogging", {}, "cogging"),
])
def test_predict_bad_input(source, params, name):
    with pytest.raises(InputError, match=name):
        predict(source, OP, **params)


def test_an_injection_dict_passes_straight_through():
    injection = {"ia_offset_a": 0.2, "ib_offset_a": 0.0, "ia_gain_error_pu": 0.0,
                 "ib_gain_error_pu": 0.0, "encoder_decimation": 1, "hall_mode": False,
                 "word_length_bits": 16, "pwm_period_counts": 2000, "pwm_frequency_hz": 20000.0,
                 "dead_time_s": 1e-6, "current_angle_rad": 0.1}
    assert set(injection) == INJECTION_KNOBS
    for source in SOURCES:
        pred = predict(source, OP, **injection)
        assert isinstance(pred, Prediction) and pred.inputs["current_angle_rad"] == 0.1
        assert math.isfinite(pred.pk_pk_pu) and pred.pk_pk_pu >= 0
        data = pred.to_dict()
        assert {"pk_pk_pu", "base", "base_nm", "order", "inputs", "assumptions"} <= set(data)


def test_remembered_predictions_hand_back_copies_inside_the_block_only(monkeypatch):
    from hil.model import sources

    calls = []
    real = sources.SOURCES["dead_time"]

    @functools.wraps(real)                  # predict reads the source's signature
    def counted(op, **kw):
        calls.append(kw)
        return real(op, **kw)

    monkeypatch.setitem(sources.SOURCES, "dead_time", counted)
    with sources.remembered_predictions():
        first = predict("dead_time", OP, dead_time_s=1e-6)
        first.extras["changed by a caller"] = True
        again = predict("dead_time", OP, dead_time_s=1e-6)
        other = predict("dead_time", OP, dead_time_s=2e-6)
        with sources.remembered_predictions():          # nested: the same memory
            predict("dead_time", OP, dead_time_s=2e-6)
    assert len(calls) == 2                                # computed once per distinct call
    assert "changed by a caller" not in again.extras and again.pk_pk_pu == first.pk_pk_pu
    assert other.pk_pk_pu != first.pk_pk_pu
    predict("dead_time", OP, dead_time_s=1e-6)            # outside: computed again
    assert len(calls) == 3


def test_remembered_predictions_blocks_may_end_in_any_order():
    from hil.model import sources

    first, second = sources.remembered_predictions(), sources.remembered_predictions()
    first.__enter__()
    second.__enter__()
    first.__exit__(None, None, None)
    assert sources._memo is not None                       # the second block still open
    second.__exit__(None, None, None)
    assert sources._memo is None                           # nothing kept after the last
