"""The validity study covers pole counts 2…14 with count orders that are not whole per
electrical revolution, and runs the plans in random orders (issue 30 item 4)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

from hil.model.encoder import count_period

STUDY = Path(__file__).parents[2] / "studies" / "validity.py"


def load_study():
    spec = importlib.util.spec_from_file_location("validity_study_orders", STUDY)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_pole_counts_2_to_14_and_non_dividing_count_orders():
    study = load_study()
    poles = sorted(study.motor_parameters(name).pole_count for name in study.MOTORS)
    assert poles[0] == 2 and poles[-1] == 14
    periods = [count_period(pole_pairs=study.motor_parameters(name).pole_pairs,
                            encoder_decimation=25)[0] for name in study.MOTORS]
    assert any(m > 1 for m in periods)                    # 10 and 14 poles: not whole


def test_shuffled_plan_orders_are_seeded_permutations_after_the_self_check():
    study = load_study()
    from hil.commands.run import SELF_CHECK, plan_modules

    plans = sorted(n for n in plan_modules() if n != SELF_CHECK)
    orders = [study.plan_order(seed) for seed in (1, 2, 3)]
    assert all(sorted(order) == plans for order in orders)
    assert len({tuple(order) for order in orders}) == 3
    assert study.plan_order(2) == orders[1]
