"""Entire special functions of the bending angle ``u = kappa * L``.

Every curvature-dependent factor of the PCS energies is an integral over the
normalised arc length ``sigma in [0, 1]`` (or a value at ``sigma = 1``) of
terms ``c * sigma**n * u**p * trig(m * u * sigma)`` with ``p`` possibly
negative.  Integrated, such a function has apparent poles at ``u = 0`` that
cancel exactly: it is entire.  We keep the defining term list as exact data,
from which we get

* its exact Taylor series at ``u = 0`` (rational coefficients, poles checked
  to cancel exactly), used for ``|u| < SERIES_RADIUS``;
* its closed form (a short recurrence for ``int sigma**n e^{i w sigma}``), used
  elsewhere, where it has no cancellation problem;
* its derivative in ``u`` as another function of the same family.

No epsilon is ever added to ``u``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from fractions import Fraction

import numpy as np
import sympy as sp
from numpy.typing import NDArray

__all__ = [
    "SpecialFunction",
    "SpecialBank",
    "SERIES_RADIUS",
    "SERIES_ORDER",
    "special",
    "sympy_function",
    "define",
    "closed_form_table",
    "register_backbone_functions",
]

#: |u| below which the Taylor series is used (closed form above).
SERIES_RADIUS = 3.0
#: highest power of u kept in the Taylor series (error < 3**50/50! ~ 1e-41 relative to O(1) terms)
SERIES_ORDER = 50

# A term: (coefficient, n, p, trig, m) meaning c * sigma**n * u**p * trig(m u sigma), trig in {"cos", "sin"}.
Term = tuple[Fraction, int, int, str, int]


def _normalise(terms: Iterable[Term]) -> tuple[Term, ...]:
    acc: dict[tuple[int, int, str, int], Fraction] = {}
    for c, n, p, trig, m in terms:
        if m < 0:  # cos(-x) = cos x, sin(-x) = -sin x
            m = -m
            c = -c if trig == "sin" else c
        if m == 0 and trig == "sin":
            continue
        key = (n, p, trig, m)
        acc[key] = acc.get(key, Fraction(0)) + Fraction(c)
    return tuple(sorted((c, *k) for k, c in acc.items() if c != 0))


def multiply(a: Iterable[Term], b: Iterable[Term]) -> tuple[Term, ...]:
    """Product of two integrands (product-to-sum of the trigonometric factors)."""
    out: list[Term] = []
    half = Fraction(1, 2)
    for c1, n1, p1, t1, m1 in a:
        for c2, n2, p2, t2, m2 in b:
            c, n, p = c1 * c2 * half, n1 + n2, p1 + p2
            if t1 == "cos" and t2 == "cos":
                out += [(c, n, p, "cos", m1 - m2), (c, n, p, "cos", m1 + m2)]
            elif t1 == "sin" and t2 == "sin":
                out += [(c, n, p, "cos", m1 - m2), (-c, n, p, "cos", m1 + m2)]
            elif t1 == "sin":  # sin A cos B
                out += [(c, n, p, "sin", m1 + m2), (c, n, p, "sin", m1 - m2)]
            else:  # cos A sin B
                out += [(c, n, p, "sin", m1 + m2), (c, n, p, "sin", m2 - m1)]
    return _normalise(out)


def differentiate(terms: Iterable[Term]) -> tuple[Term, ...]:
    """d/du of an integrand (sigma held fixed)."""
    out: list[Term] = []
    for c, n, p, trig, m in terms:
        if p != 0:
            out.append((c * p, n, p - 1, trig, m))
        if m != 0:
            if trig == "cos":
                out.append((-c * m, n + 1, p, "sin", m))
            else:
                out.append((c * m, n + 1, p, "cos", m))
    return _normalise(out)


def _taylor(terms: tuple[Term, ...], integrated: bool, order: int) -> tuple[Fraction, ...]:
    """Exact Taylor coefficients of u**0 .. u**order; raises if a pole does not cancel."""
    coef: dict[int, Fraction] = {}
    for c, n, p, trig, m in terms:
        k = 0
        while True:
            power = 2 * k if trig == "cos" else 2 * k + 1
            if p + power > order:
                break
            if m == 0 and power > 0:
                break
            sign = -1 if k % 2 else 1
            val = Fraction(sign * m**power, math.factorial(power)) if power else Fraction(1)
            if integrated:
                val /= n + power + 1
            coef[p + power] = coef.get(p + power, Fraction(0)) + c * val
            k += 1
    for power, val in coef.items():
        if power < 0 and val != 0:
            raise ArithmeticError(f"special function has a pole u**{power} that does not cancel")
    return tuple(coef.get(i, Fraction(0)) for i in range(order + 1))


class SpecialFunction:
    """One entire function of ``u`` defined by exact integrand data.

    Parameters
    ----------
    name : str
        Identifier (also the name of the sympy function class).
    terms : tuple of terms
        Integrand ``sum c sigma**n u**p trig(m u sigma)``.
    integrated : bool
        ``True``: integral over ``sigma in [0, 1]``; ``False``: value at ``sigma = 1``.
    """

    def __init__(self, name: str, terms: tuple[Term, ...], integrated: bool) -> None:
        self.name = name
        self.terms = _normalise(terms)
        self.integrated = bool(integrated)
        self.taylor = _taylor(self.terms, self.integrated, SERIES_ORDER)
        self._taylor_float = np.array([float(c) for c in self.taylor])
        # closed-form data grouped for the vectorised evaluation
        self._max_n = max((t[1] for t in self.terms), default=0)

    @property
    def value_at_zero(self) -> Fraction:
        """Exact value at ``u = 0``."""
        return self.taylor[0]

    @property
    def derivative_name(self) -> str:
        return self.name + "_u"

    # -- numerics ------------------------------------------------------------
    def _series(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.zeros_like(u)
        for c in self._taylor_float[::-1]:
            out = out * u + c
        return out

    def _closed(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.zeros_like(u)
        moments: dict[int, list[NDArray[np.complex128]]] = {}
        for c, n, p, trig, m in self.terms:
            if m == 0:
                val = np.full_like(u, 1.0 / (n + 1) if self.integrated else 1.0)
            else:
                if self.integrated:
                    if m not in moments:
                        moments[m] = _moments(m * u, self._max_n)
                    z = moments[m][n]
                else:
                    z = np.exp(1j * m * u)
                val = z.real if trig == "cos" else z.imag
            out += float(c) * u**p * val
        return out

    def __call__(self, u: NDArray[np.float64] | float) -> NDArray[np.float64]:
        u = np.asarray(u, dtype=float)
        small = np.abs(u) < SERIES_RADIUS
        if np.all(small):
            return self._series(u)
        out = np.empty_like(u)
        out[small] = self._series(u[small])
        out[~small] = self._closed(u[~small])
        return out


def _moments(w: NDArray[np.float64], max_n: int) -> list[NDArray[np.complex128]]:
    """``int_0^1 sigma**n e^{i w sigma} d sigma`` for n = 0..max_n, |w| >= SERIES_RADIUS.

    Upward recurrence ``J_n = (e^{iw} - n J_{n-1}) / (i w)``: its error grows like
    n!/|w|**n, harmless for the small n used here and |w| >= 3.
    """
    ew = np.exp(1j * w)
    iw = 1j * w
    out = [(ew - 1.0) / iw]
    for k in range(1, max_n + 1):
        out.append((ew - k * out[-1]) / iw)
    return out


# --------------------------------------------------------------------------
# Registry
# --------------------------------------------------------------------------
_REGISTRY: dict[str, SpecialFunction] = {}
_SYMPY_CLASSES: dict[str, type] = {}


def define(name: str, terms: Iterable[Term], integrated: bool) -> SpecialFunction:
    """Register (or return the already registered) special function ``name``."""
    terms = _normalise(terms)
    if name in _REGISTRY:
        if _REGISTRY[name].terms != terms or _REGISTRY[name].integrated != integrated:
            raise ValueError(f"special function {name!r} already defined differently")
        return _REGISTRY[name]
    fn = SpecialFunction(name, terms, integrated)
    _REGISTRY[name] = fn
    return fn


def special(name: str) -> SpecialFunction:
    """The registered special function ``name``; derivatives ``<name>_u`` are created on demand."""
    if name not in _REGISTRY:
        if not name.endswith("_u"):
            raise KeyError(f"unknown special function {name!r}")
        base = special(name[:-2])
        define(name, differentiate(base.terms), base.integrated)
    return _REGISTRY[name]


class _SpecialSympyFunction(sp.Function):
    """Base of the sympy function classes standing for registered special functions."""

    nargs = 1
    _sf_name: str = ""

    @classmethod
    def eval(cls, arg):  # exact value at the straight configuration (used by the limit rule)
        if arg.is_zero:
            v = special(cls._sf_name).value_at_zero
            return sp.Rational(v.numerator, v.denominator)
        return None

    def fdiff(self, argindex=1):
        return sympy_function(special(self._sf_name).derivative_name)(self.args[0])


def sympy_function(name: str) -> type:
    """The sympy ``Function`` class of special function ``name`` (differentiable)."""
    special(name)
    if name not in _SYMPY_CLASSES:
        _SYMPY_CLASSES[name] = type(name, (_SpecialSympyFunction,), {"_sf_name": name})
    return _SYMPY_CLASSES[name]


# --------------------------------------------------------------------------
# The backbone functions of one segment (complex E(sigma) = a + i b)
# --------------------------------------------------------------------------
_ONE = Fraction(1)
#: a(sigma) = sin(u sigma)/u
A_TERMS: tuple[Term, ...] = ((_ONE, 0, -1, "sin", 1),)
#: b(sigma) = (1 - cos(u sigma))/u
B_TERMS: tuple[Term, ...] = _normalise([(_ONE, 0, -1, "cos", 0), (-_ONE, 0, -1, "cos", 1)])
AU_TERMS = differentiate(A_TERMS)
BU_TERMS = differentiate(B_TERMS)


def _add(*parts: tuple[Term, ...], signs: Iterable[int] | None = None) -> tuple[Term, ...]:
    signs = list(signs) if signs is not None else [1] * len(parts)
    return _normalise([(c * s, n, p, t, m) for part, s in zip(parts, signs) for c, n, p, t, m in part])


def register_backbone_functions() -> dict[str, SpecialFunction]:
    """Define the special functions used by the PCS Lagrangian (idempotent).

    Names: ``Ea, Eb`` (E(1)), ``Eua, Eub`` (dE/du at 1), ``IEa, IEb`` (int E),
    ``IEua, IEub`` (int dE/du), ``IEE`` (int |E|^2), ``IEEu_re, IEEu_im``
    (int E conj(dE/du)), ``IEuEu`` (int |dE/du|^2).
    """
    defs = {
        "Ea": (A_TERMS, False),
        "Eb": (B_TERMS, False),
        "Eua": (AU_TERMS, False),
        "Eub": (BU_TERMS, False),
        "IEa": (A_TERMS, True),
        "IEb": (B_TERMS, True),
        "IEua": (AU_TERMS, True),
        "IEub": (BU_TERMS, True),
        "IEE": (_add(multiply(A_TERMS, A_TERMS), multiply(B_TERMS, B_TERMS)), True),
        "IEEu_re": (_add(multiply(A_TERMS, AU_TERMS), multiply(B_TERMS, BU_TERMS)), True),
        "IEEu_im": (_add(multiply(B_TERMS, AU_TERMS), multiply(A_TERMS, BU_TERMS), signs=(1, -1)), True),
        "IEuEu": (_add(multiply(AU_TERMS, AU_TERMS), multiply(BU_TERMS, BU_TERMS)), True),
    }
    return {name: define(name, terms, integ) for name, (terms, integ) in defs.items()}


# --------------------------------------------------------------------------
# Closed forms as polynomials in 1/u times {1, cos(mu), sin(mu)} (exact tables)
# --------------------------------------------------------------------------
def closed_form_table(fn: SpecialFunction) -> dict[tuple[str, int, int], Fraction]:
    """Exact closed form of ``fn``: ``sum c * u**(-j) * trig(m u)`` as ``{(trig, m, j): c}``.

    ``trig`` is ``"1"``, ``"cos"`` or ``"sin"``.  Uses
    ``int_0^1 s**n e^{iws} ds = e^{iw} sum_k (-1)^k n!/(n-k)! (iw)^-(k+1) - (-1)^n n! (iw)^-(n+1)``.
    """
    out: dict[tuple[str, int, int], Fraction] = {}

    def add(trig: str, m: int, j: int, c: Fraction) -> None:
        if c == 0:
            return
        if trig == "sin" and m == 0:
            return
        if trig != "1" and m == 0:
            trig = "1"
        key = (trig, m, j)
        out[key] = out.get(key, Fraction(0)) + c

    for c, n, p, trig, m in fn.terms:
        if m == 0:
            add("1", 0, -p, c / (n + 1) if fn.integrated else c)
            continue
        if not fn.integrated:
            add(trig, m, -p, c)
            continue
        # complex coefficient list of e^{iw} (-i)^j w^-j  and  (-i)^j w^-j
        pieces: list[tuple[bool, int, Fraction]] = []  # (with e^{iw}, j, real coefficient)
        for k in range(n + 1):
            pieces.append((True, k + 1, Fraction((-1) ** k * math.factorial(n), math.factorial(n - k))))
        pieces.append((False, n + 1, Fraction(-((-1) ** n) * math.factorial(n))))
        for with_e, j, coef in pieces:
            scale = coef / Fraction(m) ** j
            r = j % 4  # (-i)^j = 1, -i, -1, i
            if with_e:
                # Re/Im of (cos w + i sin w) (-i)^j
                re = {0: ("cos", 1), 1: ("sin", 1), 2: ("cos", -1), 3: ("sin", -1)}[r]
                im = {0: ("sin", 1), 1: ("cos", -1), 2: ("sin", -1), 3: ("cos", 1)}[r]
                part = re if trig == "cos" else im
                add(part[0], m, j - p, c * scale * part[1])
            else:
                re = {0: 1, 1: 0, 2: -1, 3: 0}[r]
                im = {0: 0, 1: -1, 2: 0, 3: 1}[r]
                val = re if trig == "cos" else im
                add("1", 0, j - p, c * scale * val)
    return {k: v for k, v in out.items() if v != 0}


class SpecialBank:
    """Vectorised evaluation of several special functions at several ``u`` at once.

    ``bank(u)`` with ``u`` of shape (k,) returns (k, len(names)); a handful of
    numpy calls whatever the number of functions (used by the fast
    single-sample dynamics).
    """

    def __init__(self, names: list[str]) -> None:
        fns = [special(n) for n in names]
        self.names = list(names)
        self.taylor = np.array([f._taylor_float for f in fns]).T  # (K+1, n_fn)
        tables = [closed_form_table(f) for f in fns]
        keys = sorted({(t, m) for tab in tables for (t, m, _j) in tab})
        jmax = max((j for tab in tables for (_t, _m, j) in tab), default=0)
        self._trig_keys = keys
        self._jmax = jmax
        C = np.zeros((len(keys) * (jmax + 1), len(fns)))
        for col, tab in enumerate(tables):
            for (t, m, j), c in tab.items():
                C[keys.index((t, m)) * (jmax + 1) + j, col] = float(c)
        self.closed = C
        self._ms = np.array([m for _t, m in keys], dtype=float)
        self._mcos = np.array([t == "cos" for t, _m in keys], dtype=float)
        self._msin = np.array([t == "sin" for t, _m in keys], dtype=float)
        self._mone = np.array([t == "1" for t, _m in keys], dtype=float)
        self._powers = np.arange(self.taylor.shape[0])
        self._jpowers = np.arange(self._jmax + 1)

    def _series(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        return (u[:, None] ** self._powers) @ self.taylor

    def _closed(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        w = u[:, None] * self._ms
        trig = np.cos(w) * self._mcos + np.sin(w) * self._msin + self._mone
        inv = (1.0 / u)[:, None] ** self._jpowers
        return (trig[:, :, None] * inv[:, None, :]).reshape(u.size, -1) @ self.closed

    def __call__(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        u = np.asarray(u, dtype=float)
        small = np.abs(u) < SERIES_RADIUS
        n_small = int(small.sum())
        if n_small == u.size:
            return self._series(u)
        if n_small == 0:
            return self._closed(u)
        out = np.empty((u.size, len(self.names)))
        out[small] = self._series(u[small])
        out[~small] = self._closed(u[~small])
        return out
