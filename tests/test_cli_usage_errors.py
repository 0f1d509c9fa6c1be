"""Errors click finds in the command line itself (a value out of range, an unknown option, a
missing argument): one `error:` line naming the option and the value given, exit 2."""

from __future__ import annotations

import pytest
from conftest import ROOT
from typer.testing import CliRunner

from stratcli.cli import app

runner = CliRunner()
TASK_D = str(ROOT / "scenarios" / "sim4_task_d.toml")
AUTO = str(ROOT / "scenarios" / "sim4_auto.toml")

CASES = {
    "time-scale 0": (
        ["plan", TASK_D, "--time-scale", "0"],
        "error: --time-scale: must be from 0.001 to 1000 (got 0)",
    ),
    "time-scale nan": (
        ["plan", TASK_D, "--time-scale", "nan"],
        "error: --time-scale: must be from 0.001 to 1000 (got nan)",
    ),
    "time-scale word": (
        ["plan", TASK_D, "--time-scale", "fast"],
        "error: --time-scale: must be a number from 0.001 to 1000 (got 'fast')",
    ),
    "jobs 0": (
        ["compare-sequences", AUTO, "--jobs", "0"],
        "error: --jobs: must be at least 1 (got 0)",
    ),
    "jobs 1.5": (
        ["compare-sequences", AUTO, "--jobs", "1.5"],
        "error: --jobs: must be a whole number at least 1 (got 1.5)",
    ),
    "max-length 0": (
        ["decompose", AUTO, "--max-length", "0"],
        "error: --max-length: must be from 1 to 8 (got 0)",
    ),
    "max-length 50": (
        ["compare-sequences", AUTO, "--max-length", "50"],
        "error: --max-length: must be from 1 to 8 (got 50)",
    ),
    "degree 9": (
        ["check", "one-arm", "--degree", "9"],
        "error: --degree: must be from 1 to 3 (got 9)",
    ),
    "samples -1": (
        ["check", "one-arm", "--samples", "-1"],
        "error: --samples: must be from 0 to 100000 (got -1)",
    ),
    "format jpg": (
        ["plan", TASK_D, "--format", "jpg"],
        "error: --format: must be png, svg or pdf (got 'jpg')",
    ),
    "unknown option": (
        ["plan", TASK_D, "--jsno"],
        "error: --jsno: no such option (did you mean --json?)",
    ),
    "unknown option, not close": (  # click, comparing with the dashes, suggested --out
        ["plan", TASK_D, "--bogus"],
        "error: --bogus: no such option (see stratplan plan --help)",
    ),
    "objective misspelt": (
        ["plan", TASK_D, "--objective", "newtn"],
        "error: --objective: must be energy or newton (got 'newtn': did you mean 'newton'?)",
    ),
    "choice in another case": (
        ["plan", TASK_D, "--search", "Loops"],
        "error: --search: must be loops, starts or legwise (got 'Loops': did you mean 'loops'?)",
    ),
    "choice with letters swapped": (
        ["sweep", TASK_D, "--records", "bets"],
        "error: --records: must be best, failed, all or none (got 'bets': did you mean 'best'?)",
    ),
    "option without its value": (["plan", TASK_D, "--out"], "error: --out: requires an argument"),
    "empty out": (  # an unset shell variable: not the current directory
        ["compare-sequences", AUTO, "--out", ""],
        "error: --out: empty: give a directory (e.g. runs)",
    ),
    "missing argument": (["plan"], "error: FILE: missing (see stratplan plan --help)"),
    "empty file": (["plan", ""], "error: FILE: empty: give a file"),  # (was '.: not a regular')
    "empty sweep file": (["sweep", " "], "error: FILE: empty: give a file"),
    "empty sweep out": (  # (it wrote the sweep into the current folder)
        ["sweep", "scenarios/sweeps/sim4_goal_map.toml", "--out", ""],
        "error: --out: empty: give a directory (e.g. runs)",
    ),
    "empty baseline": (["regress", "--baseline", ""], "error: --baseline: empty: give a file"),
    "empty show": (["show", ""], "error: RUN: empty: give a directory (e.g. runs)"),
    "unknown command, not close": (
        ["frobnicate"],
        "error: no such command 'frobnicate' (see stratplan --help)",
    ),
    "extra argument": (
        ["plan", TASK_D, "extra"],
        "error: unexpected extra argument(s) (extra) (see stratplan plan --help)",
    ),
    "unknown command": (["paln", TASK_D], "error: no such command 'paln' (did you mean 'plan'?)"),
}


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_a_bad_command_line_is_one_error_line_naming_option_and_value(case):
    args, line = CASES[case]
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    assert result.stderr.splitlines() == [line]
    assert result.stdout == ""


def test_help_is_still_help():
    result = runner.invoke(app, [])
    assert "Usage: stratplan" in result.output and "compare-sequences" in result.output
    assert "error:" not in result.output
    result = runner.invoke(app, ["plan", "--help"])
    assert result.exit_code == 0 and "--time-scale" in result.stdout and not result.stderr
