"""Words for counts and legs in messages, tables, figures and reprs: one place says "1 leg",
"3 legs", "newton (continuation)", the choice a misspelt word meant (no I/O)."""

from __future__ import annotations

import difflib

__all__ = ["closest_choice", "counted", "either", "method_words"]


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """`n` and `noun`, plural unless `n` is 1: "1 task", "0 tasks", "2 tasks"; `plural` where
    it is not `noun` + "s" ("stratum", "strata"; "process", "processes")."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"


def method_words(method: str, strategy: str | None) -> str:
    """A leg's method as tables and figures name it: "newton"; "newton (continuation)" where
    the homotopy reached the leg's goal (`strategy` "continuation"), "newton (constrained)"
    where the constrained search over all legs planned it (`strategy` "constrained")."""
    return method + (f" ({strategy})" if strategy in ("continuation", "constrained") else "")


def closest_choice(got: str, choices, cutoff: float = 0.75) -> str | None:
    """The choice `got` most likely meant: the same letters in another case ('Newton'), the
    same letters in another order ('lei', 'rl-C1': difflib offered 'l-C1'), else a close
    spelling ('optimize', difflib's ratio at least `cutoff`); None when none is close."""
    choices = list(choices)
    near = [c for c in choices if c.lower() == got.lower()]
    near = near or [c for c in choices if sorted(c.lower()) == sorted(got.lower())]
    near = near or difflib.get_close_matches(got, choices, n=1, cutoff=cutoff)
    return near[0] if near else None


def either(words) -> str:
    """ "a", "a or b", "a, b or c": the choices a message offers."""
    words = tuple(words)
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} or {words[-1]}"
