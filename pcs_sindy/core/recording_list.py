"""Per-recording arrays that scikit-learn's metrics read as one stacked array.

The estimators of the package take their samples as recordings: ``X`` is a list
of trajectories and ``y`` a list of one (T_k, d) array per recording.  A
scikit-learn string scorer (``scoring="r2"``, ``"neg_mean_squared_error"``)
compares ``y`` with ``predict(X)`` after converting both with ``np.asarray``,
which a plain list of arrays of different lengths does not survive.
:class:`RecordingList` is that list with two additions:

* ``np.asarray(y)`` stacks the recordings along time (shape ``(sum T_k, d)``:
  the recordings flattened), so every metric of :mod:`sklearn.metrics` applies;
* indexing by an array of recording indices (what cross-validation does)
  returns a :class:`RecordingList` again, and ``shape`` is ``(n_recordings,)``
  so that scikit-learn counts and splits recordings, not samples.

It is still a list: everything that takes a list of arrays takes it.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["RecordingList"]


class RecordingList(list):
    """A list of per-recording arrays; as an array, the recordings stacked along time.

    Parameters
    ----------
    recordings : iterable of array_like, each of shape (T_k, d) (or (T_k,))
        One array per recording; all with the same trailing shape.

    Examples
    --------
    >>> import numpy as np
    >>> y = RecordingList([np.ones((3, 2)), np.zeros((2, 2))])
    >>> len(y), np.asarray(y).shape, y.shape
    (2, (5, 2), (2,))
    >>> type(y[[1, 0]]).__name__
    'RecordingList'

    Use it for ``y`` in scikit-learn's model selection with a string scorer::

        cross_val_score(EulerLagrangeRegressor(), strains, RecordingList(taus), scoring="r2", cv=GroupKFold(4))
    """

    def __init__(self, recordings: Iterable[Any] = ()) -> None:
        items = list(recordings)
        arrays = [np.asarray(a) for a in items]
        tails = {a.shape[1:] for a in arrays}
        if any(a.ndim == 0 for a in arrays) or len(tails) > 1:
            shapes = [a.shape for a in arrays]
            raise ValueError(
                f"recordings must be arrays of shape (T_k, ...) with the same trailing shape; got shapes {shapes}"
            )
        super().__init__(items)

    @property
    def shape(self) -> tuple[int]:
        """``(n_recordings,)``: the sample unit scikit-learn splits and counts."""
        return (len(self),)

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, tuple) and len(key) == 2 and key[1] is Ellipsis:  # scikit-learn's array indexing
            key = key[0]
        if isinstance(key, (int, np.integer)):
            return list.__getitem__(self, int(key))
        if isinstance(key, slice):
            return RecordingList(list.__getitem__(self, key))
        idx = np.asarray(key)
        if idx.dtype == bool:
            if idx.shape != (len(self),):
                raise IndexError(f"a boolean index must have shape ({len(self)},); got {idx.shape}")
            idx = np.flatnonzero(idx)
        if idx.ndim != 1 or not np.issubdtype(idx.dtype, np.integer):
            raise IndexError(f"index recordings by an int, a slice or a 1-D array of ints; got {key!r}")
        return RecordingList(list.__getitem__(self, int(i)) for i in idx)

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> NDArray:
        if len(self) == 0:
            raise ValueError("an empty RecordingList has no array (no recordings)")
        return np.concatenate([np.asarray(a, dtype=dtype) for a in self], axis=0)

    def __repr__(self) -> str:
        shapes = ", ".join(str(np.shape(a)) for a in self)
        return f"RecordingList([{shapes}])"
