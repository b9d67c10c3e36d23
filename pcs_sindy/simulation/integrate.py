"""Time integration of the ground-truth robots: :meth:`PCSRobot.simulate` and :meth:`PCSRobot.advance`.

The same code integrates the spatial robot (:class:`~pcs_sindy.simulation.SpatialPCSRobot`): a robot
gives its compiled kernels a geometry tuple (``robot._jit_geometry()``) and
:mod:`pcs_sindy.simulation._dispatch` picks the planar or spatial kernels from it; a robot with a
``_trajectory(q, t, qd, metadata)`` method builds its own trajectory container (the planar robot
returns a :class:`~pcs_sindy.core.StrainTrajectory`).

Two paths, one contract (:mod:`pcs_sindy.core.simulate_contract`):

- ``method="radau"`` with tabulated inputs: the simulator's own Radau IIA,
  compiled (:mod:`pcs_sindy.simulation._radau`), stepping across samples
  without restarts, each robot of a batch with its own steps; fixed steps
  (the default) or error control.  Every scenario uses this path.
- every other method, and callable inputs: :func:`scipy.integrate.solve_ivp`
  on the compiled state derivative (and, for its implicit methods, the
  compiled Jacobian), restarted wherever a tabulated input switches and
  sampled with ``t_eval``.  A batch is integrated as one system (common
  steps, error norm over all robots).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.linalg import block_diag as dense_block_diag
from scipy.sparse import block_diag as sparse_block_diag
from tqdm.auto import tqdm

from ..core.simulate_contract import SCIPY_METHODS, SimulationError, canonical_method
from ..core.trajectory import StrainTrajectory
from . import _dispatch, _radau

__all__ = [
    "METHODS_SUPPORTED",
    "DEFAULT_STEP",
    "UNSET",
    "simulate",
    "advance",
    "check_inputs",
    "integrate",
    "RadauStepper",
]

#: methods of :data:`pcs_sindy.core.simulate_contract.METHODS` the simulator implements ("radau" first: the default)
METHODS_SUPPORTED = ("radau", "dopri5", "dop853", "bdf", "lsoda", "rk23")
#: fixed Radau step of ``step="auto"`` [s]
DEFAULT_STEP = 5e-4
_IMPLICIT = ("radau", "bdf", "lsoda")


class _Unset:
    """Marks a deprecated keyword that was not given (None is a meaningful value of the new one)."""

    def __repr__(self) -> str:
        return "UNSET"


UNSET: Any = _Unset()


def integrate(
    robot: Any,
    y0: NDArray,
    t: NDArray,
    u_rows: NDArray | None,
    u_fn: Callable | None,
    *,
    method: str,
    rtol: float,
    atol: float,
    step: float | None,
    max_step: float,
    progress: bool,
) -> tuple[NDArray[np.float64], dict[str, int]]:
    """Sampled states (T, B, 2n) of ``robot`` from ``y0`` (B, 2n), and integrator counts.

    Arguments are validated by the caller: ``u_rows`` (T, B, p) tabulated
    inputs held on ``[t_k, t_{k+1})`` or ``u_fn(t) -> (B, p)``; ``step`` a
    fixed Radau step (tabulated inputs only) or None for error control.
    """
    geo = robot._jit_geometry()
    if method == "radau" and u_fn is None:
        return _radau_tabulated(geo, y0, t, u_rows, rtol, atol, max_step, step, progress)
    return _scipy(geo, y0, t, u_rows, u_fn, method, rtol, atol, max_step, progress)


# --------------------------------------------------------------------------
# the public entry points and their argument checks
# --------------------------------------------------------------------------
def simulate(
    robot: Any,
    q0: ArrayLike,
    qd0: ArrayLike,
    t: ArrayLike,
    u: Any,
    *,
    method: str,
    rtol: float | None,
    atol: float | None,
    step: float | None | str,
    max_step: float | None,
    progress: bool,
    tau: Any,
    fixed_step: Any,
) -> StrainTrajectory | list[StrainTrajectory]:
    """:meth:`PCSRobot.simulate` (documented there)."""
    u = _renamed(u, tau, "u", "tau")
    if u is None:
        raise ValueError("simulate needs the inputs u (tabulated (T, p) or a callable u(t))")
    if fixed_step is not UNSET:
        warnings.warn("fixed_step is deprecated; use step", FutureWarning, stacklevel=3)
        step = fixed_step
    method = canonical_method(method, METHODS_SUPPORTED, owner=f"{type(robot).__name__}.simulate")
    q0 = robot._check("q0", q0)
    qd0 = robot._check("qd0", qd0, q0)
    if q0.ndim > 2:
        raise ValueError(f"q0 must have shape (n,) or (B, n); got shape {q0.shape}")
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 1:
        raise ValueError(f"t must be a non-empty 1-D array of time stamps; got shape {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ValueError("t must be finite and strictly increasing")
    batch = q0.shape[:-1]
    u_rows, u_fn = check_inputs(robot, u, t, batch)
    if isinstance(step, str):
        if step != "auto":
            raise ValueError(f"step must be a float, None or 'auto'; got {step!r}")
        tabulated_radau = method == "radau" and u_fn is None
        step = DEFAULT_STEP if (tabulated_radau and rtol is None and atol is None) else None
    rtol, atol, max_step = _tolerances(rtol, atol, max_step)
    if step is not None:
        if not (np.isfinite(step) and step > 0):
            raise ValueError(f"step must be finite and > 0, None or 'auto'; got {step!r}")
        if method != "radau" or u_fn is not None:
            raise ValueError(
                f"a fixed step needs method='radau' and tabulated inputs; got method={method!r}"
                f"{' and a callable u' if u_fn is not None else ''} (use step=None)"
            )
    y0 = np.concatenate([q0.reshape(-1, robot.n_q), qd0.reshape(-1, robot.n_q)], axis=1)
    out, counts = integrate(
        robot, y0, t, u_rows, u_fn, method=method, rtol=rtol, atol=atol, step=step, max_step=max_step, progress=progress
    )
    meta = {"method": method, "step": step, "rtol": rtol, "atol": atol, "counts": counts}
    build = getattr(robot, "_trajectory", None)
    if build is None:

        def build(q, t, qd, metadata):
            return StrainTrajectory(
                q, t, segment_lengths=robot.segment_lengths, qd=qd, base_pose=tuple(robot.base_pose), metadata=metadata
            )

    runs = [
        build(
            out[:, b, : robot.n_q],
            t,
            out[:, b, robot.n_q :],
            {**meta, "u": u if u_rows is None else u_rows[:, b]},
        )
        for b in range(out.shape[1])
    ]
    return runs if batch else runs[0]


def advance(
    robot: Any,
    q: ArrayLike,
    qd: ArrayLike,
    u: ArrayLike,
    dt: float,
    *,
    step: float | None,
    rtol: float | None,
    atol: float | None,
    max_steps: int | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:meth:`PCSRobot.advance` (documented there)."""
    if max_steps is not None and (
        isinstance(max_steps, bool) or not isinstance(max_steps, (int, np.integer)) or max_steps < 1
    ):
        raise ValueError(f"max_steps must be an integer >= 1 or None; got {max_steps!r}")
    q = robot._check("q", q)
    qd = robot._check("qd", qd, q)
    if q.ndim > 2:
        raise ValueError(f"q must have shape (n,) or (B, n); got shape {q.shape}")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be finite and > 0; got {dt!r}")
    if step is not None and not (np.isfinite(step) and step > 0):
        raise ValueError(f"step must be finite and > 0 or None; got {step!r}")
    rtol, atol, _ = _tolerances(rtol, atol, None)
    u = np.asarray(u, dtype=float)
    if u.shape != q.shape[:-1] + (robot.n_inputs,):
        raise ValueError(
            f"u must have shape q.shape[:-1] + (p,) = {q.shape[:-1] + (robot.n_inputs,)} "
            f"(p = {robot.n_inputs} inputs); got shape {u.shape}"
        )
    if not np.all(np.isfinite(u)):
        raise ValueError("u contains NaN or inf")
    if robot.actuation is not None:
        robot.actuation.check_inputs(u, None)
    u_rows = np.ascontiguousarray(
        np.broadcast_to(u.reshape(1, -1, robot.n_inputs), (2, u.size // robot.n_inputs, robot.n_inputs))
    )
    y = np.concatenate([q.reshape(-1, robot.n_q), qd.reshape(-1, robot.n_q)], axis=1)
    B = y.shape[0]
    # the integrator state of the last call carries over when this call continues from where it ended
    key = (B, step, rtol, atol, float(dt))
    cached = getattr(robot, "_advance_cache", None)
    if cached is None or cached[0] != key or not np.array_equal(cached[2], y):
        stepper = RadauStepper(B, robot.n_q, robot.n_inputs, min(dt, step) if step is not None else dt)
    else:
        stepper = cached[1]
    out = np.empty((2, B, 2 * robot.n_q))
    out[0] = y
    try:
        stepper.run(
            0,
            1,
            np.array([0.0, float(dt)]),
            u_rows,
            out,
            robot._jit_geometry(),
            rtol,
            atol,
            np.inf if step is None else step,
            step is not None,
            0 if max_steps is None else int(max_steps),
        )
    except SimulationError:
        robot._advance_cache = None  # a failed call leaves the integrator state half-way: start afresh
        raise
    robot._advance_cache = (key, stepper, out[1].copy())
    return out[1, :, : robot.n_q].reshape(q.shape), out[1, :, robot.n_q :].reshape(q.shape)


def check_inputs(robot: Any, u: Any, t: NDArray, batch: tuple[int, ...]) -> tuple[NDArray | None, Callable | None]:
    """Validated inputs: tabulated rows (T, B, p), or a checked callable returning (B, p)."""
    p = robot.n_inputs
    B = int(np.prod(batch)) if batch else 1
    check = getattr(robot.actuation, "check_inputs", None)
    if callable(u):
        shape = batch + (p,)

        def fn(time: float) -> NDArray:
            val = np.asarray(u(time), dtype=float)
            if val.shape != shape:
                raise ValueError(f"u(t) must return shape {shape}; got shape {val.shape} at t = {time:g}")
            if not np.all(np.isfinite(val)):
                raise ValueError(f"u(t) returned NaN or inf at t = {time:g}")
            if check is not None:
                check(val, time, name="u(t)")
            return np.ascontiguousarray(val.reshape(B, p))

        return None, fn
    arr = np.asarray(u, dtype=float)
    expected = (t.size,) + batch + (p,)
    if arr.shape != expected:
        raise ValueError(
            f"u must have shape (len(t),) + q0.shape[:-1] + (p,) = {expected} (p = {p} inputs); got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"u contains NaN or inf (first at sample {int(np.argwhere(~np.isfinite(arr))[0][0])})")
    if check is not None:
        check(arr, t)
    return arr.reshape(t.size, B, p), None


def _renamed(new: Any, old: Any, new_name: str, old_name: str) -> Any:
    if old is None:
        return new
    if new is not None:
        raise ValueError(f"give {new_name} only ({old_name} is its former name), not both")
    warnings.warn(f"{old_name}= is deprecated; use {new_name}=", FutureWarning, stacklevel=3)
    return old


def _tolerances(rtol: float | None, atol: float | None, max_step: float | None) -> tuple[float, float, float]:
    rtol = 1e-6 if rtol is None else rtol
    atol = 1e-8 if atol is None else atol
    for name, val in (("rtol", rtol), ("atol", atol)):
        if not (np.isfinite(val) and val > 0):
            raise ValueError(f"{name} must be finite and > 0; got {val!r}")
    max_step = np.inf if max_step is None else max_step
    if not (max_step > 0):
        raise ValueError(f"max_step must be > 0; got {max_step!r}")
    return float(rtol), float(atol), float(max_step)


# --------------------------------------------------------------------------
# compiled Radau IIA
# --------------------------------------------------------------------------
class RadauStepper:
    """State of the compiled Radau IIA integrator for B robots, carried from one call to the next.

    Holds everything :func:`pcs_sindy.simulation._radau.radau_run` keeps
    between samples (next step, last collocation increments, acceleration
    Jacobian and its factorisations), so that consecutive runs over a time
    grid split in pieces give exactly the numbers of one run.
    """

    def __init__(self, B: int, n: int, p: int, h0: float) -> None:
        N = 2 * n
        self.h = np.full(B, h0)
        self.h_prev = np.ones(B)
        self.have_z = np.zeros(B, dtype=bool)
        self.z_prev = np.zeros((B, 3, N))
        self.rate_last = np.full(B, -1.0)
        self.jac = np.zeros((B, n, N))  # [∂q̈/∂q, ∂q̈/∂q̇]
        self.jac_state = np.zeros(B, dtype=np.int64)
        self.h_lu = np.full(B, -1.0)
        self.lu_big, self.piv_big = np.zeros((B, 3 * n, 3 * n)), np.zeros((B, 3 * n), dtype=np.int64)
        self.lu_small, self.piv_small = np.zeros((B, n, n)), np.zeros((B, n), dtype=np.int64)
        # accepted steps, Newton iterations, Jacobians, rejected/repeated steps
        self.stats = np.zeros(4, dtype=np.int64)

    def run(
        self,
        k0: int,
        k1: int,
        t: NDArray,
        u_rows: NDArray,
        out: NDArray,
        geo: tuple,
        rtol: float,
        atol: float,
        max_step: float,
        fixed: bool,
        max_steps: int = 0,
    ) -> None:
        """Advance ``out[k0]`` to ``out[k1]`` in place; raise SimulationError on failure.

        ``max_steps`` > 0: at most that many steps attempted in this call.
        """
        status, when, robot = _radau.radau_run(
            k0,
            k1,
            t,
            u_rows,
            out,
            self.h,
            self.h_prev,
            self.have_z,
            self.z_prev,
            self.rate_last,
            self.jac,
            self.jac_state,
            self.h_lu,
            self.lu_big,
            self.piv_big,
            self.lu_small,
            self.piv_small,
            geo,
            float(rtol),
            float(atol),
            float(max_step),
            fixed,
            _radau.RADAU_A,
            _radau.RADAU_C,
            _radau.RADAU_E,
            _radau.RADAU_MU,
            _radau.JAC_REFRESH_RATE,
            self.stats,
            int(max_steps),
        )
        if status != _radau.OK:
            what = {
                _radau.NONFINITE: "the state derivative is not finite",
                _radau.COLLAPSE: "step size collapsed",
                _radau.BUDGET: f"the step budget (max_steps = {int(max_steps)}) ran out",
            }[int(status)]
            which = f" (robot {robot} of the batch)" if out.shape[1] > 1 else ""
            raise SimulationError(f"radau: {what} at t = {when:.6g} s{which}", t=when)

    def counts(self) -> dict[str, int]:
        return dict(zip(("steps", "newton_iterations", "jacobians", "rejected"), (int(v) for v in self.stats)))


def _radau_tabulated(geo, y0, t, u_rows, rtol, atol, max_step, step, progress):
    T = t.size
    B, N = y0.shape
    out = np.empty((T, B, N))
    out[0] = y0
    if step is not None:
        max_step = min(max_step, step)
    stepper = RadauStepper(B, N // 2, u_rows.shape[2], min(t[1] - t[0], max_step) if T > 1 else 0.0)
    t_c = np.ascontiguousarray(t, dtype=float)
    u_c = np.ascontiguousarray(u_rows, dtype=float)
    # the compiled run is split in chunks only to update the progress bar; its state carries over exactly
    chunk = max(1, (T - 1) // 20) if progress else max(T - 1, 1)
    with tqdm(total=T - 1, disable=not progress, desc="simulate", unit="sample") as bar:
        for k0 in range(0, T - 1, chunk):
            k1 = min(k0 + chunk, T - 1)
            stepper.run(k0, k1, t_c, u_c, out, geo, rtol, atol, max_step, step is not None)
            bar.update(k1 - k0)
    return out, stepper.counts()


# --------------------------------------------------------------------------
# scipy.integrate.solve_ivp
# --------------------------------------------------------------------------
def _scipy(geo, y0, t, u_rows, u_fn, method, rtol, atol, max_step, progress):
    T = t.size
    B, N = y0.shape
    out = np.empty((T, B, N))
    out[0] = y0
    if u_fn is None:
        # restart only where a held input switches (the last row is not used); sample in between with t_eval
        change = np.flatnonzero(np.any(u_rows[1:-1] != u_rows[:-2], axis=(1, 2))) + 1
        starts = np.concatenate([[0], change]).astype(int)
        ends = np.concatenate([change, [T - 1]]).astype(int)
    else:
        starts, ends = np.array([0]), np.array([T - 1])
    counts = {"nfev": 0, "njev": 0, "nlu": 0}
    with tqdm(total=T - 1, disable=not progress, desc="simulate", unit="sample") as bar:
        for a, b in zip(starts, ends):
            if b <= a:
                continue
            if u_fn is None:
                held = np.ascontiguousarray(u_rows[a])
                inputs = lambda tt, held=held: held  # noqa: E731 - the input held on this interval
            else:
                inputs = u_fn
            options = {}
            if method in _IMPLICIT:
                options["jac"] = _jacobian(geo, inputs, B, N, method)
            # a diverging state overflows inside scipy's step control: reported below as a SimulationError
            try:
                with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                    sol = solve_ivp(
                        _derivative(geo, inputs, B, N),
                        (t[a], t[b]),
                        out[a].reshape(-1),
                        method=SCIPY_METHODS[method],
                        t_eval=t[a + 1 : b + 1],
                        rtol=rtol,
                        atol=atol,
                        max_step=max_step,
                        **options,
                    )
            except _NonFiniteJacobian as err:
                raise SimulationError(
                    f"{method} (scipy.integrate.solve_ivp): the Jacobian is not finite at t = {err.time:.6g} s",
                    t=err.time,
                ) from None
            for key in counts:
                counts[key] += int(getattr(sol, key))
            ts, ys = np.asarray(sol.t, dtype=float), np.asarray(sol.y, dtype=float).reshape(N * B, -1)
            finite = np.all(np.isfinite(ys), axis=0)
            if sol.status != 0 or ts.size != b - a or not np.all(finite):
                # the samples reached with finite states
                reached = int(np.argmin(finite)) if not np.all(finite) else ts.size
                t_fail = float(ts[reached - 1]) if reached else float(t[a])
                y_fail = ys[:, reached - 1] if reached else out[a].reshape(-1)
                raise SimulationError(
                    f"{method} (scipy.integrate.solve_ivp) failed after t = {t_fail:.6g} s on "
                    f"[{t[a]:.6g}, {t[b]:.6g}] s: {sol.message}",
                    t=t_fail,
                    y=y_fail,
                )
            out[a + 1 : b + 1] = ys.T.reshape(b - a, B, N)
            bar.update(b - a)
    return out, counts


def _derivative(geo, inputs, B, N):
    def fun(time: float, y: NDArray) -> NDArray:
        return _dispatch.rhs_batch(y.reshape(B, N), inputs(time), geo).reshape(-1)

    return fun


class _NonFiniteJacobian(Exception):
    def __init__(self, time: float) -> None:
        super().__init__(time)
        self.time = float(time)


def _jacobian(geo, inputs, B, N, method):
    def jac(time: float, y: NDArray):
        blocks = _dispatch.state_jacobian_batch(y.reshape(B, N), inputs(time), geo)
        if not np.all(np.isfinite(blocks)):
            raise _NonFiniteJacobian(time)  # scipy's factorisation would fail with a bare ValueError
        if B == 1:
            return blocks[0]
        # robots of a batch are independent: block-diagonal (LSODA takes dense matrices only)
        return dense_block_diag(*blocks) if method == "lsoda" else sparse_block_diag(blocks, format="csc")

    return jac
