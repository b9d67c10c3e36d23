"""Declarative parameter validation (pcs_sindy.core.validation) and the estimators' tables.

* the validator itself: interval endpoints, booleans and NaN never numbers, numpy scalars,
  options, None, booleans, duck types, predicates, and the one message format;
* every estimator's ``_parameter_constraints`` covers exactly its constructor's parameters;
* a bad value of every kind of parameter makes ``fit`` raise :class:`InvalidParameterError`
  naming the class, the parameter and the value, and the joint checks do alike;
* model files check the same tables on load, and every registry entry resolves to its class.
"""

from __future__ import annotations

import importlib
import inspect
import json
import warnings
from numbers import Integral, Real

import numpy as np
import pytest
from sklearn.base import BaseEstimator
from sklearn.pipeline import Pipeline

from pcs_sindy.core import (
    Check,
    Constraint,
    HasMethods,
    InstanceOf,
    Interval,
    InvalidParameterError,
    Options,
    PlanarPCS,
    SpatialPCS,
    validate_parameters,
)
from pcs_sindy.fusion import KinematicFusion
from pcs_sindy.identification import (
    EulerLagrangeRegressor,
    PCSLagrangianLibrary,
    PhysicalPCSLibrary,
    SpatialPhysicalPCSLibrary,
    StiffnessThresholdOptimizer,
)
from pcs_sindy.io import REGISTRY, load, save
from pcs_sindy.models import (
    IdentityActuation,
    LearnedActuation,
    LinearActuation,
    PressureActuation,
    SpatialTendonActuation,
    TendonActuation,
)
from pcs_sindy.vision import MarkerPoseExtractor

KIN = PlanarPCS((0.1,))  # one segment of 10 cm: what the actuation layouts below are fitted to
KIN3 = SpatialPCS((0.1,))  # its spatial twin, for the 3-D kinds

#: every estimator with a table, and constructor arguments that make a valid instance
ESTIMATORS = {
    KinematicFusion: {},
    EulerLagrangeRegressor: {},
    StiffnessThresholdOptimizer: {},
    PhysicalPCSLibrary: {},
    PCSLagrangianLibrary: {},
    MarkerPoseExtractor: {},
    IdentityActuation: {},
    TendonActuation: {"end": [0.1], "side": [1]},
    PressureActuation: {"start": [0.0], "end": [0.1], "side": [1]},
    LinearActuation: {"pattern": [[1], [0], [0]]},
    LearnedActuation: {"n_inputs": 2},
    SpatialPhysicalPCSLibrary: {},
    SpatialTendonActuation: {"end": [0.1], "offset": [[0.01, 0.0]]},
}


def _fit(est):
    """Call ``fit`` with arguments it never gets to read when a parameter is invalid (validation comes first)."""
    if isinstance(est, StiffnessThresholdOptimizer):
        return est.fit(np.zeros((3, 2)), np.zeros(3))
    if isinstance(est, EulerLagrangeRegressor):
        return est.fit(None, None)
    if isinstance(est, MarkerPoseExtractor):
        return est.fit()
    if isinstance(est, (TendonActuation, PressureActuation, LinearActuation, IdentityActuation, LearnedActuation)):
        return est.fit(KIN)
    if isinstance(est, SpatialTendonActuation):
        return est.fit(KIN3)
    return est.fit(None)


# ----------------------------------------------------------------------
# the validator
# ----------------------------------------------------------------------
class _Toy(BaseEstimator):
    _parameter_constraints: dict = {
        "a": [None, Interval(Real, 0, None, closed="neither")],
        "b": [Options(("x", "y")), "boolean", InstanceOf(dict, "a dict")],
        "c": "no_validation",
    }

    def __init__(self, a=1.0, b="x", c=None, d=None):
        self.a, self.b, self.c, self.d = a, b, c, d


@pytest.mark.parametrize(
    "closed, inside",
    [("both", (0, 0.5, 1)), ("left", (0, 0.5)), ("right", (0.5, 1)), ("neither", (0.5,))],
)
def test_interval_endpoints(closed, inside):
    interval = Interval(Real, 0, 1, closed=closed)
    for value in (0, 0.5, 1):
        assert interval.is_satisfied_by(value) == (value in inside), (closed, value)
    assert not interval.is_satisfied_by(-0.1) and not interval.is_satisfied_by(1.1)


