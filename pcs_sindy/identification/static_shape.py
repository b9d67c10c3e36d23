"""Static holds of a tendon-driven rod in 3-D: markers of held loads -> a stiffness / gravity / tendon model.

A tendon-driven soft robot held still under constant tendon loads rests where its elastic moment
balances the tendons' and gravity's.  Two tendons that are *not* on opposite sides of the backbone
(the common case of a two-tendon tentacle: their sum bends the body one way, their difference the
other) bend it out of any single plane, so the holds of one set-up do not share a plane.  This
module models the robot in 3-D:

* ``n_segments`` constant-curvature segments, bending only (two curvatures per segment, about the
  body's x and y axes; no torsion, no stretch);
* per segment ``i`` the equilibrium ``L_i w_i = A_i u + L_i w0_i - c_i dV/dw_i``: the elastic moment
  ``k_i L_i (w_i - w0_i)`` against the tendons' (tendons ending at the tip give every segment a
  constant body-frame moment per unit load: ``A_i = B / k_i``, the compliance) and the weight's
  (``V`` the height of the centre of mass, ``c_i`` the weight over the stiffness);
* markers at arc lengths ``s_j`` with offsets along one cross-section axis (markers glued ~2 cm off
  the backbone along one face), a base standing along ``vertical`` at the recorded base marker.

Fitting, :meth:`StaticShapeRegressor.fit` on the holds' mean marker positions ``(H, M, 3)``:

1. the geometry (roll about the base tangent, marker arc lengths and offsets) with free curvatures
   per hold, by bounded least squares on the markers (a short multistart over the markers' side,
   then refined; its RMS is ``shape_rms_``);
2. the equilibrium's coefficients per segment by linear least squares at the fitted curvatures, for
   each term set of :attr:`StaticShapeRegressor.TERM_SETS`; a set whose equations are
   rank-deficient on the holds is dropped and listed in ``dropped_`` (never a silent arbitrary
   answer); among the rest, the leave-one-hold-out marker error over the training holds picks the
   terms, by the one-standard-error rule;
3. prediction: :meth:`StaticShapeRegressor.equilibrium` solves the equilibrium with
   :func:`scipy.optimize.root` from the nearest training hold's shape.

Scale convention: equilibria fix only curvature per unit load; ``stiffness_`` is reported for a
mean tendon moment arm of ``tendon_offset`` with the loads in the user's units.
"""

from __future__ import annotations

import warnings
from numbers import Integral, Real
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares, root
from scipy.spatial.transform import Rotation
from sklearn.base import BaseEstimator
from sklearn.utils.validation import check_is_fitted

from ..core.validation import Check, Interval, Options, validate_parameters

__all__ = ["StaticShapeRegressor", "cc_points"]

#: quadrature points per segment for the weight's potential
_N_QUAD = 8


