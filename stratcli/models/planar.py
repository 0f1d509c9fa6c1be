"""Planar free-floating space manipulators described by physical parameters.

A robot is a rigid base (body 0) carrying serial arms of revolute joints. With zero total
momentum the system CM is fixed, and conservation of angular momentum gives the nonholonomic
constraint of the paper (sec. 3, eq. 5 and 10)::

    f_θ(q) θ' − Σ_j f_j(q) q_j' = 0,   i.e.   θ' = Σ_j A_j(q) q_j',   A_j = f_j / f_θ.

Everything is expressed in the base frame (origin at the base CM, rotated by θ). Joints are
numbered arm by arm: arm 1's joints first (q1, q2, ...), then arm 2's, and so on. Joint j is the
proximal joint of link j. The physics and sign conventions are given in docs/planar_model.md §1-2.

This module describes the robot (`Link`, `Arm`, `Base`, `PlanarManipulator`, the paper's
robots) and its vectorised base-frame kinematics (`link_geometry`). The connection A(q) and its
derivatives, numeric and symbolic, are computed in `connection`; with the robots
`paper_one_arm` and `paper_two_arm` they reproduce eq. 6 and eq. 11 exactly, up to the paper's
print scale 12·M.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

__all__ = [
    "Arm",
    "Base",
    "Link",
    "PlanarManipulator",
    "Structure",
    "kinematics",
    "link_geometry",
    "paper_one_arm",
    "paper_two_arm",
    "points_first",
    "points_last",
    "structure",
]


def _real(name: str, value: Any, *, positive: bool = False, nonneg: bool = False) -> float:
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if positive and not x > 0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    if nonneg and not x >= 0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return x


# --------------------------------------------------------------------------------------------
# Robot description
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Link:
    """A rigid link, the body distal to its (proximal) revolute joint.

    `com` is the distance of the link CM from the proximal joint, measured along the link. It
    defaults to `length / 2`. `inertia` is the moment of inertia about the link's own CM. It
    defaults to a uniform rod, `mass * length**2 / 12`. The paper's models use 1/3, which is not
    the rod value (docs/planar_model.md §5). Defaults are resolved at construction, so after
    construction both fields are always floats.
    """

    mass: float
    length: float
    com: float | None = None
    inertia: float | None = None

    def __post_init__(self) -> None:
        m = _real("Link.mass", self.mass, nonneg=True)
        length = _real("Link.length", self.length, nonneg=True)
        com = length / 2 if self.com is None else _real("Link.com", self.com)
        inertia = (
            m * length**2 / 12
            if self.inertia is None
            else _real("Link.inertia", self.inertia, nonneg=True)
        )
        object.__setattr__(self, "mass", m)
        object.__setattr__(self, "length", length)
        object.__setattr__(self, "com", com)
        object.__setattr__(self, "inertia", inertia)


@dataclass(frozen=True)
class Arm:
    """A serial arm attached to the base.

    * `mount` is the position of the arm's first joint in the base frame.
    * `zero_angle` (rad, base frame) is the direction of the first link when all of this arm's
      joints are zero.
    * `sense` (+1 or −1) is the direction in which the joints count. +1 is counter-clockwise.
      −1 gives the mirrored arm 2 of the paper's model 2.

    The orientation of link h relative to the base is
    `β_h = zero_angle + sense·(q_1 + … + q_h)`, where the q are this arm's joints
    (docs/planar_model.md §3).

    Attributes
    ----------
    mount : tuple of float
        (x, y) of the first joint in the base frame, m.
    zero_angle : float
        rad.
    sense : int
        +1 or −1.
    links : tuple of Link
        From the base out, one per joint.
    """

    mount: tuple[float, float]
    zero_angle: float
    sense: int
    links: tuple[Link, ...]

    def __post_init__(self) -> None:
        mount = tuple(_real("Arm.mount", x) for x in self.mount)
        if len(mount) != 2:
            raise ValueError(f"Arm.mount must have 2 coordinates, got {self.mount!r}")
        if self.sense not in (1, -1):
            raise ValueError(f"Arm.sense must be +1 or -1, got {self.sense!r}")
        links = tuple(self.links)
        if not links or not all(isinstance(link, Link) for link in links):
            raise ValueError("Arm.links must be a non-empty sequence of Link")
        object.__setattr__(self, "mount", mount)
        object.__setattr__(self, "zero_angle", _real("Arm.zero_angle", self.zero_angle))
        object.__setattr__(self, "sense", int(self.sense))
        object.__setattr__(self, "links", links)


@dataclass(frozen=True)
class Base:
    """The free-floating base (body 0).

    `inertia` is taken about the base CM, which is the origin of the base frame. `a` and `b` are
    the width and height of a rectangular base, optional: the base drawn and the body that
    `[constraints]` keeps the links and obstacles clear of (`geometry.base_extent`; without
    them, a square just reaching the mounts: docs/planar_model.md §6).

    Attributes
    ----------
    mass : float
        kg.
    inertia : float
        kg m², about the base CM.
    a, b : float or None
        The sides of the base rectangle, m (the one along the base's x axis is the one that
        puts the mounts on its boundary).
    """

    mass: float
    inertia: float
    a: float | None = None
    b: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "mass", _real("Base.mass", self.mass, positive=True))
        object.__setattr__(self, "inertia", _real("Base.inertia", self.inertia, nonneg=True))
        for name in ("a", "b"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _real(f"Base.{name}", value, nonneg=True))

    @classmethod
    def rectangle(cls, mass: float, a: float, b: float) -> Base:
        """A uniform a×b rectangle: I0 = m(a² + b²)/12 (docs/planar_model.md §2).

        Parameters
        ----------
        mass : float
            kg.
        a, b : float
            Side lengths, m.

        Returns
        -------
        Base
        """
        return cls(mass, mass * (a * a + b * b) / 12, a, b)


@dataclass(frozen=True)
class PlanarManipulator:
    """A base with one or more arms. Joints are numbered arm by arm, in the order of `arms`."""

    base: Base
    arms: tuple[Arm, ...]

    def __post_init__(self) -> None:
        arms = tuple(self.arms)
        if not arms or not all(isinstance(arm, Arm) for arm in arms):
            raise ValueError("PlanarManipulator.arms must be a non-empty sequence of Arm")
        object.__setattr__(self, "arms", arms)

    @property
    def n_joints(self) -> int:
        """Number of joints, which is also the number of links."""
        return sum(len(arm.links) for arm in self.arms)

    @property
    def links(self) -> tuple[Link, ...]:
        """All links in joint order."""
        return tuple(link for arm in self.arms for link in arm.links)

    @property
    def joint_arm(self) -> tuple[int, ...]:
        """Index (0-based) of the arm of each joint."""
        return tuple(a for a, arm in enumerate(self.arms) for _ in arm.links)

    @property
    def arm_joints(self) -> tuple[tuple[int, ...], ...]:
        """Joint indices (0-based) of each arm, from proximal to distal."""
        out, start = [], 0
        for arm in self.arms:
            out.append(tuple(range(start, start + len(arm.links))))
            start += len(arm.links)
        return tuple(out)

    @property
    def total_mass(self) -> float:
        """M = m0 + Σ m_i."""
        return self.base.mass + sum(link.mass for link in self.links)


# --------------------------------------------------------------------------------------------
# The paper's robots (docs/planar_model.md §2)
# --------------------------------------------------------------------------------------------


def _paper_link() -> Link:
    # Unit mass and length with CM at mid-length. The link inertia 1/3 is what the printed
    # coefficients require (docs/planar_model.md §4-5).
    return Link(mass=1.0, length=1.0, com=0.5, inertia=1.0 / 3.0)


def paper_one_arm() -> PlanarManipulator:
    """Model 1 (paper eq. 5-6): m0 = 10, a = 1, b = 0.6, three unit links.

    The first joint sits at b/2 = 0.3 on the base axis, the zero direction points outward and
    the joints count counter-clockwise. I0 = 17/15.
    """
    base = Base.rectangle(10.0, 1.0, 0.6)
    arm = Arm(mount=(0.3, 0.0), zero_angle=0.0, sense=1, links=(_paper_link(),) * 3)
    return PlanarManipulator(base, (arm,))


def paper_two_arm() -> PlanarManipulator:
    """Model 2 (paper eq. 10-11): m0 = 15, a = b = 1, two arms of two unit links.

    Arm 1 (q1, q2) is mounted at (+0.5, 0) with zero direction 0 and sense +1. Arm 2 (q3, q4)
    is its mirror image: mounted at (−0.5, 0) with zero direction π and sense −1. I0 = 5/2.
    """
    base = Base.rectangle(15.0, 1.0, 1.0)
    arm1 = Arm(mount=(0.5, 0.0), zero_angle=0.0, sense=1, links=(_paper_link(),) * 2)
    arm2 = Arm(mount=(-0.5, 0.0), zero_angle=math.pi, sense=-1, links=(_paper_link(),) * 2)
    return PlanarManipulator(base, (arm1, arm2))


# --------------------------------------------------------------------------------------------
# Numeric kinematics (docs/planar_model.md §3), vectorised over leading axes of q
# --------------------------------------------------------------------------------------------
# Internally every per-link quantity is stored with shape (n, K), or (n, n, K) for pairs, with
# the K evaluation points last. This makes numpy's inner loops long and contiguous; with the
# points first, broadcasting over (K, n, n) is about 10x slower. Vectors are split into x and y
# arrays.


@dataclass(frozen=True)
class Structure:
    """Per-link parameter arrays and distal masks, shaped for broadcasting against (n, K)."""

    m: np.ndarray  # (n,) link masses
    m_col: np.ndarray  # (n, 1)
    length: np.ndarray  # (n, 1)
    com: np.ndarray  # (n, 1) CM offset from the proximal joint
    s: np.ndarray  # (n, 1) sense of the joint's arm
    alpha: np.ndarray  # (n, 1) zero angle of the joint's arm
    mount_x: np.ndarray  # (n, 1) mount point of the joint's arm
    mount_y: np.ndarray  # (n, 1)
    D: np.ndarray  # (n, n) D[k, i] = 1 if link i is at or after joint k on the same arm
    DsT: np.ndarray  # (n, n) strictly distal mask, transposed: DsT[j, k] = [k proximal to j]
    Ds: np.ndarray  # (n, n) D − I: Ds @ x sums x over the joints strictly distal to each joint
    DI: np.ndarray  # (n, 1) Σ_{i ∈ D(j)} I_i
    mu: np.ndarray  # (n, 1) Σ_{i ∈ D(j)} m_i
    same: np.ndarray  # (n, n) 1 if joints j and k are on the same arm
    lower_same: np.ndarray  # (n, n) bool: j, k on one arm and k ≤ j (k at or before j)
    upper_same: np.ndarray  # (n, n) bool: j, k on one arm and k > j
    m0: float
    M: float
    sum_inertia: float  # I0 + Σ I_i


@lru_cache(maxsize=64)
def structure(robot: PlanarManipulator) -> Structure:
    links = robot.links
    n = len(links)
    arm_of = robot.joint_arm
    D = np.zeros((n, n))
    for joints in robot.arm_joints:
        for a, k in enumerate(joints):
            D[k, joints[a:]] = 1.0
    m = np.array([link.mass for link in links])
    inertia = np.array([link.inertia for link in links])
    s = np.array([float(robot.arms[a].sense) for a in arm_of])
    DsT = (D - np.eye(n)).T
    arm = np.array(arm_of)
    same = (arm[:, None] == arm[None, :]).astype(float)
    j, k = np.indices((n, n))

    def col(x: Any) -> np.ndarray:
        return np.asarray(x, dtype=float).reshape(n, 1)

    arrays = {
        "m": m,
        "m_col": col(m),
        "length": col([link.length for link in links]),
        "com": col([link.com for link in links]),
        "s": col(s),
        "alpha": col([robot.arms[a].zero_angle for a in arm_of]),
        "mount_x": col([robot.arms[a].mount[0] for a in arm_of]),
        "mount_y": col([robot.arms[a].mount[1] for a in arm_of]),
        "D": D,
        "DsT": DsT,
        "Ds": np.ascontiguousarray(DsT.T),
        "DI": col(D @ inertia),
        "mu": col(D @ m),
        "same": same,
        # joints are numbered proximal to distal on each arm
        "lower_same": (same > 0) & (j >= k),
        "upper_same": (same > 0) & (j < k),
    }
    for value in arrays.values():
        value.setflags(write=False)
    return Structure(
        **arrays,
        m0=robot.base.mass,
        M=robot.total_mass,
        sum_inertia=robot.base.inertia + float(inertia.sum()),
    )


def points_last(robot: PlanarManipulator, q: Any) -> tuple[np.ndarray, tuple[int, ...]]:
    """q of shape (..., n) -> array (n, K) and the leading shape."""
    q = np.asarray(q, dtype=float)
    if q.ndim == 0 or q.shape[-1] != robot.n_joints:
        raise ValueError(f"q must have shape (..., {robot.n_joints}), got {q.shape}")
    return np.ascontiguousarray(q.reshape(-1, q.shape[-1]).T), q.shape[:-1]


def points_first(x: np.ndarray, lead: tuple[int, ...]) -> np.ndarray:
    """Inverse of `points_last` for arrays (..., K) -> (lead..., ...), made contiguous."""
    return np.ascontiguousarray(np.moveaxis(x, -1, 0)).reshape(*lead, *x.shape[:-1])


def kinematics(st: Structure, q: np.ndarray):
    """Base-frame kinematics for q of shape (n, K): β, u(β), joints o and CMs p, each (n, K).

    β_i = α + s Σ_{k ≤ i} q_k,  o_i = P + Σ_{g < i} l_g u(β_g),  p_i = o_i + c_i u(β_i).
    """
    beta = st.alpha + st.s * (st.D.T @ q)
    ux, uy = np.cos(beta), np.sin(beta)
    ox = st.mount_x + st.DsT @ (st.length * ux)
    oy = st.mount_y + st.DsT @ (st.length * uy)
    return beta, (ux, uy), (ox, oy), (ox + st.com * ux, oy + st.com * uy)


def link_geometry(robot: PlanarManipulator, q: Any) -> dict[str, Any]:
    """Base-frame geometry for drawing and checks. q has shape (..., n).

    Keys:

    * `base_size`: `(a, b)` or `None`.
    * `mount`: `(n_arms, 2)`.
    * `arm_of_link`: `(n,)` int.
    * `proximal`, `distal`, `com`: joint and CM positions, `(..., n, 2)`.
    * `angle`: link orientation β relative to the base, `(..., n)`.
    * `system_com`: p_c, `(..., 2)`.

    The base CM is the origin. World coordinates (inertial frame at the fixed system CM) are
    `R(θ) (x − p_c)`.
    """
    st = structure(robot)
    qT, lead = points_last(robot, q)
    beta, (ux, uy), (ox, oy), (px, py) = kinematics(st, qT)
    base = robot.base

    def vec(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return points_first(np.stack((x, y), axis=-2), lead)

    return {
        "base_size": None if base.a is None or base.b is None else (base.a, base.b),
        "mount": np.array([arm.mount for arm in robot.arms], dtype=float),
        "arm_of_link": np.array(robot.joint_arm, dtype=int),
        "proximal": vec(ox, oy),
        "distal": vec(ox + st.length * ux, oy + st.length * uy),
        "com": vec(px, py),
        "angle": points_first(beta, lead),
        "system_com": vec(st.m @ px, st.m @ py) / st.M,
    }
