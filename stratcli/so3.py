"""The rotation group SO(3): exponential and logarithm, their Jacobians, quaternions, RPY.

Conventions: a rotation `R` maps base-frame vectors to world-frame vectors; its
rotation vector `φ = log(R)` (rad, world frame) has `R = exp([φ]×)`. Quaternions are
`(w, x, y, z)` with `w ≥ 0`. Roll-pitch-yaw `(r, p, y)` follows URDF/ROS:
`R = Rz(y) Ry(p) Rx(r)` (fixed axes x, then y, then z). The right Jacobian `J_r(φ)` relates
`exp(φ + δ) = exp(φ) exp(J_r(φ) δ)`; `J_r⁻¹` turns a body-frame perturbation of `R` into
one of its rotation vector. Everything is vectorised over leading axes and pure numpy.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "cross",
    "exp",
    "hat",
    "log",
    "matrix_from_quaternion",
    "orthogonality_error",
    "quaternion_from_matrix",
    "right_jacobian",
    "right_jacobian_inverse",
    "rpy_to_matrix",
]

_SMALL = 1e-4  # below this angle the series expansions are used (error < 1e-17)
_EYE = np.eye(3)
_EYE.setflags(write=False)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """`a × b` over the last axis (length 3): the products and differences of `np.cross`,
    in the same order (the same bits), without its axis juggling (costly on small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def hat(v: np.ndarray) -> np.ndarray:
    """`[v]×` with shape (..., 3, 3) for v of shape (..., 3)."""
    v = np.asarray(v, dtype=float)
    out = np.zeros((*v.shape[:-1], 3, 3))
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    out[..., 0, 1], out[..., 0, 2] = -z, y
    out[..., 1, 0], out[..., 1, 2] = z, -x
    out[..., 2, 0], out[..., 2, 1] = -y, x
    return out


def _norm(v: np.ndarray) -> np.ndarray:
    """`np.linalg.norm(v, axis=-1)` for real v: its arithmetic, without its dispatch."""
    return np.sqrt(np.add.reduce(v * v, axis=-1))


def _coefficients(theta: np.ndarray, wanted: str = "abc"):
    """sin θ / θ, (1 − cos θ)/θ², (θ − sin θ)/θ³ with series below `_SMALL` (those in
    `wanted`, None for the others)."""
    small = theta < _SMALL
    if not small.any():  # the same values as the general case below, fewer operations
        t = theta
        a = np.sin(t) / t if "a" in wanted else None
        b = (1 - np.cos(t)) / (t * t) if "b" in wanted else None
        c = (t - np.sin(t)) / (t * t * t) if "c" in wanted else None
        return np.asarray(a), np.asarray(b), np.asarray(c)
    t = np.where(small, 1.0, theta)
    t2 = theta * theta
    a = np.where(small, 1 - t2 / 6 + t2 * t2 / 120, np.sin(t) / t)
    b = np.where(small, 0.5 - t2 / 24 + t2 * t2 / 720, (1 - np.cos(t)) / (t * t))
    c = np.where(small, 1 / 6 - t2 / 120 + t2 * t2 / 5040, (t - np.sin(t)) / (t * t * t))
    return a, b, c


def exp(phi: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of rotation vectors (..., 3) (Rodrigues)."""
    phi = np.asarray(phi, dtype=float)
    K = hat(phi)
    a, b, _ = _coefficients(_norm(phi), "ab")
    return _EYE + a[..., None, None] * K + b[..., None, None] * (K @ K)


def log(R: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3), |φ| ≤ π, of rotation matrices (..., 3, 3).

    Through the quaternion, which is accurate at every angle (also near 0 and π).
    """
    q = quaternion_from_matrix(R)
    w, v = q[..., 0], q[..., 1:]
    s = _norm(v)
    angle = 2.0 * np.arctan2(s, w)  # w ≥ 0: angle in [0, π]
    scale = np.where(s < 1e-12, 2.0 / np.where(w == 0, 1.0, w), angle / np.where(s == 0, 1, s))
    return v * scale[..., None]


def right_jacobian(phi: np.ndarray) -> np.ndarray:
    """`J_r(φ) = I − (1 − cos θ)/θ² [φ]× + (θ − sin θ)/θ³ [φ]×²`, shape (..., 3, 3)."""
    phi = np.asarray(phi, dtype=float)
    K = hat(phi)
    _, b, c = _coefficients(_norm(phi), "bc")
    return _EYE - b[..., None, None] * K + c[..., None, None] * (K @ K)


def right_jacobian_inverse(phi: np.ndarray) -> np.ndarray:
    """`J_r⁻¹(φ) = I + [φ]×/2 + (1/θ² − (1 + cos θ)/(2θ sin θ)) [φ]×²` (|φ| < 2π)."""
    phi = np.asarray(phi, dtype=float)
    K = hat(phi)
    theta = _norm(phi)
    small = theta < _SMALL
    t = np.where(small, 1.0, theta)
    t2 = theta * theta
    d = np.where(
        small,
        1 / 12 + t2 / 720 + t2 * t2 / 30240,
        1 / (t * t) - (1 + np.cos(t)) / (2 * t * np.sin(t)),
    )
    return _EYE + 0.5 * K + d[..., None, None] * (K @ K)


def quaternion_from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternions (w, x, y, z), w ≥ 0, of rotation matrices (..., 3, 3).

    Shepperd's method: the largest of the four candidate divisors is used at each point.
    """
    R = np.asarray(R, dtype=float)
    lead = R.shape[:-2]
    M = R.reshape(-1, 3, 3)
    tr = np.trace(M, axis1=1, axis2=2)
    q = _shepperd_few(M, tr) if M.shape[0] <= 8 else _shepperd_many(M, tr)
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return q.reshape(*lead, 4)


def _shepperd_many(M: np.ndarray, tr: np.ndarray) -> np.ndarray:
    """Shepperd's quaternions (unnormalised) of matrices (n, 3, 3), vectorised per case."""
    d = (M[:, 0, 0], M[:, 1, 1], M[:, 2, 2])
    k = np.argmax(np.stack([tr, *d], axis=1), axis=1)
    q = np.empty((M.shape[0], 4))
    with np.errstate(divide="ignore", invalid="ignore"):  # in the branches not taken
        pick = k == 0
        if pick.any():
            m = M[pick]
            s = 2.0 * np.sqrt(np.maximum(1.0 + tr[pick], 0.0))
            q[pick, 0] = s / 4
            q[pick, 1] = (m[:, 2, 1] - m[:, 1, 2]) / s
            q[pick, 2] = (m[:, 0, 2] - m[:, 2, 0]) / s
            q[pick, 3] = (m[:, 1, 0] - m[:, 0, 1]) / s
        for a in range(3):
            pick = k == a + 1
            if not pick.any():
                continue
            m = M[pick]
            b, c = (a + 1) % 3, (a + 2) % 3
            s = 2.0 * np.sqrt(np.maximum(1.0 + m[:, a, a] - m[:, b, b] - m[:, c, c], 0.0))
            q[pick, 0] = (m[:, c, b] - m[:, b, c]) / s
            q[pick, 1 + a] = s / 4
            q[pick, 1 + b] = (m[:, b, a] + m[:, a, b]) / s
            q[pick, 1 + c] = (m[:, c, a] + m[:, a, c]) / s
    return q


def _shepperd_few(M: np.ndarray, tr: np.ndarray) -> np.ndarray:
    """The same arithmetic on Python floats: faster for a few matrices."""
    q = np.empty((M.shape[0], 4))
    for i, (m, t) in enumerate(zip(M.tolist(), tr.tolist(), strict=True)):
        k = max(range(4), key=[t, m[0][0], m[1][1], m[2][2]].__getitem__)
        if k == 0:
            s = 2.0 * math.sqrt(max(1.0 + t, 0.0))
            x, y, z = m[2][1] - m[1][2], m[0][2] - m[2][0], m[1][0] - m[0][1]
            q[i] = (s / 4, x / s, y / s, z / s)
        else:
            a = k - 1
            b, c = (a + 1) % 3, (a + 2) % 3
            s = 2.0 * math.sqrt(max(1.0 + m[a][a] - m[b][b] - m[c][c], 0.0))
            v = [0.0, 0.0, 0.0]
            v[a] = s / 4
            v[b] = (m[b][a] + m[a][b]) / s
            v[c] = (m[c][a] + m[a][c]) / s
            q[i] = ((m[c][b] - m[b][c]) / s, *v)
    return q


def matrix_from_quaternion(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of quaternions (w, x, y, z) (normalised first)."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    rows = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    return np.moveaxis(np.array(rows), (0, 1), (-2, -1))


def rpy_to_matrix(rpy: np.ndarray) -> np.ndarray:
    """`Rz(yaw) Ry(pitch) Rx(roll)` for (roll, pitch, yaw) in rad (URDF's convention)."""
    r, p, y = (float(v) for v in rpy)
    return exp([0.0, 0.0, y]) @ exp([0.0, p, 0.0]) @ exp([r, 0.0, 0.0])


def orthogonality_error(R: np.ndarray) -> float:
    """max ‖RᵀR − I‖ (Frobenius) over the leading axes."""
    R = np.asarray(R, dtype=float)
    E = np.swapaxes(R, -1, -2) @ R - np.eye(3)
    return float(np.linalg.norm(E, axis=(-2, -1)).max(initial=0.0))
