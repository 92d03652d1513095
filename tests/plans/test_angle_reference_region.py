"""Where the self-check's angle reference (back EMF against the angle channel) is refused before
capturing (``testplans/test_self_check.angle_reference_problem``): the EMF channel's range on
either side, a scope's screen as well as a DAQ's int16 range, and the time-skew bound alone at
a high electrical frequency. Each case against the same point let through where it fits."""

from __future__ import annotations

from types import SimpleNamespace

from ripple_hil_drivers.daq_register_map import Channel
from ripple_hil_drivers.scpi_scope import ScopeChannel, ScopeChannelMap
from hil.config import default_sim_bench
from ripple_hil_testplans.test_self_check import angle_reference_problem, channel_span_si


def daq_map(scale: float, offset: float = 0.0):
    return SimpleNamespace(channels=(Channel("vab_v", 6, "int16", scale, offset),))


def bench_at(speed_rpm: float, **motor):
    return default_sim_bench().with_overrides({"motor": motor,
                                               "operating_point": {"speed_rpm": speed_rpm}})


def test_a_range_offset_from_zero_is_judged_on_each_side():
    config = bench_at(500.0)                     # Table I: √3·E ≈ 2.9 V
    assert angle_reference_problem(config, daq_map(0.001)) is None
    assert angle_reference_problem(config, daq_map(-0.001)) is None     # either sign of scale
    assert channel_span_si(daq_map(-0.001), "vab_v") == (-32.767, 32.768)    # lowest first
    # +40 V offset: 7.2..72.8 V, no room below zero for the EMF's negative half
    refused = angle_reference_problem(config, daq_map(0.001, 40.0))
    assert refused and "would clip" in refused and "7.232..72.77" in refused


def test_a_scope_screen_is_a_range_too():
    channel = ScopeChannel("vab_v", "CHANnel3", si_per_volt=10.0, volts_per_div=0.5)
    scope = ScopeChannelMap("keysight", 8, 8, 1000, (channel,), "test")
    assert channel_span_si(scope, "vab_v") == (-20.0, 20.0)
    p8 = dict(pole_count=8, dc_bus_v=48.0, phase_resistance_ohm=0.12, phase_inductance_h=0.3e-3,
              max_reactance_ohm=0.4, ke_v_s_per_rad=0.06, ke_definition="rms_phase")
    assert angle_reference_problem(bench_at(1000.0, **p8), scope) is None        # 15.4 V
    refused = angle_reference_problem(bench_at(2000.0, **p8), scope)            # 30.8 V
    assert refused and "would clip" in refused


def test_the_skew_bound_alone_refuses_a_fast_electrical_frequency():
    p20 = dict(pole_count=20, dc_bus_v=48.0, phase_resistance_ohm=0.05,
               phase_inductance_h=0.1e-3, max_reactance_ohm=0.4, ke_v_s_per_rad=0.005,
               ke_definition="rms_phase")
    refused = angle_reference_problem(bench_at(2900.0, **p20), daq_map(0.001))   # 483 Hz
    assert refused and "time skew" in refused and "5.02°" in refused
    assert angle_reference_problem(bench_at(2000.0, **p20), daq_map(0.001)) is None   # 3.5°
