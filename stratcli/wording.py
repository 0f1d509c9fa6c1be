"""Words for counts in messages, tables and reprs: one place says "1 leg", "3 legs" (no I/O)."""

from __future__ import annotations

__all__ = ["counted"]


def counted(n: int, noun: str) -> str:
    """`n` and `noun`, plural (an "s") unless `n` is 1: "1 task", "0 tasks", "2 tasks"."""
    return f"{n} {noun}" + ("" if n == 1 else "s")
