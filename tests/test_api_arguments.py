"""The public API's arguments are checked at the entry points, before any work: a wrong type is
a TypeError, a bad value an InputError (a ValueError), each one line naming the argument and
what it may be (`stratcli.arguments`)."""

from __future__ import annotations

import math
import tomllib
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import ROOT
from typer.testing import CliRunner

import stratcli
from stratcli import api
from stratcli.arguments import checked, flag, integer
from stratcli.cli import app
from stratcli.errors import InputError

UNICYCLE = tomllib.loads((ROOT / "scenarios" / "unicycle.toml").read_text())
AUTO = ROOT / "scenarios" / "sim4_auto.toml"


@pytest.fixture(scope="module")
def plan():
    """The unicycle parked sideways: one 2 s leg, planned through the public API."""
    return stratcli.plan(UNICYCLE, check=False)


def _raises(kind, pattern, call):
    with pytest.raises(kind, match=pattern) as caught:
        call()
    assert type(caught.value) is kind  # not a subclass met by accident (pydantic's, numpy's)
    assert "\n" not in str(caught.value)  # one line
    return caught.value


ONE_TO_1000 = r"from 0\.001 to 1000"
BAD_CALLS = {
    "scenario None": (TypeError, r"^scenario: must be a Task, a scenario path, TOML text or a "
                      r"dict \(got None of type NoneType\)$", lambda: stratcli.plan(None)),
    "scenario int": (TypeError, r"^scenario: .* \(got 42 of type int\)$",
                     lambda: stratcli.plan(42)),
    "scenario list": (TypeError, r"^scenario: .* \(got \[1, 2\] of type list\)$",
                      lambda: stratcli.plan([1, 2])),
    "time_scale -1": (InputError, rf"^time_scale: must be a finite number {ONE_TO_1000} "
                      r"\(got -1\)$", lambda: stratcli.plan(UNICYCLE, time_scale=-1)),
    "time_scale str": (TypeError, r"^time_scale: must be a number .*\(got '2' of type str\)$",
                       lambda: stratcli.plan(UNICYCLE, time_scale="2")),
    "check str": (TypeError, r"^check: must be True or False \(got 'no' of type str\)$",
                  lambda: stratcli.plan(UNICYCLE, check="no")),
    "jobs 0": (InputError, r"^jobs: must be an integer of at least 1 \(got 0\)$",
               lambda: stratcli.plan(UNICYCLE, jobs=0)),
    "degree 7": (InputError, r"^degree: must be an integer from 1 to 3 \(got 7\)$",
                 lambda: stratcli.check_controllability("one-arm", degree=7)),
    "samples -1": (InputError, r"^samples: must be an integer from 0 to 100000 \(got -1\)$",
                   lambda: stratcli.check_controllability("one-arm", samples=-1)),
    "seed -1": (InputError, r"^seed: must be an integer from 0 to 9223372036854775807 \(got -1\)$",
                lambda: stratcli.check_controllability("one-arm", seed=-1)),
    "target None": (TypeError, r"^target: ", lambda: stratcli.check_controllability(None)),
    "strategy": (InputError, r"^strategy: must be conservative, postponed or both "
                 r"\(got 'eager'\)$", lambda: stratcli.decompose(UNICYCLE, strategy="eager")),
    "criterion": (InputError, r"^criterion: must be energy, peak-control, excursion or "
                  r"duration \(got 'fast'\)$",
                  lambda: stratcli.compare_sequences(UNICYCLE, criterion="fast")),
    "max_length 9": (InputError, r"^max_length: must be an integer from 1 to 8 \(got 9\)$",
                     lambda: stratcli.compare_sequences(UNICYCLE, max_length=9)),
    "max_length 0": (InputError, r"^max_length: must be an integer from 1 to 8 \(got 0\)$",
                     lambda: stratcli.decompose(UNICYCLE, max_length=0)),
    "sweep int": (TypeError, r"^file: must be a Sweep, a sweep path, TOML text or a dict",
                  lambda: stratcli.run_sweep(42)),
    "sweep records": (InputError, r"^records: must be best, failed, all or none \(got 'some'\)$",
                      lambda: stratcli.run_sweep({}, records="some")),
    "load_run int": (TypeError, r"^path: must be a path .*\(got 3 of type int\)$",
                     lambda: stratcli.load_run(3)),
    "read_sweep None": (TypeError, r"^path: must be a path .*\(got None of type NoneType\)$",
                        lambda: stratcli.read_sweep(None)),
    "unknown keyword": (TypeError, r"^plan\(\) got an unexpected keyword argument 'tolerance' "
                        r"\(plan takes scenario, check, time_scale, jobs; a scenario's own "
                        r"settings change with its with_changes, e\.g\. ",
                        lambda: stratcli.plan(UNICYCLE, tolerance=1e-4)),
    "missing argument": (TypeError, r"^decompose\(\) missing a required argument: 'scenario' "
                         r"\(decompose takes scenario, ",
                         lambda: stratcli.decompose()),
    "empty scenario": (InputError, r"^an empty string is no scenario: give a path, TOML text "
                       r"or a dict$", lambda: stratcli.plan("")),
    "criterion typo": (InputError, r"^criterion: must be energy, peak-control, excursion or "
                       r"duration \(got 'peak_control': did you mean 'peak-control'\?\)$",
                       lambda: stratcli.compare_sequences(UNICYCLE, criterion="peak_control")),
    "preset name": (InputError, r"^name: no preset 'onearm' \(did you mean 'one-arm'\? presets: "
                    r"one-arm, two-arm\)$", lambda: stratcli.preset("onearm")),
    "preset int": (TypeError, r"^name: must be a preset's name \(a str\) \(got 3 of type int\)$",
                   lambda: stratcli.preset(3)),
}  # fmt: skip


