"""Independent re-integration of a spatial plan's result.json, for tests.

The planner integrates the attitude with Magnus steps and reports rotation vectors; here every
leg is integrated again from the recorded start with scipy's `solve_ivp` (DOP853, rtol 1e-12)
on (joints, quaternion), renormalised, with the controls rebuilt from the documented basis and
the body rate `ξ = S_ω(q) u` from Pinocchio's centroidal map. `verify_spatial` checks every
promise of the document against it, attitudes compared on the group.
"""

from __future__ import annotations

import numpy as np
import pytest
from reintegrate import check_switches, controls
from scipy.integrate import solve_ivp

from stratcli import so3


def _quaternion_rate(quat, xi):
    w, x, y, z = quat
    return 0.5 * np.array(
        [
            -x * xi[0] - y * xi[1] - z * xi[2],
            w * xi[0] + y * xi[2] - z * xi[1],
            w * xi[1] + z * xi[0] - x * xi[2],
            w * xi[2] + x * xi[1] - y * xi[0],
        ]
    )


def reintegrate_spatial(doc: dict, robot) -> list[dict]:
    """Per leg: start and end joints, end rotation matrix, energy (scipy on (q, quaternion))."""
    inputs, k = doc["inputs"], robot.n_joints
    q = np.array(doc["start"][:k], dtype=float)
    quat = so3.quaternion_from_matrix(so3.exp(np.array(doc["start"][k:], dtype=float)))
    out = []
    for leg in doc["legs"]:
        start = q.copy()
        energy = 0.0
        for piece in leg["pieces"]:

            def rhs(t, y, piece=piece):
                u = controls(piece, inputs, t)
                S, _ = robot.connection(y[:k][None])
                xi = S[0, 3:] @ u
                return np.concatenate(
                    [u, _quaternion_rate(y[k:-1] / np.linalg.norm(y[k:-1]), xi), [u @ u]]
                )

            y0 = np.concatenate([q, quat, [0.0]])
            sol = solve_ivp(
                rhs, (0, piece["duration"]), y0, method="DOP853", rtol=1e-12, atol=1e-13
            )
            assert sol.success, sol.message
            q, quat = sol.y[:k, -1], sol.y[k:-1, -1] / np.linalg.norm(sol.y[k:-1, -1])
            energy += sol.y[-1, -1]
        out.append(
            {
                "start": start,
                "end": q.copy(),
                "R": so3.matrix_from_quaternion(quat),
                "energy": energy,
            }
        )
    return out


def verify_spatial(doc: dict, robot) -> None:
    """The result.json promises of a spatial plan, judged by `reintegrate_spatial`."""
    assert doc["status"] == "ok", doc["message"]
    tol, k = doc["tolerance"], robot.n_joints
    replay = reintegrate_spatial(doc, robot)
    previous = np.array(doc["start"], dtype=float)
    for i, (leg, again) in enumerate(zip(doc["legs"], replay, strict=True)):
        np.testing.assert_allclose(leg["start"], previous, atol=1e-9)
        goal = np.array([np.nan if g is None else g for g in leg["goal"]])
        locked = [doc["coordinates"].index(c) for c in leg["locked"]]
        joints = [j for j in range(k) if j not in locked and np.isfinite(goal[j])]
        residual = list(again["end"][joints] - goal[joints])
        if np.all(np.isfinite(goal[k:])):  # the attitude on the group
            residual += list(so3.log(so3.exp(goal[k:]).T @ again["R"]))
        else:
            phi = so3.log(again["R"])
            residual += [phi[a] - goal[k + a] for a in range(3) if np.isfinite(goal[k + a])]
        assert np.linalg.norm(residual) <= tol * (1 + 1e-6) + 1e-9, (i, residual)
        # the recorded end is the true one: joints, and the attitude on the group
        np.testing.assert_allclose(leg["end"][:k], again["end"], atol=1e-9)
        gap = np.linalg.norm(so3.log(so3.exp(np.array(leg["end"][k:])).T @ again["R"]))
        assert gap <= 1e-8, (i, gap)  # as reintegrate.verify for planar ends
        np.testing.assert_allclose(
            again["end"][[j for j in locked]], again["start"][locked], atol=1e-12
        )
        assert leg["energy"] == pytest.approx(again["energy"], rel=1e-6, abs=1e-9)
        audit = doc["attitude"]["legs"][i]["audit"]
        assert audit["max_momentum"] < 1e-10 and audit["orthogonality"] < 1e-12
        assert audit["com_drift"] < 1e-6
        previous = np.array(leg["end"])
    check_switches(doc)
