"""Euler–Lagrange images of the basis atoms, compiled to numpy source, and its disk cache.

The derivation (:mod:`.derivation`) yields the Lagrangian as terms over
distinct *atom products* ``g_j(q, qd)``.  Here each ``g_j`` becomes a sympy
expression (special functions as differentiable sympy functions of
``L_k kappa_k``), its Euler–Lagrange image

    psi_j = d2g/dqd2 qdd + d2g/dqd dq qd - dg/dq

is derived with sympy, and numpy source is generated that evaluates all
``g_j`` and ``psi_j`` for whole batches, with the segment lengths as runtime
arguments.  Function values (special functions, cos, sin) are computed once
per call and shared by all columns.

The Euler–Lagrange images are also kept as plain polynomial data (atoms,
exact rational factor, length exponents) from which the fast single-sample
dynamics of :meth:`PCSLagrangianLibrary.compile_dynamics` is assembled.

The cache holds only JSON: the term list, the Psi polynomial data and the
generated source text, each with its SHA-256.  The hashes are stored in the same
file, so they detect accidental damage (a truncated or partly overwritten file),
not tampering: anyone who can write the cache directory can write matching
hashes.  **The cache directory must therefore be trusted** (writable only by
you; see ``cache_dir`` of :func:`build_basis` and ``$PCS_SINDY_CACHE``).  As a
defence in depth, cached source is executed only when its syntax tree has
exactly the form the generator writes (:func:`_check_generated_source`: three
functions without defaults or decorators, single assignments to local names or
indexed stores into their result arrays, arithmetic, small literal powers, and
calls of ``np.cos/sin/zeros/empty``, ``float`` and ``SF['name']``; no attribute
stores, imports, loops or other names), in a namespace without builtins, and
must then evaluate one state to arrays of the right shapes.  Cached text that
fails any of this is a cache miss: a warning, a new derivation, and the file
is replaced (atomically, :mod:`pcs_sindy.core.atomic`).  No pickle, no
``sympify``/``eval`` of stored expressions.
"""

from __future__ import annotations

import ast
import hashlib
import json
import math
import os
import re as _re
import stat
from collections.abc import Callable
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from ...core import atomic
from . import special as _special
from .derivation import LagrangianTerm, atom_names, derive_lagrangian_terms

__all__ = ["CompiledBasis", "build_basis", "default_cache_dir", "atom_expression"]

#: bump when the derivation or the generated code changes meaning
FORMAT_VERSION = 5
# largest cache file read (the m = 3 basis is a few MB)
_MAX_CACHE_BYTES = 512 * 2**20


