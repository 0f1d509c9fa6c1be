"""How a leg or a plan ended: an enumeration whose values are what the user should read.

In the style of diffrax's `RESULTS`: every failure is a value, not an exception, and its
message says what to try. `result.json` stores the member's name in lower case
(`"not_converged"`), the CLI prints the sentence.
"""

from __future__ import annotations

import enum

__all__ = ["Status", "UnknownStatus"]


class Status(enum.Enum):
    """Outcome of a leg (and, by its worst leg, of a plan).

    The value of each member is an actionable message; `describe` adds the leg's numbers.
    """

    SUCCESS = "reached its goal"
    NOT_CONVERGED = (
        "did not reach its goal; try more harmonics (planner.basis.harmonics), a longer leg, "
        "a via configuration closer to the start, or other strata (stratplan "
        "compare-sequences, or auto mode: a [decompose] table instead of [[legs]])"
    )
    LIE_NOT_CONVERGED = (
        "did not reach its goal; try a smaller lie.gamma, "
        "lie.degree = 3, more lie.max_steps, a goal closer to the start (the method is "
        'local), or method = "newton"'
    )
    NUMERICAL_FAILURE = (
        "stopped by a numerical failure (overflow, a singular matrix or a failed "
        "integration); check the model's parameters and expressions, or try a via "
        "configuration closer to the start"
    )
    DIVERGED = (
        "was abandoned: the search diverged; the stratum is weak for this displacement: try "
        "another stratum, a via configuration closer to the start, or auto mode"
    )
    NOT_PLANNED = "was not planned: an earlier leg failed"
    CONSTRAINT_VIOLATED = (
        "reached its goals but violates a limit of [constraints]; try via configurations that "
        "keep the robot away from the limit, another stratum sequence, more harmonics, or the "
        "other objective"
    )

    @property
    def ok(self) -> bool:
        """True for `SUCCESS` only."""
        return self is Status.SUCCESS

    @property
    def key(self) -> str:
        """The name used in result.json, e.g. ``"not_converged"``."""
        return self.name.lower()

    @classmethod
    def from_key(cls, key: str) -> Status:
        """The member named `key`.

        Parameters
        ----------
        key : str
            As `key` writes it (result.json's leg status, e.g. "not_converged").

        Returns
        -------
        Status

        Raises
        ------
        KeyError
            No member has that name (the message lists those that have).
        """
        try:
            return cls[str(key).upper()]
        except KeyError:
            keys = ", ".join(member.key for member in cls)
            raise UnknownStatus(f"{key!r} is not a status: one of {keys}") from None


class UnknownStatus(KeyError):
    """`Status.from_key` of a name no status has: a KeyError whose message reads as written
    (a KeyError's own is quoted again: `"'sucess' is not a status ..."`)."""

    def __str__(self) -> str:
        return str(self.args[0])