def test_interval_refuses_booleans_nan_and_non_numbers():
    everything = Interval(Real, None, None, closed="both")
    for bad in (True, False, np.True_, np.nan, np.float32("nan"), "1", None, 1j, [1.0], np.array([1.0])):
        assert not everything.is_satisfied_by(bad), bad
    assert not Interval(Integral, None, None).is_satisfied_by(True)


def test_interval_takes_integers_for_reals_and_numpy_scalars():
    positive = Interval(Real, 0, None, closed="neither")
    for good in (1, 2.5, np.int64(3), np.int8(1), np.float32(0.5), np.float64(2.0), np.uint16(7)):
        assert positive.is_satisfied_by(good), good
    count = Interval(Integral, 1, None, closed="left")
    assert count.is_satisfied_by(np.int64(3)) and count.is_satisfied_by(1)
    for bad in (1.0, np.float64(3.0), 0):
        assert not count.is_satisfied_by(bad), bad


def test_interval_none_bounds_are_infinite_and_closed_decides_on_infinity():
    assert not Interval(Real, 0, None, closed="neither").is_satisfied_by(np.inf)
    assert Interval(Real, 0, None, closed="right").is_satisfied_by(np.inf)
    assert Interval(Real, None, 0, closed="both").is_satisfied_by(-np.inf)
    assert not Interval(Real, None, None, closed="neither").is_satisfied_by(-np.inf)


@pytest.mark.parametrize(
    "interval, text",
    [
        (Interval(Real, 0, None, closed="neither"), "a finite number > 0"),
        (Interval(Real, 0, None, closed="right"), "a number > 0"),
        (Interval(Real, 1, None, closed="left"), "a finite number >= 1"),
        (Interval(Real, None, None, closed="neither"), "a finite number"),
        (Interval(Real, 0, 1, closed="neither"), "a number in (0, 1)"),
        (Interval(Real, 0, 255, closed="both"), "a number in [0, 255]"),
        (Interval(Real, 1e-3, 0.5, closed="left"), "a number in [0.001, 0.5)"),
        (Interval(Integral, 1, None, closed="left"), "an integer >= 1"),
        (Interval(Integral, 2, None, closed="neither"), "an integer > 2"),
        (Interval(Integral, None, 10, closed="right"), "an integer <= 10"),
    ],
)
def test_interval_descriptions(interval, text):
    assert interval.description == text


def test_interval_arguments_are_checked():
    with pytest.raises(ValueError, match="kind"):
        Interval(float, 0, 1)
    with pytest.raises(ValueError, match="closed"):
        Interval(Real, 0, 1, closed="open")
    with pytest.raises(ValueError, match="left must be <= right"):
        Interval(Real, 1, 0)


def test_options():
    merge = Options(("runs", "closest_pair"))
    assert merge.description == "one of 'runs', 'closest_pair'"
    assert merge.is_satisfied_by("runs") and merge.is_satisfied_by(np.str_("closest_pair"))
    for bad in ("Runs", "", None, 1, ["runs"], np.array("runs")):
        assert not merge.is_satisfied_by(bad), bad
    assert Options(("auto",)).description == "'auto'"
    assert Options({"b", "a"}).description == "one of 'a', 'b'"  # a set is listed in a fixed order


def test_none_boolean_instance_methods_and_check():
    assert validate_parameters(_Toy(a=None)) is None
    assert validate_parameters(_Toy(b=np.True_)) is None and validate_parameters(_Toy(b=False)) is None
    with pytest.raises(InvalidParameterError):
        validate_parameters(_Toy(b=1))  # an integer is not a boolean
    assert InstanceOf((list, tuple)).description == "an instance of list or tuple"
    assert InstanceOf(dict).is_satisfied_by({}) and not InstanceOf(dict).is_satisfied_by([])
    fits = HasMethods(["fit", "transform"])
    assert fits.is_satisfied_by(KinematicFusion()) and not fits.is_satisfied_by(EulerLagrangeRegressor())
    assert fits.description == "an object with methods 'fit', 'transform'"
    odd = Check(lambda v: int(v) % 2 == 1, "an odd number")
    assert odd.is_satisfied_by(3) and not odd.is_satisfied_by(4)
    assert not odd.is_satisfied_by("x") and not odd.is_satisfied_by(None) and not odd.is_satisfied_by(np.inf)