def default_cache_dir() -> Path:
    """``$PCS_SINDY_CACHE`` or ``$XDG_CACHE_HOME/pcs_sindy`` or ``~/.cache/pcs_sindy``.

    The directory holds generated code that the libraries execute: point ``PCS_SINDY_CACHE``
    only at a directory that no one you do not trust can write.
    """
    env = os.environ.get("PCS_SINDY_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "pcs_sindy"


class _Symbols:
    def __init__(self, m: int) -> None:
        names = atom_names(m)
        self.m = m
        self.q = [sp.Symbol(n) for n in names["q"]]
        self.qd = [sp.Symbol(n) for n in names["qd"]]
        self.qdd = [sp.Symbol("d" + n) for n in names["qd"]]
        self.L = [sp.Symbol(f"L_{i + 1}", positive=True) for i in range(m)]
        self.by_name = {s.name: s for s in self.q + self.qd}

    def kappa(self, i: int) -> sp.Symbol:
        return self.q[3 * i]


def _parse_phase(tag: str) -> tuple[int, ...]:
    return tuple(-int(p[1:]) if p.startswith("m") else int(p) for p in tag.split("_"))


def atom_expression(name: str, syms: _Symbols, numeric_lengths=None) -> sp.Expr:
    """Sympy expression of one atom (state symbol, special function or phase trig)."""
    L = syms.L if numeric_lengths is None else [sp.Float(v, 17) for v in numeric_lengths]
    if name in syms.by_name:
        return syms.by_name[name]
    if name.startswith("F"):
        fn, seg = name[1:].rsplit("_", 1)
        i = int(seg) - 1
        return _special.sympy_function(fn)(L[i] * syms.kappa(i))
    if name[0] in "cs":
        phase = _parse_phase(name[1:])
        arg = sum((a * L[k] * syms.kappa(k) for k, a in enumerate(phase) if a), sp.Integer(0))
        return sp.cos(arg) if name[0] == "c" else sp.sin(arg)
    raise ValueError(f"unknown atom {name!r}")


def product_expression(atoms, syms: _Symbols, numeric_lengths=None) -> sp.Expr:
    out = sp.Integer(1)
    for name, power in atoms:
        out *= atom_expression(name, syms, numeric_lengths) ** power
    return out


def euler_lagrange(expr: sp.Expr, syms: _Symbols) -> list[sp.Expr]:
    """Rows of ``d/dt dexpr/dqd - dexpr/dq``."""
    rows = []
    for r in range(len(syms.q)):
        dqd = sp.diff(expr, syms.qd[r])
        row = -sp.diff(expr, syms.q[r])
        if dqd != 0:
            for c in range(len(syms.q)):
                row += sp.diff(dqd, syms.qd[c]) * syms.qdd[c] + sp.diff(dqd, syms.q[c]) * syms.qd[c]
        rows.append(sp.expand(row))
    return rows


class _Printer(PythonCodePrinter):
    def _print_Pow(self, expr, rational=False):
        base, exp = expr.args
        if exp.is_Integer and 1 < int(exp) <= 4:
            b = self.parenthesize(base, 100)
            return "*".join([b] * int(exp))
        return super()._print_Pow(expr, rational)


def _function_atoms(exprs) -> list[sp.Expr]:
    found: set[sp.Expr] = set()
    for e in exprs:
        found |= {a for a in e.atoms(sp.Function) if isinstance(a, (_special._SpecialSympyFunction, sp.cos, sp.sin))}
    return sorted(found, key=sp.default_sort_key)


def _canonical_atom_map(funcs, syms: _Symbols) -> dict[sp.Expr, sp.Expr]:
    """Function applications -> (sign *) atom symbols named as in the derivation."""
    kap_index = {syms.kappa(i): i for i in range(syms.m)}
    out = {}
    for f in funcs:
        coeffs = sp.expand(f.args[0]).as_coefficients_dict()
        phase = [0] * syms.m
        for mono, c in coeffs.items():
            seg = [kap_index[x] for x in mono.free_symbols if x in kap_index]
            if len(seg) != 1:
                raise ArithmeticError(f"unexpected argument {f.args[0]}")
            phase[seg[0]] += int(c)
        if isinstance(f, _special._SpecialSympyFunction):
            seg = next(k for k, a in enumerate(phase) if a)
            out[f] = sp.Symbol(f"F{type(f)._sf_name}_{seg + 1}")
            continue
        sign = 1
        if next(a for a in phase if a) < 0:
            phase = [-a for a in phase]
            sign = -1 if isinstance(f, sp.sin) else 1
        tag = "_".join(str(a) if a >= 0 else f"m{-a}" for a in phase)
        out[f] = sign * sp.Symbol(("c" if isinstance(f, sp.cos) else "s") + tag)
    return out


def _poly_data(expr: sp.Expr, amap, syms: _Symbols) -> list:
    """Expanded ``expr`` as ``[[atoms], num, den, [L exponents]]`` entries."""
    L_index = {L: k for k, L in enumerate(syms.L)}
    out = []
    for mono, c in sp.expand(expr.xreplace(amap)).as_coefficients_dict().items():
        c = sp.Rational(c)
        lexp = [0] * syms.m
        atoms = []
        for base, power in mono.as_powers_dict().items():
            if base == 1:
                continue
            if base in L_index:
                lexp[L_index[base]] += int(power)
            else:
                atoms.append([base.name, int(power)])
        atoms.sort()
        out.append([atoms, int(c.p), int(c.q), lexp])
    return out


def _generate_source(products: list[tuple[tuple[str, int], ...]], m: int, progress: bool = False):
    """numpy source of ``features(q, qd, L)`` and ``psi(q, qd, qdd, L)``, and Psi as polynomial data."""
    from tqdm.auto import tqdm

    syms = _Symbols(m)
    g = [product_expression(p, syms) for p in products]
    psi = [euler_lagrange(e, syms) for e in tqdm(g, desc=f"Euler-Lagrange (m={m})", disable=not progress)]
    everything = g + [x for rows in psi for x in rows]
    funcs = _function_atoms(everything)
    repl = {}
    fnames = []
    for k, f in enumerate(funcs):
        v = sp.Symbol(f"_f{k}")
        repl[f] = v
        fnames.append(v.name)
    printer = _Printer({"fully_qualified_modules": False})
    n = 3 * m
    head = []
    for i in range(m):
        head.append(f"    L_{i + 1} = float(L[{i}])")
    for r in range(n):
        head.append(f"    {syms.q[r].name} = q[:, {r}]")
    func_lines = []
    for f, name in zip(funcs, fnames):
        arg = printer.doprint(f.args[0])
        if isinstance(f, sp.cos):
            func_lines.append(f"    {name} = np.cos({arg})")
        elif isinstance(f, sp.sin):
            func_lines.append(f"    {name} = np.sin({arg})")
        else:
            func_lines.append(f"    {name} = SF[{type(f)._sf_name!r}]({arg})")
    feat = ["def features(q, qd, L):", *head]
    feat += [f"    {syms.qd[r].name} = qd[:, {r}]" for r in range(n)]
    feat += func_lines
    feat.append(f"    out = np.empty((q.shape[0], {len(g)}))")
    for j, e in enumerate(g):
        feat.append(f"    out[:, {j}] = {printer.doprint(e.xreplace(repl))}")
    feat.append("    return out")
    ps = ["def psi(q, qd, qdd, L):", *head]
    ps += [f"    {syms.qd[r].name} = qd[:, {r}]" for r in range(n)]
    ps += [f"    {syms.qdd[r].name} = qdd[:, {r}]" for r in range(n)]
    ps += func_lines
    ps.append(f"    out = np.zeros((q.shape[0], {n}, {len(g)}))")
    for j, rows in enumerate(psi):
        for r, e in enumerate(rows):
            if e != 0:
                ps.append(f"    out[:, {r}, {j}] = {printer.doprint(e.xreplace(repl))}")
    ps.append("    return out")
    # weak form: Psi = d/dt dg/dqd - dg/dq, so P = dg/dqd and R = -dg/dq
    wk = ["def weak(q, qd, L):", *head]
    wk += [f"    {syms.qd[r].name} = qd[:, {r}]" for r in range(n)]
    wk += func_lines
    wk.append(f"    mom = np.zeros((q.shape[0], {n}, {len(g)}))")
    wk.append(f"    rest = np.zeros((q.shape[0], {n}, {len(g)}))")
    for j, e in enumerate(g):
        for r in range(n):
            p_e = sp.diff(e, syms.qd[r])
            r_e = -sp.diff(e, syms.q[r])
            if p_e != 0:
                wk.append(f"    mom[:, {r}, {j}] = {printer.doprint(sp.expand(p_e).xreplace(repl))}")
            if r_e != 0:
                wk.append(f"    rest[:, {r}, {j}] = {printer.doprint(sp.expand(r_e).xreplace(repl))}")
    wk.append("    return mom, rest")
    amap = _canonical_atom_map(funcs, syms)
    psi_data = [[_poly_data(e, amap, syms) for e in rows] for rows in psi]
    return "\n".join(feat) + "\n\n\n" + "\n".join(ps) + "\n\n\n" + "\n".join(wk) + "\n", psi_data


def _terms_to_json(terms: list[LagrangianTerm]) -> list:
    return [
        [
            t.coefficient.numerator,
            t.coefficient.denominator,
            list(t.length_exponents),
            t.param,
            [list(a) for a in t.atoms],
        ]
        for t in terms
    ]


def _terms_from_json(data: list) -> list[LagrangianTerm]:
    return [
        LagrangianTerm(
            Fraction(int(a), int(b)), tuple(int(x) for x in le), str(p), tuple((str(n), int(e)) for n, e in at)
        )
        for a, b, le, p, at in data
    ]


class CompiledBasis:
    """Derived and compiled Lagrangian atoms of an m-segment model.

    Attributes
    ----------
    m : int
    terms : list of LagrangianTerm
    products : list of atom products (one per distinct ``g_j``)
    psi_data : list
        ``psi_data[j][r]``: row r of the Euler–Lagrange image of ``g_j`` as
        ``[[atoms], num, den, [L exponents]]`` entries (qdd atoms named ``dd<q>``).
    features(q, qd, L) -> (N, n_g);  psi(q, qd, qdd, L) -> (N, 3m, n_g);
    weak(q, qd, L) -> (P, R), each (N, 3m, n_g): ``psi = dP/dt + R`` (P = dg/dqd, R = -dg/dq)
    source : str
        The generated numpy source.
    from_cache : bool
    """

    def __init__(self, m: int, terms: list[LagrangianTerm], source: str, psi_data: list, from_cache: bool) -> None:
        self.m = m
        self.psi_data = psi_data
        self.terms = terms
        self.products = _distinct_products(terms)
        self.source = source
        self.from_cache = from_cache
        _special.register_backbone_functions()
        _check_generated_source(source)
        names = sorted(set(_SF_CALL.findall(source)))
        if any(_re.search(r"(_u){5,}$", n) for n in names):  # derivatives are made on demand: bound their order
            raise _SourceShapeError("cached source calls a special function derivative of order above 4")
        try:
            functions = {n: _special.special(n) for n in names}
        except KeyError as err:
            raise _SourceShapeError(f"cached source calls an unknown special function: {err}") from None
        # No builtins but float: even text that slipped past the check cannot reach eval/open/__import__.
        namespace: dict[str, Any] = {"__builtins__": {"float": float}, "np": np, "SF": functions}
        # text of the generator's form (checked above): defining the three functions runs no other code
        exec(compile(source, f"<pcs_sindy basis m={m}>", "exec"), namespace)
        self.features: Callable = namespace["features"]
        self.psi: Callable = namespace["psi"]
        self.weak: Callable = namespace["weak"]
        if from_cache:
            self._smoke_test()

    def _smoke_test(self) -> None:
        """Evaluate the three functions on one state: cached text that fails or mis-shapes is refused."""
        n, n_g = 3 * self.m, len(self.products)
        z = np.full((1, n), 0.1)
        lengths = np.full(self.m, 0.1)
        with np.errstate(all="ignore"):
            shapes = (
                np.shape(self.features(z, z, lengths)),
                np.shape(self.psi(z, z, z, lengths)),
                *(np.shape(a) for a in self.weak(z, z, lengths)),
            )
        if shapes != ((1, n_g), (1, n, n_g), (1, n, n_g), (1, n, n_g)):
            raise _SourceShapeError(f"cached source returns arrays of shapes {shapes}; expected {n_g} basis columns")


_SF_CALL = _re.compile(r"SF\['([A-Za-z0-9_]+)'\]")

#: the functions the generator writes, with their arguments (positional only, no defaults)
_SIGNATURES = {"features": ["q", "qd", "L"], "psi": ["q", "qd", "qdd", "L"], "weak": ["q", "qd", "L"]}
#: the arrays each function fills by indexed assignment and returns
_RESULTS = {"features": ("out",), "psi": ("out",), "weak": ("mom", "rest")}
_GLOBALS = {"np", "SF", "float"}  # names the generated code reads but must never rebind
_ALLOWED_NP = {"cos", "sin", "zeros", "empty"}
_BINOPS = (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow)
_UNARYOPS = (ast.USub, ast.UAdd)
# largest integer literal (rational factors of the derivation stay far below it) and power
_MAX_LITERAL = 10**15
_MAX_POWER = 64
# largest literal dimension of an array the generated code allocates (columns of the basis)
_MAX_DIMENSION = 10**5


class _SourceShapeError(ValueError):
    """Cached source that is not of the form the generator writes."""


def _fail(node: ast.AST | None, what: str) -> _SourceShapeError:
    line = getattr(node, "lineno", None)
    return _SourceShapeError(f"cached source{'' if line is None else f' line {line}'}: {what}")


def _number(node: ast.AST, limit: float = _MAX_LITERAL) -> bool:
    """An int or finite float literal of magnitude at most ``limit`` (no bool, str, bytes, complex)."""
    return (
        isinstance(node, ast.Constant)
        and type(node.value) in (int, float)
        and math.isfinite(node.value)
        and abs(node.value) <= limit
    )


class _GeneratedForm:
    """The statement and expression forms :func:`_generate_source` writes, and nothing else."""

    def __init__(self, local: set[str], state: set[str]) -> None:
        self.local = local
        # names that hold the state (the arguments, and locals computed from them, in statement order):
        # a power must raise one of these, never a constant, which aliasing through locals could make
        # an integer that grows without bound (c = 9; d = c**64; e = d**64; ...)
        self.state = set(state)

    def holds_state(self, node: ast.AST) -> bool:
        return any(isinstance(n, ast.Name) and n.id in self.state for n in ast.walk(node))

    # -- expressions ----------------------------------------------------------
    def expr(self, node: ast.AST) -> None:
        if _number(node):
            return
        if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Load):
            if node.id not in self.local and node.id != "float":
                raise _fail(node, f"reads an unknown name {node.id!r}")
            return
        if isinstance(node, ast.BinOp) and isinstance(node.op, _BINOPS):
            if isinstance(node.op, ast.Pow):
                # x**k with a literal integer k of a term that holds a variable (never 9**9**9)
                exponent = node.right
                if isinstance(exponent, ast.UnaryOp) and isinstance(exponent.op, ast.USub):
                    exponent = exponent.operand
                if not (_number(exponent, _MAX_POWER) and type(exponent.value) is int and self.holds_state(node.left)):
                    raise _fail(node, "a power must raise an expression of the state to a small literal integer")
            self.expr(node.left)
            self.expr(node.right)
            return
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, _UNARYOPS):
            self.expr(node.operand)
            return
        if isinstance(node, ast.Subscript) and isinstance(node.ctx, ast.Load):
            self.subscript(node)
            return
        if isinstance(node, ast.Call):
            self.call(node)
            return
        raise _fail(node, f"forbidden expression {ast.unparse(node)[:60]!r}")

    def subscript(self, node: ast.Subscript) -> None:
        """``x[:, k]``, ``L[k]`` and ``q.shape[0]``: a local array indexed by literals and full slices."""
        value = node.value
        if isinstance(value, ast.Attribute):
            if not (
                isinstance(value.value, ast.Name) and value.value.id in self.local and value.attr == "shape"
            ) or not (_number(node.slice) and node.slice.value == 0):
                raise _fail(node, "only q.shape[0] may be read from an attribute")
            return
        if not (isinstance(value, ast.Name) and value.id in self.local):
            raise _fail(node, "only local arrays may be indexed")
        self.index(node.slice)

    def index(self, node: ast.AST) -> None:
        parts = node.elts if isinstance(node, ast.Tuple) else [node]
        for part in parts:
            if isinstance(part, ast.Slice):
                if part.lower is not None or part.upper is not None or part.step is not None:
                    raise _fail(part, "only full slices ':' are written")
            elif not (_number(part, _MAX_DIMENSION) and type(part.value) is int and part.value >= 0):
                raise _fail(part, "indices must be literal non-negative integers")

    def call(self, node: ast.Call) -> None:
        if node.keywords:
            raise _fail(node, "calls take no keyword arguments")
        f = node.func
        if isinstance(f, ast.Name) and f.id == "float":
            if len(node.args) != 1:
                raise _fail(node, "float() takes one argument")
            self.expr(node.args[0])
            return
        if isinstance(f, ast.Subscript) and isinstance(f.value, ast.Name) and f.value.id == "SF":
            if not (isinstance(f.slice, ast.Constant) and isinstance(f.slice.value, str)):
                raise _fail(node, "special functions are named by a string literal")
            if len(node.args) != 1:
                raise _fail(node, "special functions take one argument")
            self.expr(node.args[0])
            return
        if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id == "np":
            if f.attr in ("cos", "sin") and len(node.args) == 1:
                self.expr(node.args[0])
                return
            if f.attr in ("zeros", "empty") and len(node.args) == 1 and isinstance(node.args[0], ast.Tuple):
                dims = node.args[0].elts
                for k, dim in enumerate(dims):
                    if k == 0 and isinstance(dim, ast.Subscript):
                        self.subscript(dim)
                    elif not (_number(dim, _MAX_DIMENSION) and type(dim.value) is int and dim.value >= 0):
                        raise _fail(node, "array sizes must be q.shape[0] and small literal integers")
                return
        allowed = f"np.{sorted(_ALLOWED_NP)}, float, SF"
        raise _fail(node, f"forbidden call {ast.unparse(node.func)[:40]!r} (allowed: {allowed})")

    # -- statements -----------------------------------------------------------
    def function(self, fn: ast.stmt, name: str) -> None:
        if not isinstance(fn, ast.FunctionDef) or fn.name != name:
            raise _fail(fn, f"expected def {name}(...)")
        a = fn.args
        if (
            fn.decorator_list
            or fn.returns is not None
            or getattr(fn, "type_params", None)
            or a.posonlyargs
            or a.vararg
            or a.kwonlyargs
            or a.kw_defaults
            or a.kwarg
            or a.defaults
            or [x.arg for x in a.args] != _SIGNATURES[name]
            or any(x.annotation is not None for x in a.args)
        ):
            raise _fail(fn, f"{name} must be def {name}({', '.join(_SIGNATURES[name])}) without defaults or decorators")
        if not fn.body or not isinstance(fn.body[-1], ast.Return):
            raise _fail(fn, f"{name} must end with its return")
        results = _RESULTS[name]
        for stmt in fn.body[:-1]:
            if not (isinstance(stmt, ast.Assign) and len(stmt.targets) == 1):
                raise _fail(stmt, f"only single assignments are written, not {type(stmt).__name__}")
            target = stmt.targets[0]
            if isinstance(target, ast.Name):
                if target.id in _GLOBALS or target.id.startswith("__"):
                    raise _fail(stmt, f"rebinds the reserved name {target.id!r}")
            elif isinstance(target, ast.Subscript):
                if not (isinstance(target.value, ast.Name) and target.value.id in results):
                    raise _fail(stmt, f"only {', '.join(results)} are filled by index")
                self.index(target.slice)
            else:  # attribute stores (np.cos = np.sin), tuple unpacking, starred
                raise _fail(stmt, f"assigns to a {type(target).__name__}")
            self.expr(stmt.value)
            if isinstance(target, ast.Name) and self.holds_state(stmt.value):
                self.state.add(target.id)
        ret = fn.body[-1].value
        names = ret.elts if isinstance(ret, ast.Tuple) else [ret]
        if [getattr(n, "id", None) for n in names] != list(results):
            raise _fail(fn.body[-1], f"{name} must return {', '.join(results)}")


