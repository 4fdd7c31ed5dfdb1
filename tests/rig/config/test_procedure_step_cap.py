"""One cap on a procedure's steps, listed or expanded (issue 34 item 7): at most MAX_STEPS (10,000), with one
line saying so; a listed count is refused before its steps are validated one by one."""

from __future__ import annotations

import pytest

from rig.config.procedure import MAX_STEPS, load_procedure_text
from rig.errors import RigInputError

HEAD = "format: rig-procedure/1\nname: many\nsensor: {accel_range_g: 4, sample_rate_hz: 100}\ndwell: {seconds: 0.2}\n"


def _listed(n: int) -> str:
    return HEAD + "steps:\n" + '  - pose: "+Z up"\n' * n


def test_the_cap_is_ten_thousand_steps_and_that_many_listed_steps_load():
    assert MAX_STEPS == 10_000
    assert len(load_procedure_text(_listed(MAX_STEPS), "many.yaml").steps) == MAX_STEPS


def test_more_listed_steps_are_refused_with_the_limit_before_any_step_is_validated():
    with pytest.raises(RigInputError) as exc:  # the last step is no pose: the count is refused first
        load_procedure_text(_listed(MAX_STEPS) + '  - pose: "sideways"\n', "many.yaml")
    assert str(exc.value) == ("many.yaml:5: steps: 10001 steps listed: at most 10000 steps in a procedure, listed or "
                              "after expanding repeat: and ramps; split it into several procedures")


def test_repeats_that_expand_beyond_the_cap_are_refused_with_the_same_limit():
    text = HEAD + "steps:\n  - repeat: 1000\n    steps:\n      - repeat: 11\n        steps:\n          - pose: '+Z up'\n"
    with pytest.raises(RigInputError, match="more than 10000 steps: at most 10000 steps in a procedure, listed or "
                                            "after expanding repeat: and ramps"):
        load_procedure_text(text, "r.yaml")
