"""The connection A(q) of a planar free-floating manipulator and its derivatives, in numpy.

Angular momentum conservation gives θ' = Σ_j A_j(q) q_j' with A_j = f_j / f_θ (paper sec. 3,
eq. 5 and 10; the robot and its conventions are in `planar`). `connection` evaluates A and
∂A/∂q from the closed forms in docs/planar_model.md §3 (with `f_theta_and_f` and `connection_A`),
vectorised, without sympy; `connection_gradient` and `connection_hessian` give the contracted
first and second derivatives the energy objective needs, in O(n) and O(n²) per node. Arrays
follow `planar`'s layout: per-link quantities (n, K), with the K evaluation points last. The
exact symbolic derivation from docs/planar_model.md §1 is `connection_symbolic`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .planar import PlanarManipulator, Structure, kinematics, points_first, points_last, structure

if TYPE_CHECKING:
    pass

__all__ = [
    "connection",
    "connection_A",
    "connection_gradient",
    "connection_hessian",
    "f_theta_and_f",
]

# --------------------------------------------------------------------------------------------
# Numeric evaluation (docs/planar_model.md §3), vectorised over leading axes of q
# --------------------------------------------------------------------------------------------


def _f_parts(st: Structure, o, p):
    """p_c (each (K,)), S_j = Σ_{i∈D(j)} m_i (p_i − p_c), f_θ (K,) and f (n, K)
    (docs/planar_model.md §3)."""
    (ox, oy), (px, py) = o, p
    pcx, pcy = (st.m @ px) / st.M, (st.m @ py) / st.M
    mPx, mPy = st.m_col * (px - pcx), st.m_col * (py - pcy)
    f_theta = (
        st.sum_inertia + st.m0 * (pcx**2 + pcy**2) + (mPx * (px - pcx) + mPy * (py - pcy)).sum(0)
    )
    Sx, Sy = st.D @ mPx, st.D @ mPy
    # −f_j = s_j Σ_{i∈D(j)} [I_i + m_i (p_i − p_c)·(p_i − o_j)]
    neg_f = st.s * (st.DI + st.D @ (mPx * px + mPy * py) - ox * Sx - oy * Sy)
    return (pcx, pcy), (Sx, Sy), f_theta, -neg_f


def f_theta_and_f(robot: PlanarManipulator, q: Any) -> tuple[np.ndarray, np.ndarray]:
    """Physical f_θ(q) with shape (...) and f_j(q) with shape (..., n) (docs/planar_model.md §3).

    The paper prints 12·M times these values.
    """
    st = structure(robot)
    qT, lead = points_last(robot, q)
    _, _, o, p = kinematics(st, qT)
    _, _, f_theta, f = _f_parts(st, o, p)
    return f_theta.reshape(lead), points_first(f, lead)


def connection_A(robot: PlanarManipulator, q: Any) -> np.ndarray:
    """A(q) = f/f_θ with shape (..., n), so that θ' = A(q)·q' (paper eq. 5, 10)."""
    f_theta, f = f_theta_and_f(robot, q)
    return f / f_theta[..., None]


def _connection_block(st: Structure, q: np.ndarray, v: np.ndarray | None = None):
    """A (n, K) and dA (K, n, n) for q of shape (n, K); with weights v (n, K) also
    H (K, n, n) = Σ_j v_j ∂²A_j/∂q_k∂q_l (the pair arrays with the points first)."""
    _, _, o, p = kinematics(st, q)
    (pcx, pcy), (Sx, Sy), f_theta, f = _f_parts(st, o, p)
    (ox, oy), (px, py) = o, p
    M = st.M
    # ∂p_i/∂q_k = s_k rot90(p_i − o_k) for i ∈ D(k), and rot90(a)·b = a × b. Summing the
    # docs/planar_model.md §3 derivatives over the distal sets gives
    #   c_k = Σ_{i∈D(k)} m_i (p_i − o_k) / M              so that ∂p_c/∂q_k = s_k rot90(c_k)
    #   ∂f_θ/∂q_k    = 2 s_k M c_k × (o_k − p_c)
    #   ∂(−f_j)/∂q_k = s_j s_k [W_jk × (2 o_k − o_j − p_c) + μ_jk o_k × (o_j + p_c)
    #                           − M c_k × c_j − [k strictly proximal to j] (o_j − o_k) × S_j]
    # with E_jki = D_ji D_ki m_i, W_jk = Σ_i E_jki p_i, μ_jk = Σ_i E_jki, S_j = Σ_{i∈D(j)} m_i P_i.
    # On one arm W_jk = Y_d and μ_jk = μ_d for d the more distal of j, k (Y_k = Σ_{i∈D(k)} m_i
    # p_i), so the bracket is a sum of outer products of per-joint vectors, O(n²) per point:
    #   k ≤ j:  r_j + α_j x_k + β_j y_k − M c_k × c_j,  with o_k = (x_k, y_k), g_j = o_j + p_c,
    #           r_j = g_j × Y_j + S_j × o_j,  α_j = μ_j g_{j,y} + S_{j,y} − 2 Y_{j,y},
    #           β_j = 2 Y_{j,x} − μ_j g_{j,x} − S_{j,x}
    #   k > j:  2 Y_k × o_k − M c_k × p_c − M c_k × (o_j + c_j)
    #   other arms: − M c_k × c_j
    Yx, Yy = st.D @ (st.m_col * px), st.D @ (st.m_col * py)
    cx = (Yx - st.mu * ox) / M
    cy = (Yy - st.mu * oy) / M
    d_f_theta = 2.0 * M * st.s * (cx * (oy - pcy) - cy * (ox - pcx))  # [k, K]

    gx, gy = ox + pcx, oy + pcy
    r = (gx * Yy - gy * Yx) + (Sx * oy - Sy * ox)
    alpha = st.mu * gy + Sy - 2.0 * Yy
    beta = 2.0 * Yx - st.mu * gx - Sx
    Mcx, Mcy = M * cx, M * cy
    rho = 2.0 * (Yx * oy - Yy * ox) - (Mcx * pcy - Mcy * pcx)
    # Each case is a sum of outer products of per-joint vectors, evaluated as one batched
    # matrix product (K, n, r) @ (K, r, n) with the points first; the signs s_j s_k, the term
    # −A_j ∂f_θ/∂q_k and the division by f_θ are folded into the vectors.
    one = np.ones_like(ox)
    A = f / f_theta
    rows_x, cols_x = (Mcx, -Mcy), (cy, cx)  # − M c_k × c_j
    cases = (
        ((r, alpha, beta, *rows_x), (one, ox, oy, *cols_x)),  # k ≤ j on one arm
        ((one, -oy, ox, *rows_x), (rho, Mcx, Mcy, *cols_x)),  # k > j on one arm
        (rows_x, cols_x),  # other arms
    )
    lower, upper, cross = (
        _outer(
            (*(-st.s * x / f_theta for x in rows), -A / f_theta),
            (*(st.s * y for y in cols), d_f_theta),
        )
        for rows, cols in cases
    )
    dA = _by_case(st, lower, upper, cross)
    if v is None:
        return A, dA
    parts = (o, p, (pcx, pcy), (Yx, Yy), (cx, cy), f_theta, d_f_theta)
    g = (v.T[:, None, :] @ dA)[:, 0, :].T  # Σ_j v_j ∂A_j/∂q_k, (n, K)
    return A, dA, _second_derivatives(st, parts, v, (v * f).sum(0), g)


def _by_case(st: Structure, lower: np.ndarray, upper: np.ndarray, cross: np.ndarray):
    """lower where k ≤ j on one arm, upper where k > j on one arm, cross elsewhere."""
    if not st.upper_same.any():  # one joint per arm
        return np.where(st.lower_same, lower, cross)
    if st.lower_same.sum() + st.upper_same.sum() == st.lower_same.size:  # a single arm
        return np.where(st.lower_same, lower, upper)
    return np.where(st.lower_same, lower, np.where(st.upper_same, upper, cross))


def _outer(rows: tuple[np.ndarray, ...], cols: tuple[np.ndarray, ...]) -> np.ndarray:
    """Σ_t rows[t]_j cols[t]_k at every point, (K, n, n), from per-joint vectors (n, K)."""
    U = np.ascontiguousarray(np.stack(rows, axis=-1).transpose(1, 0, 2))  # (K, n, r)
    W = np.ascontiguousarray(np.stack(cols, axis=0).transpose(2, 0, 1))  # (K, r, n)
    return U @ W  # contiguous operands: numpy's batched product is ~10x faster on them


def _second_derivatives(st: Structure, parts, v: np.ndarray, F: np.ndarray, g: np.ndarray):
    """H = Σ_j v_j ∂²A_j/∂q_k∂q_l (K, n, n) in O(n²) per point, from F = Σ_j v_j f_j (K,) and
    g = Σ_j v_j ∂A_j/∂q (n, K).

    Second derivatives of a point x moved by joints k and l are
    ∂²x/∂q_k∂q_l = −s_k s_l (x − o_d), d the more distal of k, l (p the more proximal). With
    σ_j = s_j v_j, ω_i = Σ_{j∈P(i)} σ_j (prefix sums along the arm) and the distal sums Y, c of
    `_connection_block`, −F = const + Σ_j σ_j g_j, g_j = Σ_{i∈D(j)} m_i (p_i − p_c)·(p_i − o_j)
    = T1 + T2 + T3 summed over j, whose Hessians are (for joints on one arm, k ≤ l):

    * T1 = Σ_i m_i ω_i |p_i|²:     −2 s_k s_l o_p·a_d,  a_d = Σ_{i∈D(d)} m_i ω_i (p_i − o_d)
    * T2 = −Σ_j σ_j o_j·Y_j:       s_k s_l [M B_p·c_d + M (ω_d − ω_p) o_p·c_d
      + o_p·Σ_{j>d} σ_j (Y_j + μ_j o_j − 2 μ_j o_d)],  B_p = Σ_{j≤p} σ_j o_j
    * T3 = −p_c·h, h = M Σ_j σ_j c_j: s_k s_l [same (c_d·h + M p_c·e_d) − M (c_k·e_l + c_l·e_k)],
      e_k = ω_k c_k + Σ_{j>k} σ_j c_j (this one couples the arms through p_c)

    and ∇²f_θ = 2 M s_k s_l [same (p_c − o_p)·c_d − c_k·c_l]. Joints on different arms give
    zero except for the c_k, c_l products. The quotient rule twice, with a = F/f_θ, gives
    H = (∇²F − a ∇²f_θ − g ∇f_θᵀ − ∇f_θ gᵀ) / f_θ. On one arm s_k s_l = 1, and every term is
    a sum of outer products u_d w_p of per-joint vectors, which is what is evaluated: the
    matrix L_jk = u_j w_k taken as L on k ≤ j and Lᵀ on k > j.
    """
    (ox, oy), (px, py), (pcx, pcy), (Yx, Yy), (cx, cy), f_theta, d_f_theta = parts
    M, D, Ds, m = st.M, st.D, st.Ds, st.m_col
    sigma = st.s * v
    omega = D.T @ sigma  # (n, K)
    mw = m * omega
    a = F / f_theta

    # o_p · V_d, with V collecting T1, the last two terms of T2 and the ω_d part of the first
    nu = D @ mw
    mu_sig = st.mu * sigma
    Vx = -2.0 * (D @ (mw * px) - nu * ox) + Ds @ (sigma * Yx + mu_sig * ox) - 2 * (Ds @ mu_sig) * ox
    Vy = -2.0 * (D @ (mw * py) - nu * oy) + Ds @ (sigma * Yy + mu_sig * oy) - 2 * (Ds @ mu_sig) * oy
    Vx, Vy = Vx + M * omega * cx, Vy + M * omega * cy
    # w_p · M c_d: the rest of T2 and −a ∇²f_θ's (p_c − o_p)·c_d
    Wx = D.T @ (sigma * ox) - omega * ox + 2.0 * a * (pcx - ox)
    Wy = D.T @ (sigma * oy) - omega * oy + 2.0 * a * (pcy - oy)
    # T3's c_d·h + M p_c·e_d
    hx, hy = M * (sigma * cx).sum(0), M * (sigma * cy).sum(0)  # (K,)
    ex = omega * cx + Ds @ (sigma * cx)
    ey = omega * cy + Ds @ (sigma * cy)
    diag = cx * hx + cy * hy + M * (pcx * ex + pcy * ey)
    # −M (c_k·ê_l + c_l·ê_k) with ê = e + a c (T3 and −a ∇²f_θ's c_k·c_l), signs s_k s_l, and
    # −(g ∇f_θᵀ + ∇f_θ gᵀ): a symmetric sum of outer products, R + Rᵀ
    ehx, ehy = st.s * (ex + a * cx), st.s * (ey + a * cy)
    scx, scy = (st.s * M) * cx, (st.s * M) * cy
    r_rows = tuple(x / f_theta for x in (scx, scy, -g, ehx, ehy, d_f_theta))
    r_cols = (ehx, ehy, d_f_theta, scx, scy, -g)
    # on one arm, minus L_jk = u_j·w_k for k ≤ j and minus its transpose for k > j
    one = np.ones_like(ox)
    u = tuple(-x / f_theta for x in (Vx, Vy, diag, M * cx, M * cy))
    w = (ox, oy, one, Wx, Wy)
    ut = tuple(-x / f_theta for x in w)
    wt = (Vx, Vy, diag, M * cx, M * cy)
    lower = _outer(r_rows + u, r_cols + w)
    upper = _outer(r_rows + ut, r_cols + wt)
    return _by_case(st, lower, upper, _outer(r_rows, r_cols))


def connection(robot: PlanarManipulator, q: Any) -> tuple[np.ndarray, np.ndarray]:
    """A(q) (shape (..., n)) and dA (shape (..., n, n)), with dA[..., j, k] = ∂A_j/∂q_k.

    The closed forms of docs/planar_model.md §3, vectorised over the leading axes of q, with
    no sympy.
    Points are processed in blocks of about 2.5e4 / n² columns. This keeps the (block, n, n)
    temporaries cache-sized, which is about 2x faster for K = 1000, n = 10.
    """
    st = structure(robot)
    qT, lead = points_last(robot, q)
    n, K = qT.shape
    block = max(64, 25_000 // (n * n))
    A, dA = np.empty((K, n)), np.empty((K, n, n))
    for k0 in range(0, K, block):
        a, dA[k0 : k0 + block] = _connection_block(st, qT[:, k0 : k0 + block])
        A[k0 : k0 + block] = a.T
    return A.reshape(*lead, n), dA.reshape(*lead, n, n)


def _gradient_block(st: Structure, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, ...]:
    """A (n, K) and g (n, K) = Σ_j v_j ∂A_j/∂q_k for q, v of shape (n, K), in O(n) per point
    (plus products with the distal masks).

    With the notation of `_second_derivatives` (σ, ω, Y, c, h, e), ∂p/∂q_k = s_k rot90(p − o_k)
    and rot90(a)·b = a × b, the derivative of −F = −Σ_j v_j f_j is
    s_k [2 Z_k × o_k + M B_k × c_k + o_k × Σ_{j>k} σ_j (Y_j + μ_j o_j) − c_k × h − M e_k × p_c]
    with Z_k = Σ_{i∈D(k)} m_i ω_i p_i and B_k = Σ_{j≤k} σ_j o_j.
    """
    _, _, (ox, oy), (px, py) = kinematics(st, q)
    (pcx, pcy), _, f_theta, f = _f_parts(st, (ox, oy), (px, py))
    M, D, Ds = st.M, st.D, st.Ds
    Yx, Yy = D @ (st.m_col * px), D @ (st.m_col * py)
    cx, cy = (Yx - st.mu * ox) / M, (Yy - st.mu * oy) / M
    d_f_theta = 2.0 * M * st.s * (cx * (oy - pcy) - cy * (ox - pcx))
    sigma = st.s * v
    omega = D.T @ sigma
    mw = st.m_col * omega
    mu_sig = st.mu * sigma
    Zx, Zy = D @ (mw * px), D @ (mw * py)
    Bx, By = D.T @ (sigma * ox), D.T @ (sigma * oy)
    Qx, Qy = Ds @ (sigma * Yx + mu_sig * ox), Ds @ (sigma * Yy + mu_sig * oy)
    hx, hy = M * (sigma * cx).sum(0), M * (sigma * cy).sum(0)
    ex, ey = omega * cx + Ds @ (sigma * cx), omega * cy + Ds @ (sigma * cy)
    neg = 2.0 * (Zx * oy - Zy * ox) + M * (Bx * cy - By * cx) + (ox * Qy - oy * Qx)
    neg -= cx * hy - cy * hx
    neg -= M * (ex * pcy - ey * pcx)
    F, dF = (v * f).sum(0), -st.s * neg
    A = f / f_theta
    return A, (dF - F * d_f_theta / f_theta) / f_theta


def connection_gradient(robot: PlanarManipulator, q: Any, v: Any) -> tuple[np.ndarray, np.ndarray]:
    """A (..., n) and g[..., k] = Σ_j v_j ∂A_j/∂q_k (..., n): one contraction of dA, the one an
    end point's Jacobian needs, in closed form at O(n) per point (`_gradient_block`) where dA
    costs O(n²). `v` has the shape of `q`."""
    st = structure(robot)
    qT, lead = points_last(robot, q)
    vT, _ = points_last(robot, np.broadcast_to(v, np.shape(q)))
    A, g = _gradient_block(st, qT, vT)
    return points_first(A, lead), points_first(g, lead)


def connection_hessian(
    robot: PlanarManipulator, q: Any, v: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A, dA (as `connection`) and H[..., k, l] = Σ_j v_j ∂²A_j/∂q_k∂q_l, all in closed form.

    `v` has the shape of `q` (weights per point). The contracted second derivatives cost O(n²)
    per point, like dA (`_second_derivatives`), where the full tensor would cost O(n³).
    """
    st = structure(robot)
    qT, lead = points_last(robot, q)
    vT, _ = points_last(robot, np.broadcast_to(v, np.shape(q)))
    n, K = qT.shape
    block = max(64, 25_000 // (n * n))
    A, dA, H = np.empty((K, n)), np.empty((K, n, n)), np.empty((K, n, n))
    for k0 in range(0, K, block):
        cols = slice(k0, k0 + block)
        a, dA[cols], H[cols] = _connection_block(st, qT[:, cols], vT[:, cols])
        A[cols] = a.T
    return A.reshape(*lead, n), dA.reshape(*lead, n, n), H.reshape(*lead, n, n)
