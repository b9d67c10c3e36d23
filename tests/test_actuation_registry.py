"""One registration point for the actuation kinds: the class attribute ``kind`` (issue 26 item 6).

Every concrete subclass of :class:`~pcs_sindy.models.actuation.Actuation` registers itself when it
is defined; layouts, model files and forward models read that registry.  Checked here: every
subclass the package defines is registered and round-trips through model files; a kind defined in
this file (a minimal subclass, touching no other file) registers itself, is built from its layout,
round-trips alone and inside a fitted regressor, and rolls out through the Python path (it has no
compiled form).  Truths: the saved object itself (a round trip must give it back bit for bit), the
ground-truth simulator's recordings (an independent implementation of the dynamics) and the same
map written as a compiled :class:`LinearActuation` (another code path).
"""

from __future__ import annotations

import gc
import importlib
import inspect
import weakref
from numbers import Real
from typing import Any

import numpy as np
import pytest

from pcs_sindy.core import PlanarPCS, StrainTrajectory
from pcs_sindy.core.spatial import SpatialPCS
from pcs_sindy.core.validation import Interval
from pcs_sindy.identification import EulerLagrangeRegressor
from pcs_sindy.io import REGISTRY, load, save
from pcs_sindy.io.model_files import _resolve
from pcs_sindy.models import LinearActuation, LumpedPCSModel, _jit_dynamics
from pcs_sindy.models.actuation import (
    COMPILED_FORMS,
    Actuation,
    actuation_from_layout,
    actuation_kinds,
    registered_kinds,
)
from pcs_sindy.simulation import get_scenario

#: the five kinds and the (module, attribute) paths the model-file registry listed by hand before
OLD_REGISTRY_PATHS = {
    "identity": ("pcs_sindy.models.actuation", "IdentityActuation"),
    "tendon": ("pcs_sindy.models.actuation", "TendonActuation"),
    "pressure": ("pcs_sindy.models.actuation", "PressureActuation"),
    "linear": ("pcs_sindy.models.actuation", "LinearActuation"),
    "learned": ("pcs_sindy.models.actuation", "LearnedActuation"),
}
#: the kinds added since, by module path (each registered by its class like the five above)
NEW_KINDS = {"spatial_tendon": ("pcs_sindy.models.actuation", "SpatialTendonActuation")}
#: a layout of every built-in kind on KIN, or KIN3 for the spatial-only kinds (a new built-in kind adds its own)
EXAMPLES: dict[str, list[dict[str, Any]]] = {
    "identity": [{"type": "identity"}],
    "tendon": [
        {"type": "tendon", "end": [0.07, 0.17], "side": [1, -1]},
        {"type": "tendon", "end": [0.07, 0.17], "side": [1, -1], "offset": [0.01, 0.02], "shared": False},
        {"type": "tendon", "end": [0.12], "side": [1], "drive": "displacement", "stiffness": [300.0]},
    ],
    "pressure": [{"type": "pressure", "start": [0.0, 0.05], "end": [0.1, 0.17], "side": [1, -1]}],
    "linear": [{"type": "linear", "pattern": np.eye(6, 2, dtype=bool).tolist()}],
    "learned": [{"type": "learned", "n_inputs": 2, "terms": ["u", "u*q", "pull"], "strains": "all"}],
    "spatial_tendon": [
        {"type": "spatial_tendon", "end": [0.07, 0.17], "offset": [[0.01, 0.0], [0.0, -0.01]]},
        {"type": "spatial_tendon", "end": [0.07, 0.17], "angle": [0.5, 2.5], "shared": True},
        {"type": "spatial_tendon", "end": [0.12], "angle": [1.0], "drive": "displacement", "stiffness": [300.0]},
    ],
}
KIN = PlanarPCS((0.07, 0.1))
KIN3 = SpatialPCS((0.07, 0.1))
SPATIAL_ONLY = {"spatial_tendon"}


def _kin(layout: dict) -> Any:
    return KIN3 if layout["type"] in SPATIAL_ONLY else KIN


def _package_kinds() -> dict[str, type]:
    return {k: c for k, c in actuation_kinds().items() if c.__module__.startswith("pcs_sindy.")}


def _subclasses(cls: type) -> list[type]:
    out = []
    for sub in cls.__subclasses__():
        out += [sub, *_subclasses(sub)]
    return out


def _fitted(layout: dict, seed: int = 0) -> Actuation:
    act = actuation_from_layout(layout).fit(_kin(layout))
    rng = np.random.default_rng(seed)
    # nonzero gains and offsets, so a round trip that dropped them would show
    act.set_identified(rng.uniform(0.5, 2.0, act.n_gains) * 1e-3, act.offsets_ * rng.uniform(0.8, 1.2))
    return act


