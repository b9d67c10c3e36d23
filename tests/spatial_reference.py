"""Extended-precision reference for the spatial (3-D) PCS dynamics, written from the energies.

This file is a test oracle, independent of the package by construction: it imports only
``mpmath`` and ``numpy`` and never ``pcs_sindy``.  It shares no Jacobian, Christoffel or
closed-form kinematics code with the package; everything follows from three definitions
(COMMON.md, "Spatial PCS conventions"):

1. Kinematics.  Segment ``i`` has the constant body twist
   ``omega = (q1, q2, q0)``, ``v = (q3, 1 + q5, q4)`` (its six strains), and inside it
   ``g(s) = g(start) · expm(s · xi^)`` with ``mpmath.expm`` of the 4x4 twist matrix, chained
   base to tip.
2. Energies.  ``T = Σ_i ∫ [½ ρA |ṗ|² + ½ ω_bᵀ diag(ρI, 2ρI, ρI) ω_b] ds`` with ``ṗ`` and
   ``[ω_b]_× = Rᵀ Ṙ`` the derivative of the kinematics along ``q̇`` (central differences of the
   poses at raised working precision), ``U_g = −Σ_i ρA ∫ gᵀ p ds``; both integrals by
   Gauss–Legendre quadrature whose nodes are computed in mpmath (Newton on the Legendre
   recurrence).
3. Lagrange.  ``M`` by polarisation of ``T`` (``T`` is exactly quadratic in ``q̇``:
   ``M_ab = T(e_a + e_b) − T(e_a) − T(e_b)``), ``C(q, q̇) q̇ = d/dt ∂T/∂q̇ |_{q̈=0} − ∂T/∂q``
   and ``G = ∂U_g/∂q`` by central differences of those energies; ``K q`` and ``D q̇`` as defined.

Differentiation.  Every derivative is a central difference with step ``h = 10^-(dps//2 + 3)``
(divided by the robot's length when it exceeds 1 m) evaluated at ``2 dps + 16`` working digits, so
truncation (``O(h²)``) and cancellation (``dps + 6`` digits for a mixed second difference) both stay
below ``10^-dps`` relative; tests/test_spatial_reference.py checks dps 30 against dps 50.  ``T`` is
quadratic in ``q̇``, so the work runs along ``u = q̇ / |q̇|_∞`` and ``C q̇`` is scaled back by
``|q̇|_∞²``.  The two second-order terms of ``C q̇`` are mixed derivatives of the kinematics along
``u`` and along each ``e_a``; both come from the same four points ``q ± h u ± h e_a``, whose means
over ``± h u`` also give ``M`` and ``G`` (an ``O(h²)`` error).  A perturbation ``e_a`` only changes
the exponentials of its own segment, so a call costs about ``4 n (n_quadrature + 1)`` exponentials
(``2 n (n_quadrature + 1)`` when ``q̇ = 0``).  ``mpmath.diff`` would pick its own step and double the
precision at each nesting level, so these stencils could not be shared; the tests use it
independently (passivity).

Cost (2 CPU cores shared, CPU time, 2 segments, n_quadrature = 8): dps 30 about 2.3 s, dps 40 about
2.7 s (1.1 s and 1.3 s with ``q̇ = 0``); one segment at dps 30 about 1 s.

Public names (another test codes against them, keep them stable):
:func:`reference_terms`, :func:`reference_accelerations`, :func:`reference_pose`.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache

import mpmath
import numpy as np

__all__ = ["reference_accelerations", "reference_pose", "reference_terms"]

mp = mpmath.mp


# --------------------------------------------------------------------------
# input checks
# --------------------------------------------------------------------------
def _lengths(segment_lengths) -> np.ndarray:
    lengths = np.atleast_1d(np.asarray(segment_lengths, dtype=float))
    if lengths.ndim != 1 or lengths.size == 0:
        raise ValueError(f"segment_lengths must be a non-empty 1-D sequence; got shape {lengths.shape}")
    if not np.all(np.isfinite(lengths) & (lengths > 0)):
        raise ValueError(f"segment_lengths must be finite and > 0; got {lengths.tolist()}")
    return lengths


def _vector(value, size: int, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (size,):
        raise ValueError(f"{name} must have shape ({size},); got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite; got {arr.tolist()}")
    return arr


def _exact_vector(value, size: int, name: str) -> list:
    """Validated entries, kept as given: mpmath numbers keep their digits (for extended-precision callers)."""
    if isinstance(value, mpmath.matrix):
        entries = [value[k] for k in range(value.rows * value.cols)]
    else:
        entries = list(np.asarray(value, dtype=object).reshape(-1))
        if np.shape(value) != (size,):
            raise ValueError(f"{name} must have shape ({size},); got shape {np.shape(value)}")
    if len(entries) != size:
        raise ValueError(f"{name} must have {size} entries; got {len(entries)}")
    try:
        as_float = np.array([float(v) for v in entries])
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name} must hold real numbers; got {value!r}") from err
    if not np.all(np.isfinite(as_float)):
        raise ValueError(f"{name} must be finite; got {as_float.tolist()}")
    return [v if isinstance(v, mpmath.mpf) else float(v) for v in entries]


def _per_segment(value, m: int, name: str, *, positive: bool) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(m, float(arr))
    if arr.shape != (m,):
        raise ValueError(f"{name} must be a scalar or have shape ({m},); got shape {arr.shape}")
    if not np.all(np.isfinite(arr) & ((arr > 0) if positive else (arr >= 0))):
        raise ValueError(f"{name} must be finite and {'> 0' if positive else '>= 0'}; got {arr.tolist()}")
    return arr


# the difference step is 10^-(dps/2 + _STEP_GUARD); _work_dps leaves room for the cancellation of a
# mixed second difference (dps + 2 _STEP_GUARD digits) plus a guard
_STEP_GUARD = 3


def _work_dps(dps: int) -> int:
    return 2 * dps + 2 * _STEP_GUARD + 10


def _dps(dps) -> int:
    if isinstance(dps, bool) or int(dps) != dps or not 15 <= dps <= 500:
        raise ValueError(f"dps must be an integer in [15, 500]; got {dps!r}")
    return int(dps)


# --------------------------------------------------------------------------
# kinematics: 4x4 matrices as nested lists of mpf (faster than mpmath.matrix indexing)
# --------------------------------------------------------------------------
def _twist_matrix(strains, s) -> mpmath.matrix:
    """``s · xi^`` for one segment's six strains (COMMON.md order)."""
    kz, kx, ky, sx, sz, sy = strains
    wx, wy, wz = kx * s, ky * s, kz * s
    return mpmath.matrix(
        [
            [0, -wz, wy, sx * s],
            [wz, 0, -wx, (1 + sy) * s],
            [-wy, wx, 0, sz * s],
            [0, 0, 0, 0],
        ]
    )


