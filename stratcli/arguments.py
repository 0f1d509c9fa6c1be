"""Checks of the public API's arguments: one line naming the argument and what it may be,
raised before any work is done (stdlib only: the light use cases import it too).

One rule at every entry point: a value of the wrong Python type raises `TypeError` (nothing a
scenario file or the command line can produce: a programming mistake); a value of the right
type that is out of range or not one of the choices raises `InputError` (a `ValueError`),
the error the same value gets from a scenario file or a command-line flag, which the command
line turns into exit code 2. Both read ``name: must be ... (got value)``.

Use `checked` on a function (``@checked(check=flag, jobs=optional(integer(1)))``), or call a
rule directly: ``integer(2)("samples_per_leg", n)``.
"""

from __future__ import annotations

import functools
import inspect
import math
import numbers
import os
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

from .errors import InputError, Problem
from .wording import either

__all__ = [
    "checked",
    "choice",
    "flag",
    "instance",
    "integer",
    "number",
    "optional",
    "pathlike",
    "source",
]

Rule = Callable[[str, Any], None]  # rule(name, value): returns, or raises naming `name`
F = TypeVar("F", bound=Callable[..., Any])


def checked(**rules: Rule) -> Callable[[F], F]:
    """Decorate a public function: each named argument passes its rule before the call.

    A call that does not match the signature raises `TypeError` naming the function and its
    arguments (`signature.bind`'s message alone names neither); an argument left at its
    default is not checked (the default is right). A checked numpy scalar (``np.int64(2)``,
    ``np.float32(2)``) is passed on as Python's: it would otherwise reach the records, which
    JSON cannot write.
    """

    def decorate(func: F) -> F:
        signature = inspect.signature(func)
        unknown = set(rules) - set(signature.parameters)
        if unknown:  # a typo here would silently check nothing
            raise AssertionError(f"{func.__qualname__} has no argument {', '.join(unknown)}")

        @functools.wraps(func)
        def call(*args: Any, **kwargs: Any) -> Any:
            try:
                bound = signature.bind(*args, **kwargs)
            except TypeError as exc:  # "got an unexpected keyword argument 'x'": name the call
                takes = ", ".join(signature.parameters)
                hint = _settings_hint(str(exc)) if "scenario" in signature.parameters else ""
                raise TypeError(
                    f"{func.__name__}() {exc} ({func.__name__} takes {takes}{hint})"
                ) from None
            given = bound.arguments
            for name, rule in rules.items():
                if name in given:
                    rule(name, given[name])
                    given[name] = _python(given[name])
            return func(*bound.args, **bound.kwargs)

        return call  # type: ignore[return-value]

    return decorate


def _settings_hint(message: str) -> str:
    """For a use case taking a scenario and given an unknown keyword (`plan(task,
    tolerance=1e-4)`): where a scenario's own settings go instead."""
    if "unexpected keyword argument" not in message:
        return ""
    return (
        "; a scenario's own settings change with its with_changes, e.g. "
        "load_scenario(path).with_changes({'planner': {'tolerance': 1e-4}})"
    )


def _python(value: Any) -> Any:
    """A numpy scalar as the Python number or bool it stands for; anything else as it is."""
    if type(value).__module__ == "numpy" and getattr(value, "ndim", None) == 0:
        return value.item()
    return value


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else f"{text[:77]}..."


def wrong_type(name: str, what: str, value: Any) -> TypeError:
    """The TypeError of an argument `name` that must be `what`."""
    return TypeError(f"{name}: must be {what} (got {_shown(value)} of type {type(value).__name__})")


def bad_value(name: str, what: str, value: Any) -> InputError:
    """The InputError of an argument `name` whose value must be `what`."""
    return InputError([Problem(name, f"must be {what} (got {_shown(value)})")])


def _is_bool(value: Any) -> bool:
    if isinstance(value, bool):
        return True
    return type(value).__module__ == "numpy" and type(value).__name__ in ("bool", "bool_")


