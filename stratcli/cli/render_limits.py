"""The [constraints] lines of a plan's summary (`render_plan`): the limits the table asks for
(`limits_asked`) and the smallest margin to each per leg (`limit_margins`), from result.json."""

from __future__ import annotations

from ..wording import counted

__all__ = ["broken", "limit_margins", "limits_asked"]

MARGINS = (  # result.json's per-leg margins: (key, label, unit)
    ("joint_limit", "joints", " rad"),
    ("self_clearance", "self-clearance", ""),
    ("obstacle_clearance", "obstacles", ""),
    ("rate", "rate", " rad/s"),
    ("acceleration", "acceleration", " rad/s²"),
)


def limit_margins(report: dict | None) -> str:
    """One line of the smallest margin to each limit per leg (result.json's `constraints`),
    negative where a limit is broken; "" without a [constraints] report."""
    if not report or not report.get("legs"):
        return ""
    legs = []
    for i, margins in enumerate(report["legs"]):
        found = [  # a limit met exactly (rate limits, by slowing down) as 0, not -5.55e-16:
            f"{label} {_met(margins[key]):.3g}{unit}"  # within the tolerance of the check
            for key, label, unit in MARGINS
            if margins.get(key) is not None
        ]
        legs.append(f"leg {i + 1}: {', '.join(found) or 'none limited'}")
    if not any(m.get(key) is not None for m in report["legs"] for key, _, _ in MARGINS):
        return ""  # an empty [constraints] table: no margin to show
    samples = report.get("samples_per_leg")
    clearance = (report.get("spec") or {}).get("clearance")
    measured = any(
        m.get(k) is not None
        for m in report["legs"]
        for k in ("self_clearance", "obstacle_clearance")
    )
    beyond = f"; clearances beyond the {clearance:g} asked" if measured and clearance else ""
    head = f"smallest margins to the limits ({samples} re-integrated samples a leg{beyond}): "
    return head + "; ".join(legs)


def limits_asked(report: dict | None, urdf: bool = False) -> str:
    """One line of the limits a plan was held to (result.json's `constraints.spec`), so that
    the margins beside it can be read without the scenario; "" without a [constraints] report.
    `urdf`: a URDF robot's, whose joints the table does not name keep the URDF's limits."""
    spec = (report or {}).get("spec")
    if not spec or not report.get("legs"):
        return ""
    parts = []
    joints = spec.get("joint_limits")
    others = "the other joints within the URDF's" if urdf else ""
    if _is_pair(joints):
        parts.append(f"joints within [{joints[0]:g}, {joints[1]:g}] rad")
    elif isinstance(joints, dict) and all(_is_pair(v) for v in joints.values()):
        named = ", ".join(f"{k} within [{v[0]:g}, {v[1]:g}] rad" for k, v in joints.items())
        parts.append(f"{named}{' (the table), ' + others if others else ''}")
    elif joints:
        parts.append("joints within their own limits (the table's, per joint)")
    elif urdf and any(m.get("joint_limit") is not None for m in report["legs"]):
        parts.append("joints within the URDF's limits")
    elif any(m.get("joint_limit") is not None for m in report["legs"]):
        parts.append("joints within their own limits")
    bodies = (["itself"] if spec.get("self_collision") else []) + (
        [counted(len(spec["obstacles"]), "obstacle")] if spec.get("obstacles") else []
    )
    if bodies:
        parts.append(
            f"clearance {spec.get('clearance', 0):g} from {' and '.join(bodies)} (links as "
            f"capsules of radius {spec.get('link_radius', 0):g})"
        )
    for key, what, unit in (
        ("max_rate", "rate", "rad/s"),
        ("max_acceleration", "acceleration", "rad/s²"),
    ):
        value = spec.get(key)
        if isinstance(value, int | float):
            parts.append(f"{what} at most {value:g} {unit}")
        elif isinstance(value, dict) and value:  # by name: the others unlimited
            each = ", ".join(f"{name} {v:g}" for name, v in value.items())
            parts.append(f"{what} at most {each} {unit} (the table's; others unlimited)")
        elif value:  # ("within its per-joint limits" read as a URDF's velocity limits)
            each = ", ".join(f"{v:g}" for v in value)
            parts.append(f"{what} at most {each} {unit}, input by input (the table's)")
    return "limits: " + ("; ".join(parts) if parts else "none (the [constraints] table sets none)")


def _is_pair(value) -> bool:
    return (
        isinstance(value, list | tuple)
        and len(value) == 2
        and all(isinstance(v, int | float) for v in value)
    )


VIOLATED = -1e-9  # a margin below this breaks its limit (`constraints.VIOLATION_TOL`)


def broken(margins: dict) -> bool:
    """Whether a leg's margins (result.json's `constraints.legs[i]`) break a limit."""
    return any(v < VIOLATED for v in margins.values() if v is not None)


def _met(margin: float) -> float:
    """`margin`, rounding error below zero shown as 0 (`VIOLATED`)."""
    return 0.0 if VIOLATED <= margin < 0 else margin
