"""Command-line usage errors (a bad option value, an unknown option) as one `error:` line.

Click and typer check the options' types, ranges and choices before a command runs; left to
themselves they print a usage line and a boxed panel. Here every such error becomes the line
the rest of stratplan prints for bad input, naming the option and the value given:
`error: --time-scale: must be from 0.001 to 1000 (got 0)`, exit 2.
"""

from __future__ import annotations

import types
import typing
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import typer

from ..wording import either

try:  # recent typer runs its own copy of click, and raises its exceptions
    from typer._click import exceptions as _click
except ImportError:  # older typer: click itself
    from click import exceptions as _click

UsageError = _click.UsageError
# `stratplan` alone: the help (raised since click 8.2; before, printed without an exception)
NoArgsIsHelpError = getattr(_click, "NoArgsIsHelpError", ())

_RANGE_ERRORS = {"greater_than", "greater_than_equal", "less_than", "less_than_equal"}


@contextmanager
def one_line() -> Iterator[None]:
    """Turn a click usage error raised inside into one `error:` line on stderr and exit 2
    (`stratplan` alone still prints its help)."""
    try:
        yield
    except NoArgsIsHelpError:
        raise
    except UsageError as exc:
        from . import render  # start-up speed: rich loads only for an error

        render.error("error", describe(exc))
        raise typer.Exit(2) from None


def describe(exc: UsageError) -> str:
    """The line for `exc`, without its `error: ` label."""
    see = f" (see {exc.ctx.command_path} --help)" if exc.ctx is not None else ""
    if isinstance(exc, _click.MissingParameter) and exc.param is not None:
        return f"{_name(exc.param)}: missing{see}"
    if isinstance(exc, _click.BadParameter) and exc.param is not None:
        return _bad_value(exc)
    if isinstance(exc, _click.NoSuchOption):  # click compares with the dashes: --bogus, --out
        close = ", ".join(sorted(p for p in exc.possibilities or () if _near(exc.option_name, p)))
        return f"{exc.option_name}: no such option" + (
            f" (did you mean {close}?)" if close else see
        )
    message = _sentence(exc.message).removeprefix("got ")  # unexpected extra argument(s)
    if isinstance(exc, _click.BadOptionUsage):
        message = message.removeprefix(f"option {exc.option_name!r} ")
        return f"{exc.option_name}: {message}"
    first, _, then = message.partition(". ")  # "No such command 'x'. Did you mean 'y'?"
    return f"{first} ({_sentence(then)})" if then else f"{message}{see}"


def _near(given: str, option: str) -> bool:
    """Whether `option` is a likely meaning of `given`, compared without their dashes."""
    from difflib import SequenceMatcher

    return SequenceMatcher(None, given.lstrip("-"), option.lstrip("-")).ratio() >= 0.6


def _bad_value(exc: _click.BadParameter) -> str:
    """`--option: must be ... (got VALUE)` from the parameter's declared type and range."""
    param = exc.param
    detail = _validation_error(exc)
    kind = detail.get("type", "")
    given = f" (got {_shown(detail['input'])})" if "input" in detail else ""
    choices = _choices(param)
    if choices:
        must = "must be " + either(choices)
        if given and isinstance(detail["input"], str):  # `--records bets`: 'best'
            from ..wording import closest_choice

            near = closest_choice(detail["input"], choices)
            given = f"{given[:-1]}: did you mean {near!r}?)" if near else given
    elif kind in _RANGE_ERRORS or kind.endswith("_parsing") or kind == "int_from_float":
        words = [] if kind in _RANGE_ERRORS else ["a whole number" if "int" in kind else "a number"]
        must = " ".join(["must be", *words, _range(param)]).rstrip()
    else:
        must = _sentence(detail.get("msg") or exc.message).removeprefix("value error, ")
    return f"{_name(param)}: {must}{given}"


def _validation_error(exc: _click.BadParameter) -> dict[str, Any]:
    """The first pydantic error behind `exc` (typer validates values with pydantic), or {}."""
    errors = getattr(exc.__cause__, "errors", None)
    if errors is None:
        return {}
    found = errors()
    return dict(found[0]) if found else {}


def _range(param) -> str:
    """`from 1 to 8`, `at least 1`, `at most 3`, or "" for a parameter without bounds."""
    low, high = getattr(param, "min", None), getattr(param, "max", None)
    if low is not None and high is not None:
        return f"from {low:g} to {high:g}"
    if low is not None:
        return f"at least {low:g}"
    return f"at most {high:g}" if high is not None else ""


def _annotation(param) -> Any:
    """The parameter's declared type (X of `X | None`)."""
    descriptor = getattr(param, "type_descriptor", None)
    annotation = getattr(descriptor, "annotation", None)
    args = [a for a in typing.get_args(annotation) if a is not type(None)]
    if typing.get_origin(annotation) in (typing.Union, types.UnionType) and len(args) == 1:
        return args[0]
    return annotation


def _choices(param) -> tuple[str, ...]:
    annotation = _annotation(param)
    if typing.get_origin(annotation) is typing.Literal:
        return tuple(str(a) for a in typing.get_args(annotation))
    return ()


def _name(param) -> str:
    """An option's long name (`--time-scale`), an argument's metavar (`FILE`)."""
    if getattr(param, "param_type_name", "") == "option":
        longs = [o for o in param.opts if o.startswith("--")]
        return (longs or param.opts)[0]
    return param.metavar or param.name.upper()


def _shown(value: Any) -> str:
    """A number as typed (`0`), anything else quoted (`'jpg'`)."""
    if isinstance(value, str):
        try:
            float(value)
        except ValueError:
            return repr(value)
        return value
    return repr(value)


def _sentence(message: str) -> str:
    """Click's message as a clause: lower-case start, no final full stop."""
    message = message.strip().rstrip(".")
    return message[:1].lower() + message[1:]
