"""Compiled (numba) dynamics of planar PCS models with lumped physical parameters.

A physically parameterised model is fully described by per-segment lumped
parameters: ``rho A_i``, ``rho I_i`` (rotary), ``rho A_i g`` and, per active
strain, stiffness ``k_e``, damping ``d_e`` and a constant force ``f0_e``.  The
kernels evaluate

    M(q) = sum_p w_p rhoA Re(J_p^H J_p) + M_rot,
    bias = Re sum_p w_p J_p^H (rhoA Jdot_p qd - rhoA g) + K q + D qd - f0

with complex backbone positions, closed-form Jacobians and Gauss–Legendre
quadrature: segment j contributes ``e^{i phi_j} w_j l E_0(kappa_j l)`` with
``E_n(u) = int_0^1 t^n e^{iut} dt`` (:func:`moments`, the one implementation of
these integrals on the identification side), exact through ``kappa = 0``.

The parameters travel as one tuple ``P = (act, L, ell, wts, rhoA, rhoAg, M_rot,
stiff, damp, f0, akind, aoff, acover, amat)`` and the work arrays as
``W = (M, bias, J, v, acc, tau)`` (:func:`workspace`), so the rollout loops in
:mod:`pcs_sindy.models._jit_rollout` stay independent of what is inside.  The last
four entries of ``P`` map the inputs ``u`` to generalised forces
(:func:`input_forces`); ``akind`` is the code in :data:`INPUT_MAPS` of the form an
actuation's ``compiled()`` names: ``"forces"`` (``u`` are the forces on the modelled
strains), ``"tendon"`` (tendons at signed offsets ``aoff`` covering ``acover[k, i]`` of
segment i: ``A = -dl/dq``), ``"matrix"`` (a constant matrix ``amat`` (n, p)), ``"servo"``
(servo-wound elastic tendons: tendons whose tension is ``k max(0, r u pi/180 + l(q) - l(0) - s)``,
``amat`` rows ``[k, r, s]`` (3, p)) or ``"affine"`` (a map affine in the strains,
``amat = [B0 | B1 | C0 | C1]`` (n, 2 p (1 + n)): ``tau = sum_k (B0[:, k] + B1[:, k*n:(k+1)*n] q) u_k``
plus the same with ``C`` in ``max(0, u_k)``).  The codes live here only: the actuation
kinds name their form (:data:`pcs_sindy.models.actuation.COMPILED_FORMS`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..core.linalg import solve

__all__ = [
    "moments",
    "moments_array",
    "dynamics",
    "input_forces",
    "strain_layout_free_forces",
    "rhs",
    "mass_bias_batch",
    "workspace",
    "INPUT_MAPS",
]

#: codes of the input maps in ``P[10]`` (module globals: numba compiles them in as constants)
FORCES, TENDON, MATRIX, SERVO, AFFINE = 0, 1, 2, 3, 4
#: the code of each input map by the form name an actuation's ``compiled()`` gives
INPUT_MAPS = {"forces": FORCES, "tendon": TENDON, "matrix": MATRIX, "servo": SERVO, "affine": AFFINE}

_SERIES_RADIUS = 1.0
_N_SERIES = 20  # 1 / 20! < 1e-18
# Horner tables, highest power first: row j holds the coefficient of u^(2(J-1-j)) for n = 0, 1, 2
_SER_RE = np.array(
    [[(-1) ** j / (math.factorial(2 * j) * (n + 2 * j + 1)) for n in range(3)] for j in range(_N_SERIES // 2)]
)[::-1].copy()
_SER_IM = np.array(
    [[(-1) ** j / (math.factorial(2 * j + 1) * (n + 2 * j + 2)) for n in range(3)] for j in range(_N_SERIES // 2)]
)[::-1].copy()


@numba.njit(cache=True)
def moments(u: float):
    """``E_n(u) = int_0^1 t^n e^{iut} dt``, n = 0, 1, 2.

    |u| <= 1: Taylor series, real arithmetic on the even/odd powers (complex
    division is the slow path in compiled code); 20 terms, error < 1/20! < 1e-18.
    |u| > 1: integration by parts, ``E_{n+1} = (e^{iu} - (n+1) E_n) / (iu)``;
    each division by ``|u| > 1`` at most doubles the absolute error.
    """
    if abs(u) <= _SERIES_RADIUS:
        # E_n = sum_k (iu)^k / (k! (n + k + 1)): even k give the real part, odd k the
        # imaginary part, each a polynomial in u^2 (Horner with constant tables)
        u2 = u * u
        r0 = _SER_RE[0, 0]
        r1 = _SER_RE[0, 1]
        r2 = _SER_RE[0, 2]
        i0 = _SER_IM[0, 0]
        i1 = _SER_IM[0, 1]
        i2 = _SER_IM[0, 2]
        for j in range(1, _SER_RE.shape[0]):
            r0 = r0 * u2 + _SER_RE[j, 0]
            r1 = r1 * u2 + _SER_RE[j, 1]
            r2 = r2 * u2 + _SER_RE[j, 2]
            i0 = i0 * u2 + _SER_IM[j, 0]
            i1 = i1 * u2 + _SER_IM[j, 1]
            i2 = i2 * u2 + _SER_IM[j, 2]
        return complex(r0, u * i0), complex(r1, u * i1), complex(r2, u * i2)
    c = math.cos(u)
    sn = math.sin(u)
    # 1/(iu) = -i/u: multiply instead of dividing complex numbers
    inv = 1.0 / u
    e0 = complex(sn * inv, (1.0 - c) * inv)  # (e^{iu} - 1) / (iu)
    a = complex(c, sn) - e0
    e1 = complex(a.imag * inv, -a.real * inv)
    b = complex(c, sn) - 2.0 * e1
    e2 = complex(b.imag * inv, -b.real * inv)
    return e0, e1, e2


@numba.njit(cache=True)
def dynamics(q, qd, P, W):
    """Fill ``W[0] = M`` (n, n) and ``W[1] = bias`` (n,) at the active strains ``q``, ``qd``.

    ``W[2] = J`` (2, 3m, m K) (real, imaginary parts of the Jacobian columns) and
    ``W[3] = v`` (2, m K) (the node forces) are work arrays.
    """
    act, L, ell, wts, rhoA, rhoAg, M_rot, stiff, damp, f0 = P[0], P[1], P[2], P[3], P[4], P[5], P[6], P[7], P[8], P[9]
    M, bias, J, v = W[0], W[1], W[2], W[3]
    m = L.size
    K = wts.shape[1]
    n = act.size
    qf = np.zeros(3 * m)
    qdf = np.zeros(3 * m)
    for a in range(n):
        qf[act[a]] = q[a]
        qdf[act[a]] = qd[a]
    J[:, :, :] = 0.0
    phi = 0.0
    phid = 0.0
    zstart = 0.0j
    acc_start = 0.0j
    acc_end = 0.0j
    own_end_be = np.zeros(m, dtype=np.complex128)
    own_end_sh = np.zeros(m, dtype=np.complex128)
    zend = np.zeros(m, dtype=np.complex128)
    for i in range(m):
        kap = qf[3 * i]
        kd = qdf[3 * i]
        w = qf[3 * i + 1] + 1j * (1.0 + qf[3 * i + 2])
        wd = qdf[3 * i + 1] + 1j * qdf[3 * i + 2]
        eph = np.exp(1j * phi)
        ew = eph * w
        # convective acceleration coefficients (qdd = 0): e^{i phi} (c0 F + c1 F_k + c2 F_kk)
        ipd = 2j * phid
        c0 = ew * (-(phid * phid)) + ipd * eph * wd
        c1 = (ipd * ew + 2.0 * eph * wd) * kd
        c2 = ew * (kd * kd)
        for p in range(K + 1):
            s = ell[i, p]
            e0, e1, e2 = moments(kap * s)
            F = s * e0
            Fk = 1j * s * s * e1
            Fkk = -(s * s * s) * e2
            sh = eph * F
            be = ew * Fk
            T = w * sh
            Tdd = c0 * F + c1 * Fk + c2 * Fkk
            if p == K:
                own_end_be[i] = be
                own_end_sh[i] = sh
                zend[i] = zstart + T
                acc_end = acc_start + Tdd
            else:
                row = i * K + p
                z = zstart + T
                J[0, 3 * i, row] = be.real
                J[1, 3 * i, row] = be.imag
                J[0, 3 * i + 1, row] = sh.real
                J[1, 3 * i + 1, row] = sh.imag
                J[0, 3 * i + 2, row] = -sh.imag
                J[1, 3 * i + 2, row] = sh.real
                for k in range(i):
                    jk = own_end_be[k] + 1j * L[k] * (z - zend[k])
                    J[0, 3 * k, row] = jk.real
                    J[1, 3 * k, row] = jk.imag
                    J[0, 3 * k + 1, row] = own_end_sh[k].real
                    J[1, 3 * k + 1, row] = own_end_sh[k].imag
                    J[0, 3 * k + 2, row] = -own_end_sh[k].imag
                    J[1, 3 * k + 2, row] = own_end_sh[k].real
                wa = wts[i, p] * rhoA[i]
                vr = wa * (acc_start + Tdd) - wts[i, p] * rhoAg[i]
                v[0, row] = vr.real
                v[1, row] = vr.imag
        zstart = zend[i]
        acc_start = acc_end
        phi += kap * L[i]
        phid += kd * L[i]
    _assemble(J, v, act, wts, rhoA, M_rot, stiff, damp, f0, q, qd, M, bias)


# reassociation lets LLVM vectorise the quadrature sums (no NaN/inf assumptions)
@numba.njit(cache=True, fastmath={"reassoc", "contract"})
def _assemble(J, v, act, wts, rhoA, M_rot, stiff, damp, f0, q, qd, M, bias):
    """``M = sum_p w rhoA Re(J^H J) + M_rot`` and ``bias = Re(J^H v) + K q + D qd - f0`` (J as (2, 3m, mK))."""
    n = act.size
    m, K = wts.shape
    for a in range(n):
        ca = act[a]
        sa = ca // 3
        acc = 0.0
        for row in range(sa * K, m * K):
            acc += J[0, ca, row] * v[0, row] + J[1, ca, row] * v[1, row]
        bias[a] = acc + stiff[a] * q[a] + damp[a] * qd[a] - f0[a]
        for b in range(a, n):
            cb = act[b]
            acc = 0.0
            # only nodes beyond both strains' segments see both columns
            for i in range(max(sa, cb // 3), m):
                wa = rhoA[i]
                part = 0.0
                for p in range(K):
                    row = i * K + p
                    part += wts[i, p] * (J[0, ca, row] * J[0, cb, row] + J[1, ca, row] * J[1, cb, row])
                acc += wa * part
            M[a, b] = acc + M_rot[a, b]
            M[b, a] = M[a, b]


@numba.njit(cache=True)
def moments_array(u):
    """:func:`moments` of every element of a 1-D array: three complex arrays."""
    e0 = np.empty(u.size, dtype=np.complex128)
    e1 = np.empty(u.size, dtype=np.complex128)
    e2 = np.empty(u.size, dtype=np.complex128)
    for k in range(u.size):
        e0[k], e1[k], e2[k] = moments(u[k])
    return e0, e1, e2


def workspace(P):
    """Work arrays ``(M, bias, J, v, acc, tau)`` for the parameters ``P``."""
    act, L, wts = P[0], P[1], P[3]
    n, m, K = act.size, L.size, wts.shape[1]
    return (np.empty((n, n)), np.empty(n), np.zeros((2, 3 * m, m * K)), np.zeros((2, m * K)), np.empty(n), np.empty(n))


@numba.njit(cache=True)
def strain_layout_free_forces(kind, amat, q, u, tau):
    """``tau = A(q) u`` for the maps that need no strain layout (``FORCES``, ``MATRIX``, ``AFFINE``); False otherwise.

    Shared with the spatial models (:mod:`pcs_sindy.models._jit_spatial`): ``q`` (n,) the modelled strains.
    """
    n = tau.size
    if kind == FORCES:
        for a in range(n):
            tau[a] = u[a]
        return True
    if kind == MATRIX:
        for a in range(n):
            s = 0.0
            for k in range(u.size):
                s += amat[a, k] * u[k]
            tau[a] = s
        return True
    if kind == AFFINE:
        # affine in the strains, in the inputs and in their positive parts:
        # tau_a = sum_k (B0[a, k] + sum_b B1[a, k, b] q_b) u_k + (C0 + C1 q) max(0, u_k), amat = [B0 | B1 | C0 | C1]
        p = u.size
        block = p * (1 + n)
        for a in range(n):
            s = 0.0
            for part in range(2):
                off = part * block
                for k in range(p):
                    coef = amat[a, off + k]
                    for b in range(n):
                        coef += amat[a, off + p + k * n + b] * q[b]
                    uk = u[k] if part == 0 else max(u[k], 0.0)
                    s += coef * uk
            tau[a] = s
        return True
    return False


@numba.njit(cache=True)
def input_forces(q, u, P, tau):
    """``tau = A(q) u`` on the modelled strains ``q`` (n,) for the input map of ``P``."""
    act, L = P[0], P[1]
    kind = P[10][0]
    n = act.size
    if strain_layout_free_forces(kind, P[13], q, u, tau):
        return
    # tendons: l_k = sum_i c_ki sqrt(sh_i^2 + (1 + ax_i + d_k be_i)^2), a tension does -dl/dq
    aoff, acover = P[11], P[12]
    m = L.size
    qf = np.zeros(3 * m)
    for a in range(n):
        qf[act[a]] = q[a]
    full = np.zeros(3 * m)
    for k in range(u.size):
        d = aoff[k]
        force = u[k]
        if kind == SERVO:
            # servo-wound elastic tendon: f = k max(0, r u pi/180 + l(q) - l(0) - s), amat rows [k, r, s]
            drive = P[13]
            ell = 0.0
            rest = 0.0
            for i in range(m):
                c = acover[k, i]
                if c == 0.0:
                    continue
                w = 1.0 + qf[3 * i + 2] + d * qf[3 * i]
                ell += c * math.sqrt(qf[3 * i + 1] ** 2 + w * w)
                rest += c
            e = drive[1, k] * u[k] * (math.pi / 180.0) + ell - rest - drive[2, k]
            force = drive[0, k] * e if e > 0.0 else 0.0
        for i in range(m):
            c = acover[k, i]
            if c == 0.0:
                continue
            kap = qf[3 * i]
            sh = qf[3 * i + 1]
            w = 1.0 + qf[3 * i + 2] + d * kap
            scale = c * force / math.sqrt(sh * sh + w * w)
            full[3 * i] -= scale * d * w
            full[3 * i + 1] -= scale * sh
            full[3 * i + 2] -= scale * w
    for a in range(n):
        tau[a] = full[act[a]]


@numba.njit(cache=True)
def rhs(y, u, P, W, out):
    """``out = [qd, M^-1 (A(q) u - bias)]`` at the state ``y = [q, qd]``; False if ``M`` is singular."""
    n = P[0].size
    tau = W[5]
    input_forces(y[:n], u, P, tau)
    dynamics(y[:n], y[n:], P, W)
    M, bias, acc = W[0], W[1], W[4]
    for a in range(n):
        bias[a] = tau[a] - bias[a]
        out[a] = y[n + a]
    # LU, not Cholesky: an identified M need not be positive definite
    ok = solve(M, bias, acc)
    for a in range(n):
        out[n + a] = acc[a]
    return ok


@numba.njit(cache=True)
def mass_bias_batch(q, qd, P, W):
    """``M`` (B, n, n) and bias (B, n) at the states ``q``, ``qd`` (B, n)."""
    B, n = q.shape
    Ms = np.empty((B, n, n))
    bs = np.empty((B, n))
    for b in range(B):
        dynamics(q[b], qd[b], P, W)
        Ms[b] = W[0]
        bs[b] = W[1]
    return Ms, bs
