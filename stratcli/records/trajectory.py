"""Geometry of planar manipulators for plots and the MCAP log: `models.geometry` and the
samples of `stratcli.simulate`, re-exported where the record writers look for them."""

from __future__ import annotations

from ..models.geometry import base_extent, world_geometry
from ..simulate import Trajectory, sample

__all__ = ["Trajectory", "base_extent", "sample", "world_geometry"]
