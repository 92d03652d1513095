"""Issue 22.8: `hil budget` says which quantity it budgets (the air-gap torque at full
bandwidth) and, when only the switching ripple is out of reach, what a requirement judged on the
torque transducer's reading (which does not see the switching frequency) adds up to."""

import json

import pytest

from hil.cli import main

NOTE = "on the torque transducer's reading (what requirements are judged on)"


def budget(capsys, *args):
    status = main(["budget", *args])
    return status, capsys.readouterr().out


@pytest.mark.parametrize("point", [(), ("--speed-rpm", "500", "--current-a", "10")])
def test_only_switching_unmet_says_what_the_transducer_sees(capsys, point):
    status, text = budget(capsys, "--limit-pct", "2", *point)
    json_status, raw = budget(capsys, "--limit-pct", "2", "--json", *point)
    data = json.loads(raw)
    assert status == json_status == 1 and data["not_met"] == ["pwm_switching"]
    lines = text.splitlines()
    assert lines[1].startswith("quantity: the air-gap torque at full bandwidth")
    assert lines[-1].startswith("LIMIT NOT ATTAINABLE: 2 % of the air-gap torque")
    contributions = data["check"]["contributions_pu"]
    in_band = sum(v for k, v in contributions.items() if k != "pwm_switching")
    assert data["quantity"]["worst_case_sum_in_transducer_band_pu"] == pytest.approx(in_band)
    assert in_band < 0.02 < data["check"]["worst_case_sum_pu"]
    assert lines[-2] == (f"{NOTE} the pwm_switching ripple does not appear: the other sources' "
                         f"worst-case sum {100 * in_band:.4g} % meets 2 %")


def test_an_attainable_limit_has_no_transducer_note(capsys):
    status, text = budget(capsys, "--limit-pct", "30")
    assert status == 0 and NOTE not in text
    assert "quantity: the air-gap torque" in text


def test_alone_allocation_is_not_judged_on_a_sum(capsys):
    status, text = budget(capsys, "--limit-pct", "2", "--allocation", "alone")
    assert status == 1
    assert text.splitlines()[-2] == (f"{NOTE} the pwm_switching ripple does not appear: the "
                                     f"other sources each meet 2 % alone")