def _inputs(act: Actuation, rows: int = 5) -> np.ndarray:
    u = np.random.default_rng(1).uniform(0.0, 2.0, (rows, act.n_inputs_))
    return act.check_inputs(u)


# ----------------------------------------------------------------------
# the package's kinds
# ----------------------------------------------------------------------
def test_every_concrete_subclass_of_the_package_is_registered_under_its_kind():
    kinds = actuation_kinds()  # imports every module of pcs_sindy.models.actuation
    ours = [c for c in _subclasses(Actuation) if c.__module__.startswith("pcs_sindy.")]
    concrete = [c for c in ours if not inspect.isabstract(c)]
    assert {c.__name__ for c in concrete} == {attr for _, attr in (*OLD_REGISTRY_PATHS.values(), *NEW_KINDS.values())}
    for cls in concrete:
        assert kinds[cls.kind] is cls, cls
        assert "kind" in vars(cls), f"{cls.__name__} inherits its kind"
        assert REGISTRY[cls.__name__].attribute == cls.__name__
        assert _resolve(cls.__name__) is cls
    # abstract bases (the constant maps' base) are not kinds
    abstract = [c for c in ours if inspect.isabstract(c)]
    assert abstract and not set(abstract) & set(kinds.values())
    assert set(_package_kinds()) == set(EXAMPLES)


@pytest.mark.parametrize("kind", sorted(OLD_REGISTRY_PATHS))
def test_the_class_paths_of_the_former_registry_still_resolve(kind):
    """Files saved before the move name these classes; the paths the old REGISTRY held still lead to them."""
    module, attribute = OLD_REGISTRY_PATHS[kind]
    cls = getattr(importlib.import_module(module), attribute)
    assert cls is actuation_kinds()[kind] is _resolve(attribute)
    assert attribute in REGISTRY


def test_the_compiled_forms_are_the_kernels_input_maps():
    assert set(COMPILED_FORMS) == set(_jit_dynamics.INPUT_MAPS)
    codes = list(_jit_dynamics.INPUT_MAPS.values())
    assert len(set(codes)) == len(codes)
    for layouts in EXAMPLES.values():
        for layout in layouts:
            act = _fitted(layout)
            if not type(act).compiled_forms:  # a kind without a compiled form says so
                with pytest.raises(NotImplementedError, match="no compiled form"):
                    act.compiled()
                continue
            assert act.compiled()[0] in type(act).compiled_forms, layout


@pytest.mark.parametrize(
    "layout", [lay for kind in sorted(EXAMPLES) for lay in EXAMPLES[kind]], ids=lambda lay: lay["type"]
)
def test_every_kind_round_trips_through_model_files(layout, tmp_path):
    act = _fitted(layout)
    loaded = load(save(act, tmp_path / "act"))
    assert type(loaded) is type(act)
    assert loaded.layout() == act.layout() and loaded.design_layout() == act.design_layout()
    np.testing.assert_array_equal(loaded.gains_, act.gains_)
    np.testing.assert_array_equal(loaded.offsets_, act.offsets_)
    assert loaded.gain_names_ == act.gain_names_ and loaded.offset_names_ == act.offset_names_
    kin = _kin(layout)
    scale = [20.0, 0.1, 0.1] if kin is KIN else [20.0, 20.0, 20.0, 0.1, 0.1, 0.1]
    q = np.random.default_rng(2).uniform(-1, 1, (5, kin.n_q)) * np.tile(scale, 2)
    u = _inputs(act)
    np.testing.assert_array_equal(loaded.forces(q, u), act.forces(q, u))
    # and through its JSON layout: the same parameters
    again = actuation_from_layout(act.layout())
    assert type(again) is type(act)
    assert {k: np.asarray(v).tolist() for k, v in again.get_params().items() if v is not None} == {
        k: np.asarray(v).tolist() for k, v in act.get_params().items() if v is not None
    }