def test_message_format_and_error_type():
    with pytest.raises(InvalidParameterError) as info:
        validate_parameters(_Toy(a=-1))
    assert str(info.value) == "_Toy: a must be None or a finite number > 0; got -1"
    assert isinstance(info.value, ValueError) and isinstance(info.value, TypeError)
    with pytest.raises(InvalidParameterError) as info:
        validate_parameters(_Toy(b="z"))
    assert str(info.value) == "_Toy: b must be one of 'x', 'y', a boolean or a dict; got 'z'"
    error = InvalidParameterError.of(_Toy(), "a", "< b", 3)
    assert str(error) == "_Toy: a must be < b; got 3"


def test_unchecked_parameters_and_table_errors():
    validate_parameters(_Toy(c=object(), d=object()))  # "no_validation", and a parameter without an entry

    class NoTable(BaseEstimator):
        def __init__(self, a=1):
            self.a = a

    class Unknown(BaseEstimator):
        _parameter_constraints: dict = {"a": [float]}

        def __init__(self, a=1.0):
            self.a = a

    with pytest.raises(TypeError, match="declares no _parameter_constraints"):
        validate_parameters(NoTable())
    with pytest.raises(TypeError, match="unknown parameter constraint"):
        validate_parameters(Unknown())


# ----------------------------------------------------------------------
# the estimators' tables
# ----------------------------------------------------------------------
@pytest.mark.parametrize("cls", list(ESTIMATORS), ids=lambda c: c.__name__)
def test_table_covers_exactly_the_constructor_parameters(cls):
    params = [
        p.name
        for p in inspect.signature(cls).parameters.values()
        if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)  # object.__init__ of a class without parameters
    ]
    assert sorted(cls._parameter_constraints) == sorted(params)
    for name, entry in cls._parameter_constraints.items():
        if isinstance(entry, str):
            assert entry == "no_validation", name
            continue
        assert isinstance(entry, list) and entry, name
        for item in entry:
            assert item is None or item == "boolean" or isinstance(item, Constraint), (name, item)


@pytest.mark.parametrize("cls", list(ESTIMATORS), ids=lambda c: c.__name__)
def test_valid_instances_fit_the_table(cls):
    validate_parameters(cls(**ESTIMATORS[cls]))


def test_every_registered_estimator_of_the_package_declares_its_table():
    for name, spec in REGISTRY.items():
        cls = getattr(importlib.import_module(spec.module), spec.attribute)
        if spec.kind == "estimator" and spec.module.startswith("pcs_sindy.") and name != "PCSPipeline":
            assert "_parameter_constraints" in vars(cls), name
            assert cls in ESTIMATORS, name