def _as_lists(A: mpmath.matrix) -> list[list]:
    return [[A[r, c] for c in range(4)] for r in range(4)]


def _matmul(A: list[list], B: list[list]) -> list[list]:
    # homogeneous transforms: the last row stays (0, 0, 0, 1)
    out = [[mpmath.fsum(A[r][k] * B[k][c] for k in range(3)) for c in range(4)] for r in range(3)]
    for r in range(3):
        out[r][3] += A[r][3]
    out.append([mp.zero, mp.zero, mp.zero, mp.one])
    return out


def _identity() -> list[list]:
    return [[mp.one if r == c else mp.zero for c in range(4)] for r in range(4)]


@lru_cache(maxsize=32)
def _gauss_legendre(n: int, dps: int) -> tuple[tuple, tuple]:
    """Nodes and weights on [-1, 1] to ``dps`` digits (Newton from numpy's double nodes)."""
    with mp.workdps(dps + 10):
        x0, _ = np.polynomial.legendre.leggauss(n)
        nodes, weights = [], []
        for x in x0:
            x = mpmath.mpf(float(x))
            for _ in range(100):
                p_prev, p = mp.one, x
                for k in range(1, n):
                    p_prev, p = p, ((2 * k + 1) * x * p - k * p_prev) / (k + 1)
                dp = n * (x * p - p_prev) / (x * x - 1)
                step = p / dp
                x -= step
                if abs(step) < mpmath.mpf(10) ** (-(dps + 5)):
                    break
            p_prev, p = mp.one, x
            for k in range(1, n):
                p_prev, p = p, ((2 * k + 1) * x * p - k * p_prev) / (k + 1)
            dp = n * (x * p - p_prev) / (x * x - 1)
            nodes.append(x)
            weights.append(2 / ((1 - x * x) * dp * dp))
    return tuple(nodes), tuple(weights)


