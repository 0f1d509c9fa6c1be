"""DOP853 with dense output, for the re-integration of plans (no scipy.integrate import).

The same algorithm as `scipy.integrate.solve_ivp(method="DOP853", t_eval=...)` (Hairer's
explicit Runge-Kutta 8(5,3) with step-size control and 7th-order dense output, the tableau in
`dop853_tableau`), forward in time only. It exists because importing `scipy.integrate` costs
about 0.2 s of CPU, a fifth of a whole `stratplan plan` run, for this one solver; a test holds
it to scipy's results. The planner itself never uses it (its end points are quadratures).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from . import dop853_tableau as tab

__all__ = ["OutOfSteps", "dop853"]

SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0  # step-size control (as scipy's)
_S = tab.N_STAGES
_B = tab.B
# per stage: its row of A (contiguous) and its node as a Python float (cheaper arithmetic)
_A_ROWS = [np.ascontiguousarray(tab.A[s, :s]) for s in range(tab.N_STAGES_EXTENDED)]
_C_ALL = tab.C.tolist()
_ERROR_EXPONENT = -1.0 / 8.0  # error estimator of order 7
_BATCH = 4096  # points interpolated at once at most (bounds the (points, 7, n) gather)


class OutOfSteps(RuntimeError):
    """The step size fell below what the floating-point time axis can resolve."""


def _rms(x: np.ndarray) -> float:
    return float(np.linalg.norm(x) / x.size**0.5)


def _initial_step(fun, t0, y0, f0, length, rtol, atol) -> float:
    """Hairer's starting step (II.4), as scipy's `select_initial_step`."""
    scale = atol + np.abs(y0) * rtol
    d0, d1 = _rms(y0 / scale), _rms(f0 / scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, length)
    f1 = fun(t0 + h0, y0 + h0 * f0)
    d2 = _rms((f1 - f0) / scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100 * h0, h1, length)


def _error_norm(KT: np.ndarray, h: float, scale: np.ndarray) -> float:
    """The error estimate (scipy's), from the transposed stages `KT` (n, 13)."""
    err5 = KT @ tab.E5 / scale
    err3 = KT @ tab.E3 / scale
    e5, e3 = float(np.dot(err5, err5)), float(np.dot(err3, err3))
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return float(abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * scale.size))


def _dense(fun, K, KT, t_old, h, y_old, y, f) -> np.ndarray:
    """The interpolant's coefficients F (7, n) on the step [t_old, t_old + h]."""
    for s in range(_S + 1, tab.N_STAGES_EXTENDED):
        K[s] = fun(t_old + _C_ALL[s] * h, y_old + KT[s].dot(_A_ROWS[s]) * h)
    F = np.empty((tab.INTERPOLATOR_POWER, y.size))
    delta = y - y_old
    F[0] = delta
    F[1] = h * K[0] - delta
    F[2] = 2 * delta - h * (f + K[0])
    F[3:] = h * (tab.D @ K)
    return F


def _interpolate(out, t_eval, first: int, steps: list) -> None:
    """Fill `out[first:]` from `t_eval[first:]`, the points of `steps` (coefficients F (7, n),
    y_old, t_old, h, number of points) in order. All those steps' points at once (elementwise,
    so the same numbers as step by step) spares a dozen numpy calls per step."""
    F, y_old, t_old, h, count = zip(*steps, strict=True)
    of = np.repeat(np.arange(len(steps)), count)
    end = first + of.size
    x = ((t_eval[first:end] - np.array(t_old)[of]) / np.array(h)[of])[:, None]
    rest = 1 - x
    F = np.stack(F)[of]
    y = np.zeros((of.size, F.shape[2]))
    for i in range(tab.INTERPOLATOR_POWER - 1, -1, -1):
        y += F[:, i]
        y *= x if i % 2 == 0 else rest
    out[first:end] = y + np.stack(y_old)[of]


def dop853(
    fun: Callable[[float, np.ndarray], np.ndarray],
    t_end: float,
    y0: np.ndarray,
    t_eval: np.ndarray,
    rtol: float,
    atol: float,
) -> np.ndarray:
    """Integrate `y' = fun(t, y)` from t = 0 to `t_end` > 0; states at `t_eval`.

    Parameters
    ----------
    fun : callable
        The right-hand side; it may raise to stop the integration (e.g. an evaluation budget).
    t_end : float
        End time (> 0).
    y0 : ndarray
        State at t = 0, (n,).
    t_eval : ndarray
        Sorted times in [0, t_end] at which the states are wanted.
    rtol, atol : float
        Relative and absolute tolerances of the local error.

    Returns
    -------
    ndarray
        (len(t_eval), n) states.

    Raises
    ------
    OutOfSteps
        The step size fell below the resolution of the time axis.
    """
    y = np.asarray(y0, dtype=float).copy()
    t_eval = np.asarray(t_eval, dtype=float)
    out = np.empty((t_eval.size, y.size))
    done = first = int(np.searchsorted(t_eval, 0.0, side="right"))
    out[:done] = y
    f = np.asarray(fun(0.0, y), dtype=float)
    h_abs = _initial_step(fun, 0.0, y, f, t_end, rtol, atol)
    K = np.empty((tab.N_STAGES_EXTENDED, y.size))
    KT = [K[:s].T for s in range(tab.N_STAGES_EXTENDED)]  # views: K is filled in place
    steps: list[tuple[np.ndarray, np.ndarray, float, float, int]] = []  # not yet interpolated
    t = 0.0
    while t < t_end:
        min_step = 10 * abs(math.nextafter(t, math.inf) - t)
        h_abs = max(h_abs, min_step)
        rejected = False
        while True:
            if h_abs < min_step:
                raise OutOfSteps(f"step size below {min_step:.3g} at t = {t:.6g}")
            t_new = min(t + h_abs, t_end)
            h = t_new - t
            K[0] = f
            for s in range(1, _S):
                K[s] = fun(t + _C_ALL[s] * h, y + KT[s].dot(_A_ROWS[s]) * h)
            y_new = y + h * KT[_S].dot(_B)
            f_new = fun(t_new, y_new)
            K[_S] = f_new
            scale = atol + np.maximum(np.abs(y), np.abs(y_new)) * rtol
            error = _error_norm(KT[_S + 1], h, scale)
            if error < 1:
                factor = (
                    MAX_FACTOR if error == 0 else min(MAX_FACTOR, SAFETY * error**_ERROR_EXPONENT)
                )
                h_abs = h * (min(1.0, factor) if rejected else factor)
                break
            h_abs = h * max(MIN_FACTOR, SAFETY * error**_ERROR_EXPONENT)
            rejected = True
        upto = int(np.searchsorted(t_eval, t_new, side="right"))
        if upto > done:
            steps.append((_dense(fun, K, KT, t, h, y, y_new, f_new), y, t, h, upto - done))
            done = upto
            if done - first >= _BATCH:
                _interpolate(out, t_eval, first, steps)
                first, steps = done, []
        t, y, f = t_new, y_new, f_new
    if steps:
        _interpolate(out, t_eval, first, steps)
    return out
