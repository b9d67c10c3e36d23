"""Symbolic derivation of the planar PCS Lagrangian as a sum of monomial-like terms.

Positions are complex numbers ``z = x + i y``.  Inside segment ``i`` (local
normalised arc length ``sigma``, bending angle ``u_i = kappa_i L_i``)

    z(sigma) = Z_{i-1} + e^{i phi_i} L_i w_i E(u_i, sigma),   w_i = sh_i + i (1 + ax_i),
    E(u, sigma) = int_0^sigma e^{i u t} dt = a + i b,
    phi_i = u_1 + ... + u_{i-1}.

Velocities are therefore sums of phasors ``e^{i (integer combination of u)}``
times polynomials in the strains, their rates and ``E, dE/du`` of single
segments.  The kinetic energy ``int |z'|^2`` only needs the sigma-integrals of
``E, dE/du`` and of their pairwise products: those are the entire special
functions of :mod:`.special` (exact at ``u = 0``).  Phasors are kept as exact
integer phase vectors, so no trigonometric simplification is ever needed; the
Lagrangian comes out as a polynomial in "atoms" (strains, strain rates,
special-function values, cos/sin of phase sums) whose coefficients are
polynomials in the segment lengths and the lumped physical unknowns

    mA_i = rho_i A_i,  mI_i = rho_i I_i,  gx_i = rho_i A_i g_x,  gy_i = rho_i A_i g_y,
    kbe_i, ksh_i, kax_i (stiffnesses, elastic energy k q^2 / 2).

Only geometry (the number of segments; lengths stay symbols) enters the
derivation.  The result is plain data (JSON-serialisable).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import sympy as sp

from .special import register_backbone_functions

__all__ = ["LagrangianTerm", "derive_lagrangian_terms", "atom_names", "PARAM_KINDS"]

#: lumped unknowns per segment, in the order used for parameter vectors
PARAM_KINDS = ("mA", "mI", "gx", "gy", "kbe", "ksh", "kax")

Phase = tuple[int, ...]


@dataclass(frozen=True)
class LagrangianTerm:
    """``rational * prod(L_k ** l_exp[k]) * param * prod(atom ** power)``."""

    coefficient: Fraction
    length_exponents: tuple[int, ...]
    param: str  # e.g. "mA_1"
    atoms: tuple[tuple[str, int], ...]  # sorted (atom name, power)


class _Phasors:
    """Sum of ``(re + i im) e^{i phase . u}``; re/im are sympy expressions."""

    def __init__(self, m: int, data: dict[Phase, tuple[sp.Expr, sp.Expr]] | None = None) -> None:
        self.m = m
        self.data = data or {}

    @classmethod
    def const(cls, m: int, re, im=0, phase: Phase | None = None) -> _Phasors:
        return cls(m, {phase or (0,) * m: (sp.sympify(re), sp.sympify(im))})

    def __add__(self, other: _Phasors) -> _Phasors:
        out = dict(self.data)
        for ph, (r, i) in other.data.items():
            r0, i0 = out.get(ph, (0, 0))
            out[ph] = (r0 + r, i0 + i)
        return _Phasors(self.m, out)

    def __mul__(self, other: _Phasors) -> _Phasors:
        out: dict[Phase, tuple] = {}
        for p1, (r1, i1) in self.data.items():
            for p2, (r2, i2) in other.data.items():
                ph = tuple(a + b for a, b in zip(p1, p2))
                r0, i0 = out.get(ph, (0, 0))
                out[ph] = (r0 + r1 * r2 - i1 * i2, i0 + r1 * i2 + i1 * r2)
        return _Phasors(self.m, out)

    def scale(self, factor) -> _Phasors:
        return _Phasors(self.m, {p: (r * factor, i * factor) for p, (r, i) in self.data.items()})

    def conj(self) -> _Phasors:
        return _Phasors(self.m, {tuple(-a for a in p): (r, -i) for p, (r, i) in self.data.items()})

    def real(self, trig) -> sp.Expr:
        """Re(sum) with cos/sin of a phase given by ``trig(kind, phase)``."""
        out = 0
        for p, (r, i) in self.data.items():
            out += r * trig("c", p) - i * trig("s", p)
        return out

    def imag(self, trig) -> sp.Expr:
        out = 0
        for p, (r, i) in self.data.items():
            out += i * trig("c", p) + r * trig("s", p)
        return out


def atom_names(m: int) -> dict[str, list[str]]:
    """Names of the state atoms: q (strains) and qd (rates), in q order."""
    q = [f"{n}_{i + 1}" for i in range(m) for n in ("kap", "sh", "ax")]
    return {"q": q, "qd": ["d" + n for n in q]}


def derive_lagrangian_terms(m: int) -> list[LagrangianTerm]:
    """Expand the Lagrangian of an m-segment planar PCS robot into terms.

    Parameters
    ----------
    m : int
        Number of segments (>= 1).

    Returns
    -------
    list of LagrangianTerm
        ``L = T - V_g - V_e`` as a sum of terms; atoms are named
        ``kap_i, sh_i, ax_i`` (strains), ``dkap_i, ...`` (rates),
        ``F<fn>_<i>`` (special function ``fn`` of ``u_i``), ``c<phase>`` /
        ``s<phase>`` (cos/sin of ``sum_k phase_k u_k``, phase written as
        ``c1_0_m1`` for ``(1, 0, -1)``).
    """
    if int(m) != m or m < 1:
        raise ValueError(f"m (number of segments) must be a positive integer; got {m!r}")
    m = int(m)
    register_backbone_functions()
    sym = sp.Symbol
    L = [sym(f"L_{i + 1}", positive=True) for i in range(m)]
    sh = [sym(f"sh_{i + 1}") for i in range(m)]
    ax = [sym(f"ax_{i + 1}") for i in range(m)]
    kap = [sym(f"kap_{i + 1}") for i in range(m)]
    dkap = [sym(f"dkap_{i + 1}") for i in range(m)]
    dsh = [sym(f"dsh_{i + 1}") for i in range(m)]
    dax = [sym(f"dax_{i + 1}") for i in range(m)]
    params = {f"{k}_{i + 1}": sym(f"{k}_{i + 1}") for i in range(m) for k in PARAM_KINDS}

    def F(name: str, i: int) -> sp.Symbol:
        return sym(f"F{name}_{i + 1}")

    trig_cache: dict[tuple[str, Phase], sp.Expr] = {}

    def trig(kind: str, phase: Phase) -> sp.Expr:
        if not any(phase):
            return sp.Integer(1) if kind == "c" else sp.Integer(0)
        # canonical sign: first nonzero entry positive (cos even, sin odd)
        first = next(a for a in phase if a != 0)
        sign = 1
        if first < 0:
            phase = tuple(-a for a in phase)
            sign = -1 if kind == "s" else 1
        key = (kind, phase)
        if key not in trig_cache:
            tag = "_".join(str(a) if a >= 0 else f"m{-a}" for a in phase)
            trig_cache[key] = sym(f"{kind}{tag}")
        return sign * trig_cache[key]

    def ph_start(i: int, sign: int = 1) -> Phase:  # e^{i sign phi_i}
        return tuple(sign if j < i else 0 for j in range(m))

    def C(re, im=0, phase: Phase | None = None) -> _Phasors:
        return _Phasors.const(m, re, im, phase)

    w = [C(sh[i], 1 + ax[i]) for i in range(m)]
    wd = [C(dsh[i], dax[i]) for i in range(m)]
    E1 = [C(F("Ea", i), F("Eb", i)) for i in range(m)]
    Eu1 = [C(F("Eua", i), F("Eub", i)) for i in range(m)]
    IE = [C(F("IEa", i), F("IEb", i)) for i in range(m)]
    IEu = [C(F("IEua", i), F("IEub", i)) for i in range(m)]
    IEEu = [C(F("IEEu_re", i), F("IEEu_im", i)) for i in range(m)]
    phid = [sum((L[j] * dkap[j] for j in range(i)), sp.Integer(0)) for i in range(m)]
    ud = [L[i] * dkap[i] for i in range(m)]
    I_ = C(0, 1)

    lagrangian = sp.Integer(0)
    for i in range(m):
        # velocity of segment k's tip motion, expressed in segment k's start frame
        A = _Phasors(m)
        Z = _Phasors(m)
        for k in range(i):
            Vk = (I_.scale(phid[k]) * w[k] + wd[k]) * E1[k] + w[k] * Eu1[k].scale(ud[k])
            rel = tuple(-1 if k <= j < i else 0 for j in range(m))  # e^{-i (phi_i - phi_k)}
            A = A + (Vk * C(1, 0, rel)).scale(L[k])
            Z = Z + (w[k] * E1[k] * C(1, 0, ph_start(k))).scale(L[k])
        c1 = I_.scale(phid[i]) * w[i] + wd[i]
        c2 = w[i].scale(ud[i])
        intB = (c1 * IE[i] + c2 * IEu[i]).scale(L[i])
        cross = (A * intB.conj()).real(trig)
        absA2 = (A * A.conj()).real(trig)
        c1c1 = (c1 * c1.conj()).real(trig)
        c2c2 = (c2 * c2.conj()).real(trig)
        c1c2 = (c1 * c2.conj() * IEEu[i]).real(trig)
        intB2 = L[i] ** 2 * (c1c1 * F("IEE", i) + 2 * c1c2 + c2c2 * F("IEuEu", i))
        kinetic = params[f"mA_{i + 1}"] * L[i] / 2 * (absA2 + 2 * cross + intB2)
        kinetic += params[f"mI_{i + 1}"] * L[i] / 2 * (phid[i] ** 2 + phid[i] * ud[i] + ud[i] ** 2 / 3)
        Z = Z + (w[i] * IE[i] * C(1, 0, ph_start(i))).scale(L[i])
        gravity = L[i] * (params[f"gx_{i + 1}"] * Z.real(trig) + params[f"gy_{i + 1}"] * Z.imag(trig))
        elastic = (
            -(
                params[f"kbe_{i + 1}"] * kap[i] ** 2
                + params[f"ksh_{i + 1}"] * sh[i] ** 2
                + params[f"kax_{i + 1}"] * ax[i] ** 2
            )
            / 2
        )
        lagrangian += kinetic + gravity + elastic

    param_syms = list(params.values())
    gens = [s for s in lagrangian.free_symbols if s not in set(L) | set(param_syms)]
    gens.sort(key=lambda s: s.name)
    poly = sp.Poly(sp.expand(lagrangian), *gens, *param_syms, *L)
    ng, npar = len(gens), len(param_syms)
    terms: list[LagrangianTerm] = []
    for monom, coeff in poly.terms():
        atoms = tuple((gens[k].name, e) for k, e in enumerate(monom[:ng]) if e)
        pe = monom[ng : ng + npar]
        if sum(pe) != 1:
            raise ArithmeticError("each Lagrangian term must carry exactly one lumped parameter")
        param = param_syms[pe.index(1)].name
        coeff = sp.Rational(coeff)
        terms.append(
            LagrangianTerm(
                Fraction(int(coeff.p), int(coeff.q)), tuple(int(e) for e in monom[ng + npar :]), param, atoms
            )
        )
    terms.sort(key=lambda t: (t.atoms, t.param, t.length_exponents))
    return terms
