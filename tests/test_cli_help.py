"""`--help` reads well in an 80-column terminal (and the same at 100 and 160): each option's,
argument's and command's help starts within the first 40 columns, at the same column in every
command and width, and nothing of what typer showed (names, negative forms, types, defaults,
ranges) is dropped."""

from __future__ import annotations

import pytest
import typer
from typer.testing import CliRunner

from stratcli.cli import app

runner = CliRunner()
COMMANDS = [
    [],
    ["plan"],
    ["compare-sequences"],
    ["decompose"],
    ["sweep"],
    ["check"],
    ["models"],
    ["show"],
    ["runs"],
    ["regress"],
]
WIDTHS = (80, 100, 160)
ids = [" ".join(c) or "stratplan" for c in COMMANDS]


def _help(command: list[str], width: int) -> str:
    result = runner.invoke(app, [*command, "--help"], env={"COLUMNS": str(width)})
    assert result.exit_code == 0, result.output
    return result.output


def _command(path: list[str]):
    """The click command of `stratplan PATH` (the group for [])."""
    found = typer.main.get_command(app)
    for name in path:
        found = found.commands[name]
    return found


def _entries(path: list[str]) -> dict[str, str]:
    """What the help lists, each with the first words of its help text."""
    command = _command(path)
    entries = {p.name: p.help for p in command.params if not p.hidden and p.help}
    entries["help"] = "Show this message and exit."
    for name, sub in getattr(command, "commands", {}).items():
        entries[name] = sub.help
    return {name: " ".join(text.split()[:2]) for name, text in entries.items()}


def _help_columns(text: str, path: list[str]) -> dict[str, int]:
    """The column at which each entry's help starts (in a panel row, after a wide gap)."""
    rows = [line for line in text.splitlines() if line.startswith("│")]
    found = {}
    for name, words in _entries(path).items():
        at = [row.find("  " + words) for row in rows if "  " + words in row]
        assert at, f"{name}: help {words!r} is not on one line of {path} --help:\n{text}"
        found[name] = at[0] + 2
    return found


@pytest.mark.parametrize("command", COMMANDS, ids=ids)
def test_every_help_starts_within_40_columns_at_80(command):
    """At 80 columns typer's layout started an option's help at column 57 (plan): the names
    and types took the width and the help wrapped every word or two."""
    late = {k: v for k, v in _help_columns(_help(command, 80), command).items() if v > 40}
    assert not late, f"help starts after column 40: {late}\n{_help(command, 80)}"


def test_help_starts_at_one_column_in_every_command_and_width():
    columns = {
        (" ".join(command) or "stratplan", width, name): at
        for command in COMMANDS
        for width in WIDTHS
        for name, at in _help_columns(_help(command, width), command).items()
    }
    assert len(set(columns.values())) == 1, columns


@pytest.mark.parametrize("command", COMMANDS, ids=ids)
@pytest.mark.parametrize("width", WIDTHS)
def test_no_line_is_wider_than_the_terminal(command, width):
    text = _help(command, width)
    assert max(len(line) for line in text.splitlines()) <= width, text


@pytest.mark.parametrize("command", COMMANDS[1:], ids=ids[1:])
def test_every_option_name_and_negative_form_is_shown(command):
    text = _help(command, 80)
    for param in _command(command).params:
        for name in [*param.opts, *param.secondary_opts]:
            if param.param_type_name == "option":
                assert f" {name}" in text, f"{name} missing:\n{text}"


def test_types_defaults_and_ranges_are_shown():
    plan = _help(["plan"], 80)
    for shown in (
        "--out <path>",
        "[default: runs]",
        "--quiet, -q",
        "--no-animation",
        "[default: no-animation]",
        "--time-scale S",
        "[0.001<=x<=1000.0]",
        "--no-check",
        "[default: check]",
        "png|svg|pdf",  # typer's type string: <png|svg|pdf> (0.2x), [png|svg|pdf] (0.19)
        "[default: png]",
        "[required]",
    ):
        assert shown in plan, f"{shown!r} missing:\n{plan}"
    check = _help(["check"], 80)
    assert "[default: 2; 1<=x<=3]" in check and "0<=x<=100000]" in check, check
    sweep = _help(["sweep"], 80)
    assert "best|failed|all|none" in sweep and "[default: failed]" in sweep, sweep


def test_a_bad_ranged_value_is_still_one_line_naming_the_option():
    """`--time-scale S` is only how the help shows it: the value is checked as before."""
    result = runner.invoke(app, ["plan", "x.toml", "--time-scale", "-1"])
    assert result.exit_code == 2
    assert result.output.strip() == "error: --time-scale: must be from 0.001 to 1000 (got -1)"


@pytest.mark.parametrize("command", COMMANDS, ids=ids)
def test_h_is_help_too(command):
    """`stratplan plan -h` was "No such option: -h"."""
    short = runner.invoke(app, [*command, "-h"], env={"COLUMNS": "100"})
    assert short.exit_code == 0 and short.output == _help(command, 100)
