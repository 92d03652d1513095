"""Controller word length (paper III-B, eqs 10-14). The paper gives only a worst-case bound
10/2^(n-1), which a drive ignoring the injection also meets; the plan judges against the derived
two-sided truncation-bias model of hil.model.word_length (order 1 where it dominates) and checks
the sweep's slope, and records the paper's bound beside each point."""

import pytest

from ripple_hil_testplans import conditions as c
from ripple_hil_testplans.sensitivity import check_sensitivity

pytestmark = pytest.mark.ripple_source("word_length")


def plan(config, injection):
    return c.point(config.operating_point, "word_length", injection, c.DERIVED_RANGE_RULE,
                   prediction_params={"model": "derived", "max_order": 48,
                                      **c.WORD_LENGTH_FIRMWARE},
                   expectation="judged against the derived truncation-bias model (two-sided, its "
                               "own stated range): two's-complement truncation is biased by "
                               "-1/2 LSB, which acts like a dc offset on both current sensors "
                               "(order-1 ripple); the paper's worst-case bound 10/2^(n-1) is "
                               "recorded beside it (prediction.extras.paper_pk_pk_pu)")


@pytest.mark.parametrize("injection", c.WORD_LENGTH_SWEEP, ids=c.sweep_id)
def test_word_length(measure, bench, injection):
    outcome = measure(plan(bench.config, injection))
    assert outcome.passed, outcome.summary()


def test_word_length_sensitivity(record):
    """The sweep's measured ripple scales with the word length as the derived model says."""
    result = check_sensitivity(record, "word_length", c.DERIVED_RANGE_SLOPE_TOL)
    assert result["accepted"], result["statement"]
