"""Poses of a planar manipulator drawn in the inertial frame: its base, links and joints at
chosen samples of `trajectory.world_geometry`, as three batched collections (the stroboscope,
the GIF's ghosts, the closest approaches of `closest_marks`)."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.colors import to_rgb, to_rgba

__all__ = ["draw_poses", "segments"]


def segments(geo: dict[str, np.ndarray], idx: np.ndarray) -> np.ndarray:
    """Link segments of the samples idx, shape (len(idx) * k, 2, 2)."""
    seg = np.stack((geo["proximal"][idx], geo["distal"][idx]), axis=-2)
    return seg.reshape(-1, 2, 2)


def draw_poses(
    ax,
    geo: dict[str, np.ndarray],
    idx: np.ndarray,
    colors: list,
    lw: float,
    zorder: float,
    linestyle: str = "-",
    face: str | None = None,
    face_alpha: float = 0.5,
    edge_alpha: float = 1.0,
) -> None:
    """Draw the poses of samples `idx` (one colour each) as three batched collections."""
    idx = np.atleast_1d(idx)
    k = geo["proximal"].shape[1]
    faces = "none" if face is None else [(*to_rgb(face), face_alpha)] * idx.size
    ax.add_collection(
        PolyCollection(
            geo["base_corners"][idx],
            facecolors=faces,
            edgecolors=[(*to_rgb(c), edge_alpha) for c in colors],
            linewidths=lw * 0.6,
            linestyles=linestyle,
            zorder=zorder,
        )
    )
    ax.add_collection(
        LineCollection(
            segments(geo, idx),
            colors=np.repeat(np.asarray([to_rgba(c) for c in colors]), k, axis=0),
            linewidths=lw,
            linestyles=linestyle,
            zorder=zorder + 0.1,
            capstyle="round",
        )
    )
    joints = geo["proximal"][idx].reshape(-1, 2)
    ax.scatter(
        joints[:, 0],
        joints[:, 1],
        s=(lw + 1.2) ** 2,
        c=np.repeat(np.asarray([to_rgba(c) for c in colors]), k, axis=0),
        zorder=zorder + 0.2,
        linewidths=0,
    )