def flag(name: str, value: Any) -> None:
    """True or False (numpy's booleans too)."""
    if not _is_bool(value):
        raise wrong_type(name, "True or False", value)


def _bound(x: float) -> str:
    return str(x) if isinstance(x, int) else f"{x:g}"  # an integer's in full: seed's 2**63 - 1


def _range(low: float | None, high: float | None, above: bool) -> str:
    if low is not None and high is not None:
        return f"from {_bound(low)} to {_bound(high)}"
    if low is not None:
        return f"above {_bound(low)}" if above else f"of at least {_bound(low)}"
    return f"of at most {_bound(high)}" if high is not None else ""


def number(low: float | None = None, high: float | None = None, *, above: bool = False) -> Rule:
    """A finite real number (numpy's too) in [low, high]; `above`: strictly greater than low."""
    where = _range(low, high, above)

    def rule(name: str, value: Any) -> None:
        if _is_bool(value) or not isinstance(value, numbers.Real):
            raise wrong_type(name, f"a number{' ' + where if where else ''}", value)
        x = float(value)
        if (
            not math.isfinite(x)
            or (low is not None and (x <= low if above else x < low))
            or (high is not None and x > high)
        ):
            raise bad_value(name, f"a finite number{' ' + where if where else ''}", value)

    return rule


def integer(low: int | None = None, high: int | None = None) -> Rule:
    """An integer (numpy's too, not a bool) in [low, high]."""
    where = _range(low, high, False)

    def rule(name: str, value: Any) -> None:
        if _is_bool(value) or not isinstance(value, numbers.Integral):
            raise wrong_type(name, f"an integer{' ' + where if where else ''}", value)
        if (low is not None and value < low) or (high is not None and value > high):
            raise bad_value(name, f"an integer {where}", value)

    return rule


def choice(*options: str) -> Rule:
    """One of the strings `options`."""
    what = either(options)

    def rule(name: str, value: Any) -> None:
        if not isinstance(value, str):
            raise wrong_type(name, f"a string: {what}", value)
        if value not in options:
            from .wording import closest_choice  # (as the command line's options)

            near = closest_choice(value, options)  # peak_control for peak-control
            if near is None:
                raise bad_value(name, what, value)
            meant = f"must be {what} (got {_shown(value)}: did you mean {near!r}?)"
            raise InputError([Problem(name, meant)])

    return rule


def optional(inner: Rule) -> Rule:
    """None, or what `inner` accepts."""

    def rule(name: str, value: Any) -> None:
        if value is not None:
            inner(name, value)

    return rule


def _classes(types: tuple) -> tuple[type, ...]:
    """`types`, each a class or a function returning classes (called when a value is checked:
    classes of heavy modules are imported only then)."""
    out: list[type] = []
    for t in types:
        found = t if isinstance(t, type) else t()
        out.extend(found if isinstance(found, tuple) else (found,))
    return tuple(out)


def instance(what: str, *types: type | Callable[[], type | tuple[type, ...]]) -> Rule:
    """An instance of one of `types` (see `_classes`)."""

    def rule(name: str, value: Any) -> None:
        if not isinstance(value, _classes(types)):
            raise wrong_type(name, what, value)

    return rule


def pathlike(name: str, value: Any) -> None:
    """A file system path: str or os.PathLike."""
    if not isinstance(value, str | os.PathLike):
        raise wrong_type(name, "a path (str or pathlib.Path)", value)


def source(what: str, *loaded: type | Callable[[], type | tuple[type, ...]]) -> Rule:
    """What `load_scenario` takes (a path, TOML text or a dict), or an instance of `loaded`
    (the value already loaded); `what` names the file kind in the message."""

    def rule(name: str, value: Any) -> None:
        classes = _classes(loaded)
        if not isinstance(value, (str, os.PathLike, Mapping, *classes)):
            names = "".join(f"a {c.__name__}, " for c in classes)
            raise wrong_type(name, f"{names}a {what} path, TOML text or a dict", value)

    return rule