class _Robot:
    """Geometry, quadrature and the cached kinematics of one evaluation (at the current mp precision)."""

    def __init__(self, lengths, n_quadrature, dps_nodes):
        self.m = len(lengths)
        self.L = [mpmath.mpf(float(v)) for v in lengths]
        x, w = _gauss_legendre(n_quadrature, dps_nodes)
        # per segment: the quadrature nodes in [0, L_i], then the segment's end (not needed for the tip)
        self.n_nodes = len(x)
        self.s = [[(xk + 1) * Li / 2 for xk in x] + ([Li] if i < self.m - 1 else []) for i, Li in enumerate(self.L)]
        self.w = [[wk * Li / 2 for wk in w] for Li in self.L]
        self._exp_cache: dict = {}
        self._fk_cache: dict = {}

    def segment_exps(self, i: int, key, strains) -> list[list[list]]:
        """``expm(s · xi_i^)`` at the segment's nodes and end; ``key`` identifies ``strains``."""
        k = (i, key)
        if k not in self._exp_cache:
            self._exp_cache[k] = [_as_lists(mpmath.expm(_twist_matrix(strains, s))) for s in self.s[i]]
        return self._exp_cache[k]

    def poses(self, key, q) -> list[list[list[list]]]:
        """Poses at every quadrature node, ``[segment][node] -> 4x4``; ``key(i)`` names segment i's strains."""
        full = tuple(key(i) for i in range(self.m))
        if full not in self._fk_cache:
            start = _identity()
            out = []
            for i in range(self.m):
                exps = self.segment_exps(i, full[i], q[6 * i : 6 * i + 6])
                out.append([_matmul(start, E) for E in exps[: self.n_nodes]])
                if i < self.m - 1:
                    start = _matmul(start, exps[-1])
            self._fk_cache[full] = out
        return self._fk_cache[full]


# --------------------------------------------------------------------------
# energies
# --------------------------------------------------------------------------
def _velocity(plus, minus, two_h):
    """Central difference of two pose lists: the 12 moving entries of ġ per node."""
    return [
        [[[(a[r][c] - b[r][c]) / two_h for c in range(4)] for r in range(3)] for a, b in zip(sp, sm, strict=True)]
        for sp, sm in zip(plus, minus, strict=True)
    ]


def _entrywise(op, v1, v2):
    """``op`` entry by entry on two per-node matrix lists ``[segment][node][row][col]``."""
    return [
        [
            [[op(x, y) for x, y in zip(r1, r2, strict=True)] for r1, r2 in zip(n1, n2, strict=True)]
            for n1, n2 in zip(s1, s2, strict=True)
        ]
        for s1, s2 in zip(v1, v2, strict=True)
    ]


def _mean(v1, v2):
    return _entrywise(lambda x, y: (x + y) / 2, v1, v2)


def _add(v1, v2):
    return _entrywise(lambda x, y: x + y, v1, v2)


def _kinetic(robot: _Robot, poses, vel, rho_a, rho_i) -> mpmath.mpf:
    """``T`` of the velocity field ``vel`` (per node ``ġ``) at the configuration ``poses``."""
    total = mp.zero
    for i in range(robot.m):
        seg = mp.zero
        for g, gd, w in zip(poses[i], vel[i], robot.w[i], strict=True):
            pdot2 = gd[0][3] ** 2 + gd[1][3] ** 2 + gd[2][3] ** 2
            # A = Rᵀ Ṙ is skew up to the O(h²) of the difference: take its skew part
            A = [[mpmath.fsum(g[k][r] * gd[k][c] for k in range(3)) for c in range(3)] for r in range(3)]
            wx = (A[2][1] - A[1][2]) / 2
            wy = (A[0][2] - A[2][0]) / 2
            wz = (A[1][0] - A[0][1]) / 2
            seg += w * (rho_a[i] * pdot2 + rho_i[i] * (wx * wx + 2 * wy * wy + wz * wz))
        total += seg
    return total / 2


