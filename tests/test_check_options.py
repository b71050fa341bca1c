"""`CheckOptions`, the one record of how a job is checked: its defaults are those of
`pathcheck JOB.apt` without options, a record that names no planner or no posting policy the
check knows is refused when it is built (one line, code usage), and it cannot change after."""

from __future__ import annotations

import dataclasses

import pytest

from checker.check.options import CheckOptions
from checker.errors import PathcheckError


def test_the_defaults_are_the_plain_command():
    o = CheckOptions()
    assert (o.cutter, o.machine, o.config, o.b_range, o.stock, o.machine_clearance,
            o.output) == (None,) * 7
    assert (o.reorient, o.strategy, o.on_findings) == (False, "allowable", "refuse")
    assert not o.to_post and not o.stock_asked


@pytest.mark.parametrize("field, value, names", [
    ("strategy", "fastest", "allowable, contact-order"),
    ("on_findings", "ignore", "refuse, stop, comment")])
def test_an_unknown_choice_is_refused_when_built(field, value, names):
    with pytest.raises(PathcheckError) as err:
        CheckOptions(**{field: value})
    assert err.value.code == "usage"
    assert f"{field} '{value}': expected one of {names}" in str(err.value)
    assert "\n" not in str(err.value)


def test_the_record_is_frozen(tmp_path):
    o = CheckOptions(output=tmp_path / "job.nc", reorient=True)
    assert o.to_post
    with pytest.raises(dataclasses.FrozenInstanceError):
        o.reorient = False  # type: ignore[misc]
