"""Mutation suite: a simulated drive that is wrong in the way a plan exists to catch must make
that plan fail (issue 13 item 3; design.md §7: "a verdict that cannot fail is a defect").

Each case runs the relevant plans end to end against the simulated bench with one test-only
defect and asserts every plan that should catch it failed. The full table (every defect against
every plan) is printed by ``studies/mutation_table.py``.
"""

from __future__ import annotations

import pytest

from mutation_run import failed_sources, run_plans
from test_phase_mutations import PHASE_CASES

pytestmark = [pytest.mark.integration, pytest.mark.slow]

#: Every plan that injects: a drive ignoring every injection must fail each of them.
INJECTION_PLANS = ["dc_offset", "gain_mismatch", "dead_time", "encoder", "pwm_switching",
                   "word_length", "pwm_resolution"]

CASES = [
    # defect, plans run, plans that must fail (one run per defect: a run's fixed cost, the
    # bench's characterisation and self-check, is paid once)
    ({"ignore_injection": "*"}, INJECTION_PLANS, set(INJECTION_PLANS)),
    # every injection applied scaled; a PWM counter applied scaled: the plan's non-synchronous
    # noise check catches it
    ({"injection_scale": 1.5}, ["dc_offset", "gain_mismatch", "dead_time", "pwm_resolution"],
     {"dc_offset", "gain_mismatch", "dead_time", "pwm_resolution"}),
    # a drive applying 70 % of the commanded dead time: inside the ±35 % pk-pk band; the order-6
    # amplitude check (±15 %) and the sweep's slope catch it; 70 % of the PWM counter: the noise
    # check
    ({"injection_scale": 0.7}, ["dead_time", "pwm_resolution"], {"dead_time", "pwm_resolution"}),
    ({"hidden_ia_offset_a": 0.3}, ["baseline", "dc_offset"], {"baseline", "dc_offset"}),
    ({"word_length_offset_bits": -2}, ["word_length"], {"word_length"}),
    ({"transducer_scale": 1.05}, ["self_check"], {"self_check"}),
    # the DAQ's encoder 30° electrical from the rotor's zero while the bench file states 0
    ({"encoder_commutation_offset_elec_deg": 30.0}, ["self_check"], {"self_check"}),
    *PHASE_CASES,
]


def case_id(case) -> str:
    defects, _, _ = case
    return ",".join(f"{k}={v}" for k, v in defects.items()) + "->" + "+".join(sorted(case[2]))


@pytest.mark.parametrize("case", CASES, ids=case_id)
def test_a_defective_drive_fails_the_plans_that_exist_to_catch_it(case, tmp_path):
    defects, sources, must_fail = case
    run = run_plans(sources, defects, tmp_path)
    assert run["outcomes"], "no record was written:\n" + run["output"]
    # a verdict that failed: a plan that errored (or broke the session for the plans after it)
    # has not caught the defect
    missed = must_fail - failed_sources(run, outcomes=("failed",))
    assert not missed, (f"defect {defects}: plans {sorted(missed)} gave no failed verdict "
                        f"although they exist to catch it; outcomes {run['outcomes']}\n"
                        f"{run['output']}")
    assert run["returncode"] == 1, run["output"]


def test_a_daq_dropping_samples_stops_the_run_at_the_characterisation_stage(tmp_path):
    """A DAQ that drops every 10th sample: its first capture is now the characterisation stage's
    (before the self-check), whose integrity check refuses it. No plan runs as a judged plan:
    the record is closed as stopped with the reason, every test "not run", exit 6 — never a
    pass (it had been caught by the self-check before the stage existed)."""
    run = run_plans(["self_check"], {"daq_drop_every_nth": 10}, tmp_path)
    assert run["returncode"] == 6, run["output"]
    assert "time base not uniform" in run["output"], run["output"]
    assert run["outcomes"] and set(run["outcomes"]["self_check"]) == {"not run"}, run["outcomes"]
    assert "passed" not in str(run["outcomes"])


def test_the_same_plans_pass_on_the_drive_without_defects(tmp_path):
    """The control: without a defect the plans the cases run pass, in the same runs (so a
    case's failure is the defect's doing)."""
    sources = ["self_check", "baseline", *INJECTION_PLANS]
    run = run_plans(sources, {}, tmp_path)
    assert failed_sources(run) == set(), run["output"]
    assert run["returncode"] == 0, run["output"]