@pytest.mark.parametrize("case", list(BAD_CALLS))
def test_a_bad_argument_of_a_use_case_is_one_line_naming_it(case):
    kind, pattern, call = BAD_CALLS[case]
    error = _raises(kind, pattern, call)
    if kind is InputError:
        assert isinstance(error, ValueError) and error.source is None


def test_time_scaled_names_its_speed_up_and_takes_numpy_numbers(plan):
    for s in (0, -2, math.nan, 1e4):
        _raises(
            InputError,
            rf"^s: must be a finite number {ONE_TO_1000} \(got ",
            lambda s=s: stratcli.time_scaled(plan, s),
        )
    _raises(
        TypeError,
        r"^plan: must be a SequencePlan \(got \{\} of type dict\)$",
        lambda: stratcli.time_scaled({}, 2.0),
    )
    faster = stratcli.time_scaled(plan, np.float64(2.0))
    assert faster.duration == pytest.approx(plan.duration / 2)


def test_write_record_names_a_wrong_outcome_and_format_before_writing(tmp_path, plan):
    out = tmp_path / "runs"
    _raises(
        TypeError,
        r"^outcome: must be a SequencePlan, PlanOutcome or ComparisonOutcome",
        (lambda: stratcli.write_record(out, UNICYCLE)),
    )
    _raises(
        InputError,
        r"^fmt: must be png, svg or pdf \(got 'jpg'\)$",
        lambda: stratcli.write_record(out, plan, fmt="jpg"),
    )
    _raises(TypeError, r"^out: must be a path", lambda: stratcli.write_record(None, plan))
    assert not out.exists()  # nothing was started


def test_sample_takes_an_integer_of_at_least_two(plan):
    _raises(
        InputError,
        r"^samples_per_leg: must be an integer of at least 2 \(got 0\)$",
        (lambda: plan.sample(0)),
    )
    _raises(TypeError, r"^samples_per_leg: .*\(got 2\.5 of type float\)$", lambda: plan.sample(2.5))
    assert plan.sample(np.int64(3)).size == 3 * len(plan.legs)