BAD = [
    (KinematicFusion, "threshold", 0),
    (KinematicFusion, "threshold", "0.2"),
    (KinematicFusion, "threshold", np.nan),
    (KinematicFusion, "threshold", np.inf),
    (KinematicFusion, "threshold", True),
    (KinematicFusion, "q_max", (1.0, 2.0)),
    (KinematicFusion, "q_max", (60.0, 0.0, 0.3)),
    (KinematicFusion, "scaling", "median"),
    (KinematicFusion, "total_length", 0.0),
    (KinematicFusion, "total_length", True),
    (KinematicFusion, "shape_fit", "spline"),
    (KinematicFusion, "min_segment_markers", 0),
    (KinematicFusion, "min_segment_markers", 2.0),
    (KinematicFusion, "merge", "all"),
    (KinematicFusion, "pose_std", (5e-4, -1.0)),
    (KinematicFusion, "pose_std", (5e-4,)),
    (KinematicFusion, "max_refine_frames", 0),
    (KinematicFusion, "max_refine_frames", 2.5),
    (KinematicFusion, "max_refine_frames", True),
    (KinematicFusion, "n_jobs", 0),
    (KinematicFusion, "n_jobs", True),
    (EulerLagrangeRegressor, "feature_library", "cubic"),
    (EulerLagrangeRegressor, "feature_library", KinematicFusion()),
    (EulerLagrangeRegressor, "formulation", "mixed"),
    (EulerLagrangeRegressor, "optimizer", "lstsq"),
    (EulerLagrangeRegressor, "window_length", 4),
    (EulerLagrangeRegressor, "window_length", 1),
    (EulerLagrangeRegressor, "window_length", 7.0),
    (EulerLagrangeRegressor, "polyorder", 1),
    (EulerLagrangeRegressor, "polyorder", 3.0),
    (EulerLagrangeRegressor, "weak_window", 1),
    (EulerLagrangeRegressor, "weak_window", True),
    (EulerLagrangeRegressor, "weak_stride", 0),
    (EulerLagrangeRegressor, "weak_stride", 2.5),
    (EulerLagrangeRegressor, "weak_hold", "foh"),
    (EulerLagrangeRegressor, "rtol", 0),
    (EulerLagrangeRegressor, "atol", np.inf),
    (EulerLagrangeRegressor, "rtol", True),
    (EulerLagrangeRegressor, "actuation", "tendon"),
    (StiffnessThresholdOptimizer, "threshold", 0),
    (StiffnessThresholdOptimizer, "threshold", np.nan),
    (StiffnessThresholdOptimizer, "threshold", "1"),
    (StiffnessThresholdOptimizer, "rcond", 1),
    (StiffnessThresholdOptimizer, "rcond", 0.0),
    (StiffnessThresholdOptimizer, "max_iter", 0),
    (StiffnessThresholdOptimizer, "max_iter", 1.5),
    (StiffnessThresholdOptimizer, "max_iter", True),
    (StiffnessThresholdOptimizer, "youngs_modulus_max", -1.0),
    (StiffnessThresholdOptimizer, "shear_modulus_max", np.inf),
    (StiffnessThresholdOptimizer, "radius", 0),
    (StiffnessThresholdOptimizer, "shear_factor", None),
    (StiffnessThresholdOptimizer, "stiffness_scaling", "area"),
    (StiffnessThresholdOptimizer, "max_stiffness", [1.0, -1.0, 2.0]),
    (SpatialPhysicalPCSLibrary, "density", "per_segment"),
    (SpatialPhysicalPCSLibrary, "identify_gravity", "all"),
    (SpatialPhysicalPCSLibrary, "n_quadrature", 0),
    (SpatialPhysicalPCSLibrary, "gravity", (0.0, 9.81)),
    (SpatialTendonActuation, "drive", "pull"),
    (SpatialTendonActuation, "max_offset", 0.0),
    (SpatialTendonActuation, "offset", [[0.01, np.nan]]),
    (PhysicalPCSLibrary, "segment_lengths", [0.1, -0.1]),
    (PhysicalPCSLibrary, "segment_lengths", []),
    (PhysicalPCSLibrary, "active_strains", [[1, 2, 0]]),
    (PhysicalPCSLibrary, "active_strains", [1, 1]),
    (PhysicalPCSLibrary, "radius", 0.0),
    (PhysicalPCSLibrary, "gravity", (0.0, 9.81, 0.0)),
    (PhysicalPCSLibrary, "identify_gravity", 1),
    (PhysicalPCSLibrary, "n_quadrature", 0),
    (PhysicalPCSLibrary, "rotary_inertia", "solid"),
    (PhysicalPCSLibrary, "rest_strain", "yes"),
    (PhysicalPCSLibrary, "rest_strain", ("be", "xx")),
    (PhysicalPCSLibrary, "mass", 0.0),
    (PCSLagrangianLibrary, "basis", "fourier"),
    (PCSLagrangianLibrary, "segment_lengths", "abc"),
    (PCSLagrangianLibrary, "active_strains", "all"),
    (MarkerPoseExtractor, "n_markers", 0),
    (MarkerPoseExtractor, "threshold", "mean"),
    (MarkerPoseExtractor, "threshold", 300),
    (MarkerPoseExtractor, "threshold", ((0, 0, 0), (10, 10))),
    (MarkerPoseExtractor, "threshold", ((10,), (0,))),
    (MarkerPoseExtractor, "polarity", "grey"),
    (MarkerPoseExtractor, "blur", 4),
    (MarkerPoseExtractor, "blur", True),
    (MarkerPoseExtractor, "roi", (0, 0, 0, 10)),
    (MarkerPoseExtractor, "roi", (0.5, 0, 10, 10)),
    (MarkerPoseExtractor, "marker_area", -1.0),
    (MarkerPoseExtractor, "area_tolerance", (1.2, 2.0)),
    (MarkerPoseExtractor, "aspect_tolerance", 0.5),
    (MarkerPoseExtractor, "camera", 3),
    (MarkerPoseExtractor, "pixels_per_metre", -1.0),
    (MarkerPoseExtractor, "robot_length", 0),
    (MarkerPoseExtractor, "base_position", (1.0, np.nan)),
    (MarkerPoseExtractor, "rest_direction", np.nan),
    (MarkerPoseExtractor, "reference_frame", -1),
    (MarkerPoseExtractor, "fps", 0),
    (MarkerPoseExtractor, "dt", True),
    (MarkerPoseExtractor, "on_missing", "skip"),
    (MarkerPoseExtractor, "fill_missing", 1),
    (MarkerPoseExtractor, "min_area", 0),
    (TendonActuation, "end", [0.1, -0.1]),
    (TendonActuation, "end", []),
    (TendonActuation, "side", [2]),
    (TendonActuation, "offset", [0.0]),
    (TendonActuation, "max_offset", 0),
    (TendonActuation, "drive", "servo"),
    (TendonActuation, "pulley_radius", [0.0]),
    (TendonActuation, "stiffness", [-1.0]),
    (LearnedActuation, "n_inputs", 0),
    (LearnedActuation, "terms", ("u*q",)),
    (LearnedActuation, "terms", ("pull", "u*q")),
    (LearnedActuation, "strains", "shear"),
    (TendonActuation, "max_offset", True),
    (TendonActuation, "shared", "yes"),
    (TendonActuation, "weighting", "ols"),
    (PressureActuation, "start", [-0.01]),
    (PressureActuation, "end", [0.0]),
    (PressureActuation, "side", [0.5]),
    (PressureActuation, "bending_gain", [np.nan]),
    (PressureActuation, "axial_gain", "x"),
    (LinearActuation, "pattern", [[2], [0], [0]]),
    (LinearActuation, "pattern", [1, 0, 0]),
]