# ----------------------------------------------------------------------
# a kind defined here, touching no other file
# ----------------------------------------------------------------------
def _define_scaled_forces() -> type:
    class ScaledForces(Actuation):
        """``tau = scale u`` on the modelled strains: one input per modelled strain, no identified gain."""

        kind = "test_scaled_forces"
        _parameter_constraints: dict = {"scale": [Interval(Real, 0, None, closed="neither")]}

        def __init__(self, scale: float = 1.0) -> None:
            self.scale = scale

        def _structure(self, kinematics):
            return {
                "n_inputs": kinematics.n_active,
                "gain_names": [],
                "gains": np.zeros(0),
                "offset_names": [],
                "offsets": np.zeros(0),
            }

        def parts(self, q, u, offsets=None):
            u = np.atleast_2d(np.asarray(u, dtype=float))
            return self.scale * u, np.zeros(u.shape + (0,))

        def describe(self, precision: int = 3) -> list[str]:
            return [f"tau = {self.scale:.{precision}g} u"]

    return ScaledForces


@pytest.fixture
def scaled_forces():
    return _define_scaled_forces()


@pytest.fixture(scope="module", autouse=True)
def _no_test_kind_outlives_this_file():
    """The kinds defined here leave the registry with their classes (other files read it whole)."""
    yield
    gc.collect()
    assert not [k for k in registered_kinds() if k.startswith("test_")]
    assert not [n for n in REGISTRY if n in ("ScaledForces", "MislabelledMatrix")]


def test_a_kind_defined_and_dropped_leaves_the_registry():
    cls = _define_scaled_forces()
    assert registered_kinds()["test_scaled_forces"] is cls and "ScaledForces" in REGISTRY
    ref = weakref.ref(cls)
    del cls
    gc.collect()  # the registry holds its classes weakly
    assert ref() is None
    assert "test_scaled_forces" not in registered_kinds() and "ScaledForces" not in REGISTRY


def test_a_new_kind_registers_itself_and_round_trips(scaled_forces, tmp_path):
    assert actuation_kinds()["test_scaled_forces"] is scaled_forces
    assert _resolve("ScaledForces") is scaled_forces
    act = actuation_from_layout({"type": "test_scaled_forces", "scale": 2.5}).fit(KIN)
    assert type(act) is scaled_forces
    loaded = load(save(act, tmp_path / "scaled"))
    assert type(loaded) is scaled_forces and loaded.scale == 2.5 and loaded.n_inputs_ == KIN.n_active
    u = _inputs(act)
    np.testing.assert_array_equal(loaded.forces(np.zeros_like(u), u), 2.5 * u)
    # its parameters are checked on load like the built-in kinds' (the class's own table)
    doc = (tmp_path / "scaled.json").read_text().replace('"scale": 2.5', '"scale": -1.0')
    (tmp_path / "bad.json").write_text(doc)
    (tmp_path / "bad.npz").write_bytes((tmp_path / "scaled.npz").read_bytes())
    with pytest.raises(ValueError, match="scale"):
        load(tmp_path / "bad")


def _lumped(act):
    m = KIN.n_segments
    return LumpedPCSModel(
        KIN,
        [0.1] * m,
        [1e-6] * m,
        [[0.0, 1.0]] * m,
        [1e-3, 1.0, 1.0] * m,
        [1e-5, 1e-3, 1e-3] * m,
        actuation=act,
        n_quadrature=8,
        fast_quadrature=None,
    )


def test_a_kind_without_compiled_form_rolls_out_through_python_like_the_compiled_map(scaled_forces):
    """The same map as a compiled LinearActuation (A = 2.5 I, the matrix input map): the same rollout."""
    scale = 2.5
    python = _lumped(scaled_forces(scale).fit(KIN))
    assert python.python_inputs and python.compiled_methods == () and python.default_method == "radau"
    compiled_act = LinearActuation(pattern=np.eye(6, dtype=bool)).fit(KIN).set_identified(np.full(6, scale), [])
    compiled = _lumped(compiled_act)
    assert not compiled.python_inputs
    rng = np.random.default_rng(3)
    q = rng.uniform(-1, 1, 6) * np.tile([20.0, 0.1, 0.1], 2)
    u = rng.uniform(-1e-3, 1e-3, 6)
    np.testing.assert_allclose(python.input_forces(q, u), scale * u, rtol=1e-15)
    np.testing.assert_allclose(compiled.input_forces(q, u), scale * u, rtol=1e-15)
    np.testing.assert_allclose(python.input_matrix(q), scale * np.eye(6), rtol=1e-15)
    t = np.linspace(0.0, 0.05, 26)
    U = np.tile(u, (t.size, 1))
    a = python.simulate(np.zeros(6), np.zeros(6), t, U)
    b = compiled.simulate(np.zeros(6), np.zeros(6), t, U, method="radau")
    np.testing.assert_allclose(a.q, b.q, rtol=1e-9, atol=1e-12 * np.abs(b.q).max())
    assert np.abs(b.q).max() > 1e-3  # it moved
    with pytest.raises(ValueError, match="rosenbrock"):
        python.simulate(np.zeros(6), np.zeros(6), t, U, method="rosenbrock")


