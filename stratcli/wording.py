"""Words for counts and legs in messages, tables, figures and reprs: one place says "1 leg",
"3 legs", "newton (continuation)" (no I/O)."""

from __future__ import annotations

__all__ = ["counted", "method_words"]


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """`n` and `noun`, plural unless `n` is 1: "1 task", "0 tasks", "2 tasks"; `plural` where
    it is not `noun` + "s" ("stratum", "strata"; "process", "processes")."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"


def method_words(method: str, strategy: str | None) -> str:
    """A leg's method as tables and figures name it: "newton"; "newton (continuation)" where
    the homotopy reached the leg's goal (`strategy` "continuation"), "newton (constrained)"
    where the constrained search over all legs planned it (`strategy` "constrained")."""
    return method + (f" ({strategy})" if strategy in ("continuation", "constrained") else "")
