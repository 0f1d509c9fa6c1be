"""Planar free-floating manipulators: the robot description and its validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stratcli.models.connection import (
    connection,
)
from stratcli.models.planar import (
    Arm,
    Base,
    Link,
    PlanarManipulator,
    paper_one_arm,
    paper_two_arm,
)


def test_paper_robot_parameters():
    r1, r2 = paper_one_arm(), paper_two_arm()
    assert r1.n_joints == 3 and r2.n_joints == 4
    assert r1.total_mass == 13 and r2.total_mass == 19
    assert r1.base.inertia == pytest.approx(17 / 15, abs=1e-15)
    assert r2.base.inertia == pytest.approx(5 / 2, abs=1e-15)
    assert (r1.base.a, r1.base.b) == (1.0, 0.6)
    assert r1.arms[0].mount == (0.3, 0.0)
    assert [(a.mount, a.zero_angle, a.sense) for a in r2.arms] == [
        ((0.5, 0.0), 0.0, 1),
        ((-0.5, 0.0), math.pi, -1),
    ]
    assert all((link.mass, link.length, link.com) == (1, 1, 0.5) for link in r1.links + r2.links)
    assert all(link.inertia == pytest.approx(1 / 3) for link in r1.links + r2.links)
    assert r2.arm_joints == ((0, 1), (2, 3))
    assert r2.joint_arm == (0, 0, 1, 1)


def test_link_defaults_and_validation():
    link = Link(2.0, 3.0)
    assert link.com == 1.5 and link.inertia == pytest.approx(2.0 * 9.0 / 12)
    assert Link(1, 1) == Link(1.0, 1.0, 0.5, 1 / 12)
    rect = Base.rectangle(12.0, 1.0, 2.0)
    assert rect.inertia == pytest.approx(5.0) and (rect.a, rect.b) == (1.0, 2.0)
    assert Base(3.0, 1.0).a is None
    arm = Arm([0.1, 0.2], 0.0, 1, [Link(1, 1)])  # lists are accepted and frozen to tuples
    assert arm.mount == (0.1, 0.2) and isinstance(arm.links, tuple)
    hash(PlanarManipulator(Base(1, 1), [arm]))
    with pytest.raises(ValueError):
        Arm((0, 0), 0.0, 0, (Link(1, 1),))
    with pytest.raises(ValueError):
        Arm((0, 0), 0.0, 1, ())
    with pytest.raises(ValueError):
        Link(-1.0, 1.0)
    with pytest.raises(ValueError):
        Base(0.0, 1.0)
    with pytest.raises(ValueError):
        connection(paper_one_arm(), np.zeros(4))