def test_a_compiled_form_the_class_does_not_declare_is_refused():
    class MislabelledMatrix(LinearActuation):
        kind = "test_mislabelled_matrix"
        compiled_forms = ("tendon",)  # but compiled() gives "matrix"

    act = MislabelledMatrix(pattern=np.eye(6, dtype=bool)).fit(KIN).set_identified(np.ones(6), [])
    with pytest.raises(ValueError, match=r"gave the input map 'matrix'.*compiled_forms = \('tendon',\)"):
        _lumped(act)
    del MislabelledMatrix, act
    gc.collect()


def test_a_new_kind_is_identified_and_round_trips_inside_a_fitted_regressor(scaled_forces, tmp_path):
    """The simulator's forces given as inputs u = tau / scale: the fitted model matches the robot."""
    scenario = get_scenario("one_segment")
    data = scenario.generate(seed=0, n_train=3, train_duration=0.1, validation=False, cache=False)
    lengths = scenario.robot.kinematics.segment_lengths
    X = [StrainTrajectory(r.q, r.t, segment_lengths=lengths) for r in data.train]
    scale = 4.0
    model = EulerLagrangeRegressor(actuation={"type": "test_scaled_forces", "scale": scale})
    model.fit(X, [r.tau / scale for r in data.train])
    assert type(model.actuation_) is scaled_forces
    # independent truth: the robot's stiffness (the simulator's material table)
    np.testing.assert_allclose(model.stiffness_, scenario.robot.stiffness, rtol=5e-3)
    # the same regression as with the forces given as generalised forces (the identity kind)
    forces = EulerLagrangeRegressor().fit(X, [r.tau for r in data.train])
    np.testing.assert_allclose(model.coef_, forces.coef_, rtol=1e-9, atol=1e-12 * np.abs(forces.coef_).max())
    loaded = load(save(model, tmp_path / "model"))
    assert type(loaded.actuation_) is scaled_forces and loaded.actuation_.scale == scale
    rec = data.train[0]
    k = 60
    a = model.simulate(rec.q[0], rec.qd[0], rec.t[:k], rec.tau[:k] / scale)
    b = loaded.simulate(rec.q[0], rec.qd[0], rec.t[:k], rec.tau[:k] / scale)
    np.testing.assert_array_equal(a.q, b.q)
    # the Python path rolls out like the robot
    span = np.abs(rec.q[:k]).max(axis=0)
    assert np.all(np.abs(a.q - rec.q[:k]).max(axis=0) <= 2e-3 * span)


# ----------------------------------------------------------------------
# the registration rules
# ----------------------------------------------------------------------
def test_a_concrete_subclass_without_its_own_kind_is_refused():
    from pcs_sindy.models import TendonActuation

    with pytest.raises(TypeError, match=r"must declare its own kind.*inherits kind = 'tendon'"):

        class MyTendons(TendonActuation):
            pass


def test_a_taken_kind_or_class_name_is_refused():
    from pcs_sindy.models import TendonActuation

    with pytest.raises(TypeError, match=r"kind 'tendon' is taken by pcs_sindy\.models\.actuation\.tendons"):

        class OtherTendons(TendonActuation):
            kind = "tendon"

    with pytest.raises(TypeError, match="the class name 'TendonActuation' is taken"):

        class TendonActuation(TendonActuation):  # noqa: F811 - the clash is the point
            kind = "test_other_tendons"

    gc.collect()
    assert actuation_kinds()["tendon"].__module__ == "pcs_sindy.models.actuation.tendons"
    assert "test_other_tendons" not in actuation_kinds()


def test_an_unknown_compiled_form_is_refused():
    with pytest.raises(TypeError, match="compiled_forms must be a tuple of names from"):

        class Magnets(LinearActuation):
            kind = "test_magnets"
            compiled_forms = ("magnetic",)


def test_an_abstract_subclass_is_no_kind():
    class Half(Actuation):
        kind = "test_half"  # declares a kind, but leaves parts and describe abstract

        def _structure(self, kinematics):
            return {}

    assert inspect.isabstract(Half)
    assert "test_half" not in actuation_kinds()


def test_an_unknown_layout_type_names_the_kinds():
    with pytest.raises(ValueError, match=r"layout type must be one of \['identity', 'learned', 'linear'"):
        actuation_from_layout({"type": "magnet"})
