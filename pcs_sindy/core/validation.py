"""Constructor parameters checked the scikit-learn way: one table per class, one message format.

An estimator declares, in the class attribute ``_parameter_constraints``, what each constructor
parameter may be (a list of constraints, any one of which suffices), and its ``fit`` calls
:func:`validate_parameters` first::

    class Fusion(BaseEstimator):
        _parameter_constraints = {
            "threshold": [Interval(Real, 0, None, closed="neither")],
            "total_length": [None, Interval(Real, 0, None, closed="neither")],
            "merge": [Options(("runs", "closest_pair"))],
            "progress": "no_validation",
        }

A value outside every constraint of its parameter raises :class:`InvalidParameterError`, worded
alike for every class::

    Fusion: threshold must be a finite number > 0; got -1

The constraint kinds follow scikit-learn's (``sklearn.utils._param_validation``, which is
private and not used here):

* :class:`Interval` - real or integral numbers between two bounds;
* :class:`Options` - a fixed set of values (e.g. strings);
* ``None`` - the literal None;
* ``"boolean"`` - ``bool`` or ``numpy.bool_``;
* :class:`InstanceOf` - instances of given types;
* :class:`HasMethods` - objects with given methods;
* :class:`Check` - any one-value predicate with its description, for what the others
  cannot say ("an odd integer >= 3", "two positive numbers").

An entry ``"no_validation"`` instead of a list leaves the parameter unchecked.  Checks that
involve several parameters (``polyorder < window_length``) stay in the estimator's ``fit``,
raising :meth:`InvalidParameterError.of` in the same format.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from numbers import Integral, Real
from typing import Any

import numpy as np

__all__ = [
    "InvalidParameterError",
    "validate_parameters",
    "Constraint",
    "Interval",
    "Options",
    "InstanceOf",
    "HasMethods",
    "Check",
]


class InvalidParameterError(ValueError, TypeError):
    """A constructor parameter outside its constraints (a ``ValueError`` and a ``TypeError``, as in scikit-learn)."""

    @classmethod
    def of(cls, obj: Any, name: str, expected: str, value: Any) -> InvalidParameterError:
        """The error ``"{ClassName}: {name} must be {expected}; got {value!r}"``.

        Parameters
        ----------
        obj : object
            The estimator whose parameter is invalid (its class names the error).
        name : str
            The parameter.
        expected : str
            What it must be, readable after "must be" (e.g. ``"a number > 0"``).
        value : object
            The value it has.

        Returns
        -------
        InvalidParameterError
        """
        return cls(f"{type(obj).__name__}: {name} must be {expected}; got {value!r}")


class Constraint:
    """Base of the constraint kinds: a readable ``description`` and :meth:`is_satisfied_by`.

    A new kind subclasses it, sets ``description`` and implements :meth:`is_satisfied_by`.

    Attributes
    ----------
    description : str
        What the constraint accepts, readable after "must be" (e.g. "a finite number > 0").
    """

    description: str = ""

    def is_satisfied_by(self, value: Any) -> bool:
        """Whether ``value`` meets the constraint.

        Parameters
        ----------
        value : object

        Returns
        -------
        bool
        """
        raise NotImplementedError


class Interval(Constraint):
    """Real or integral numbers between two bounds (booleans and NaN never qualify).

    Parameters
    ----------
    kind : numbers.Real or numbers.Integral
        ``Real`` accepts Python and numpy integers and floats; ``Integral`` Python and numpy integers.
    left, right : float or None
        The bounds; None is ``-inf`` / ``+inf``.
    closed : {"left", "right", "both", "neither"}, default "both"
        Which bounds belong to the interval.  With a None bound this decides whether the
        infinity itself is accepted: ``Interval(Real, 0, None, closed="neither")`` is "a finite
        number > 0", ``closed="right"`` admits ``inf``.
    """

    def __init__(self, kind: type, left: float | None, right: float | None, *, closed: str = "both") -> None:
        if kind not in (Real, Integral):
            raise ValueError(f"kind must be numbers.Real or numbers.Integral; got {kind!r}")
        if closed not in ("left", "right", "both", "neither"):
            raise ValueError(f"closed must be 'left', 'right', 'both' or 'neither'; got {closed!r}")
        if left is not None and right is not None and left > right:
            raise ValueError(f"left must be <= right; got {left!r} > {right!r}")
        self.kind, self.left, self.right, self.closed = kind, left, right, closed
        self.description = self._describe()

    def is_satisfied_by(self, value: Any) -> bool:
        types = (int, np.integer) if self.kind is Integral else (int, float, np.integer, np.floating)
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, types) or value != value:
            return False
        lo = -math.inf if self.left is None else self.left
        hi = math.inf if self.right is None else self.right
        above = value >= lo if self.closed in ("left", "both") else value > lo
        below = value <= hi if self.closed in ("right", "both") else value < hi
        return bool(above and below)

    def _describe(self) -> str:
        lo_in, hi_in = self.closed in ("left", "both"), self.closed in ("right", "both")
        noun = "an integer" if self.kind is Integral else "a number"
        if self.kind is Real:
            infinite = [(self.left is None, lo_in), (self.right is None, hi_in)]
            if any(none and not inside for none, inside in infinite) and not any(n and i for n, i in infinite):
                noun = "a finite number"
        left, right = (_number(b) for b in (self.left, self.right))
        if self.left is None and self.right is None:
            return noun
        if self.right is None:
            return f"{noun} {'>=' if lo_in else '>'} {left}"
        if self.left is None:
            return f"{noun} {'<=' if hi_in else '<'} {right}"
        return f"{noun} in {'[' if lo_in else '('}{left}, {right}{']' if hi_in else ')'}"


def _number(bound: float | None) -> str:
    return "" if bound is None else str(bound) if isinstance(bound, (int, np.integer)) else f"{bound:g}"


class Options(Constraint):
    """One of a fixed set of (hashable) values, e.g. strings.

    Parameters
    ----------
    options : iterable
        The allowed values, described in the given order (a set is sorted).
    """

    def __init__(self, options: Iterable[Any]) -> None:
        values = sorted(options, key=repr) if isinstance(options, (set, frozenset)) else list(options)
        self.options = tuple(dict.fromkeys(values))
        listed = ", ".join(repr(o) for o in self.options)
        self.description = listed if len(self.options) == 1 else f"one of {listed}"

    def is_satisfied_by(self, value: Any) -> bool:
        try:
            return value in frozenset(self.options)
        except TypeError:  # unhashable: a list or an array is none of the options
            return False


class InstanceOf(Constraint):
    """An instance of one of ``types``.

    Parameters
    ----------
    types : type or tuple of types
    description : str, optional
        Default: "an instance of X".
    """

    def __init__(self, types: type | tuple[type, ...], description: str | None = None) -> None:
        self.types = types
        names = " or ".join(t.__name__ for t in (types if isinstance(types, tuple) else (types,)))
        self.description = description or f"an instance of {names}"

    def is_satisfied_by(self, value: Any) -> bool:
        return isinstance(value, self.types)


class HasMethods(Constraint):
    """An object with every one of the named methods (duck typing).

    Parameters
    ----------
    methods : str or sequence of str
    """

    def __init__(self, methods: str | Iterable[str]) -> None:
        self.methods = (methods,) if isinstance(methods, str) else tuple(methods)
        self.description = "an object with methods " + ", ".join(repr(m) for m in self.methods)

    def is_satisfied_by(self, value: Any) -> bool:
        return all(callable(getattr(value, m, None)) for m in self.methods)


class Check(Constraint):
    """A one-value predicate for what the other kinds cannot express.

    Parameters
    ----------
    predicate : callable
        ``predicate(value) -> bool``.  A predicate raising ``TypeError``, ``ValueError`` or an
        ``ArithmeticError`` counts as False (e.g. ``np.asarray(value, dtype=float)`` of a string).
    description : str
        What the predicate accepts, readable after "must be" ("an odd integer >= 3").
    """

    def __init__(self, predicate: Callable[[Any], bool], description: str) -> None:
        self.predicate = predicate
        self.description = description

    def is_satisfied_by(self, value: Any) -> bool:
        try:
            return bool(self.predicate(value))
        except (TypeError, ValueError, ArithmeticError):
            return False


_NONE = Check(lambda value: value is None, "None")
_BOOLEAN = Check(lambda value: isinstance(value, (bool, np.bool_)), "a boolean")


def _make_constraint(item: Any) -> Constraint:
    if item is None:
        return _NONE
    if isinstance(item, str) and item == "boolean":
        return _BOOLEAN
    if isinstance(item, Constraint):
        return item
    raise TypeError(
        f"unknown parameter constraint {item!r}: use None, 'boolean', Interval, Options, InstanceOf, HasMethods "
        "or Check"
    )


def _either(descriptions: list[str]) -> str:
    return descriptions[0] if len(descriptions) == 1 else ", ".join(descriptions[:-1]) + " or " + descriptions[-1]


def validate_parameters(obj: Any) -> None:
    """Check ``obj``'s constructor parameters against its class's ``_parameter_constraints``.

    Parameters
    ----------
    obj : estimator
        Has ``get_params(deep=False)``; its class has ``_parameter_constraints``, a dict from
        parameter name to a list of constraints (or ``"no_validation"``).  Parameters without
        an entry are not checked (a subclass may add parameters its base cannot know).

    Raises
    ------
    InvalidParameterError
        ``"{ClassName}: {name} must be {description} or {description}; got {value!r}"`` for the
        first parameter that satisfies none of its constraints.
    TypeError
        If the class has no table, or the table holds an unknown kind of constraint.
    """
    table = getattr(type(obj), "_parameter_constraints", None)
    if not isinstance(table, dict):
        raise TypeError(f"{type(obj).__name__} declares no _parameter_constraints table")
    for name, value in obj.get_params(deep=False).items():
        entry = table.get(name, "no_validation")
        if isinstance(entry, str) and entry == "no_validation":
            continue
        constraints = [_make_constraint(item) for item in entry]
        if not any(c.is_satisfied_by(value) for c in constraints):
            raise InvalidParameterError.of(obj, name, _either([c.description for c in constraints]), value)