def test_controls_refuse_times_outside_the_plan_but_not_rounding(plan):
    T = plan.duration
    for t in (99.0, -1.0, [0.0, 3.0], math.nan):
        _raises(
            InputError,
            rf"^t: must be within the plan, from 0 to {T:g} s \(got ",
            (lambda t=t: plan.controls(t)),
        )
    inside = plan.controls([-1e-12 * T, 0.0, T / 2, T, T * (1 + 1e-12)])
    assert inside.shape == (5, len(plan.inputs)) and np.all(np.isfinite(inside))
    end = plan.legs[-1].controls(plan.legs[-1].duration)
    np.testing.assert_allclose(inside[3], end, rtol=0, atol=1e-12)
    assert plan.controls(T / 2).shape == (len(plan.inputs),)  # one time: one vector
    assert plan.legs[0].controls(0.0).shape == (len(plan.inputs),)  # a leg's too
    assert plan.legs[0].controls([0.0]).shape == (1, len(plan.inputs))
    np.testing.assert_allclose(plan.controls(np.float64(T / 2)), inside[2], rtol=0, atol=1e-12)
    for t in ("1", ["0.5", "1"], True, None):  # a string was read as the number it spells
        _raises(
            TypeError,
            r"^t: must be a time or an array of times \(s\)",
            lambda t=t: plan.controls(t),
        )


def test_controls_name_t_for_a_table_of_times_and_show_digits_that_differ(plan):
    """A 2-D `t` raised numpy's IndexError from inside; a float32 end time just past the
    duration read 'from 0 to 0.666667 s (got 0.666667)'."""
    _raises(
        InputError,
        r"^t: must be a time or a 1-D array of times \(got 3x2\)$",
        lambda: plan.controls(np.zeros((3, 2))),
    )
    fast = stratcli.time_scaled(plan, 3.0)
    end = np.float32(fast.duration)
    assert float(end) > fast.duration * (1 + 1e-9)  # float32 rounding, beyond `controls`' slack
    with pytest.raises(InputError) as caught:
        fast.controls(end)
    assert str(caught.value) == (
        f"t: must be within the plan, from 0 to {fast.duration:.17g} s (got {float(end):.17g})"
    )


def test_a_legs_controls_refuse_the_plans_time_and_wrong_types(plan):
    """`plan.legs[k].controls` took any time and extrapolated the Fourier series (a new
    user passed the plan's time 1.5 to leg 2 and got u = -167 where the plan has 4.46), read
    None as NaN, and both took a string as `derivative`."""
    leg = plan.legs[-1]
    T = leg.duration
    _raises(
        InputError,
        rf"^t: must be within the leg \(times from its start: plan.controls takes the plan's\), "
        rf"from 0 to {T:g} s \(got {1.5 * T:g}\)$",
        lambda: leg.controls(1.5 * T),
    )
    for t in (None, "x", ["0.5"]):
        _raises(
            TypeError, r"^t: must be a time or an array of times \(s\)", lambda t=t: leg.controls(t)
        )
    for call in (lambda: leg.controls(0.0, "no"), lambda: plan.controls(0.0, derivative="no")):
        _raises(TypeError, r"^derivative: must be True or False \(got 'no'", call)
    # the plan's last instant, within rounding of the plan but past the leg's: the leg's end
    end = plan.controls(plan.duration * (1 + 1e-12))
    np.testing.assert_allclose(end, leg.controls(T), rtol=0, atol=1e-12)


def test_leg_slice_of_a_leg_the_trajectory_has_not_is_an_index_error(plan):
    traj = plan.sample(5)
    assert traj.leg_slice(0) == slice(0, 5)
    for k in (1, 5, -1):
        with pytest.raises(IndexError, match=rf"^leg {k} out of range: the trajectory has 1 legs"):
            traj.leg_slice(k)


def test_use_case_errors_name_the_argument_and_the_command_line_the_flag():
    with pytest.raises(InputError) as caught:
        api.decompose(AUTO, max_length=1)
    assert [p.path for p in caught.value.problems] == ["max_length"]
    bad = CliRunner().invoke(app, ["check", "one-arm", "--at", "0, 1"])
    assert bad.exit_code == 2
    assert "error: --at: needs 4 values (q1, q2, q3, theta), got 2" in bad.output


