"""Units of what the package prints and stores: SI dimensions as powers of kg, m and s.

Holds :class:`Unit` (a dimension with arithmetic and a readable symbol such as ``N·m³``) and the
units of the strains and of their generalised forces, from which every coefficient's unit follows.
It knows no model and no library: the libraries combine these into the units of their coefficients.

Generalised forces
------------------
The Lagrangian is an energy [J = N·m] and the generalised force of a strain ``q_e`` is
``d/dt dL/dq̇_e - dL/dq_e``, so its unit is ``J / unit(q_e)``: **N·m²** for a curvature (bending,
twist) [1/m], **N·m** for a shear or axial strain [-].  A stiffness (``K q`` is a generalised force)
is then N·m³ for bending and N·m for shear and axial strain, a damping (``D q̇``) N·m³·s and N·m·s.

Stiffness convention: ``K_i = f_L diag(E I, c_sh G A, E A)`` with ``E I`` in N·m² and ``G A``,
``E A`` in N; dimensional consistency makes ``f_L`` a length: ``f_L = 1 m`` in the seed's convention
(the numbers are those of ``E I``, ``c_sh G A``, ``E A``) or ``f_L = L_i`` (the elastic energy of a
constant-strain segment).  Either way the coefficient is in the units above.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

__all__ = [
    "Unit",
    "DIMENSIONLESS",
    "KILOGRAM",
    "METRE",
    "SECOND",
    "NEWTON",
    "JOULE",
    "STRAIN_UNITS",
    "strain_unit",
    "strain_rate_unit",
    "generalised_force_unit",
]

_SUPERSCRIPT = str.maketrans("0123456789-/", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻ᐟ")


def _power(symbol: str, exponent: Fraction) -> str:
    if exponent == 1:
        return symbol
    return symbol + str(exponent).translate(_SUPERSCRIPT)


@dataclass(frozen=True)
class Unit:
    """A physical dimension ``kg^kg · m^m · s^s`` (exponents may be fractions).

    Units multiply, divide and take powers; ``str(unit)`` is the symbol the package prints
    (``kg/m``, ``kg·m``, ``N·m³``, ``N·m·s``, ``1/m``; ``1`` when dimensionless).

    Parameters
    ----------
    kg, m, s : int or Fraction
        Exponents of kilogram, metre and second.

    Examples
    --------
    >>> from pcs_sindy.core.units import JOULE, METRE, SECOND
    >>> str(JOULE * METRE**2)
    'N·m³'
    >>> str(JOULE / (1 / (METRE * SECOND)))
    'N·m²·s'
    """

    kg: int | Fraction = 0
    m: int | Fraction = 0
    s: int | Fraction = 0

    def __post_init__(self) -> None:
        for name in ("kg", "m", "s"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, Fraction)):
                raise TypeError(f"Unit exponent {name} must be an int or a Fraction; got {value!r}")
            object.__setattr__(self, name, Fraction(value))

    # -- algebra ----------------------------------------------------------------
    def __mul__(self, other: Unit) -> Unit:
        if not isinstance(other, Unit):
            return NotImplemented
        return Unit(self.kg + other.kg, self.m + other.m, self.s + other.s)

    def __truediv__(self, other: Unit) -> Unit:
        if not isinstance(other, Unit):
            return NotImplemented
        return Unit(self.kg - other.kg, self.m - other.m, self.s - other.s)

    def __rtruediv__(self, other: object) -> Unit:
        if other == 1:
            return Unit(-self.kg, -self.m, -self.s)
        return NotImplemented

    def __pow__(self, exponent: int | Fraction) -> Unit:
        e = Fraction(exponent)
        return Unit(self.kg * e, self.m * e, self.s * e)

    @property
    def dimensionless(self) -> bool:
        """True for a pure number."""
        return self.kg == 0 and self.m == 0 and self.s == 0

    def scale(self, *, length: float = 1.0, time: float = 1.0, mass: float = 1.0) -> float:
        """Factor by which a value in this unit changes when the units of length, time and mass shrink.

        A quantity measured with a metre ``length`` times smaller (e.g. 1000 for millimetres) has a value
        ``length**m`` times larger; likewise for time and mass.
        """
        return float(mass) ** float(self.kg) * float(length) ** float(self.m) * float(time) ** float(self.s)

    # -- text -------------------------------------------------------------------
    def __str__(self) -> str:
        kg, m, s = self.kg, self.m, self.s
        num: list[str] = []
        den: list[str] = []
        newtons = Fraction(0)
        if kg > 0 and s < 0:
            # forces first: kg·m/s² is N (a damping, kg·m⁴/s, reads N·m³·s)
            newtons = kg
            kg, m, s = Fraction(0), m - newtons, s + 2 * newtons
            num.append(_power("N", newtons))
        for symbol, e in (("kg", kg), ("m", m), ("s", s)):
            if e > 0:
                num.append(_power(symbol, e))
            elif e < 0:
                den.append(_power(symbol, -e))
        top = "·".join(num) if num else "1"
        if not den:
            return top
        bottom = den[0] if len(den) == 1 else "(" + "·".join(den) + ")"
        return f"{top}/{bottom}"

    def __repr__(self) -> str:
        return f"Unit({str(self)!r})"


#: A pure number.
DIMENSIONLESS = Unit()
KILOGRAM = Unit(kg=1)
METRE = Unit(m=1)
SECOND = Unit(s=1)
NEWTON = Unit(kg=1, m=1, s=-2)
JOULE = NEWTON * METRE

#: Unit of each strain, by kind: the planar ``be``, ``sh``, ``ax`` and the spatial names.
STRAIN_UNITS: dict[str, Unit] = {
    "be": 1 / METRE,
    "sh": DIMENSIONLESS,
    "ax": DIMENSIONLESS,
    "bend_z": 1 / METRE,
    "bend_x": 1 / METRE,
    "twist": 1 / METRE,
    "shear_x": DIMENSIONLESS,
    "shear_z": DIMENSIONLESS,
    "axial": DIMENSIONLESS,
}


def strain_unit(name: str) -> Unit:
    """Unit of a strain, by kind (``"be"``) or by name with its segment (``"be_2"``, ``"twist_1"``).

    Raises
    ------
    ValueError
        If ``name`` is not a strain kind of :data:`STRAIN_UNITS` (with an optional ``_<segment>``).
    """
    if not isinstance(name, str):
        raise ValueError(f"name must be a strain name such as 'be_1'; got {name!r}")
    kind = name
    if kind not in STRAIN_UNITS:
        head, _, tail = name.rpartition("_")
        if head and tail.isdigit():
            kind = head
    if kind not in STRAIN_UNITS:
        raise ValueError(f"name must be a strain name of the kinds {list(STRAIN_UNITS)} (e.g. 'be_1'); got {name!r}")
    return STRAIN_UNITS[kind]


def strain_rate_unit(name: str) -> Unit:
    """Unit of a strain's rate (``1/(m·s)`` for a curvature, ``1/s`` otherwise)."""
    return strain_unit(name) / SECOND


def generalised_force_unit(name: str) -> Unit:
    """Unit of the generalised force of a strain: energy per strain unit (N·m² bending, N·m shear/axial)."""
    return JOULE / strain_unit(name)