def _check_generated_source(source: str) -> None:
    """Refuse cached text that is not of the form we generate (defence beyond the hash).

    Accepted: exactly ``def features(q, qd, L)``, ``def psi(q, qd, qdd, L)`` and
    ``def weak(q, qd, L)`` (no defaults, annotations or decorators), whose bodies are
    single assignments to local names or indexed stores into their result arrays, then
    ``return``; expressions of literal numbers, local names, ``+ - * /``, powers of a state
    expression by a small literal integer, indexing of local arrays by literals and ``:``,
    ``q.shape[0]``, and calls of ``np.cos``, ``np.sin``, ``np.zeros``/``np.empty`` (of a
    literal shape), ``float`` and ``SF['name']``.  No attribute stores, imports, defaults,
    loops, comprehensions, lambdas or other names.

    Raises
    ------
    ValueError
        Naming the first construct outside this form.
    """
    try:
        tree = ast.parse(source)
    except (SyntaxError, ValueError, RecursionError, MemoryError) as err:
        raise _SourceShapeError(f"cached source does not parse: {type(err).__name__}: {err}") from None
    if len(tree.body) != len(_SIGNATURES):
        raise _SourceShapeError("cached source must define exactly features(), psi() and weak()")
    for fn, name in zip(tree.body, _SIGNATURES):
        local = set(_SIGNATURES[name]) | {
            t.id
            for stmt in getattr(fn, "body", [])
            if isinstance(stmt, ast.Assign)
            for t in stmt.targets
            if isinstance(t, ast.Name)
        }
        _GeneratedForm(local - _GLOBALS, set(_SIGNATURES[name])).function(fn, name)


