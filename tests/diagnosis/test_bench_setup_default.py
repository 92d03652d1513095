"""A drive whose loop design nobody stated is diagnosed with the family of plausible loops."""

from hil.diagnosis.bench_setup import setup_from_bench_dict


def test_a_bench_without_a_loop_design_gets_the_unknown_family():
    setup, _ = setup_from_bench_dict({"drive": {"current_loop_bandwidth_hz": 1000.0}})
    assert setup.current_loop_design == "unknown"
    assert len(setup.loop_variants()) > 2


def test_a_stated_design_is_kept():
    setup, _ = setup_from_bench_dict({"drive": {"current_loop_bandwidth_hz": 1000.0,
                                                "current_loop_design": "discrete"}})
    assert setup.current_loop_design == "discrete"