def _gravity_energy(robot: _Robot, poses, rho_a, g) -> mpmath.mpf:
    total = mp.zero
    for i in range(robot.m):
        total -= rho_a[i] * mpmath.fsum(w * (g[0] * P[0][3] + g[1] * P[1][3] + g[2] * P[2][3])
                                        for P, w in zip(poses[i], robot.w[i], strict=True))
    return total


def _prepare(q, qd, segment_lengths, rho, radius, youngs, shear, damping, gravity, c_sh, length_scaled,
             n_quadrature, dps):
    lengths = _lengths(segment_lengths)
    m = lengths.size
    n = 6 * m
    q = _exact_vector(q, n, "q")
    qd = _exact_vector(qd, n, "qd")
    rho = _per_segment(rho, m, "rho", positive=True)
    radius = _per_segment(radius, m, "radius", positive=True)
    youngs = _per_segment(youngs, m, "youngs", positive=False)
    shear = _per_segment(shear, m, "shear", positive=False)
    damping = _vector(damping, n, "damping")
    gravity = _vector(gravity, 3, "gravity")
    if not (np.isfinite(c_sh) and c_sh > 0):
        raise ValueError(f"c_sh must be finite and > 0; got {c_sh!r}")
    if isinstance(n_quadrature, bool) or int(n_quadrature) != n_quadrature or n_quadrature < 1:
        raise ValueError(f"n_quadrature must be a positive integer; got {n_quadrature!r}")
    return (q, qd, lengths, rho, radius, youngs, shear, damping, gravity, float(c_sh), bool(length_scaled),
            int(n_quadrature), _dps(dps))