def _distinct_products(terms: list[LagrangianTerm]) -> list[tuple[tuple[str, int], ...]]:
    seen: dict[tuple, None] = {}
    for t in terms:
        seen.setdefault(t.atoms, None)
    return list(seen)


def _cache_file(cache_dir: Path, m: int) -> Path:
    return cache_dir / f"pcs_basis_m{m}_v{FORMAT_VERSION}.json"


def _read_cache(path: Path, m: int) -> CompiledBasis | None:
    """The basis stored in ``path``, or None (with a warning when the file is there but unusable)."""
    import warnings

    try:
        with open(path, "rb") as fh:
            if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
                raise ValueError("not a regular file")
            raw = fh.read(_MAX_CACHE_BYTES + 1)
        if len(raw) > _MAX_CACHE_BYTES:
            raise ValueError(f"larger than {_MAX_CACHE_BYTES} bytes")
        data = json.loads(raw.decode("utf-8"))
        source = data["source"]
        ok = (
            data.get("format") == FORMAT_VERSION
            and data.get("m") == m
            and hashlib.sha256(source.encode()).hexdigest() == data.get("sha256")
            and hashlib.sha256(json.dumps(data["terms"]).encode()).hexdigest() == data.get("terms_sha256")
            and hashlib.sha256(json.dumps(data["psi"]).encode()).hexdigest() == data.get("psi_sha256")
        )
        if not ok:
            return None  # another version or a damaged file: derive again and overwrite, as for a miss
        return CompiledBasis(m, _terms_from_json(data["terms"]), source, data["psi"], from_cache=True)
    except Exception as err:  # noqa: BLE001 - any failure of cached text means: derive again
        warnings.warn(
            f"the derivation cache {str(path)!r} is not usable ({type(err).__name__}: {str(err)[:200]}); "
            "deriving the basis again and replacing it",
            RuntimeWarning,
            stacklevel=3,
        )
        return None