def _rodrigues(w: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrices (..., 3, 3) of rotation vectors ``w`` (..., 3) whose z component is 0."""
    theta = np.linalg.norm(w, axis=-1)[..., None, None]
    K = np.zeros(w.shape[:-1] + (3, 3))
    K[..., 0, 2], K[..., 1, 2] = w[..., 1], -w[..., 0]
    K[..., 2, 0], K[..., 2, 1] = -w[..., 1], w[..., 0]
    # sin(t)/t and (1 - cos t)/t^2, both smooth at 0
    a = np.sinc(theta / np.pi)
    b = 0.5 * np.sinc(theta / (2 * np.pi)) ** 2
    return np.eye(3) + a * K + b * (K @ K)


def _cc_step(w: NDArray[np.float64], sigma: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Local rotation (..., 3, 3) and displacement (..., 3) after arc ``sigma`` of curvature ``w = (wx, wy)``."""
    wv = np.zeros(np.broadcast_shapes(w.shape[:-1], np.shape(sigma)) + (3,))
    wv[..., :2] = w[..., :2] * np.asarray(sigma)[..., None]
    theta = np.linalg.norm(wv, axis=-1)
    sig = np.broadcast_to(sigma, theta.shape)
    R = _rodrigues(wv)
    # displacement: int_0^sigma exp(s w^) e_z ds
    c1 = sig * np.sinc(theta / np.pi)  # sin(t)/k
    c2 = sig * 0.5 * np.sinc(theta / (2 * np.pi)) ** 2  # (1 - cos t)/(k t) * t = (1 - cos t)/t^2 * sigma
    d = np.zeros_like(wv)
    d[..., 0] = c2 * wv[..., 1]
    d[..., 1] = -c2 * wv[..., 0]
    d[..., 2] = c1
    return R, d


def cc_points(
    w: ArrayLike, lengths: ArrayLike, s: ArrayLike, base_R: ArrayLike | None = None, base_p: ArrayLike | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Backbone frames of a 3-D piecewise-constant-curvature rod (bending only) at arc lengths ``s``.

    Parameters
    ----------
    w : array_like, shape (m, 2)
        Curvatures of the segments about the body x and y axes [1/m].
    lengths : array_like, shape (m,)
        Segment lengths [m].
    s : array_like, shape (k,)
        Arc lengths from the base; beyond the tip the last segment continues.
    base_R, base_p : array_like, optional
        Base orientation (3, 3) (its z column the base tangent) and position (3,); default identity, 0.

    Returns
    -------
    R : ndarray, shape (k, 3, 3)
    p : ndarray, shape (k, 3)
    """
    w = np.asarray(w, dtype=float).reshape(-1, 2)
    L = np.asarray(lengths, dtype=float)
    s = np.asarray(s, dtype=float)
    R0 = np.eye(3) if base_R is None else np.asarray(base_R, dtype=float)
    p0 = np.zeros(3) if base_p is None else np.asarray(base_p, dtype=float)
    ends = np.cumsum(L)
    starts = ends - L
    Rs, ds = _cc_step(w, L)
    Rk, pk = [R0], [p0]
    for i in range(L.size - 1):
        pk.append(pk[-1] + Rk[-1] @ ds[i])
        Rk.append(Rk[-1] @ Rs[i])
    Rk, pk = np.asarray(Rk), np.asarray(pk)
    seg = np.clip(np.searchsorted(ends, s, side="left"), 0, L.size - 1)
    seg = np.where(s < 0, 0, seg)
    Rl, dl = _cc_step(w[seg], s - starts[seg])
    R = Rk[seg] @ Rl
    p = pk[seg] + np.einsum("kij,kj->ki", Rk[seg], dl)
    return R, p


class StaticShapeRegressor(BaseEstimator):
    """Identify a 3-D static model of a tendon-driven rod from the markers of held loads.

    Parameters
    ----------
    n_segments : int, default 2
        Constant-curvature segments of equal length.  Their bending stiffnesses are tied when the
        holds cannot tell them apart (see ``dropped_``).
    length : float or None, default None
        The body's length [m] from its base; default: the tip marker's fitted arc length.
    marker_arc_lengths : array_like of shape (M - 1,) or None, default None
        Arc lengths [m] of the markers after the base marker; default: fitted.
    tendon_offset : float, default 0.02
        The scale convention: the tendons' mean moment arm [m] (the loads in the user's units).
        Equilibria do not depend on it; ``stiffness_`` and ``weight_`` are reported in its units.
    vertical : array_like of shape (3,), default (0, 1, 0)
        Up in the capture frame (gravity acts along ``-vertical``; its sign is identified, so a
        hanging robot is fine too).
    gravity : bool, default True
        Model the body's weight (dropped, and said so, when the holds do not determine it).
    rank_tol : float, default 1e-3
        Relative singular value (columns scaled to unit norm) below which a term set's equations
        count as rank-deficient on the holds.
    base : {"vertical", "free"}, default "vertical"
        ``"vertical"``: the base stands along ``vertical`` at the recorded base marker (a clamped
        robot); ``"free"``: its position may move 0.3 body lengths and its tangent tilt.

    Attributes
    ----------
    base_position_ : ndarray (3,)
    base_rotation_ : ndarray (3, 3)
        Columns: body x, body y, base tangent in the capture frame.
    marker_arc_lengths_ : ndarray (M - 1,)
    marker_offsets_ : ndarray (M - 1, 2)
        Each body marker's offset from the backbone in the cross-section [m].
    segment_lengths_ : ndarray (n_segments,)
    shape_curvatures_ : ndarray (H, n_segments, 2)
        The training holds' curvatures of the kinematic fit.
    terms_ : tuple of str
        The chosen term set; ``term_errors_`` the leave-one-hold-out mean marker error [m] per set.
    coef_ : list of ndarray
        Per segment the equilibrium's coefficients (compliance row-major, rest curvature, weight).
    compliance_ : ndarray (n_segments, 2, p)
        ``L_i w_i`` per unit load of each tendon.
    rest_curvature_ : ndarray (n_segments, 2)
    stiffness_ : ndarray (n_segments,)
        Bending stiffness under the scale convention.
    tendon_arms_ : ndarray (n_segments, 2, p)
        Body-frame moment per unit load of each tendon under the scale convention.
    weight_ : ndarray (n_segments,)
        Weight per unit length under the scale convention (0 without the gravity term).
    dropped_ : list of str
        Term sets dropped because the holds did not determine them.
    singular_values_ : ndarray (n_segments,)
        Smallest relative singular value of the chosen terms' equations per segment.
    shape_rms_ : float
        RMS marker error [m] of the kinematic fit (free curvatures per hold).
    fit_rms_ : float
        RMS marker error [m] of the training holds' equilibria.
    input_range_ : ndarray (2, p)
        Smallest and largest training load per tendon; ``equilibrium`` warns outside it.
    """

    _parameter_constraints: dict = {
        "n_segments": [Interval(Integral, 1, None, closed="left")],
        "length": [Interval(Real, 0, None, closed="neither"), None],
        "marker_arc_lengths": [
            Check(lambda v: np.asarray(v, dtype=float).ndim == 1, "a 1-D array of arc lengths [m]"),
            None,
        ],
        "tendon_offset": [Interval(Real, 0, None, closed="neither")],
        "vertical": [Check(lambda v: np.asarray(v, dtype=float).shape == (3,), "a 3-vector")],
        "gravity": ["boolean"],
        "base": [Options(("vertical", "free"))],
        "rank_tol": [Interval(Real, 0, 1, closed="neither")],
    }

    def __init__(
        self,
        n_segments: int = 2,
        *,
        length: float | None = None,
        marker_arc_lengths: ArrayLike | None = None,
        tendon_offset: float = 0.02,
        vertical: ArrayLike = (0.0, 1.0, 0.0),
        gravity: bool = True,
        rank_tol: float = 1e-3,
        base: str = "vertical",
    ) -> None:
        self.n_segments = n_segments
        self.length = length
        self.marker_arc_lengths = marker_arc_lengths
        self.tendon_offset = tendon_offset
        self.vertical = vertical
        self.gravity = gravity
        self.rank_tol = rank_tol
        self.base = base

    # ---------------------------------------------------------------- geometry
    def _unpack_geometry(self, g: NDArray[np.float64], n_markers: int) -> dict[str, Any]:
        """Geometry from its parameter vector: base shift (3), base rotation vector (3), the markers'
        arc-length increments (unless given) and their offsets along the body x axis (one direction
        for all markers: glued along one face; the roll about the base tangent is its gauge)."""
        nb = n_markers - 1
        k = 7
        if self._s_given is None:
            s = np.cumsum(g[k : k + nb])
            k += nb
        else:
            s = self._s_given
        offs = np.zeros((nb, 2))
        offs[:, 0] = g[k : k + nb]
        k += nb
        L = self.length if self.length is not None else s[-1]
        return {
            "p": self._base + g[:3],
            "R": Rotation.from_rotvec(g[3:6]).as_matrix() @ Rotation.from_rotvec([0.0, 0.0, g[6]]).as_matrix(),
            "s": s,
            "offsets": offs,
            "lengths": np.full(self.n_segments, L / self.n_segments),
            "n": k,
        }

    @staticmethod
    def _markers(w: NDArray[np.float64], geo: dict[str, Any]) -> NDArray[np.float64]:
        R, p = cc_points(w, geo["lengths"], geo["s"], geo["R"], geo["p"])
        return p + R[:, :, 0] * geo["offsets"][:, :1] + R[:, :, 1] * geo["offsets"][:, 1:]

    def _fit_geometry(self, P: NDArray[np.float64]) -> tuple[dict[str, Any], NDArray[np.float64], float]:
        H, M, _ = P.shape
        m = self.n_segments
        base = P[:, 0].mean(axis=0)
        up = np.asarray(self.vertical, dtype=float)
        up = up / np.linalg.norm(up)
        # the base stands along the vertical from the recorded base marker (a clamped robot); only the roll
        # about it (the markers' side) is fitted: a free base pose trades off against the arc lengths
        rot0 = Rotation.align_vectors(self._up[None], np.array([[0.0, 0.0, 1.0]]))[0].as_rotvec()
        chords = np.linalg.norm(np.diff(P, axis=1), axis=2).mean(axis=0)
        self._base = base
        self._base_marker = base.copy()
        span = float(np.linalg.norm(P[:, -1] - base, axis=1).max())
        tilt = 0.0 if self.base == "vertical" else np.pi / 2
        shift = 0.0 if self.base == "vertical" else 0.3 * span
        g0, lo, hi = (
            [np.zeros(3), rot0, [0.0]],
            [np.full(3, -shift) - 1e-9, rot0 - tilt - 1e-9, [-np.pi]],
            [np.full(3, shift) + 1e-9, rot0 + tilt + 1e-9, [np.pi]],
        )
        if self._s_given is None:
            g0.append(chords)
            lo.append(np.full(M - 1, 1e-3 * span))
            hi.append(np.full(M - 1, 2.0 * span))
        g0.append(np.zeros(M - 1))
        lo.append(np.full(M - 1, -0.2 * span))
        hi.append(np.full(M - 1, 0.2 * span))
        g0, lo, hi = (np.concatenate(v) for v in (g0, lo, hi))
        n_geo = g0.size
        body = P[:, 1:]
        w_max = 4 * np.pi / span  # two turns over the body
        lo = np.r_[lo, np.full(H * m * 2, -w_max)]
        hi = np.r_[hi, np.full(H * m * 2, w_max)]

        def residual(x: NDArray[np.float64]) -> NDArray[np.float64]:
            geo = self._unpack_geometry(x[:n_geo], M)
            W = x[n_geo:].reshape(H, m, 2)
            return np.concatenate([(self._markers(W[h], geo) - body[h]).ravel() for h in range(H)])

        # each hold's curvatures move only its own markers: a sparse Jacobian
        sparsity = np.zeros((H * (M - 1) * 3, n_geo + H * m * 2), dtype=bool)
        sparsity[:, :n_geo] = True
        for h in range(H):
            sparsity[h * (M - 1) * 3 : (h + 1) * (M - 1) * 3, n_geo + h * m * 2 : n_geo + (h + 1) * m * 2] = True
        # start each hold bent towards its tip: the bending direction in the base's cross-section
        R0 = Rotation.from_rotvec(rot0).as_matrix()
        w0 = np.zeros((H, m, 2))
        for h in range(H):
            d = R0.T @ (P[h, -1] - base)
            lat = np.hypot(d[0], d[1])
            kappa = 2 * lat / max(np.sum(d**2), 1e-12)  # the circle through base and tip, tangent at the base
            w0[h] = kappa * np.array([d[1], -d[0]]) / max(lat, 1e-12)
        # the markers' side of the backbone is not known: start from both, keep the better fit
        best = None
        for sign, roll in ((1.0, 0.0), (-1.0, 0.0), (1.0, np.pi / 2), (-1.0, np.pi / 2)):
            x0 = np.r_[g0, w0.ravel()]
            x0[6] = roll
            x0[n_geo - (M - 1) : n_geo] = sign * 0.05 * span
            sol = least_squares(
                residual, np.clip(x0, lo + 1e-9, hi - 1e-9), bounds=(lo, hi), jac_sparsity=sparsity, max_nfev=20
            )
            if best is None or sol.cost < best.cost:
                best = sol
        best = least_squares(
            residual,
            best.x,
            bounds=(lo, hi),
            jac_sparsity=sparsity,
            ftol=1e-10,
            xtol=1e-10,
            max_nfev=200,
            x_scale="jac",
        )
        geo = self._unpack_geometry(best.x[:n_geo], M)
        W = best.x[n_geo:].reshape(H, m, 2)
        rms = float(np.sqrt(np.mean(np.sum(residual(best.x).reshape(-1, 3) ** 2, axis=1))))
        return geo, W, rms

    # ---------------------------------------------------------------- statics
    def _weight_potential(self, w: NDArray[np.float64], geo: dict[str, Any]) -> float:
        """Height of the body's centre of mass times its length (a uniform weight per unit length)."""
        L = geo["lengths"]
        frac = (np.arange(_N_QUAD) + 0.5) / _N_QUAD
        s = (np.cumsum(L) - L)[:, None] + L[:, None] * frac[None, :]
        _, p = cc_points(w, L, s.ravel(), geo["R"], geo["p"])
        return float(np.sum((p @ self._up) * np.repeat(L / _N_QUAD, _N_QUAD)))

    def _weight_gradient(self, w: NDArray[np.float64], geo: dict[str, Any]) -> NDArray[np.float64]:
        """d(potential)/dw (m, 2) by central differences (a smooth function of a handful of curvatures)."""
        flat = w.ravel()
        out = np.empty(flat.size)
        eps = 1e-6
        for j in range(flat.size):
            e = np.zeros(flat.size)
            e[j] = eps
            out[j] = (
                self._weight_potential((flat + e).reshape(w.shape), geo)
                - self._weight_potential((flat - e).reshape(w.shape), geo)
            ) / (2 * eps)
        return out.reshape(w.shape)

    #: the term sets compared by leave-one-hold-out error over the training holds
    TERM_SETS = (("tendon", "rest"), ("tendon", "rest", "gravity"), ("tendon",), ("tendon", "gravity"))

    def _design(
        self, W: NDArray[np.float64], U: NDArray[np.float64], G: NDArray[np.float64], i: int, terms: tuple[str, ...]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Rows (2H, n_terms) and targets (2H,) of segment ``i``'s equilibrium ``L w = A u + L w0 - c dV/dw``."""
        H, p = U.shape
        L = self._geo["lengths"][i]
        X, y = [], []
        for h in range(H):
            for c in range(2):
                row = [np.eye(2)[c][:, None] * U[h][None, :]]  # A (2, p), row-major
                parts = [row[0].ravel()]
                if "rest" in terms:
                    parts.append(L * np.eye(2)[c])
                if "gravity" in terms:
                    parts.append([-G[h, i, c]])
                X.append(np.concatenate(parts))
                y.append(L * W[h, i, c])
        return np.asarray(X), np.asarray(y)

    def _fit_terms(
        self, W: NDArray[np.float64], U: NDArray[np.float64], G: NDArray[np.float64], terms: tuple[str, ...]
    ) -> tuple[list[NDArray[np.float64]], NDArray[np.float64]]:
        """Per-segment coefficients by least squares, and the smallest relative singular value per segment."""
        coefs, conds = [], []
        for i in range(self.n_segments):
            X, y = self._design(W, U, G, i, terms)
            norms = np.linalg.norm(X, axis=0)
            norms[norms == 0] = 1.0
            sv = np.linalg.svd(X / norms, compute_uv=False)
            conds.append(sv[-1] / sv[0])
            coefs.append(np.linalg.lstsq(X / norms, y, rcond=None)[0] / norms)
        return coefs, np.asarray(conds)

    def _solve(
        self, u: NDArray[np.float64], coefs: list[NDArray[np.float64]], terms: tuple[str, ...], w0: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], bool]:
        m, p = self.n_segments, u.size
        L = self._geo["lengths"]

        def F(x: NDArray[np.float64]) -> NDArray[np.float64]:
            w = x.reshape(m, 2)
            g = self._weight_gradient(w, self._geo) if "gravity" in terms else None
            out = []
            for i, cf in enumerate(coefs):
                f = cf[: 2 * p].reshape(2, p) @ u
                k = 2 * p
                if "rest" in terms:
                    f = f + L[i] * cf[k : k + 2]
                    k += 2
                if "gravity" in terms:
                    f = f - cf[k] * g[i]
                out.append(L[i] * w[i] - f)
            return np.concatenate(out)

        sol = root(F, np.asarray(w0, dtype=float).ravel(), method="hybr", options={"xtol": 1e-12})
        # the residual is L w minus the loads' (and weight's) share: tolerate 1e-6 of the bending it balances
        scale = float(np.max(np.abs(L[:, None] * sol.x.reshape(m, 2)), initial=0.0)) + 1e-9
        ok = bool(np.all(np.isfinite(sol.x)) and np.abs(F(sol.x)).max() <= 1e-6 * scale)
        return sol.x.reshape(m, 2), ok

    def fit(self, positions: ArrayLike, inputs: ArrayLike) -> StaticShapeRegressor:
        """Fit on the holds' marker positions.

        Parameters
        ----------
        positions : array_like, shape (H, M, 3)
            Each hold's mean marker positions [m] in the capture frame, ordered from the base marker
            (first) to the tip (see :func:`pcs_sindy.core.order_markers`).
        inputs : array_like, shape (H, p)
            Each hold's tendon loads.

        Returns
        -------
        self
        """
        validate_parameters(self)
        P = np.asarray(positions, dtype=float)
        U = np.asarray(inputs, dtype=float)
        if P.ndim != 3 or P.shape[2] != 3 or P.shape[1] < 3:
            raise ValueError(f"positions must have shape (H, M, 3) with M >= 3 markers; got {P.shape}")
        if U.ndim != 2 or U.shape[0] != P.shape[0]:
            raise ValueError(f"inputs must have shape (H, p) with H = {P.shape[0]} holds; got {U.shape}")
        if not (np.all(np.isfinite(P)) and np.all(np.isfinite(U))):
            raise ValueError("positions and inputs must be finite (average each hold over its valid samples)")
        up = np.asarray(self.vertical, dtype=float)
        if up.shape != (3,) or not np.linalg.norm(up) > 0:
            raise ValueError(f"vertical must be a non-zero 3-vector; got {self.vertical!r}")
        self._up = up / np.linalg.norm(up)
        self._s_given = None if self.marker_arc_lengths is None else np.asarray(self.marker_arc_lengths, dtype=float)
        if self._s_given is not None and self._s_given.shape != (P.shape[1] - 1,):
            raise ValueError(
                f"marker_arc_lengths must hold {P.shape[1] - 1} values (markers after the base); "
                f"got {self._s_given.shape}"
            )
        H = P.shape[0]
        p = U.shape[1]
        geo, W, self.shape_rms_ = self._fit_geometry(P)
        self._geo = geo
        self.base_position_, self.base_rotation_ = geo["p"], geo["R"]
        self.marker_arc_lengths_, self.marker_offsets_, self.segment_lengths_ = geo["s"], geo["offsets"], geo["lengths"]
        self.shape_curvatures_ = W
        self.input_range_ = np.stack([U.min(axis=0), U.max(axis=0)])
        G = np.array([self._weight_gradient(w, geo) for w in W])
        body = P[:, 1:]

        # which terms: the least leave-one-hold-out marker error over the training holds, among the term
        # sets the holds determine (a set whose equations are rank-deficient is dropped and reported)
        self.dropped_, self.term_errors_ = [], {}
        spread: dict[str, float] = {}
        allowed = [t for t in self.TERM_SETS if self.gravity or "gravity" not in t]
        for terms in allowed:
            _, conds = self._fit_terms(W, U, G, terms)
            if np.any(conds < self.rank_tol):
                self.dropped_.append(f"{'+'.join(terms)}: rank-deficient (relative singular value {conds.min():.2e})")
                continue
            errs = []
            for h in range(H):
                keep = np.arange(H) != h
                cf, c2 = self._fit_terms(W[keep], U[keep], G[keep], terms)
                if np.any(c2 < self.rank_tol):
                    errs.append(np.inf)
                    continue
                start = W[keep][int(np.argmin(np.linalg.norm(U[keep] - U[h], axis=1)))]
                w, ok = self._solve(U[h], cf, terms, start)
                errs.append(float(np.linalg.norm(self._markers(w, geo) - body[h], axis=1).mean()) if ok else np.inf)
            self.term_errors_["+".join(terms)] = float(np.mean(errs))
            spread["+".join(terms)] = float(np.std(errs) / np.sqrt(H)) if np.all(np.isfinite(errs)) else np.inf
        if not self.term_errors_:
            raise ValueError(f"the {H} holds determine none of the models {allowed}: {self.dropped_}")
        # one-standard-error rule: the fewest parameters whose error is within a standard error of the
        # least (7 holds cannot tell close candidates apart; the smaller model extrapolates more safely)
        least = min(self.term_errors_, key=self.term_errors_.get)
        within = [t for t in self.term_errors_ if self.term_errors_[t] <= self.term_errors_[least] + spread[least]]
        best = min(within, key=lambda t: (self._n_params(t.split("+"), p), self.term_errors_[t]))
        self.terms_ = tuple(best.split("+"))
        self.coef_, conds = self._fit_terms(W, U, G, self.terms_)
        self.singular_values_ = conds
        self._report_parameters(p)
        self._train_inputs = U
        self._train_w = np.array([self._solve(U[h], self.coef_, self.terms_, W[h])[0] for h in range(H)])
        pred = np.array([self._markers(w, geo) for w in self._train_w])
        self.fit_rms_ = float(np.sqrt(np.mean(np.sum((pred - body) ** 2, axis=2))))
        return self

    @staticmethod
    def _n_params(terms: Any, p: int) -> int:
        """Coefficients per segment of a term set."""
        return 2 * p + 2 * ("rest" in terms) + ("gravity" in terms)

    def _report_parameters(self, p: int) -> None:
        """Physical parameters under the scale convention (mean tendon moment arm = ``tendon_offset``)."""
        m = self.n_segments
        self.compliance_ = np.array([cf[: 2 * p].reshape(2, p) for cf in self.coef_])  # (m, 2, p): L w per unit load
        k = 2 * p
        self.rest_curvature_ = (
            np.array([cf[k : k + 2] for cf in self.coef_]) if "rest" in self.terms_ else np.zeros((m, 2))
        )
        k += 2 if "rest" in self.terms_ else 0
        arms = np.linalg.norm(self.compliance_, axis=1).mean(axis=1)  # |B| / k per segment
        self.stiffness_ = self.tendon_offset / arms  # k with |B| = tendon_offset
        self.tendon_arms_ = self.compliance_ * self.stiffness_[:, None, None]
        self.weight_ = (
            np.array([cf[k] for cf in self.coef_]) * self.stiffness_ if "gravity" in self.terms_ else np.zeros(m)
        )

    def equilibrium(self, u: ArrayLike, w0: ArrayLike | None = None) -> NDArray[np.float64]:
        """Curvatures (n_segments, 2) the model rests at under loads ``u`` (p,), started from the
        training hold with the nearest loads (or ``w0``)."""
        check_is_fitted(self, "coef_")
        u = np.asarray(u, dtype=float)
        if u.shape != (self._train_inputs.shape[1],) or not np.all(np.isfinite(u)):
            raise ValueError(f"u must be {self._train_inputs.shape[1]} finite loads; got {u!r}")
        if np.any(u < self.input_range_[0]) or np.any(u > self.input_range_[1]):
            warnings.warn(
                f"loads {u.tolist()} outside the training range {self.input_range_.tolist()}: extrapolating",
                stacklevel=2,
            )
        if w0 is None:
            starts = [self._train_w[j] for j in np.argsort(np.linalg.norm(self._train_inputs - u, axis=1))]
        else:
            starts = [np.asarray(w0, dtype=float)]
        for start in starts + [np.zeros_like(starts[0])]:  # nearest training hold first, the straight robot last
            w, ok = self._solve(u, self.coef_, self.terms_, start)
            if ok:
                break
        if not ok:
            from pcs_sindy.core.simulate_contract import SimulationError

            raise SimulationError(f"no equilibrium found for loads {u.tolist()}", 0.0, w.ravel())
        return w

    def predict(self, inputs: ArrayLike) -> NDArray[np.float64]:
        """Marker positions (H, M, 3) in the capture frame at the equilibria of loads ``inputs`` (H, p);
        the base marker (index 0) is the fitted base's."""
        check_is_fitted(self, "coef_")
        U = np.atleast_2d(np.asarray(inputs, dtype=float))
        out = []
        for u in U:
            body = self._markers(self.equilibrium(u), self._geo)
            out.append(np.vstack([self._base_marker, body]))
        return np.asarray(out)