@pytest.mark.parametrize("cls, name, value", BAD, ids=[f"{c.__name__}-{n}-{v!r}"[:60] for c, n, v in BAD])
def test_fit_refuses_a_bad_value_naming_class_parameter_and_value(cls, name, value):
    est = cls(**{**ESTIMATORS[cls], name: value})
    with pytest.raises(InvalidParameterError) as info:
        _fit(est)
    message = str(info.value)
    assert message.startswith(f"{cls.__name__}: {name} must be "), message
    assert message.endswith(f"; got {value!r}"), message


@pytest.mark.parametrize(
    "make, call, text",
    [
        (
            lambda: EulerLagrangeRegressor(window_length=7, polyorder=7),
            lambda e: e.fit(None, None),
            "EulerLagrangeRegressor: polyorder must be < window_length = 7; got 7",
        ),
        (
            lambda: EulerLagrangeRegressor(feature_library=PhysicalPCSLibrary(n_quadrature=0)),
            lambda e: e.fit(None, None),
            "PhysicalPCSLibrary: n_quadrature must be an integer >= 1; got 0",
        ),
        (
            lambda: MarkerPoseExtractor(fps=100.0, dt=0.01),
            lambda e: e.fit(),
            "MarkerPoseExtractor: dt must be None when fps is given",
        ),
        (
            lambda: PhysicalPCSLibrary(segment_lengths=[0.1, 0.1], active_strains=[[1, 1, 1]]),
            lambda e: e.fit(None),
            "PhysicalPCSLibrary: active_strains must be of shape (2, 3) or (6,)",
        ),
        (
            lambda: TendonActuation(end=[0.1, 0.05], side=[1]),
            lambda e: e.fit(KIN),
            "TendonActuation: side must be 2 values, one per actuator of end; got [1]",
        ),
        (
            lambda: PressureActuation(start=[0.06], end=[0.05], side=[1]),
            lambda e: e.fit(KIN),
            "PressureActuation: start must be below end",
        ),
        (
            lambda: PressureActuation(start=[0.0], end=[0.1], side=[1], bending_gain=[1e-6]),
            lambda e: e.fit(KIN),
            "PressureActuation: axial_gain must be given like bending_gain",
        ),
    ],
)
def test_joint_checks_raise_in_the_same_format(make, call, text):
    with pytest.raises(InvalidParameterError) as info:
        call(make())
    assert str(info.value).startswith(text), str(info.value)


