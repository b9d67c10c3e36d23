"""The Euler–Lagrange regression inside ``pysindy.SINDy``: the stacked form.

A PCS library (:class:`~pcs_sindy.identification.library.pcs_lagrangian.PCSLagrangianLibrary` or
:class:`~pcs_sindy.identification.library.physical.PhysicalPCSLibrary`) gives the Euler–Lagrange matrix
``Psi(q, qd, qdd)`` of shape (n_samples, n, n_psi), with ``tau = Psi @ pi+`` for
every degree of freedom and ONE coefficient vector ``pi+`` shared by all of
them.  pysindy 2.1 fits one coefficient row per *output coordinate*, so the
degrees of freedom cannot be coordinates; they are put on a leading spatial
axis instead:

- :class:`StackedEulerLagrangeLibrary` maps states ``x = [q, qd, qdd]`` (the n
  active strains, their rates and accelerations: ``3n`` columns, in that order)
  to ``Psi`` transposed to (n, n_time, n_psi), an ``AxesArray`` with axes
  ``ax_spatial = 0`` (degree of freedom), ``ax_time = 1``, ``ax_coord = 2``
  (what pysindy's ``comprehend_axes`` assigns to a 3-D array);
- the forces go in as ``x_dot`` of shape (n, n_time, 1) (:func:`stack_forces`).

``SINDy.fit`` then concatenates the sample axes (``concat_sample_axis``: the
spatial and time axes flattened in C order, so both arrays become
(n * n_time, ·) rows ordered dof-major) and hands the optimizer
``Theta`` (n * n_time, n_psi) and ``y`` (n * n_time, 1): exactly the stacked
regression of :class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor`, whose
single coefficient row is ``pi+``.  ``SINDy.predict(x)`` returns the forces in
the same stacked order, shape (n * n_time, 1); :func:`unstack_forces` turns
them back into (n_time, n).  No patch of pysindy is needed.

The optimizer sees ``Theta`` without the library, so the stiffness threshold
of :class:`~pcs_sindy.identification.optimizers.StiffnessThresholdOptimizer` (which needs
``library=`` and the states) does not run inside ``SINDy``: it is plain (scaled)
least squares there, as is ``pysindy.STLSQ(threshold=0, alpha=0)``.  For strain
removal use :class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor`.

Identification side: never imports :mod:`pcs_sindy.simulation`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pysindy.feature_library.base import BaseFeatureLibrary, x_sequence_or_item
from pysindy.utils import AxesArray
from sklearn.utils.validation import check_is_fitted

__all__ = ["StackedEulerLagrangeLibrary", "stack_forces", "unstack_forces"]


def stack_forces(tau: ArrayLike) -> NDArray[np.float64]:
    """Forces (n_time, n) -> the ``x_dot`` of the stacked form, shape (n, n_time, 1).

    Parameters
    ----------
    tau : array_like, shape (n_time, n)
        Generalized forces on the n active strains, one row per sample.

    Returns
    -------
    ndarray, shape (n, n_time, 1)
    """
    arr = np.asarray(tau, dtype=float)
    if arr.ndim != 2:
        raise ValueError(f"tau must have shape (n_time, n); got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("tau contains NaN or inf")
    return np.ascontiguousarray(arr.T[:, :, None])


def unstack_forces(stacked: ArrayLike, n: int) -> NDArray[np.float64]:
    """Stacked forces (n * n_time, 1) or (n, n_time, 1) -> (n_time, n).

    Parameters
    ----------
    stacked : array_like
        ``SINDy.predict`` output of the stacked form (rows ordered dof-major).
    n : int
        Number of degrees of freedom.
    """
    arr = np.asarray(stacked, dtype=float)
    if isinstance(n, bool) or int(n) != n or n < 1:
        raise ValueError(f"n must be a positive integer; got {n!r}")
    n = int(n)
    if arr.size % n:
        raise ValueError(f"stacked has {arr.size} values, not a multiple of n = {n}")
    return arr.reshape(n, -1).T.copy()


class StackedEulerLagrangeLibrary(BaseFeatureLibrary):
    """pysindy feature library of the stacked Euler–Lagrange form ``tau = Psi pi+``.

    Parameters
    ----------
    library : PCSLagrangianLibrary or PhysicalPCSLibrary
        Any PCS library with ``euler_lagrange_matrix(q, qd, qdd)`` returning
        (n_samples, n, n_psi) and ``kinematics`` (its active strains).  Used as
        given (not copied); the coefficients found by ``SINDy`` are ``pi+`` in
        its Euler–Lagrange columns (Lagrangian terms, then damping for
        ``PCSLagrangianLibrary``; the physical parameters for
        ``PhysicalPCSLibrary``).

    Attributes
    ----------
    n_features_in_ : int
        ``3 n``: states ``x = [q, qd, qdd]`` of the n active strains.
    n_output_features_ : int
        ``n_psi``, the number of Euler–Lagrange columns.
    n_dof_ : int
        ``n``.

    Notes
    -----
    ``transform`` returns one (n, n_time, n_psi) array per trajectory (see the
    module docstring); pass the forces as ``x_dot=stack_forces(tau)`` (or a list
    of them).  ``SINDy.simulate`` has first-order semantics and does not apply;
    roll out with :class:`~pcs_sindy.identification.regressor.EulerLagrangeRegressor`.

    Examples
    --------
    >>> import pysindy as ps                                   # doctest: +SKIP
    >>> lib = StackedEulerLagrangeLibrary(PhysicalPCSLibrary([0.1], radius=0.02))
    >>> model = ps.SINDy(feature_library=lib, optimizer=ps.STLSQ(threshold=0.0, alpha=0.0))
    >>> model.fit(np.hstack([q, qd, qdd]), t=t, x_dot=stack_forces(tau))
    >>> pi = model.coefficients()[0]
    """

    def __init__(self, library: Any) -> None:
        self.library = library

    def _check_library(self) -> int:
        lib = self.library
        if not (hasattr(lib, "euler_lagrange_matrix") and hasattr(lib, "kinematics")):
            raise ValueError(
                "library must provide euler_lagrange_matrix(q, qd, qdd) and kinematics "
                f"(PCSLagrangianLibrary, PhysicalPCSLibrary); got {type(lib).__name__}"
            )
        return int(np.asarray(lib.kinematics.active_mask).sum())

    def _n_columns(self, n: int) -> int:
        # probe one straight, resting sample: cheaper than relying on per-library attributes
        z = np.zeros((1, n))
        return int(self.library.euler_lagrange_matrix(z, z, z).shape[-1])

    @x_sequence_or_item
    def fit(self, x: Sequence[NDArray[np.float64]], y: Any = None) -> StackedEulerLagrangeLibrary:
        """Check the state width ``3n`` of ``x = [q, qd, qdd]`` and set the output size.

        Parameters
        ----------
        x : array_like, shape (n_time, 3n), or a list of them
        y : ignored

        Returns
        -------
        self
        """
        n = self._check_library()
        width = np.shape(x[0])[-1]
        if width != 3 * n:
            raise ValueError(f"x must have 3n = {3 * n} columns [q, qd, qdd] of the {n} active strains; got {width}")
        self.n_dof_ = n
        self.n_features_in_ = 3 * n
        self.n_output_features_ = self._n_columns(n)
        return self

    @x_sequence_or_item
    def transform(self, x: Sequence[NDArray[np.float64]]) -> list[AxesArray]:
        """Stacked Euler–Lagrange matrix of each trajectory, shape (n, n_time, n_psi).

        Parameters
        ----------
        x : array_like, shape (n_time, 3n), or a list of them
            States ``[q, qd, qdd]`` of the active strains.

        Returns
        -------
        AxesArray, shape (n, n_time, n_psi), or a list of them
            Axes: ``ax_spatial = 0`` (degree of freedom), ``ax_time = 1``,
            ``ax_coord = 2``.
        """
        check_is_fitted(self, "n_output_features_")
        n = self.n_dof_
        out = []
        for xi in x:
            arr = np.asarray(xi, dtype=float)
            if arr.ndim != 2 or arr.shape[1] != 3 * n:
                raise ValueError(f"x must have shape (n_time, {3 * n}) ([q, qd, qdd]); got shape {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise ValueError("x contains NaN or inf")
            psi = self.library.euler_lagrange_matrix(arr[:, :n], arr[:, n : 2 * n], arr[:, 2 * n :])
            stacked = np.ascontiguousarray(np.transpose(psi, (1, 0, 2)))
            out.append(AxesArray(stacked, {"ax_spatial": [0], "ax_time": 1, "ax_coord": 2}))
        return out

    def get_feature_names(self, input_features: Sequence[str] | None = None) -> list[str]:
        """Names of the Euler–Lagrange columns (``library.euler_lagrange_names()``).

        ``input_features`` is accepted for pysindy's interface; the column names
        come from the library's own strain names.
        """
        check_is_fitted(self, "n_output_features_")
        if hasattr(self.library, "euler_lagrange_names"):
            names = list(self.library.euler_lagrange_names())
            if len(names) == self.n_output_features_:
                return names
        return [f"psi{j}" for j in range(self.n_output_features_)]