def build_basis(m: int, cache_dir: str | os.PathLike | None | bool = None, progress: bool = False) -> CompiledBasis:
    """Derive (or load from the cache) and compile the basis of an m-segment model.

    Parameters
    ----------
    m : int
        Number of segments.
    cache_dir : path, None or False
        Cache directory; ``None`` uses :func:`default_cache_dir`, ``False``
        disables the cache (always derive, never write).  It holds generated code
        that is executed: it must be a directory only you (or people you trust)
        can write; the hashes in its files detect damage, not tampering.
    progress : bool
        tqdm progress bar over the basis functions while deriving.
    """
    if cache_dir is False:
        path = None
    else:
        directory = default_cache_dir() if cache_dir is None or cache_dir is True else Path(cache_dir)
        path = _cache_file(directory, m)
    if path is not None and path.is_file():
        cached = _read_cache(path, m)
        if cached is not None:
            return cached
    terms = derive_lagrangian_terms(m)
    source, psi_data = _generate_source(_distinct_products(terms), m, progress)
    if path is not None:
        tj = _terms_to_json(terms)
        payload = {
            "format": FORMAT_VERSION,
            "m": m,
            "terms": tj,
            "terms_sha256": hashlib.sha256(json.dumps(tj).encode()).hexdigest(),
            "psi": psi_data,
            "psi_sha256": hashlib.sha256(json.dumps(psi_data).encode()).hexdigest(),
            "source": source,
            "sha256": hashlib.sha256(source.encode()).hexdigest(),
        }
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            atomic.write_text(path, json.dumps(payload))  # a reader never sees half a file
        except OSError:
            pass  # a read-only cache must not stop the user: we simply re-derive next time
    return CompiledBasis(m, terms, source, psi_data, from_cache=False)
