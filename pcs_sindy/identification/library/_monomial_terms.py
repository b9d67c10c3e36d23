"""Atom products of the monomial basis: the limit rule (removed strains) and readable names."""

from __future__ import annotations

from fractions import Fraction

from . import special as _special

__all__ = ["reduce_product", "readable"]


def _canonical_phase(kind: str, phase: tuple[int, ...]) -> tuple[int, str | None, tuple[int, ...]]:
    """(sign, kind or None if the atom is the constant 1, canonical phase); sign 0 means zero."""
    if not any(phase):
        return (1, None, phase) if kind == "c" else (0, None, phase)
    first = next(a for a in phase if a != 0)
    if first < 0:
        return (-1 if kind == "s" else 1, kind, tuple(-a for a in phase))
    return 1, kind, phase


def _phase_tag(phase: tuple[int, ...]) -> str:
    return "_".join(str(a) if a >= 0 else f"m{-a}" for a in phase)


def reduce_product(atoms, removed_q: set[str], removed_kappa_segments: set[int]):
    """Limit q_e, qd_e -> 0 of one atom product: (exact factor, remaining atoms)."""
    factor = Fraction(1)
    out: dict[str, int] = {}
    for name, power in atoms:
        if name.startswith("F"):
            seg = int(name.rsplit("_", 1)[1]) - 1
            if seg in removed_kappa_segments:
                factor *= _special.special(name[1:].rsplit("_", 1)[0]).value_at_zero ** power
                continue
        elif name[0] in "cs" and not name.startswith("sh_"):
            phase = tuple(-int(p[1:]) if p.startswith("m") else int(p) for p in name[1:].split("_"))
            phase = tuple(0 if k in removed_kappa_segments else a for k, a in enumerate(phase))
            sign, kind, phase = _canonical_phase(name[0], phase)
            factor *= sign**power
            if kind is None:
                continue
            name = kind + _phase_tag(phase)
        else:
            base = name[1:] if name.startswith("d") else name
            if base in removed_q:
                return Fraction(0), ()
        out[name] = out.get(name, 0) + power
        if factor == 0:
            return Fraction(0), ()
    if factor == 0:
        return Fraction(0), ()
    return factor, tuple(sorted(out.items()))


def readable(atoms, state_names: dict[str, str], lengths_known: bool) -> str:
    parts = []
    for name, power in atoms:
        if name.startswith("F"):
            fn, seg = name[1:].rsplit("_", 1)
            txt = f"{fn}(u{seg})"
        elif name in state_names:
            txt = state_names[name]
        elif name[0] in "cs":
            phase = tuple(-int(p[1:]) if p.startswith("m") else int(p) for p in name[1:].split("_"))
            arg = " ".join(
                ("+" if a > 0 else "-") + (f"{abs(a)}" if abs(a) != 1 else "") + f"u{k + 1}"
                for k, a in enumerate(phase)
                if a
            )
            txt = ("cos(" if name[0] == "c" else "sin(") + arg.lstrip("+") + ")"
        else:
            txt = name
        parts.append(txt if power == 1 else f"{txt}^{power}")
    return " ".join(parts) if parts else "1"