def _terms_mp(q, qd, segment_lengths, rho, radius, youngs, shear, damping, gravity, c_sh, length_scaled,
              n_quadrature, dps):
    """All terms as mpmath objects, at the caller's (raised) precision."""
    lengths = segment_lengths
    m = lengths.size
    n = 6 * m
    robot = _Robot(lengths, n_quadrature, mp.dps)
    mpf = mpmath.mpf
    area = [mpmath.pi * mpf(float(r)) ** 2 for r in radius]
    second = [mpmath.pi * mpf(float(r)) ** 4 / 4 for r in radius]
    rho_a = [mpf(float(r)) * a for r, a in zip(rho, area, strict=True)]
    rho_i = [mpf(float(r)) * i for r, i in zip(rho, second, strict=True)]
    g = [mpf(float(v)) for v in gravity]
    qm = [mpf(v) for v in q]
    qdm = [mpf(v) for v in qd]
    scale = max(1.0, float(lengths.sum()))
    h = mpf(10) ** (-(dps // 2 + _STEP_GUARD)) / scale
    two_h = 2 * h
    qd_inf = max(abs(v) for v in qdm)
    u = [v / qd_inf for v in qdm] if qd_inf else [mp.zero] * n

    def point(cu: int, ca: int, a: int | None):
        """Poses at ``q + cu h u + ca h e_a`` (always built in this order, so the cache keys are exact)."""
        if not qd_inf:
            cu = 0  # u = 0: every cu names the same point
        x = [qm[k] + cu * h * u[k] for k in range(n)]
        if ca:
            x[a] += ca * h
        seg_a = None if a is None else a // 6

        def key(i):
            return (cu, ca, a) if (ca and i == seg_a) else (cu, 0, None)

        return robot.poses(key, x)

    # The stencil: q, q ± h u, q ± 2h u and, per a, the four points q ± h u ± h e_a (only segment
    # a // 6 is new there).  Quantities at q ± h e_a are the means over ± h u (an O(h²) error).
    def vel_e(cu, a):
        """ġ along e_a at ``q + cu h u``, cu = ±1."""
        return _velocity(point(cu, 1, a), point(cu, -1, a), two_h)

    def T(poses, vel):
        return _kinetic(robot, poses, vel, rho_a, rho_i)

    def polar(poses, v1, v2):
        """Polarisation of the quadratic form T: the bilinear ``v1ᵀ M v2``."""
        return T(poses, _add(v1, v2)) - T(poses, v1) - T(poses, v2)

    # mass matrix at q
    base = point(0, 0, None)
    Va = [_mean(vel_e(1, a), vel_e(-1, a)) for a in range(n)]
    M = mpmath.matrix(n, n)
    for a in range(n):
        M[a, a] = 2 * T(base, Va[a])
        for b in range(a):
            M[a, b] = M[b, a] = polar(base, Va[a], Va[b])

    # gravity: G_a = ∂U_g/∂q_a
    G = mpmath.matrix(n, 1)
    for a in range(n):
        U = [sum(_gravity_energy(robot, point(cu, ca, a), rho_a, g) for cu in (1, -1)) / 2 for ca in (1, -1)]
        G[a] = (U[0] - U[1]) / two_h

    # C(q, q̇) q̇ = d/dt (M q̇) − ∂T/∂q with q(t) = q + t q̇; both are quadratic in q̇, so work along u
    Cqd = mpmath.matrix(n, 1)
    if qd_inf:
        vu = {cu: _velocity(point(cu + 1, 0, None), point(cu - 1, 0, None), two_h) for cu in (1, -1)}
        for a in range(n):
            # d/dt ∂T/∂q̇_a: the derivative along u of (M(x) u)_a, from x = q ± h u
            mu = [polar(point(cu, 0, None), vu[cu], vel_e(cu, a)) for cu in (1, -1)]
            ddt = (mu[0] - mu[1]) / two_h
            # ∂T/∂q_a from T(q ± h e_a, u)
            t = [T(_mean(point(1, ca, a), point(-1, ca, a)),
                   _velocity(point(1, ca, a), point(-1, ca, a), two_h)) for ca in (1, -1)]
            Cqd[a] = qd_inf**2 * (ddt - (t[0] - t[1]) / two_h)

    f_len = [mpf(float(v)) for v in lengths] if length_scaled else [mp.one] * m
    K = []
    for i in range(m):
        E, Gs = mpf(float(youngs[i])), mpf(float(shear[i]))
        K += [f_len[i] * k for k in (E * second[i], E * second[i], Gs * 2 * second[i],
                                     mpf(c_sh) * Gs * area[i], mpf(c_sh) * Gs * area[i], E * area[i])]
    elastic = mpmath.matrix([K[k] * qm[k] for k in range(n)])
    damp = mpmath.matrix([mpf(float(damping[k])) * qdm[k] for k in range(n)])
    return {"M": M, "coriolis": Cqd, "gravity": G, "elastic": elastic, "damping": damp}


def _to_numpy(terms: dict) -> dict:
    out = {}
    for name, value in terms.items():
        arr = np.array(value.tolist(), dtype=float)
        out[name] = arr if name == "M" else arr.reshape(-1)
    return out


def _round(terms: dict, dps: int) -> dict:
    """The mpmath terms rounded to ``dps`` digits (the working digits beyond it are not meaningful)."""
    with mp.workdps(dps):
        return {k: v.apply(lambda x: +x) for k, v in terms.items()}


# --------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------
def reference_terms(
    q,
    qd,
    segment_lengths: Sequence[float],
    *,
    rho,
    radius,
    youngs,
    shear,
    damping,
    gravity=(0.0, 9.81, 0.0),
    c_sh: float = 4.0 / 3.0,
    length_scaled: bool = False,
    n_quadrature: int = 8,
    dps: int = 40,
    as_mpmath: bool = False,
) -> dict:
    """Terms of ``M q̈ + C q̇ + G + K q + D q̇ = τ`` for a spatial PCS robot, to ``dps`` digits.

    Parameters
    ----------
    q, qd : array_like, shape (6m,)
        Strains and strain rates, six per segment in the COMMON.md order
        (bend_z, bend_x, twist, shear_x, shear_z, axial).  Entries may be ``mpmath.mpf``
        (or an ``mpmath.matrix``): they keep their digits, e.g. to differentiate the terms in ``q``.
    segment_lengths : sequence of float, shape (m,)
    rho, radius, youngs, shear : float or sequence of float, shape (m,)
        Density, cross-section radius, Young's and shear moduli.
    damping : array_like, shape (6m,)
        Diagonal of ``D``.
    gravity : array_like, shape (3,), default (0, 9.81, 0)
    c_sh : float, default 4/3
    length_scaled : bool, default False
        ``f_L = L_i`` in ``K_i`` instead of 1.
    n_quadrature : int, default 8
        Gauss–Legendre nodes per segment.
    dps : int, default 40
        Decimal digits of the result (the work runs at ``2 dps + 25``).
    as_mpmath : bool, default False
        Return ``mpmath.matrix`` objects (rounded to ``dps`` digits; column vectors for the forces)
        instead of float arrays.

    Returns
    -------
    dict
        ``"M"`` (n, n), ``"coriolis"`` ``C(q, q̇) q̇`` (n,), ``"gravity"`` ``G(q)`` (n,),
        ``"elastic"`` ``K q`` (n,), ``"damping"`` ``D q̇`` (n,).
    """
    args = _prepare(q, qd, segment_lengths, rho, radius, youngs, shear, damping, gravity, c_sh, length_scaled,
                    n_quadrature, dps)
    with mp.workdps(_work_dps(args[-1])):
        terms = _terms_mp(*args)
    terms = _round(terms, args[-1])
    return terms if as_mpmath else _to_numpy(terms)


def reference_accelerations(
    q,
    qd,
    tau,
    segment_lengths: Sequence[float],
    *,
    rho,
    radius,
    youngs,
    shear,
    damping,
    gravity=(0.0, 9.81, 0.0),
    c_sh: float = 4.0 / 3.0,
    length_scaled: bool = False,
    n_quadrature: int = 8,
    dps: int = 40,
    as_mpmath: bool = False,
):
    """``q̈ = M⁻¹ (τ − C q̇ − G − K q − D q̇)``, solved in mpmath.

    Parameters are those of :func:`reference_terms`, plus ``tau`` (6m,), the generalised forces.

    Returns
    -------
    ndarray, shape (6m,), or an ``mpmath.matrix`` column when ``as_mpmath``.
    """
    args = _prepare(q, qd, segment_lengths, rho, radius, youngs, shear, damping, gravity, c_sh, length_scaled,
                    n_quadrature, dps)
    tau = _exact_vector(tau, len(args[0]), "tau")
    with mp.workdps(_work_dps(args[-1])):
        t = _terms_mp(*args)
        rhs = mpmath.matrix([mpmath.mpf(v) for v in tau])
        rhs = rhs - t["coriolis"] - t["gravity"] - t["elastic"] - t["damping"]
        qdd = mpmath.lu_solve(t["M"], rhs)
    with mp.workdps(args[-1]):
        qdd = qdd.apply(lambda x: +x)
    return qdd if as_mpmath else np.array(qdd.tolist(), dtype=float).reshape(-1)


def reference_pose(q, segment_lengths: Sequence[float], s: float, dps: int = 40, as_mpmath: bool = False):
    """Backbone pose at the global arc length ``s`` (base frame; robot along +y at ``q = 0``).

    Returns
    -------
    p : ndarray, shape (3,)
    R : ndarray, shape (3, 3)
        Float arrays, or ``mpmath.matrix`` objects when ``as_mpmath``.
    """
    lengths = _lengths(segment_lengths)
    q = _exact_vector(q, 6 * lengths.size, "q")
    dps = _dps(dps)
    s = float(s)
    total = float(lengths.sum())
    if not (np.isfinite(s) and 0.0 <= s <= total):
        raise ValueError(f"s must be in [0, {total}] (the robot's length); got {s!r}")
    with mp.workdps(dps + 10):
        qm = [mpmath.mpf(v) for v in q]
        start = _identity()
        remaining = mpmath.mpf(s)
        for i, Li in enumerate(lengths):
            Li = mpmath.mpf(float(Li))
            strains = qm[6 * i : 6 * i + 6]
            if remaining <= Li or i == lengths.size - 1:
                g = _matmul(start, _as_lists(mpmath.expm(_twist_matrix(strains, remaining))))
                break
            start = _matmul(start, _as_lists(mpmath.expm(_twist_matrix(strains, Li))))
            remaining -= Li
    with mp.workdps(dps):
        p = mpmath.matrix([+g[r][3] for r in range(3)])
        R = mpmath.matrix([[+g[r][c] for c in range(3)] for r in range(3)])
    if as_mpmath:
        return p, R
    return np.array(p.tolist(), dtype=float).reshape(3), np.array(R.tolist(), dtype=float)
