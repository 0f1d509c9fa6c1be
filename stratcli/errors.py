"""Exception hierarchy: each maps to one exit code of the command line."""

from __future__ import annotations

from dataclasses import dataclass, replace


@dataclass(frozen=True)
class Problem:
    """One problem in an input file or argument: where it is and what is wrong.

    `path` is a field's dotted path, or a use case's Python argument (the command line shows
    its flag instead: `cli.render.flagged`). For an argument, `given` is its value, shown as
    ``out='sweeps/x': ...`` (``--out sweeps/x: ...`` on the command line), and
    `flag_message`, if set, is the message as the command line words it where it names
    other arguments (``add --resume``, where Python reads ``add resume=True``).
    """

    path: str
    message: str
    given: str | None = None
    flag_message: str | None = None

    def render(self, source: str | None = None) -> str:
        """The problem as one line, ``source: path: message``.

        Parameters
        ----------
        source : str, optional
            The file or argument it is in, put first.

        Returns
        -------
        str
        """
        where = f"{source}: " if source else ""
        head = self.path if self.given is None else f"{self.path}={self.given!r}"
        return f"{where}{head}: {self.message}" if head else f"{where}{self.message}"


class StratplanError(Exception):
    """Base class of all errors stratplan reports to users."""


class InputError(StratplanError, ValueError):
    """Bad input (scenario file, model definition, command-line value, or the value of a
    public function's argument: `stratcli.arguments`); exit code 2."""

    def __init__(self, problems: list[Problem] | str, source: str | None = None):
        if isinstance(problems, str):
            problems = [Problem("", problems)]
        self.problems = list(problems)
        self.source = source
        super().__init__("\n".join(p.render(source) for p in self.problems))

    def with_source(self, source: str) -> InputError:
        """The same problems, in `source` (a file name, shown before each).

        Parameters
        ----------
        source : str
            Where the input came from.

        Returns
        -------
        InputError
        """
        return InputError(self.problems, source)

    def prefixed(self, prefix: str) -> InputError:
        """The same problems, with `prefix` put in front of every field path.

        Parameters
        ----------
        prefix : str
            A dotted path (e.g. "legs[1]").

        Returns
        -------
        InputError
        """
        return InputError(
            [replace(p, path=f"{prefix}.{p.path}" if p.path else prefix) for p in self.problems],
            self.source,
        )


class ModelError(InputError):
    """A model definition that cannot be used (bad expression, inconsistent stratum)."""


class NotControllableError(StratplanError):
    """A leg's stratum cannot steer what the leg asks for (Lie brackets, paper eq. 4); exit 3.

    `problems` holds one sentence per failure, naming stratum and configuration.
    """

    def __init__(self, problems: list[str], source: str | None = None):
        self.problems = list(problems)
        self.source = source
        super().__init__("\n".join(self.problems))


class RecordError(StratplanError, OSError):
    """A run record that could not be written (disk full, permissions, a name the file system
    refuses); nothing complete-looking is left behind."""


class IllConditionedWarning(UserWarning):
    """A leg the controllability check expects to be ill-conditioned, and what to try instead:
    `stratcli.plan` warns with it (the command line prints it as `warning: ...`)."""


class LimitWarning(UserWarning):
    """A limit or angle that looks mistaken, planned as written: degrees written as numbers,
    joint limits wider than a URDF's own (`stratcli.plan` warns with it; the command line
    prints it as `warning: ...`)."""


class UnusedLegsWarning(UserWarning):
    """A scenario's [[legs]] that a call does not use: `decompose`, `compare_sequences` and
    `plan_auto` decompose its task.start -> task.goal afresh (the command line prints it as
    `note: ...`)."""
