"""The connection A(q) of a planar free-floating manipulator, derived exactly with sympy.

`derive_symbolic` follows the definitions of docs/planar_model.md §1 (positions, `sympy.diff`, cross
products) and returns f_θ and f_j as trigonometric polynomials in the paper's form
Σ c·cos(q_i + …) + const (`trig_canonical`, eq. 6 and 11); `connection_symbolic` divides them
into A_j = f_j / f_θ. The numeric closed forms are in `stratcli.models.connection`; tests hold
the two equal.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from fractions import Fraction
from typing import TYPE_CHECKING

from .planar import PlanarManipulator

if TYPE_CHECKING:
    import sympy as sp

__all__ = ["connection_symbolic", "derive_symbolic", "trig_canonical"]


def _exact(x: float, max_denominator: int = 10_000) -> sp.Expr:
    """Exact sympy number for a float parameter.

    Returns a small-denominator rational if one lies within 1e-13 (relative) of x, and
    otherwise the exact binary value of x.
    """
    import sympy as sp  # only here: a cached model never needs sympy

    frac = Fraction(x).limit_denominator(max_denominator)
    if abs(float(frac) - x) <= 1e-13 * max(1.0, abs(x)):
        return sp.Rational(frac.numerator, frac.denominator)
    return sp.Rational(x)


def _exact_angle(x: float) -> sp.Expr:
    """Exact angle: a rational multiple of π when x is one (denominator <= 360)."""
    import sympy as sp  # only here: a cached model never needs sympy

    frac = Fraction(x / math.pi).limit_denominator(360)
    if abs(float(frac) * math.pi - x) <= 1e-13 * max(1.0, abs(x)):
        return sp.Rational(frac.numerator, frac.denominator) * sp.pi
    return _exact(x)


def _cross_sym(a, b):
    return a[0] * b[1] - a[1] * b[0]


def trig_canonical(expr: sp.Expr, q_symbols: Sequence[sp.Symbol]) -> sp.Expr:
    """Rewrite a trigonometric polynomial in q as Σ a_k cos(k·q) + b_k sin(k·q) + c, exactly.

    Every sin/cos argument must be affine in q with integer coefficients. The method substitutes
    e^{i k·q} = Π z_j^{k_j} and expands the result as a Laurent polynomial, which is a canonical
    form, so equal functions give identical output. Each frequency k is written with its first
    nonzero entry positive. This gives the paper's form, e.g. cos(q1 + q2 + q3).
    """
    import sympy as sp  # only here: a cached model never needs sympy

    q = list(q_symbols)
    z = [sp.Dummy(f"z{j}") for j in range(len(q))]
    rep = {}
    for atom in sp.sympify(expr).atoms(sp.cos, sp.sin):
        arg = atom.args[0]
        if not arg.has(*q):
            continue
        k = [arg.diff(qj) for qj in q]
        if not all(kj.is_Integer for kj in k):
            raise ValueError(f"argument {arg} is not affine in q with integer coefficients")
        c0 = sp.expand(arg - sum(kj * qj for kj, qj in zip(k, q, strict=True)))
        if c0.has(*q):
            raise ValueError(f"argument {arg} is not affine in q")
        e = sp.exp(sp.I * c0) * sp.Mul(*(zj ** int(kj) for zj, kj in zip(z, k, strict=True)))
        rep[atom] = (e + 1 / e) / 2 if atom.func == sp.cos else (e - 1 / e) / (2 * sp.I)
    laurent = sp.expand(sp.sympify(expr).xreplace(rep))

    coeffs: dict[tuple[int, ...], sp.Expr] = {}
    for term in sp.Add.make_args(laurent):
        c, rest = term.as_independent(*z, as_Add=False)
        powers = rest.as_powers_dict()
        k = tuple(int(powers.get(zj, 0)) for zj in z)
        coeffs[k] = coeffs.get(k, sp.S.Zero) + c

    def real(x: sp.Expr) -> sp.Expr:
        return x if x.is_Rational else sp.expand(sp.expand_complex(x))

    zero = (0,) * len(q)
    out = real(coeffs.pop(zero, sp.S.Zero))

    def neg(k: tuple[int, ...]) -> tuple[int, ...]:
        return tuple(-kj for kj in k)

    canonical = {k if next(kj for kj in k if kj != 0) > 0 else neg(k) for k in coeffs}
    for k in sorted(canonical):
        ck, cm = coeffs.get(k, sp.S.Zero), coeffs.get(neg(k), sp.S.Zero)
        arg = sum(kj * qj for kj, qj in zip(k, q, strict=True))
        out += real(ck + cm) * sp.cos(arg) + real(sp.I * (ck - cm)) * sp.sin(arg)
    return out


def derive_symbolic(
    robot: PlanarManipulator, q_symbols: Sequence[sp.Symbol]
) -> tuple[sp.Expr, list[sp.Expr]]:
    """Exact physical f_θ(q) and [f_1(q), ..., f_n(q)] from angular momentum
    (docs/planar_model.md §1).

    The derivation uses only the definitions::

        f_θ = Σ_k I_k + m_k |p_k − p_c|²
        f_j = −Σ_k I_k ∂β_k/∂q_j + m_k (p_k − p_c) × ∂p_k/∂q_j

    where k runs over all bodies, base included. Float parameters are converted to exact numbers
    first (small-denominator rationals, and multiples of π for angles). For the paper's robots
    the result is a polynomial in cosines with rational coefficients, 1/(12·M) times eq. 6 and
    eq. 11. The output is in `trig_canonical` form, and A_j = f_j / f_θ.
    """
    import sympy as sp  # only here: a cached model never needs sympy

    q = list(q_symbols)
    if len(q) != robot.n_joints:
        raise ValueError(f"need {robot.n_joints} symbols, got {len(q)}")
    bodies = []  # (m, I, p, β) of the links; the base has p = 0, β = 0
    j = 0
    for arm in robot.arms:
        o = sp.Matrix([_exact(arm.mount[0]), _exact(arm.mount[1])])
        beta = _exact_angle(arm.zero_angle)
        for link in arm.links:
            beta = beta + arm.sense * q[j]
            u = sp.Matrix([sp.cos(beta), sp.sin(beta)])
            p = o + _exact(link.com) * u
            bodies.append((_exact(link.mass), _exact(link.inertia), p, beta))
            o = o + _exact(link.length) * u
            j += 1
    m0, I0 = _exact(robot.base.mass), _exact(robot.base.inertia)
    M = m0 + sum(b[0] for b in bodies)
    pc = sum((m * p for m, _, p, _ in bodies), sp.zeros(2, 1)) / M

    f_theta = I0 + m0 * pc.dot(pc)
    for m, inertia, p, _ in bodies:
        r = p - pc
        f_theta += inertia + m * r.dot(r)
    f = []
    for qj in q:
        fj = sp.S.Zero  # base: ∂β_0 = 0 and ∂p_0 = 0
        for m, inertia, p, beta in bodies:
            fj -= inertia * sp.diff(beta, qj) + m * _cross_sym(p - pc, sp.diff(p, qj))
        f.append(trig_canonical(fj, q))
    return trig_canonical(f_theta, q), f


def connection_symbolic(robot: PlanarManipulator, q_symbols: Sequence[sp.Symbol]) -> list:
    """[A_1, ..., A_n] with A_j = f_j / f_θ as exact sympy expressions (paper eq. 5, 10)."""
    f_theta, f = derive_symbolic(robot, q_symbols)
    return [fj / f_theta for fj in f]
