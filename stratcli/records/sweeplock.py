"""One writer per sweep directory: a second sweep (or `--resume`) into a directory that a
running sweep is writing is refused, not run beside it (both would plan the same tasks and
append each row twice).

The claim is a file `OUT/.writer` holding `<pid>@<host tag>` (as the run directories' partial
names, `rundir`), created whole with `os.link` so that no reader sees it empty. A claim whose
process on this host is dead (a killed sweep) is taken over; one from another host cannot be
checked, and the refusal says which file to remove if no sweep is running there.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import InputError, Problem
from .rundir import _alive, _host_tag

CLAIM = ".writer"


def _holder(claim: Path) -> str | None:
    """Who holds `claim` (`pid@host`), or None when nobody can: gone, garbled, or a dead
    process of this host."""
    try:
        text = claim.read_text().strip()
    except OSError:
        return None
    pid, _, host = text.partition("@")
    if not pid.isdigit() or not host:
        return None
    if host == _host_tag() and not _alive(int(pid)):
        return None
    return text


def _refusal(out: Path, holder: str, claim: Path) -> InputError:
    pid, _, host = holder.partition("@")
    who = f"process {pid}" if host == _host_tag() else f"process {pid} on another host"
    why = f"another sweep is writing into it ({who}); wait for it to finish, or choose another "
    unless = "" if host == _host_tag() else f" (if none is, remove {claim})"
    return InputError(
        [Problem("out", why + "out" + unless, given=str(out), flag_message=why + "--out" + unless)]
    )


def _take(out: Path) -> Path | None:
    """Claim `out`: the claim file, or None where it cannot be made (the directory is not
    writable: `sweepdir.prepare` says so, or it is only read)."""
    claim = out / CLAIM
    draft = out / f".writer.{os.getpid()}.tmp"
    try:
        draft.write_text(f"{os.getpid()}@{_host_tag()}\n")
    except OSError:
        return None
    try:
        for _ in range(3):
            try:
                os.link(draft, claim)  # fails if a claim exists: created whole, atomically
                return claim
            except FileExistsError:
                if (holder := _holder(claim)) is not None:
                    raise _refusal(out, holder, claim) from None
                claim.unlink(missing_ok=True)  # a killed sweep's: taken over
            except OSError:
                return None
        return None
    finally:
        draft.unlink(missing_ok=True)


@contextmanager
def claimed(out: Path) -> Iterator[None]:
    """Hold the sweep directory `out` (created if missing) while the block runs.

    Raises
    ------
    InputError
        Another sweep's process is writing into `out`.
    """
    out = Path(out)
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError:
        claim = None  # `sweepdir.prepare` says why `out` cannot be used
    else:
        claim = _take(out) if out.is_dir() else None
    try:
        yield
    finally:
        if claim is not None:
            claim.unlink(missing_ok=True)
        if created:
            try:
                out.rmdir()  # made here and left empty: nothing was written
            except OSError:
                pass
