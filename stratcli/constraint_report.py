"""What a plan met of its [constraints] table: each leg's smallest margins to every limit on
a dense re-integration, and the first violation (result.json's `constraints`). Frozen values,
their JSON parts read-only (`frozen_json`); no I/O."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

from .frozen_json import HoldsDocument
from .results import finite_or_none

__all__ = ["MARGINS", "ConstraintReport", "LegMargins"]

MARGINS = ("joint_limit", "rate", "acceleration", "self_clearance", "obstacle_clearance")


@dataclass(frozen=True)
class LegMargins:
    """Smallest margin of one leg to each limit on a dense re-integration (`constraints.verify`).

    Positive: inside the limit by that much; negative: violated. Joint limits in rad, rates
    in rad/s, accelerations in rad/s², clearances in the model's length unit (the distance
    between body surfaces less the required clearance). None where the limit is not set.
    """

    joint_limit: float | None = None
    rate: float | None = None
    acceleration: float | None = None
    self_clearance: float | None = None
    obstacle_clearance: float | None = None

    def to_dict(self) -> dict[str, float | None]:
        """`{limit: margin}` (None where the limit is not set)."""
        return {k: None if v is None else finite_or_none(v) for k, v in self.items()}

    def items(self):
        """(limit, margin) pairs in a fixed order."""
        return ((k, getattr(self, k)) for k in MARGINS)


@dataclass(frozen=True)
class ConstraintReport(HoldsDocument):
    """What the [constraints] table asked and what the plan met.

    Attributes
    ----------
    spec : the table as given (JSON-ready).
    legs : per leg, the smallest margins (`LegMargins`).
    samples_per_leg : re-integration samples per leg behind the margins.
    violated : empty when every margin is ≥ 0; else names the limit, the leg and the time.
    duration_set_by : the rate or acceleration limit that slowed the plan ("" if none did).
    violation : the first violation for scripts (None if none): `leg` (1-based; None for
        the budget), `limit`
        (a `LegMargins` key, or "total_duration": the budget of optimised durations, which
        the slowing to the rate limits broke), `what` (the limit named), `by` (how far past
        it), `t` (s).
    joint_limits : the joint limits verified, per coordinate that has one: `lower`,
        `upper` (None where unbounded) and `from` ("table": [constraints].joint_limits,
        "urdf": the URDF's, which a URDF robot's table need not repeat); {} in records
        made before this field.
    """

    _documents: ClassVar[tuple[str, ...]] = ("spec", "violation", "joint_limits")  # read-only

    spec: dict[str, Any]
    legs: tuple[LegMargins, ...] = ()
    samples_per_leg: int = 0
    violated: str = ""
    duration_set_by: str = ""
    violation: dict[str, Any] | None = None
    joint_limits: dict[str, dict[str, Any]] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """No limit is violated."""
        return not self.violated

    def to_dict(self) -> dict[str, Any]:
        """The result.json `constraints` object (margins per leg under `legs`)."""
        return {
            "spec": self.spec,
            "samples_per_leg": self.samples_per_leg,
            "violated": self.violated or None,
            "duration_set_by": self.duration_set_by or None,
            "violation": self.violation,
            "joint_limits": self.joint_limits,
            "legs": [m.to_dict() for m in self.legs],
        }

    @classmethod
    def from_dict(cls, doc: dict[str, Any]) -> ConstraintReport:
        """Read back what `to_dict` wrote."""
        return cls(
            spec=dict(doc.get("spec") or {}),
            legs=tuple(LegMargins(**{k: m.get(k) for k in MARGINS}) for m in doc.get("legs") or ()),
            samples_per_leg=int(doc.get("samples_per_leg") or 0),
            violated=doc.get("violated") or "",
            duration_set_by=doc.get("duration_set_by") or "",
            violation=doc.get("violation"),
            joint_limits=dict(doc.get("joint_limits") or {}),
        )
