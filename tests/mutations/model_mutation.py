"""A pytest plugin for the mutation table: a closed-form model made wrong by a factor (issue 30).

``-p model_mutation --mutate-model SOURCE=FACTOR`` multiplies what ``hil.model.predict`` states
for SOURCE — its pk-pk, its expected range and its order pk-pk — by FACTOR in that pytest process
(the plans then judge a correct drive against a model FACTOR× too large): a plan whose bands are
wider than the model's error cannot fail it (the audit's "PWM-resolution model twice too large
passes its pk-pk check"). Test-only; loaded by ``mutation_run.run_plans(model_scale=...)``.
"""

from __future__ import annotations

import dataclasses
import functools


def pytest_addoption(parser) -> None:
    parser.addoption("--mutate-model", action="append", default=[], metavar="SOURCE=FACTOR",
                     help="test-only: scale a closed-form model's prediction (mutation table)")


def scaled(function, factor: float):
    @functools.wraps(function)
    def wrong(*args, **kwargs):
        prediction = function(*args, **kwargs)
        extras = dict(prediction.extras)
        if "order_pk_pk_pu" in extras:
            extras["order_pk_pk_pu"] *= factor
        span = prediction.expected_range_pu
        return dataclasses.replace(
            prediction, pk_pk_pu=prediction.pk_pk_pu * factor, extras=extras,
            expected_range_pu=None if span is None else tuple(v * factor for v in span))
    return wrong


def pytest_configure(config) -> None:
    from hil.model import sources

    for text in config.getoption("mutate_model"):
        source, _, factor = text.partition("=")
        sources.SOURCES[source] = scaled(sources.SOURCES[source], float(factor))
