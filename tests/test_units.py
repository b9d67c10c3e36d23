"""Units of every printed and stored coefficient, checked by dimensional analysis.

Truth: the units are not compared with a table of the code under test but with the physics.

* A change of the units of length, time and mass changes every number of ``tau = Psi @ coef`` by
  a known factor: strains, rates, segment lengths and gravity are rescaled, the libraries rebuilt
  and ``Psi`` recomputed; each entry must scale as ``unit(tau_e) / unit(coef_j)``, with the
  generalised forces' units written here by hand from the Lagrangian (an energy over the strain's
  unit).  A wrong unit of any coefficient (e.g. N·m² for the bending stiffness) breaks it.
* The symbolic Lagrangian's every term (lumped unknown x powers of segment lengths x atoms) must be
  an energy when the lumped unknowns have the units written here.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from pcs_sindy.core.units import (
    DIMENSIONLESS,
    JOULE,
    METRE,
    SECOND,
    Unit,
    generalised_force_unit,
    strain_rate_unit,
    strain_unit,
)
from pcs_sindy.identification import PCSLagrangianLibrary, PhysicalPCSLibrary
from pcs_sindy.identification.library.derivation import derive_lagrangian_terms

# by hand: kg^a m^b s^c
KG_PER_M = Unit(1, -1, 0)
KG_M = Unit(1, 1, 0)
N_PER_M = Unit(1, 0, -2)
N_M = Unit(1, 2, -2)  # J: the generalised force of shear and axial strain [-]
N_M2 = Unit(1, 3, -2)  # J m: the generalised force of a curvature [1/m]
TAU = {"be": N_M2, "sh": N_M, "ax": N_M}
Q_LENGTH_EXPONENT = {"be": -1, "sh": 0, "ax": 0}


def test_unit_symbols():
    cases = {
        KG_PER_M: "kg/m",
        KG_M: "kg·m",
        N_PER_M: "N/m",
        N_M: "N·m",
        N_M2: "N·m²",
        Unit(1, 4, -2): "N·m³",
        Unit(1, 4, -1): "N·m³·s",
        Unit(1, 2, -1): "N·m·s",
        Unit(0, -1, 0): "1/m",
        Unit(0, -1, -1): "1/(m·s)",
        Unit(1, 4, 0): "kg·m⁴",
        Unit(0, 0, 0): "1",
        Unit(0, 1, -2): "m/s²",
    }
    for unit, text in cases.items():
        assert str(unit) == text
    assert JOULE == N_M and METRE / SECOND == Unit(0, 1, -1) and (1 / METRE) ** 2 == Unit(0, -2, 0)
    assert Unit(Fraction(1, 2), 0, 0) ** 2 == Unit(1, 0, 0)
    assert Unit(1, 2, -2).scale(length=1e3, time=2.0, mass=5.0) == pytest.approx(5.0 * 1e6 / 4.0)
    with pytest.raises(TypeError, match="exponent kg"):
        Unit(0.5, 0, 0)
    with pytest.raises(ValueError, match="strain name"):
        strain_unit("bend")


def test_stiffness_times_strain_is_the_generalised_force():
    """k q, d qd and f0 are generalised forces: N·m² for bending, N·m for shear and axial strain."""
    for kind in ("be", "sh", "ax"):
        assert generalised_force_unit(f"{kind}_3") == TAU[kind]
    lib = PhysicalPCSLibrary([0.07, 0.1], identify_gravity=True)
    units = dict(zip(lib.coefficient_names(), lib.coefficient_units(), strict=True))
    expected = {"rhoA_1": KG_PER_M, "rhoI_2": KG_M, "rhoAgx_1": N_PER_M, "rhoAgy_2": N_PER_M}
    expected |= {"k_be_1": Unit(1, 4, -2), "k_sh_1": N_M, "k_ax_2": N_M, "d_be_2": Unit(1, 4, -1)}
    expected |= {"d_sh_1": Unit(1, 2, -1), "f0_be_1": N_M2, "f0_ax_2": N_M}
    for name, unit in expected.items():
        assert units[name] == unit, name
    for name, unit in units.items():
        kind = name.split("_")[1]
        if name.startswith("k_"):
            assert unit * strain_unit(kind) == TAU[kind]
        elif name.startswith("d_"):
            assert unit * strain_rate_unit(kind) == TAU[kind]
        elif name.startswith("f0_"):
            assert unit == TAU[kind]


def _random_states(n_kinds, rng, n=5):
    # curvatures of a few 1/m on 0.1 m segments (bends of about a radian), small shear and elongation
    scale = np.array([8.0 if k == "be" else 0.1 for k in n_kinds])
    return [scale * rng.uniform(-1, 1, (n, len(n_kinds))) for _ in range(3)]


def _check_scaling(make, lengths, gravity, rng):
    """Psi entries scale as unit(tau_e) / unit(coef_j) under a change of the units of length, time, mass."""
    lam, mu, mass = 1e3, 7.0, 3.0  # millimetres, a slower clock, a heavier unit of mass: numbers scale as below
    lib1 = make(np.asarray(lengths), np.asarray(gravity))
    lib2 = make(lam * np.asarray(lengths), lam / mu**2 * np.asarray(gravity))
    kinds = [s.split("_")[0] for s in lib1.kinematics.strain_names(active_only=True)]
    q, qd, qdd = _random_states(kinds, rng)
    f = lam ** np.array([Q_LENGTH_EXPONENT[k] for k in kinds], dtype=float)
    psi1 = lib1.euler_lagrange_matrix(q, qd, qdd)
    psi2 = lib2.euler_lagrange_matrix(q * f, qd * f / mu, qdd * f / mu**2)
    assert lib1.coefficient_names() == lib2.coefficient_names()
    units = lib1.coefficient_units()
    assert all(u is not None for u in units)
    checked = 0
    for e, kind in enumerate(kinds):
        for j, unit in enumerate(units):
            ref = psi1[:, e, j]
            if not np.any(ref):
                continue
            factor = TAU[kind].scale(length=lam, time=mu, mass=mass) / unit.scale(length=lam, time=mu, mass=mass)
            np.testing.assert_allclose(
                psi2[:, e, j], factor * ref, rtol=1e-9, atol=1e-12 * factor * np.abs(ref).max(), err_msg=f"{e}, {j}"
            )
            checked += 1
    return checked


@pytest.mark.parametrize("identify_gravity", [False, True])
def test_physical_library_units_by_dimensional_analysis(identify_gravity):
    rng = np.random.default_rng(0)

    def make(lengths, gravity):
        return PhysicalPCSLibrary(
            tuple(lengths), gravity=tuple(gravity), identify_gravity=identify_gravity, n_quadrature=8
        )

    assert _check_scaling(make, [0.07, 0.1], [0.5, 9.81], rng) > 20


@pytest.mark.parametrize("basis", ["monomial", "physical"])
def test_symbolic_library_units_by_dimensional_analysis(basis):
    rng = np.random.default_rng(1)

    def make(lengths, gravity):  # gravity is part of the coefficients (rhoA g) of this library
        return PCSLagrangianLibrary(tuple(lengths), basis=basis)

    assert _check_scaling(make, [0.1], [0.0, 9.81], rng) > 10


def test_every_term_of_the_symbolic_lagrangian_is_an_energy():
    """rational * L^e * lumped unknown * atoms is in J with the lumped units written here by hand."""
    lumped = {"mA": KG_PER_M, "mI": KG_M, "gx": N_PER_M, "gy": N_PER_M}
    lumped |= {"kbe": Unit(1, 4, -2), "ksh": N_M, "kax": N_M}  # -k/2 q^2 is an energy
    atom = {"kap": Unit(0, -1, 0), "sh": DIMENSIONLESS, "ax": DIMENSIONLESS}
    terms = derive_lagrangian_terms(2)
    assert len(terms) > 100
    for t in terms:
        unit = lumped[t.param.split("_")[0]] * METRE ** sum(t.length_exponents)
        for name, power in t.atoms:
            base = name.rpartition("_")[0]
            if base in atom:
                unit = unit * atom[base] ** power
            elif base.startswith("d") and base[1:] in atom:
                unit = unit * (atom[base[1:]] / SECOND) ** power
            # else a special function of kappa L or a cosine/sine of bending angles: a pure number
        assert unit == JOULE, t


def test_printed_models_show_units():
    lib = PhysicalPCSLibrary([0.1], rest_strain=False)
    text = lib.equations(np.arange(1.0, 9.0))
    assert "k_be_1 = 3 N·m³" in text[3] and "rhoA_1 = 1 kg/m" in text[3]
    assert text[-1] == "D = diag(be_1: 6 N·m³·s, sh_1: 7 N·m·s, ax_1: 8 N·m·s)"
    weighed = PhysicalPCSLibrary([0.1], mass=0.25)
    assert "mass = sum_i rhoA_i L_i = 0.25 kg" in weighed.equations(np.ones(weighed.n_coefficients_))[3]


def test_learned_and_linear_gains_print_the_force_per_input_unit():
    """gain x input = generalised force of the row's strain (x the column strain for the '*q' terms)."""
    from pcs_sindy.core import PlanarPCS
    from pcs_sindy.models.actuation import LearnedActuation, LinearActuation

    kin = PlanarPCS((0.1, 0.1))
    learned = LearnedActuation(n_inputs=2).fit(kin)
    line = learned.describe()[-1]
    assert "a_be_1_u1 = 0 N·m²/u" in line  # bending: N·m² per input unit
    assert "a_be_2_u2_be_1 = 0 N·m³/u" in line  # times a curvature [1/m] gives N·m²
    pattern = np.zeros((6, 1), dtype=bool)
    pattern[[0, 2], 0] = True
    linear = LinearActuation(pattern).fit(kin)
    text = linear.describe()[0]
    assert "a_be_1_1 = " in text and "N·m²/u" in text and "a_ax_1_1 = " in text and "N·m/u" in text


def test_the_identifiability_report_and_strain_equations_carry_units():
    """Each coefficient line of the report ends in its unit; each strain equation's lhs is a generalised force."""
    from pcs_sindy import EulerLagrangeRegressor, StrainTrajectory
    from pcs_sindy.simulation import get_scenario

    d = get_scenario("one_segment").generate(seed=0, n_train=2, train_duration=0.2, validation=False)
    X = [StrainTrajectory(r.q, t=r.t, segment_lengths=[0.1]) for r in d.train]
    model = EulerLagrangeRegressor().fit(X, [r.tau for r in d.train])
    rows = {
        ln.split()[0]: ln.split()[4] for ln in model.identifiability_report().splitlines() if ln[:2] in ("rh", "k_")
    }
    assert rows == {"rhoA_1": "kg/m", "rhoI_1": "kg·m", "k_be_1": "N·m³", "k_sh_1": "N·m", "k_ax_1": "N·m"}
    first = model.strain_equations()[0]
    assert "[N·m³] be_1" in first and "[kg/m] EL[rhoA_1]" in first
