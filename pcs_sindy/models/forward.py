"""Forward models of identified dynamics: ``M(q) qdd + bias(q, qd) = tau`` and its rollouts.

A library's :meth:`~pcs_sindy.identification.library.base.LagrangianLibrary.forward_model`
turns coefficients into a :class:`ForwardModel`: batched ``M`` and bias forces
for controllers, and :meth:`ForwardModel.simulate` with the same contract as the
ground-truth simulator (:mod:`pcs_sindy.core.simulate_contract`).

* :class:`LumpedPCSModel` — physically parameterised models (per-segment
  densities, stiffness, damping, constant forces), evaluated by compiled
  kernels (:mod:`pcs_sindy.models._jit_dynamics`) and rolled out by the compiled
  Rosenbrock-W and Dormand–Prince loops (:mod:`pcs_sindy.models._jit_rollout`).
* :class:`CallableModel` — any model given as a function ``(q, qd) -> (M, bias)``
  (e.g. the monomial basis), rolled out with :func:`scipy.integrate.solve_ivp`.

Both take other scipy schemes and callable inputs through
:func:`pcs_sindy.models.integrators.solve_held`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.kinematics import PlanarPCS
from ..core.simulate_contract import SCIPY_METHODS, SimulationError, canonical_method
from ..core.trajectory import StrainTrajectory, check_time
from .integrators import COMPILED_METHODS, solve_held

__all__ = ["ForwardModel", "CompiledForwardModel", "LumpedPCSModel", "CallableModel", "reduce_strains"]


def reduce_strains(kinematics: PlanarPCS, value: ArrayLike, name: str = "q") -> NDArray[np.float64]:
    """Modelled strains of full (..., n_q) or already reduced (..., n) input, checked for NaN."""
    v = np.asarray(value, dtype=float)
    mask = kinematics.active_mask
    n = int(mask.sum())
    if v.ndim == 0 or v.shape[-1] not in (mask.size, n):
        sizes = f"{n} (the strains)" if n == mask.size else f"{mask.size} (all strains) or {n} (modelled strains)"
        raise ValueError(f"{name} must have a last axis of {sizes}; got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        idx = tuple(int(i) for i in np.argwhere(~np.isfinite(v))[0])
        raise ValueError(f"{name} contains NaN or inf ({name}[{', '.join(map(str, idx))}] = {float(v[idx])!r})")
    return v[..., mask] if v.shape[-1] == mask.size and mask.size != n else v


class ForwardModel(ABC):
    """Dynamics of the modelled strains of a segmentation, with rollouts.

    Parameters
    ----------
    kinematics : PlanarPCS
        Segmentation; its active strains are the modelled ones (``n`` of them).

    Attributes
    ----------
    methods : tuple of str
        Integration schemes :meth:`simulate` accepts (names of
        :data:`pcs_sindy.core.simulate_contract.METHODS`).
    compiled_methods : tuple of str
        Those of :attr:`methods` run by the model's own compiled loop for
        tabulated inputs; every other one goes through ``solve_ivp``.
    default_method : str
        The scheme used when ``method`` is not given (the best measured one).
    compiled_rollouts : bool
        Whether the default scheme runs compiled (rollouts of seconds of data in well under a
        second); False for a model stepped in Python, which callers avoid rolling out unasked.
    """

    methods: tuple[str, ...] = tuple(SCIPY_METHODS)
    compiled_methods: tuple[str, ...] = ()
    default_method: str = "radau"
    compiled_rollouts: bool = True

    def __init__(self, kinematics: PlanarPCS, actuation: Any = None) -> None:
        self.kinematics = kinematics
        self.n = int(kinematics.n_active)
        if actuation is not None and getattr(actuation, "is_identity", False):
            actuation = None
        if actuation is not None and not hasattr(actuation, "kinematics_"):
            raise ValueError("actuation must be fitted to the model's segmentation (actuation.fit(kinematics))")
        #: the fitted :class:`~pcs_sindy.models.Actuation` of the inputs, or None (inputs are generalised forces)
        self.actuation = actuation

    # ------------------------------------------------------------------ evaluation
    @abstractmethod
    def mass_and_bias(self, q: ArrayLike, qd: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``M(q)`` (B, n, n) and ``bias(q, qd)`` (B, n) at states of the modelled strains (B, n)."""

    @abstractmethod
    def terms(self, q: NDArray[np.float64], qd: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``M(q)`` (n, n) and ``bias(q, qd)`` (n,) at ONE state of the modelled strains (n,).

        The hot path of controllers and integrators: no input checks; ``q`` and
        ``qd`` must be float arrays of the n modelled strains.  The returned
        arrays are new (the caller may keep them).
        """

    @property
    def n_inputs(self) -> int:
        """Columns of the input ``u``: the actuators', or one generalised force per strain (n_q = 3m or 6m)."""
        return int(self.kinematics.n_q) if self.actuation is None else int(self.actuation.n_inputs_)

    @property
    def input_bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """Bounds (lower, upper) of the inputs (e.g. tendon tensions >= 0), or None."""
        return None if self.actuation is None else self.actuation.input_bounds()

    @property
    def actuation_layout(self) -> dict | None:
        """The actuator layout as the design gives it, or None for generalised-force inputs."""
        return None if self.actuation is None else self.actuation.design_layout()

    def input_matrix(self, q: ArrayLike) -> NDArray[np.float64]:
        """``A(q)`` mapping the input ``u`` (p,) to generalised forces on the modelled strains, shape (..., n, p).

        For a model driven by generalised forces, the selection of the modelled
        strains' columns (constant).
        """
        q = self._reduce(q, "q")
        if self.actuation is not None and not getattr(self.actuation, "linear_in_inputs", True):
            raise ValueError(
                f"{type(self.actuation).__name__}(drive={getattr(self.actuation, 'drive', '?')!r}) acts nonlinearly "
                "in its inputs (servo-wound tendons go slack): there is no input matrix A(q) with forces A(q) u. "
                "Use input_forces(q, u), equilibrium(u), or actuation.matrix(q) (the map of unit tendon tensions)"
            )
        if self.actuation is not None:
            flat = q.reshape(-1, self.n)
            return self.actuation.matrix(flat).reshape(q.shape[:-1] + (self.n, self.n_inputs))
        sel = np.eye(self.kinematics.n_q)[self.kinematics.active_mask]
        return np.broadcast_to(sel, q.shape[:-1] + sel.shape).copy()

    def input_forces(self, q: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        """``A(q) u`` on the modelled strains at one state (hot path: ``u`` as the rollout takes it)."""
        if self.actuation is None:
            return u
        return self.actuation.forces(q[None], u[None])[0]

    @abstractmethod
    def _state_derivative(self, y: NDArray[np.float64], tau: NDArray[np.float64]) -> NDArray[np.float64]:
        """``[qd, M^-1 (tau - bias)]`` at one state (hot path, no checks); LinAlgError if M is singular."""

    def accelerations(self, q: ArrayLike, qd: ArrayLike, tau: ArrayLike) -> NDArray[np.float64]:
        """Forward dynamics ``qdd = M^-1 (tau - bias)`` of states and forces (B, n)."""
        M, bias = self.mass_and_bias(q, qd)
        tau = np.asarray(tau, dtype=float)
        if tau.size != bias.size:
            raise ValueError(
                f"tau must hold one force per modelled strain and state, shape {bias.shape}; got shape {tau.shape}"
            )
        tau = tau.reshape(bias.shape)
        if not np.all(np.isfinite(tau)):
            raise ValueError(
                f"tau contains NaN or inf (first at {tuple(int(i) for i in np.argwhere(~np.isfinite(tau))[0])})"
            )
        return np.linalg.solve(M, (tau - bias)[..., None])[..., 0]

    # ------------------------------------------------------------------ input checks
    def _reduce(self, value: ArrayLike, name: str) -> NDArray[np.float64]:
        return reduce_strains(self.kinematics, value, name)

    def _inputs(self, u: Any, t: NDArray[np.float64]) -> NDArray[np.float64] | Callable[[float], NDArray]:
        mask = self.kinematics.active_mask
        act = self.actuation
        if act is not None:
            if callable(u):
                fn = u

                def checked(time: float) -> NDArray[np.float64]:
                    return act.check_inputs(np.asarray(fn(time), dtype=float).reshape(1, -1), "u(t)", np.array([time]))[
                        0
                    ]

                return checked
            return np.ascontiguousarray(act.check_inputs(u, "u", t))
        if callable(u):
            fn = u

            def reduced(time: float) -> NDArray[np.float64]:
                val = np.asarray(fn(time), dtype=float).reshape(-1)
                if val.size not in (mask.size, self.n):
                    raise ValueError(
                        f"u(t) must return {mask.size} (or {self.n}) forces; got {val.size} at t = {time!r}"
                    )
                if not np.all(np.isfinite(val)):
                    raise ValueError(f"u(t) returned NaN or inf at t = {time!r}: {val.tolist()}")
                return val[mask] if val.size == mask.size and mask.size != self.n else val

            return reduced
        arr = np.asarray(u, dtype=float)
        if arr.ndim != 2 or arr.shape[0] != t.size or arr.shape[1] not in (mask.size, self.n):
            raise ValueError(
                f"u must have shape ({t.size}, {mask.size}) (one row per time, one force per strain); got {arr.shape}"
            )
        return np.ascontiguousarray(self._reduce(arr, "u"))

    # ------------------------------------------------------------------ rollout
    def simulate(
        self,
        q0: ArrayLike,
        qd0: ArrayLike,
        t: ArrayLike,
        u: ArrayLike | Callable[[float], ArrayLike],
        *,
        method: str | None = None,
        rtol: float = 3e-5,
        atol: float = 3e-8,
        step: float | None = None,
        max_step: float | None = None,
        max_abs_state: float = 1e6,
        progress: bool = False,
        stats: dict | None = None,
    ) -> StrainTrajectory:
        """Roll the model out under the input ``u``.

        Parameters
        ----------
        q0, qd0 : array_like, shape (n_q,) or (n,)
            Initial strains and rates (all strains, unmodelled ones ignored, or the modelled ones).
        t : array_like, shape (T,)
            Output times (strictly increasing, at least 2).
        u : array_like, shape (T, p), or callable
            Inputs held constant on ``[t[k], t[k+1])``, or ``u(time)``: the
            generalised forces (p = n_q, or the n modelled ones) or, for a model
            with an :attr:`actuation`, the actuator inputs.
        method : str, optional
            One of :attr:`methods`; default :attr:`default_method`.
        rtol, atol : float
            Error tolerances (scaled RMS norm).
        step : float, optional
            Fixed step of the compiled schemes (must divide every sample
            period); default adaptive.
        max_step : float, optional
            Bound on the adaptive step (default: the sample period for the compiled schemes).
        max_abs_state : float
            A strain or rate larger than this in magnitude means divergence.
        progress : bool
            Progress bar (solve_ivp paths; a compiled rollout is one call).
        stats : dict, optional
            Filled with ``n_steps``, ``n_rejected``, ``n_evaluations`` (compiled schemes).

        Returns
        -------
        StrainTrajectory
            Full strains and rates (T, n_q); strains that are not modelled stay 0.

        Raises
        ------
        SimulationError
            When the state becomes non-finite or unbounded, ``M`` singular or the step collapses.
        """
        method = (
            self.default_method
            if method is None
            else canonical_method(method, self.methods, owner=f"{type(self).__name__}.simulate")
        )
        t = check_time(t, np.size(t), name="t")
        if t.size < 2:
            raise ValueError(f"t must hold at least 2 times; got {t.size}")
        y0 = np.concatenate([self._reduce(np.reshape(q0, -1), "q0"), self._reduce(np.reshape(qd0, -1), "qd0")])
        inputs = self._inputs(u, t)
        for name, val in (("rtol", rtol), ("atol", atol), ("max_abs_state", max_abs_state)):
            if not np.isfinite(val) or val <= 0:
                raise ValueError(f"{name} must be finite and > 0; got {val!r}")
        if max_step is not None and (not np.isfinite(max_step) or max_step <= 0):
            raise ValueError(f"max_step must be finite and > 0; got {max_step!r}")
        if step is not None:
            _check_step(step, t)
        names = self.kinematics.strain_names(active_only=True)
        state_names = names + [f"d{nm}/dt" for nm in names]
        if method in self.compiled_methods and not callable(inputs):
            y = self._rollout_compiled(
                y0,
                t,
                inputs,
                method,
                step=step,
                rtol=rtol,
                atol=atol,
                max_step=max_step,
                max_abs_state=max_abs_state,
                state_names=state_names,
                stats=stats,
            )
        else:
            if step is not None:
                raise ValueError(
                    f"step (fixed steps) is only available for the compiled schemes {COMPILED_METHODS} "
                    f"with tabulated inputs; got method={method!r}"
                )
            if method not in SCIPY_METHODS:
                raise ValueError(
                    f"method={method!r} needs tabulated inputs (an array u); use one of {list(SCIPY_METHODS)} "
                    "with a callable u"
                )
            y = solve_held(
                self._state_derivative,
                y0,
                t,
                inputs,
                method=method,
                rtol=rtol,
                atol=atol,
                max_step=max_step,
                max_abs_state=max_abs_state,
                state_names=state_names,
                progress=progress,
            )
        kin = self.kinematics
        n = self.n
        return self._trajectory(
            kin.to_full(y[:, :n]),
            kin.to_full(y[:, n:]),
            t,
            {"source": f"{type(self).__name__}.simulate", "method": method},
        )

    def _trajectory(self, q_full: NDArray, qd_full: NDArray, t: NDArray, metadata: dict) -> Any:
        """The rollout as the trajectory type of the segmentation (a spatial model returns its own)."""
        kin = self.kinematics
        return StrainTrajectory(
            q_full,
            t,
            segment_lengths=kin.segment_lengths,
            active_strains=kin.active_strains,
            qd=qd_full,
            base_pose=kin.base_pose,
            metadata=metadata,
        )

    def _rollout_compiled(self, y0, t, u, method, **kwargs) -> NDArray[np.float64]:
        raise NotImplementedError(f"{type(self).__name__} declares no compiled scheme")

    # ------------------------------------------------------------------ statics
    def static_residual(self, q: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        """``bias(q, 0) - A(q) u`` on the modelled strains at one configuration (zero at an equilibrium)."""
        return self.terms(q, np.zeros(self.n))[1] - self.input_forces(q, u)

    def equilibrium(
        self,
        u: ArrayLike,
        q0: ArrayLike | None = None,
        *,
        tol: float = 1e-10,
        n_continuation: int = 8,
        progress: bool = False,
    ) -> NDArray[np.float64]:
        """The strains the model rests at under constant inputs (forward statics).

        Solves ``G(q) + K q - f0 = A(q) u`` (the bias forces at rest equal the
        inputs' forces) with :func:`scipy.optimize.root` from ``q0``; when that
        fails, by continuation: the inputs ramped from 0 to ``u`` in
        ``n_continuation`` steps, each solve starting from the last.  It
        finds an equilibrium, not necessarily a stable one: start near the
        expected shape.  The inverse problem (inputs that hold a shape) is
        the control module's statics (:mod:`pcs_sindy.control.statics`).

        Parameters
        ----------
        u : array_like, shape (p,) or (B, p)
            Constant inputs (actuator inputs, or generalised forces on all
            n_q or the n modelled strains for a model without actuation).
            Several rows: one equilibrium each, each solve starting from the
            previous row's equilibrium (order a load sweep by load).
        q0 : array_like, shape (n_q,) or (n,), optional
            Starting guess (default: the straight robot).
        tol : float, default 1e-10
            Tolerance of the root finder; an equilibrium whose residual force
            exceeds ``1e-6`` of the forces involved raises.
        n_continuation : int, default 8
            Steps of the continuation in the inputs (used when the direct solve fails).
        progress : bool, default False
            A tqdm progress bar over the rows of ``u``.

        Returns
        -------
        ndarray, shape (n,) or (B, n)
            Modelled strains at rest.

        Raises
        ------
        SimulationError
            When no equilibrium is found (e.g. inputs beyond what the model can hold).
        """
        from scipy.optimize import root
        from tqdm.auto import tqdm

        u_arr = np.asarray(u, dtype=float)
        single = u_arr.ndim == 1
        rows = np.atleast_2d(u_arr)
        if rows.ndim != 2 or not np.all(np.isfinite(rows)):
            raise ValueError(f"u must be a finite array of shape (p,) or (B, p); got shape {u_arr.shape}")
        if self.actuation is not None:
            rows = self.actuation.check_inputs(rows, "u")
        else:
            rows = self._reduce(rows, "u")
        if isinstance(n_continuation, bool) or int(n_continuation) != n_continuation or n_continuation < 1:
            raise ValueError(f"n_continuation must be a positive integer; got {n_continuation!r}")
        q = np.zeros(self.n) if q0 is None else np.array(self._reduce(q0, "q0"), dtype=float).reshape(-1)
        if q.size != self.n:
            raise ValueError(f"q0 must hold {self.n} modelled strains (or all {self.kinematics.n_q}); got {q.size}")

        def solve(target: NDArray[np.float64], start: NDArray[np.float64]) -> tuple[NDArray[np.float64], bool]:
            sol = root(lambda x: self.static_residual(x, target), start, method="hybr", tol=tol)
            x = np.asarray(sol.x, dtype=float)
            res = self.static_residual(x, target)
            scale = np.abs(self.input_forces(x, target)).max() + np.abs(self.terms(x, np.zeros(self.n))[1]).max()
            ok = bool(np.all(np.isfinite(x))) and float(np.abs(res).max()) <= 1e-6 * max(scale, 1e-12)
            return x, ok

        out = np.empty((rows.shape[0], self.n))
        prev = np.zeros(rows.shape[1])
        for b in tqdm(range(rows.shape[0]), disable=not progress, desc="equilibria"):
            x, ok = solve(rows[b], q)
            if not ok:  # continuation from the previous inputs (or from rest) to these
                x = q.copy()
                for lam in np.linspace(0.0, 1.0, int(n_continuation) + 1)[1:]:
                    x, ok = solve(prev + lam * (rows[b] - prev), x)
                    if not ok:
                        break
            if not ok:
                raise SimulationError(
                    f"no equilibrium found for u[{b}] = {rows[b].tolist()} (static residual above 1e-6 of the "
                    "forces after continuation); the inputs may exceed what the model can hold",
                    0.0,
                    np.r_[x, np.zeros(self.n)],
                )
            out[b] = x
            q, prev = x, rows[b]
        return out[0] if single else out


def _check_step(step: float, t: NDArray[np.float64]) -> None:
    if not np.isfinite(step) or step <= 0:
        raise ValueError(f"step must be finite and > 0; got {step!r}")
    dt = np.diff(t)
    n_sub = dt / step
    bad = np.flatnonzero(np.abs(n_sub - np.maximum(1, np.round(n_sub))) > 1e-6 * n_sub)
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"step = {step!r} does not divide the sample interval t[{k + 1}] - t[{k}] = {dt[k]!r}")


class CallableModel(ForwardModel):
    """A forward model given by functions of the modelled strains.

    Parameters
    ----------
    kinematics : PlanarPCS
    dynamics : callable
        ``dynamics(q, qd) -> (M (n, n), bias (n,))`` at one state (hot path).
    batch : callable, optional
        ``batch(q, qd) -> (M (B, n, n), bias (B, n))``; default: ``dynamics`` per row.
    """

    methods = tuple(SCIPY_METHODS)
    default_method = "radau"

    def __init__(
        self, kinematics: PlanarPCS, dynamics: Callable, batch: Callable | None = None, actuation: Any = None
    ) -> None:
        super().__init__(kinematics, actuation)
        self._dynamics = dynamics
        self._batch = batch

    def mass_and_bias(self, q: ArrayLike, qd: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        q = np.atleast_2d(self._reduce(q, "q"))
        qd = np.atleast_2d(self._reduce(qd, "qd"))
        if q.shape != qd.shape:
            raise ValueError(f"q and qd must have the same shape; got {q.shape} and {qd.shape}")
        if self._batch is not None:
            M, bias = self._batch(q, qd)
            return np.asarray(M, dtype=float), np.asarray(bias, dtype=float)
        pairs = [self._dynamics(a, b) for a, b in zip(q, qd)]
        return np.stack([p[0] for p in pairs]), np.stack([p[1] for p in pairs])

    def terms(self, q: NDArray[np.float64], qd: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        M, bias = self._dynamics(q, qd)
        return np.array(M, dtype=float), np.array(bias, dtype=float)

    def _state_derivative(self, y: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        n = self.n
        M, bias = self._dynamics(y[:n], y[n:])
        return np.concatenate([y[n:], np.linalg.solve(M, self.input_forces(y[:n], u) - bias)])


class CompiledForwardModel(ForwardModel):
    """A forward model whose terms, input map and rollouts are compiled kernels.

    Subclasses set ``_jit`` (the module of kernels: ``dynamics``, ``mass_bias_batch``,
    ``input_forces``, ``rhs``, ``workspace``), ``_params`` (its parameter tuple), ``_work`` (its work
    arrays) and ``python_inputs`` (True when the input map has no compiled form: the kernels then take
    generalised forces, computed by the actuation in Python).
    """

    def mass_and_bias(self, q: ArrayLike, qd: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        q = np.ascontiguousarray(np.atleast_2d(self._reduce(q, "q")), dtype=float)
        qd = np.ascontiguousarray(np.atleast_2d(self._reduce(qd, "qd")), dtype=float)
        if q.shape != qd.shape:
            raise ValueError(f"q and qd must have the same shape; got {q.shape} and {qd.shape}")
        return self._jit.mass_bias_batch(q, qd, self._params, self._work)

    def terms(self, q: NDArray[np.float64], qd: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        W = self._work
        self._jit.dynamics(np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(qd, dtype=float), self._params, W)
        return W[0].copy(), W[1].copy()

    def input_forces(self, q: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        if self.python_inputs:
            return super().input_forces(q, u)
        tau = np.empty(self.n)
        self._jit.input_forces(
            np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(u, dtype=float), self._params, tau
        )
        return tau

    def _state_derivative(self, y: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.empty(y.size)
        if self.python_inputs:  # the kernels' input map is "forces": hand them A(q) u
            u = self.input_forces(y[: self.n], np.asarray(u, dtype=float))
        if not self._jit.rhs(
            np.ascontiguousarray(y, dtype=float), np.ascontiguousarray(u, dtype=float), self._params, self._work, out
        ):
            raise np.linalg.LinAlgError("singular mass matrix")
        return out

    def _loop(self, P, y0, t, u, method, step, rtol, atol, max_step, max_abs_state, state_names, stats):
        from . import _jit_rollout

        return _jit_rollout.rollout(
            P,
            self._jit.workspace(P),
            y0,
            t,
            u,
            method,
            step=step,
            rtol=rtol,
            atol=atol,
            max_step=max_step,
            max_abs_state=max_abs_state,
            state_names=state_names,
            stats=stats,
        )


class LumpedPCSModel(CompiledForwardModel):
    """Planar PCS dynamics from lumped per-segment parameters, evaluated by compiled kernels.

    Parameters
    ----------
    kinematics : PlanarPCS
        Segmentation with the modelled strains active.
    rhoA, rhoI : array_like, shape (m,)
        Line density and rotary inertia per length of each segment.
    rhoAg : array_like, shape (m, 2)
        ``rho A_i g`` (gravity force per length) per segment.
    stiffness, damping : array_like, shape (n,)
        Of the modelled strains.
    rest_force : array_like, shape (n,), optional
        Constant generalised force ``f0`` (``... + K q - f0 = tau``); default 0.
    n_quadrature : int
        Gauss–Legendre nodes per segment of the reference rule.
    fast_quadrature : int or None
        Nodes of the cheaper rule rollouts use while every ``|kappa_i L_i|``
        stays within ``fast_max_bend`` (measured exact there to ~2e-11); a
        rollout that bends further is repeated with the reference rule.
    fast_max_bend : float
    actuation : Actuation, optional
        Fitted input map ``A(q) u`` (:mod:`pcs_sindy.models.actuation`); default: the
        inputs are the generalised forces.  A kind without a compiled form (empty
        ``compiled_forms``) is evaluated in Python: the model then rolls out with
        the ``solve_ivp`` methods only (:attr:`methods`).
    """

    methods = COMPILED_METHODS + tuple(m for m in SCIPY_METHODS if m not in COMPILED_METHODS)
    compiled_methods = COMPILED_METHODS
    default_method = "rosenbrock"

    def __init__(
        self,
        kinematics: PlanarPCS,
        rhoA: ArrayLike,
        rhoI: ArrayLike,
        rhoAg: ArrayLike,
        stiffness: ArrayLike,
        damping: ArrayLike,
        rest_force: ArrayLike | None = None,
        *,
        n_quadrature: int = 16,
        fast_quadrature: int | None = 8,
        fast_max_bend: float = 6.0,
        actuation: Any = None,
    ) -> None:
        super().__init__(kinematics, actuation)
        from . import _jit_dynamics  # numba kernels load only when a model is built
        from .pcs_numeric import make_quadrature, rotary_mass

        L = np.asarray(kinematics.segment_lengths, dtype=float)
        m, n = L.size, self.n

        def arr(name: str, val: Any, shape: tuple) -> NDArray[np.float64]:
            a = np.asarray(val, dtype=float)
            if a.shape != shape or not np.all(np.isfinite(a)):
                raise ValueError(f"{name} must be finite with shape {shape}; got {np.asarray(val).tolist()}")
            return np.ascontiguousarray(a)

        self.rhoA = arr("rhoA", rhoA, (m,))
        self.rhoI = arr("rhoI", rhoI, (m,))
        self.rhoAg = arr("rhoAg", rhoAg, (m, 2))
        self.stiffness = arr("stiffness", stiffness, (n,))
        self.damping = arr("damping", damping, (n,))
        self.rest_force = arr("rest_force", np.zeros(n) if rest_force is None else rest_force, (n,))
        for name, val in (("n_quadrature", n_quadrature), ("fast_quadrature", fast_quadrature)):
            if val is not None and (isinstance(val, bool) or not isinstance(val, (int, np.integer)) or val < 1):
                raise ValueError(f"{name} must be a positive integer; got {val!r}")
        self.n_quadrature = int(n_quadrature)
        self.fast_quadrature = fast_quadrature
        self.fast_max_bend = float(fast_max_bend)
        act = np.flatnonzero(kinematics.active_mask).astype(np.int64)
        M_rot = np.einsum("i,ipr->pr", self.rhoI, rotary_mass(L))[np.ix_(act, act)]
        g = np.ascontiguousarray(self.rhoAg[:, 0] + 1j * self.rhoAg[:, 1])
        self._jit = _jit_dynamics

        #: True when the actuation has no compiled form: its forces are computed in Python (``actuation.forces``)
        #: and handed to the kernels as generalised forces, and rollouts take the solve_ivp methods only
        self.python_inputs = self.actuation is not None and not self.actuation.compiled_forms
        if self.actuation is None or self.python_inputs:
            form, aoff, acover, amat = "forces", np.zeros(0), np.zeros((0, m)), np.zeros((n, 0))
        else:
            form, aoff, acover, amat = self.actuation.compiled()
            if form not in self.actuation.compiled_forms or form not in _jit_dynamics.INPUT_MAPS:
                raise ValueError(
                    f"{type(self.actuation).__name__}.compiled() gave the input map {form!r}; it declares "
                    f"compiled_forms = {self.actuation.compiled_forms!r} and the kernels evaluate "
                    f"{sorted(_jit_dynamics.INPUT_MAPS)}"
                )
        inputs = (
            np.array([_jit_dynamics.INPUT_MAPS[form]], dtype=np.int64),
            np.ascontiguousarray(aoff, dtype=float),
            np.ascontiguousarray(acover, dtype=float),
            np.ascontiguousarray(amat, dtype=float),
        )
        if self.python_inputs:
            self.methods = tuple(SCIPY_METHODS)
            self.compiled_methods = ()
            self.default_method = ForwardModel.default_method

        def params(nodes: int) -> tuple:
            quad = make_quadrature(L, nodes)
            return (
                act,
                L,
                np.ascontiguousarray(quad.ell),
                np.ascontiguousarray(quad.weights),
                self.rhoA,
                g,
                np.ascontiguousarray(M_rot),
                self.stiffness,
                self.damping,
                self.rest_force,
                *inputs,
            )

        self._params = params(self.n_quadrature)
        self._fast = None
        if fast_quadrature is not None and fast_quadrature < self.n_quadrature:
            self._fast = params(int(fast_quadrature))
        self._work = _jit_dynamics.workspace(self._params)

    @classmethod
    def from_lumped(cls, kinematics: PlanarPCS, lumped: dict, actuation: Any = None) -> LumpedPCSModel:
        """The model of a library's ``lumped_from_coef`` dictionary (``rest_force`` optional)."""
        return cls(
            kinematics,
            lumped["rhoA"],
            lumped["rhoI"],
            lumped["rhoAg"],
            lumped["stiffness"],
            lumped["damping"],
            lumped.get("rest_force"),
            n_quadrature=lumped["n_quadrature"],
            actuation=actuation,
        )

    def _rollout_compiled(
        self, y0, t, u, method, *, step, rtol, atol, max_step, max_abs_state, state_names, stats
    ) -> NDArray[np.float64]:
        if self._fast is not None:
            y = self._loop(self._fast, y0, t, u, method, step, rtol, atol, max_step, max_abs_state, state_names, stats)
            bend = self.kinematics.to_full(y[:, : self.n])[:, 0::3] * np.asarray(self.kinematics.segment_lengths)
            if np.abs(bend).max() <= self.fast_max_bend:
                return y
        return self._loop(self._params, y0, t, u, method, step, rtol, atol, max_step, max_abs_state, state_names, stats)