def test_outcomes_and_record_error_are_public_names():
    from stratcli.sweep.run import SweepOutcome

    for name, value in [
        ("PlanOutcome", api.PlanOutcome),
        ("ComparisonOutcome", api.ComparisonOutcome),
        ("RecordError", stratcli.errors.RecordError),
        ("DecompositionOutcome", api.DecompositionOutcome),
        ("CheckReport", api.CheckReport),
        ("SweepReport", api.SweepReport),
        ("SweepOutcome", SweepOutcome),
    ]:
        assert name in stratcli.__all__ and name in dir(stratcli)
        assert getattr(stratcli, name) is value
        assert f"`{name}`" in stratcli.__doc__  # help(stratcli) lists it


def test_reprs_are_short_and_say_name_status_energy_and_legs(plan):
    text = repr(plan)
    assert len(text) < 200, text
    assert text.startswith("SequencePlan('unicycle': SUCCESS, energy ") and "1 leg (drive)" in text
    assert f"{plan.total_energy:.6g}" in text
    outcome = api.PlanOutcome(None, plan, plan.to_dict(), None, 0.0, 0.0)
    assert repr(outcome) == f"PlanOutcome({text})"
    fake = SimpleNamespace(scenario=SimpleNamespace(name="auto"))
    comparison = api.ComparisonOutcome(
        fake, None, SimpleNamespace(candidates=[1, 2, 3]), None, {}, outcome
    )
    assert repr(comparison) == f"ComparisonOutcome('auto': 3 candidate sequences, best {text})"
    assert plan == stratcli.time_scaled(plan, 1.0)  # by value: the same plan, a new object
    assert plan != stratcli.time_scaled(plan, 2.0)
    # there and back: time_scale 1 is the default again, not a line the scenario never had
    assert stratcli.time_scaled(stratcli.time_scaled(plan, 2.0), 0.5) == plan


def test_numpy_scalars_are_passed_on_as_python_numbers_the_records_can_write(tmp_path):
    """A numpy argument passes the check and reaches the records: result.json (JSON) could not
    write `np.float32`, comparison.json `np.int64` jobs."""
    seen = {}

    @checked(jobs=integer(1), flag=flag)
    def use(*, jobs, flag):
        seen.update(jobs=jobs, flag=flag)

    use(jobs=np.int64(2), flag=np.True_)
    assert type(seen["jobs"]) is int and type(seen["flag"]) is bool
    slower = stratcli.plan(UNICYCLE, check=False, time_scale=np.float32(0.5))
    assert type(slower.time_scale) is float
    run = stratcli.write_record(tmp_path / "run", slower)
    assert (run / "result.json").is_file()


def test_a_dask_scheduler_file_may_be_a_path_object(tmp_path):
    """`dask=` takes a scheduler address or file: a pathlib.Path is a file name like a str
    (it was a TypeError); a file that is not there is bad input, named."""
    from pathlib import Path

    missing = Path(tmp_path) / "scheduler.json"
    for call in (
        lambda: stratcli.compare_sequences(ROOT / "scenarios" / "sim4_auto.toml", dask=missing),
        lambda: stratcli.run_sweep(ROOT / "scenarios" / "sweeps" / "sim4_goal_map.toml",
                                   tmp_path / "out", dask=missing),
    ):  # fmt: skip
        with pytest.raises(InputError, match="dask"):
            call()


def test_load_run_of_a_file_outside_a_record_names_that_file(tmp_path, monkeypatch):
    # it named the file's folder ("." for a file in the working directory)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("x")
    _raises(
        InputError,
        r"^notes\.txt: a file, not a run record \(give a run directory\)$",
        lambda: stratcli.load_run("notes.txt"),
    )


def test_a_status_by_an_unknown_key_names_the_keys():
    """`Status.from_key('nope')` raised a bare KeyError: 'NOPE' from enum."""
    from stratcli.status import Status

    assert all(Status.from_key(s.key) is s for s in Status)
    with pytest.raises(KeyError, match=r"'nope' is not a status: one of success, not_converged"):
        Status.from_key("nope")
    with pytest.raises(KeyError) as caught:  # its message as written, not quoted again
        Status.from_key("sucess")
    assert str(caught.value).startswith("'sucess' is not a status: one of success, ")