def test_boolean_threshold_still_warns_once_per_fit():
    x, y = np.eye(3), np.ones(3)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        StiffnessThresholdOptimizer(threshold=True).fit(x, y)
    future = [w for w in caught if issubclass(w.category, FutureWarning)]
    assert len(future) == 1 and "threshold=1.0" in str(future[0].message)
    assert future[0].filename == __file__  # points at the caller of fit


# ----------------------------------------------------------------------
# model files read the same tables
# ----------------------------------------------------------------------
def _objects(node, name):
    """Every stored object of the registered class ``name`` in a model document."""
    found = []
    if isinstance(node, dict):
        if node.get("$object") == name and "params" in node:
            found.append(node)
        for value in node.values():
            found += _objects(value, name)
    elif isinstance(node, list):
        for value in node:
            found += _objects(value, name)
    return found


def _tampered(path, name, field, value):
    doc = json.loads(path.read_text())
    (obj,) = _objects(doc, name)
    obj["params"][field] = value
    path.write_text(json.dumps(doc))


@pytest.mark.parametrize(
    "make, name, field, value, text",
    [
        (
            KinematicFusion,
            "KinematicFusion",
            "merge",
            "sideways",
            "KinematicFusion: merge must be one of 'runs', 'closest_pair'; got 'sideways'",
        ),
        (
            KinematicFusion,
            "KinematicFusion",
            "threshold",
            -1.0,
            "KinematicFusion: threshold must be a finite number > 0 or one of 'auto', 'relative_drop', "
            "'largest_drop'; got -1.0",
        ),
        (
            lambda: EulerLagrangeRegressor(actuation=TendonActuation(end=[0.1], side=[1])),
            "TendonActuation",
            "max_offset",
            -0.01,
            "TendonActuation: max_offset must be a finite number > 0; got -0.01",
        ),
        (
            lambda: EulerLagrangeRegressor(feature_library=PhysicalPCSLibrary()),
            "PhysicalPCSLibrary",
            "rotary_inertia",
            "solid",
            "PhysicalPCSLibrary: rotary_inertia must be one of 'free', 'tied', 'none'; got 'solid'",
        ),
        (
            MarkerPoseExtractor,
            "MarkerPoseExtractor",
            "blur",
            2,
            "MarkerPoseExtractor: blur must be 0 or an odd integer >= 1; got 2",
        ),
    ],
)
def test_tampered_parameter_is_refused_on_load_by_the_table(make, name, field, value, text, tmp_path):
    path = save(make(), tmp_path / "model")
    load(path)  # as saved: valid
    _tampered(path, name, field, value)
    with pytest.raises(ValueError) as info:
        load(path)
    assert "invalid parameters: InvalidParameterError: " + text in str(info.value)


def test_pipeline_steps_are_checked_on_load(tmp_path):
    path = save(Pipeline([("segments", KinematicFusion()), ("dynamics", EulerLagrangeRegressor())]), tmp_path / "p")
    load(path)
    doc = json.loads(path.read_text())
    steps = doc["object"]["params"]["steps"]
    steps.reverse()  # the regressor (no transform) before the fusion
    path.write_text(json.dumps(doc))
    wrong_order = r"Pipeline: steps must fit \(and transform, but for the last\); got step 'dynamics' \(EulerLag"
    with pytest.raises(ValueError, match=wrong_order):
        load(path)
    steps.reverse()
    steps[1]["$tuple"][0] = "segments"
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="steps must have unique non-empty string names"):
        load(path)


def test_every_registry_entry_resolves_to_its_class():
    for name, spec in REGISTRY.items():
        cls = getattr(importlib.import_module(spec.module), spec.attribute)
        assert isinstance(cls, type), name
        assert cls.__name__ == spec.attribute, name
