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
generated source text, each with its SHA-256.  Source is executed only when
its hash matches and its syntax tree has exactly the shape we generate
(arithmetic, indexing, ``np.cos/sin/zeros/empty`` and special-function
calls); anything else is a cache miss.  No pickle, no ``sympify``/``eval``
of stored expressions.
"""

from __future__ import annotations

import ast
import hashlib
import json
import math
import os
import re as _re
from collections.abc import Callable
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from . import special as _special
from .derivation import LagrangianTerm, atom_names, derive_lagrangian_terms

__all__ = ["CompiledBasis", "build_basis", "default_cache_dir", "atom_expression"]

#: bump when the derivation or the generated code changes meaning
FORMAT_VERSION = 5


def default_cache_dir() -> Path:
    """``$PCS_SINDY_CACHE`` or ``$XDG_CACHE_HOME/pcs_sindy`` or ``~/.cache/pcs_sindy``."""
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
        # No builtins but float: even text that slipped past the check cannot reach eval/open/__import__.
        namespace: dict[str, Any] = {
            "__builtins__": {"float": float},
            "np": np,
            "math": math,
            "SF": {n: _special.special(n) for n in names},
        }
        exec(compile(source, f"<pcs_sindy basis m={m}>", "exec"), namespace)  # our own generated, hash-checked text
        self.features: Callable = namespace["features"]
        self.psi: Callable = namespace["psi"]
        self.weak: Callable = namespace["weak"]


_SF_CALL = _re.compile(r"SF\['([A-Za-z0-9_]+)'\]")

_ALLOWED_NODES = (
    ast.Module,
    ast.FunctionDef,
    ast.arguments,
    ast.arg,
    ast.Assign,
    ast.Return,
    ast.Name,
    ast.Load,
    ast.Store,
    ast.Attribute,
    ast.Subscript,
    ast.Slice,
    ast.Tuple,
    ast.Constant,
    ast.BinOp,
    ast.UnaryOp,
    ast.Call,
    ast.Add,
    ast.Sub,
    ast.Mult,
    ast.Div,
    ast.Pow,
    ast.USub,
    ast.UAdd,
)
_ALLOWED_CALLS = {"float"}
_GLOBALS = {"np", "SF", "float", "math"}  # names the generated code reads but must never rebind
_ALLOWED_NP = {"cos", "sin", "zeros", "empty"}


def _check_generated_source(source: str) -> None:
    """Refuse cached text that is not of the shape we generate (defence beyond the hash).

    Only the functions ``features``/``psi``/``weak`` made of arithmetic, indexing, and calls
    of ``np.cos/sin/zeros/empty``, ``float`` and ``SF['name']`` are accepted.
    """
    tree = ast.parse(source)
    if [n.name for n in tree.body if isinstance(n, ast.FunctionDef)] != ["features", "psi", "weak"] or len(
        tree.body
    ) != 3:
        raise ValueError("cached source must define exactly features(), psi() and weak()")
    local = {a.arg for fn in tree.body for a in fn.args.args}
    local |= {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)}
    if local & _GLOBALS:
        raise ValueError(f"cached source rebinds a reserved name: {sorted(local & _GLOBALS)}")
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Load) and node.id not in local | _GLOBALS:
            raise ValueError(f"cached source reads an unknown name: {node.id}")
        if not isinstance(node, _ALLOWED_NODES):
            raise ValueError(f"cached source contains a forbidden construct: {type(node).__name__}")
        if isinstance(node, ast.Attribute):
            ok = isinstance(node.value, ast.Name) and (
                (node.value.id == "np" and node.attr in _ALLOWED_NP) or node.attr == "shape"
            )
            if not ok:
                raise ValueError(f"cached source uses a forbidden attribute: {node.attr}")
        if isinstance(node, ast.Call):
            f = node.func
            ok = (
                (isinstance(f, ast.Name) and f.id in _ALLOWED_CALLS)
                or (isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id == "np")
                or (isinstance(f, ast.Subscript) and isinstance(f.value, ast.Name) and f.value.id == "SF")
            )
            if not ok or node.keywords:
                raise ValueError("cached source contains a forbidden call")
        if isinstance(node, ast.Name) and node.id.startswith("__"):
            raise ValueError(f"cached source uses a forbidden name: {node.id}")


def _distinct_products(terms: list[LagrangianTerm]) -> list[tuple[tuple[str, int], ...]]:
    seen: dict[tuple, None] = {}
    for t in terms:
        seen.setdefault(t.atoms, None)
    return list(seen)


def _cache_file(cache_dir: Path, m: int) -> Path:
    return cache_dir / f"pcs_basis_m{m}_v{FORMAT_VERSION}.json"


def build_basis(m: int, cache_dir: str | os.PathLike | None | bool = None, progress: bool = False) -> CompiledBasis:
    """Derive (or load from the cache) and compile the basis of an m-segment model.

    Parameters
    ----------
    m : int
        Number of segments.
    cache_dir : path, None or False
        Cache directory; ``None`` uses :func:`default_cache_dir`, ``False``
        disables the cache (always derive, never write).
    progress : bool
        tqdm progress bar over the basis functions while deriving.
    """
    if cache_dir is False:
        path = None
    else:
        directory = default_cache_dir() if cache_dir is None or cache_dir is True else Path(cache_dir)
        path = _cache_file(directory, m)
    if path is not None and path.is_file():
        try:
            data = json.loads(path.read_text())
            source = data["source"]
            ok = (
                data.get("format") == FORMAT_VERSION
                and data.get("m") == m
                and hashlib.sha256(source.encode()).hexdigest() == data.get("sha256")
                and hashlib.sha256(json.dumps(data["terms"]).encode()).hexdigest() == data.get("terms_sha256")
                and hashlib.sha256(json.dumps(data["psi"]).encode()).hexdigest() == data.get("psi_sha256")
            )
        except (OSError, ValueError, KeyError, TypeError):
            ok = False
        if ok:
            try:
                return CompiledBasis(m, _terms_from_json(data["terms"]), source, data["psi"], from_cache=True)
            except (ValueError, SyntaxError, TypeError, KeyError):
                pass  # not text we generated: derive again and overwrite
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
            tmp = path.with_suffix(f".tmp{os.getpid()}")
            tmp.write_text(json.dumps(payload))
            os.replace(tmp, path)
        except OSError:
            pass  # a read-only cache must not stop the user: we simply re-derive next time
    return CompiledBasis(m, terms, source, psi_data, from_cache=False)
