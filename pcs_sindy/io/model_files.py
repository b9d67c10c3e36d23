"""Safe model files: fitted estimators as JSON plus ``.npz``, never pickle.

``save(obj, "model")`` writes ``model.json`` and ``model.npz``; ``load("model")``
rebuilds the object.  The JSON is meant to be read by people:

* ``summary``: what the model is, by name and with units: the segment lengths [m],
  the modelled strains, every identified coefficient by name with its value and
  unit (``kg/m``, ``N·m³``, ...), stiffness, damping and rest strain per strain, the
  actuation's parameters, and the printed equations.  It is written for reading and
  never read back (editing it changes nothing);
* ``object``: what :func:`load` rebuilds: class names, constructor parameters and
  learned attributes, with every array of at most :data:`INLINE_ARRAY_SIZE`
  elements written in place as ``{"$ndarray": dtype, "shape": [...], "values": [...]}``
  (bit-exact: floats are written with their shortest round-trip text);
* ``arrays``: the larger arrays, which live in ``model.npz`` (uncompressed, bit-exact;
  referenced from ``object`` as ``{"$array": key}``), with the npz's sha256.

Files of format version 1 (every array in the npz, no summary) still load.

Loading an untrusted file cannot execute code:

* classes are looked up in a fixed registry (:data:`REGISTRY`, name -> module
  and attribute written in this file, plus the classes registered with a
  family's base: every actuation kind, read from
  :func:`pcs_sindy.models.actuation.actuation_kinds`); a stored string is never
  imported, evaluated, ``getattr``-ed or ``sympify``-ed;
* arrays are read with ``np.load(..., allow_pickle=False)`` and only numeric,
  boolean and unicode dtypes are accepted;
* objects are rebuilt through their constructors with the stored parameters
  (names checked against the constructor's signature) and validated against the
  class's ``_parameter_constraints`` table (:func:`pcs_sindy.core.validation.validate_parameters`,
  the check of its ``fit``); learned attributes are restricted to ``name_``
  attributes that are not properties of the class;
* symbolic libraries are rebuilt from their specification (segment lengths,
  active strains, basis) and re-derive or read their own cache; a model file
  may not choose that cache directory (it holds generated code that the
  library executes), see ``cache_dir`` of :func:`load`;
* a ``Pipeline``'s ``memory`` (a joblib cache of pickles) is not stored (a pipeline
  built with ``memory=`` is saved, and loads, with ``memory=None``), and its steps
  must be a list of uniquely named (name, estimator) pairs.

A file names its format version; files from a newer format are refused.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import inspect
import io
import json
import math
import os
import re
import stat
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..core.atomic import FileSet, recover
from ..core.units import generalised_force_unit, strain_rate_unit, strain_unit
from ..core.validation import InvalidParameterError, validate_parameters
from .npz_headers import check_npz_headers

__all__ = [
    "save",
    "load",
    "FORMAT_VERSION",
    "INLINE_ARRAY_SIZE",
    "FORMAT_NAME",
    "REGISTRY",
    "PARAMETER_RANGES",
    "MAX_SEGMENTS",
    "MAX_MONOMIAL_SEGMENTS",
]

#: Name written in every model file.
FORMAT_NAME = "pcs_sindy.model"
#: Version of the file layout; bumped on incompatible changes.  2: small arrays inline in the JSON
#: (``$ndarray``) and a readable ``summary``; 1: every array in the npz (still read).
FORMAT_VERSION = 2
#: Arrays of at most this many elements are written into the JSON (readable); larger ones go to the npz.
INLINE_ARRAY_SIZE = 64

# largest JSON part we parse: a model's JSON holds no bulk data (arrays go to the npz)
_MAX_JSON_BYTES = 64 * 2**20
# largest total of array bytes we unpack from the npz (a crafted zip can claim far more than its size)
_MAX_ARRAY_BYTES = 2**30
# largest npz file we read (the arrays plus the zip's headers)
_MAX_NPZ_BYTES = _MAX_ARRAY_BYTES + 64 * 2**20
_ALLOWED_DTYPE_KINDS = "biufcU"
_SCALAR_DTYPES = (
    "bool",
    "int8",
    "int16",
    "int32",
    "int64",
    "uint8",
    "uint16",
    "uint32",
    "uint64",
    "float16",
    "float32",
    "float64",
    "complex64",
    "complex128",
)
_STATE_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*_$")
_TAGS = ("$float", "$tuple", "$dict", "$array", "$ndarray", "$scalar", "$complex", "$object", "$ref")
# dtypes of the arrays written in place: numbers and booleans by name, unicode as U<characters>
_INLINE_DTYPES = ("bool", "int8", "int16", "int32", "int64", "uint8", "uint16", "uint32", "uint64")
_INLINE_DTYPES += ("float16", "float32", "float64")
_INLINE_UNICODE = re.compile(r"^U([1-9][0-9]{0,5})$")
_MAX_INLINE_NDIM = 32


class _Unset:
    def __repr__(self) -> str:
        return "<stored>"


_UNSET = _Unset()


# --------------------------------------------------------------------------
# Registry of the classes a model file may contain
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class ClassSpec:
    """How one registered class is stored.

    Parameters
    ----------
    module, attribute : str
        Where the class lives (fixed here, never read from a file).
    kind : {"estimator", "dataclass", "init"}
        ``"estimator"``: sklearn ``get_params(deep=False)`` plus learned
        attributes; ``"dataclass"``: the ``init`` fields; ``"init"``: the
        attributes named in ``fields`` passed to the constructor.
    fields : tuple of str
        Constructor arguments of an ``"init"`` class (read back with getattr).
    params_only : bool
        Store no learned state (stateless transformers).
    skip_state : frozenset of str
        Learned attributes deliberately not stored (training-data artefacts).

    Notes
    -----
    Parameters are validated on load by the class's ``_parameter_constraints`` table when it has
    one (pipelines by :func:`_check_pipeline`), so a spec holds no checks of its own.
    """

    module: str
    attribute: str
    kind: str = "estimator"
    fields: tuple[str, ...] = ()
    params_only: bool = False
    skip_state: frozenset = frozenset()


#: the sklearn pipelines: their ``_parameter_constraints`` is scikit-learn's, checked by :func:`_check_pipeline`
_PIPELINES = ("Pipeline", "PCSPipeline")


def _check_pipeline(obj: Any) -> None:
    """What a rebuilt pipeline must be: no joblib cache, uniquely named steps that fit (and transform on the way)."""
    name = type(obj).__name__
    if obj.memory is not None:
        raise InvalidParameterError.of(obj, "memory", "None (a joblib cache is not stored in model files)", obj.memory)
    steps = obj.steps
    if not (isinstance(steps, list) and steps and all(isinstance(s, tuple) and len(s) == 2 for s in steps)):
        raise InvalidParameterError.of(obj, "steps", "a non-empty list of (name, estimator) pairs", steps)
    names = [step_name for step_name, _ in steps]
    if not all(isinstance(n, str) and n and "__" not in n for n in names) or len(set(names)) != len(names):
        raise InvalidParameterError(
            f"{name}: steps must have unique non-empty string names without '__'; got names {names!r}"
        )
    last = len(steps) - 1
    for k, (step_name, est) in enumerate(steps):
        if est is None or (isinstance(est, str) and est == "passthrough"):
            continue  # sklearn's way of skipping a step
        missing = [m for m in (("fit",) if k == last else ("fit", "transform")) if not callable(getattr(est, m, None))]
        if missing:
            raise InvalidParameterError(
                f"{name}: steps must fit (and transform, but for the last); got step {step_name!r} "
                f"({type(est).__name__}) without {' and '.join(missing)}"
            )


class _Registry(Mapping):
    """The fixed classes, then the members of each family (classes a base registers), by class name.

    A family is read when it is used, so adding a member (an actuation kind) edits no list
    here: a file can name any member defined in the process, never make one.
    """

    def __init__(self, fixed: dict[str, ClassSpec], families: tuple[tuple[str, str], ...]) -> None:
        self.fixed = fixed
        #: (module, function) of each family: the function returns ``{key: class}`` of its members
        self.families = families

    def members(self, loaded_only: bool = False) -> dict[str, type]:
        """Class name -> class of every family member (``loaded_only``: of the families already imported)."""
        out: dict[str, type] = {}
        for module, function in self.families:
            if loaded_only and module not in sys.modules:
                continue  # an object of a family not imported cannot exist
            for cls in getattr(importlib.import_module(module), function)().values():
                if cls.__name__ not in self.fixed:
                    out[cls.__name__] = cls
        return out

    def _all(self) -> dict[str, ClassSpec]:
        members = {name: ClassSpec(cls.__module__, cls.__name__) for name, cls in self.members().items()}
        return {**self.fixed, **members}

    def __getitem__(self, name: str) -> ClassSpec:
        if name in self.fixed:
            return self.fixed[name]
        return self._all()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._all())

    def __len__(self) -> int:
        return len(self._all())


#: the classes of the registry written here (the actuation kinds register themselves: see REGISTRY)
_FIXED: dict[str, ClassSpec] = {
    "KinematicFusion": ClassSpec("pcs_sindy.fusion.kinematic_fusion", "KinematicFusion"),
    "EulerLagrangeRegressor": ClassSpec("pcs_sindy.identification.regressor", "EulerLagrangeRegressor"),
    # Theta_ is the training regression matrix (can be 100 MB); prediction does not use it
    "StiffnessThresholdOptimizer": ClassSpec(
        "pcs_sindy.identification.optimizers", "StiffnessThresholdOptimizer", skip_state=frozenset({"Theta_"})
    ),
    "PCSLagrangianLibrary": ClassSpec("pcs_sindy.identification.library.pcs_lagrangian", "PCSLagrangianLibrary"),
    "PhysicalPCSLibrary": ClassSpec("pcs_sindy.identification.library.physical", "PhysicalPCSLibrary"),
    "SpatialPhysicalPCSLibrary": ClassSpec(
        "pcs_sindy.identification.library.spatial_physical", "SpatialPhysicalPCSLibrary"
    ),
    # the optimizer's column layout when actuator gains are identified with the Lagrangian
    "WithGains": ClassSpec(
        "pcs_sindy.identification.library.with_gains",
        "WithGains",
        kind="init",
        fields=("library", "gain_names", "gain_lower", "parent_columns"),
    ),
    "MarkerPoseExtractor": ClassSpec("pcs_sindy.vision.extractor", "MarkerPoseExtractor", params_only=True),
    "Camera": ClassSpec("pcs_sindy.core.camera", "Camera", kind="dataclass"),
    "PlanarPCS": ClassSpec("pcs_sindy.core.kinematics", "PlanarPCS", kind="dataclass"),
    "SpatialPCS": ClassSpec("pcs_sindy.core.spatial", "SpatialPCS", kind="dataclass"),
    "PoseTrajectory": ClassSpec(
        "pcs_sindy.core.trajectory", "PoseTrajectory", kind="init", fields=("poses", "t", "metadata")
    ),
    "StrainTrajectory": ClassSpec(
        "pcs_sindy.core.trajectory",
        "StrainTrajectory",
        kind="init",
        fields=("q", "t", "segment_lengths", "active_strains", "qd", "base_pose", "metadata"),
    ),
    "SpatialStrainTrajectory": ClassSpec(
        "pcs_sindy.core.spatial",
        "SpatialStrainTrajectory",
        kind="init",
        fields=("q", "t", "segment_lengths", "active_strains", "qd", "base_position", "base_rotation", "metadata"),
    ),
    # a spatial forward model of given parameters (e.g. a simulator robot's): its constructor arguments
    "SpatialPCSModel": ClassSpec(
        "pcs_sindy.models.spatial_forward",
        "SpatialPCSModel",
        kind="init",
        fields=(
            "kinematics",
            "rhoA",
            "rhoI",
            "rhoAg",
            "stiffness",
            "damping",
            "rest_force",
            "n_quadrature",
            "actuation",
        ),
    ),
    "Pipeline": ClassSpec("sklearn.pipeline", "Pipeline"),
    "PCSPipeline": ClassSpec("pcs_sindy.pipeline.pcs_pipeline", "PCSPipeline"),
    # plain-parameter pysindy differentiation (no callables among its parameters); what it keeps
    # after a call (stencils, the last smoothed input) is recomputed on every call
    "FiniteDifference": ClassSpec("pysindy.differentiation", "FiniteDifference", params_only=True),
}
#: Classes a model file may hold, by the name written in the file: the fixed ones, then every
#: actuation kind (``pcs_sindy.models.actuation.actuation_kinds()``, each registered by its class),
#: stored with its parameters (the layout) and the identified offsets and gains.
REGISTRY: _Registry = _Registry(_FIXED, families=(("pcs_sindy.models.actuation", "actuation_kinds"),))


#: constructor fields of an ``"init"`` class that are not attributes of the same name
_FIELD_GETTERS = {
    ("StrainTrajectory", "base_pose"): lambda obj: tuple(float(v) for v in obj.kinematics.base_pose),
    ("SpatialStrainTrajectory", "base_position"): lambda obj: obj.kinematics.base_position,
    ("SpatialStrainTrajectory", "base_rotation"): lambda obj: np.array(obj.kinematics.base_rotation),
    # the nodes per segment (the model keeps the quadrature they give)
    ("SpatialPCSModel", "n_quadrature"): lambda obj: int(obj.quadrature[0].size // obj.kinematics.n_segments),
}


def _resolve(name: str) -> type:
    """The registered class called ``name``."""
    spec = REGISTRY[name]
    member = REGISTRY.members().get(name) if name not in REGISTRY.fixed else None
    return member if member is not None else getattr(importlib.import_module(spec.module), spec.attribute)


def _name_of(obj: Any) -> str | None:
    """Registry name of ``type(obj)`` (exact type: a subclass may behave differently)."""
    cls = type(obj)
    if REGISTRY.members(loaded_only=True).get(cls.__name__) is cls:
        return cls.__name__
    for name, spec in REGISTRY.fixed.items():
        if spec.attribute != cls.__name__ or spec.module.split(".")[0] != cls.__module__.split(".")[0]:
            continue
        if _resolve(name) is cls:
            return name
    return None


# --------------------------------------------------------------------------
# Encoding
# --------------------------------------------------------------------------
def _by_value(key: str, value: Any, label: str) -> Any:
    """The object a path parameter names, read now (a model file never stores a path)."""
    if key != "camera":
        raise ValueError(f"cannot store {label}.{key} = {str(value)!r}: model files store no paths")
    from ..core.camera import Camera

    try:
        return Camera.from_json(value)
    except (OSError, ValueError) as err:
        raise ValueError(
            f"cannot store {label}.camera = {str(value)!r}: model files store the camera by value, and reading "
            f"it failed: {err}"
        ) from None


class _Encoder:
    """JSON of an object graph; ``arrays`` collects the arrays that go to the npz.

    ``shared``: ids of the small arrays met more than once by an earlier pass: written in place once
    with an ``id`` and then referred to (``$ref``), so that the loaded graph shares them too.
    """

    def __init__(self, shared: frozenset[int] = frozenset()) -> None:
        self.arrays: dict[str, np.ndarray] = {}
        self.shared = shared
        self.repeated: set[int] = set()  # small arrays met more than once in this pass
        self._inline_seen: set[int] = set()
        self._array_keys: dict[int, str] = {}
        self._object_ids: dict[int, int] = {}
        self._alive: list[Any] = []  # keep ids unique while encoding

    def encode(self, value: Any, where: str) -> Any:
        if value is None or isinstance(value, (bool, str)):
            return value
        if isinstance(value, np.ndarray):
            return self._array(value, where)
        if isinstance(value, np.generic):
            return self._scalar(value, where)
        if isinstance(value, int):
            return int(value)
        if isinstance(value, float):
            v = float(value)
            return v if math.isfinite(v) else {"$float": repr(v)}
        if isinstance(value, complex):
            return {"$complex": [self.encode(value.real, where), self.encode(value.imag, where)]}
        if isinstance(value, tuple) and type(value) is tuple:
            return {"$tuple": [self.encode(v, f"{where}[{k}]") for k, v in enumerate(value)]}
        if type(value) is list:
            return [self.encode(v, f"{where}[{k}]") for k, v in enumerate(value)]
        if type(value) is dict:
            return {
                "$dict": [[self.encode(k, f"{where} key"), self.encode(v, f"{where}[{k!r}]")] for k, v in value.items()]
            }
        name = _name_of(value)
        if name is not None:
            return self._object(value, name, where)
        raise ValueError(
            f"cannot store {where} of type {type(value).__module__}.{type(value).__qualname__}: model files hold "
            "None, bool, int, float, str, tuples, lists, dicts, numpy arrays and scalars, and the classes of "
            f"pcs_sindy.io.model_files.REGISTRY ({', '.join(REGISTRY)})"
        )

    def _array(self, value: np.ndarray, where: str) -> dict:
        key = self._array_keys.get(id(value))
        if key is None:
            arr = np.asarray(value)  # drops ndarray subclasses such as pysindy's AxesArray
            if arr.dtype.kind not in _ALLOWED_DTYPE_KINDS or arr.dtype.fields is not None:
                raise ValueError(
                    f"cannot store {where}: arrays of dtype {arr.dtype} are not supported (numeric, bool and "
                    "unicode only; object arrays would need pickle)"
                )
            inline = _inline_dtype(arr)
            if inline is not None and arr.size <= INLINE_ARRAY_SIZE and arr.ndim <= _MAX_INLINE_NDIM:
                node = {"$ndarray": inline, "shape": list(arr.shape), "values": _inline_values(arr)}
                if id(value) in self.shared:
                    if id(value) in self._object_ids:
                        return {"$ref": self._object_ids[id(value)]}
                    node["id"] = self._object_ids[id(value)] = len(self._object_ids)
                elif id(value) in self._inline_seen:
                    self.repeated.add(id(value))
                self._inline_seen.add(id(value))
                self._alive.append(value)
                return node
            key = f"a{len(self.arrays)}"
            self.arrays[key] = arr
            self._array_keys[id(value)] = key
            self._alive.append(value)
        return {"$array": key}

    def _scalar(self, value: np.generic, where: str) -> dict:
        name = value.dtype.name
        if name not in _SCALAR_DTYPES:
            raise ValueError(f"cannot store {where}: numpy scalars of dtype {name} are not supported")
        item = value.item()
        return {"$scalar": name, "value": self.encode(item, where)}

    def _object(self, obj: Any, name: str, where: str) -> dict:
        if id(obj) in self._object_ids:
            return {"$ref": self._object_ids[id(obj)]}
        oid = len(self._object_ids)
        self._object_ids[id(obj)] = oid
        self._alive.append(obj)
        spec = REGISTRY[name]
        label = f"{where}<{name}>" if where else name
        if spec.kind == "dataclass":
            params = {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj) if f.init}
            state: dict[str, Any] = {}
        elif spec.kind == "init":
            params = {f: _FIELD_GETTERS.get((name, f), lambda o, f=f: getattr(o, f))(obj) for f in spec.fields}
            state = {}
        else:
            params = obj.get_params(deep=False)
            for key, allowed in _NO_PATHS.get(name, {}).items():
                value = params.get(key)
                if isinstance(value, (str, os.PathLike)) and value not in allowed:
                    params[key] = _by_value(key, value, label)
            if name in ("Pipeline", "PCSPipeline"):
                # a cache of fitted transformers is no part of the model (and a joblib cache holds pickles):
                # the file stores the pipeline with memory=None
                params = {**params, "memory": None}
            state = {}
            if not spec.params_only:
                for key, val in vars(obj).items():
                    if key.startswith("_") or key in params or key in spec.skip_state:
                        continue
                    state[key] = val
        return {
            "$object": name,
            "id": oid,
            "params": {k: self.encode(v, f"{label}.{k}") for k, v in params.items()},
            "state": {k: self.encode(v, f"{label}.{k}") for k, v in state.items()},
        }


def _inline_dtype(arr: np.ndarray) -> str | None:
    """The name an array's dtype is written under in the JSON, or None (the array goes to the npz)."""
    dt = arr.dtype
    if not dt.isnative and dt.itemsize > 1:
        return None  # a foreign byte order is kept bit-exact by the npz
    if dt.kind == "U":
        return f"U{dt.itemsize // 4}"
    return dt.name if dt.name in _INLINE_DTYPES else None


def _inline_values(arr: np.ndarray) -> Any:
    """The elements as nested JSON lists; a non-finite float as ``{"$float": "inf"}`` (JSON has no inf)."""
    if arr.dtype.kind != "f" or np.all(np.isfinite(arr)):
        return arr.tolist()

    def tag(v: Any) -> Any:
        if isinstance(v, list):
            return [tag(x) for x in v]
        return v if math.isfinite(v) else {"$float": repr(v)}

    return tag(arr.tolist())


# --------------------------------------------------------------------------
# Summary: the model for people (written, never read back)
# --------------------------------------------------------------------------
_ABOUT = (
    "what this model is, with units, for reading: never read back (editing it changes nothing); "
    "'object' below is what pcs_sindy.io.load rebuilds"
)


def _number(value: Any) -> Any:
    """A JSON number, or the text of a non-finite one ('inf', 'nan')."""
    v = float(value)
    return v if math.isfinite(v) else repr(v)


def _quantity(value: Any, unit: Any) -> dict[str, Any]:
    """``{"value": ..., "unit": ...}`` (a list of values shares one unit; unit None: not known)."""
    arr = np.asarray(value, dtype=float)
    out = [_number(v) for v in arr.reshape(-1)] if arr.ndim else _number(arr)
    return {"value": out, "unit": None if unit is None else str(unit)}


def _segmentation_summary(kin: Any, base: bool = True) -> dict[str, Any]:
    out = {
        "segment_lengths": _quantity(kin.segment_lengths, "m"),
        "strains": kin.strain_names(active_only=True),
    }
    if base and type(kin).__name__ == "SpatialPCS":  # a 3-D robot: its base frame in the frame of the data
        out["base_position"] = _quantity(kin.base_position, "m")
        out["base_rotation"] = [[_number(v) for v in row] for row in np.asarray(kin.base_rotation)]
    return out


def _library_summary(lib: Any) -> dict[str, Any] | None:
    # an unfitted library may have no segmentation yet (NotFittedError) or parameters its fit would
    # refuse (saved as given, refused at load): then there is nothing to describe
    try:
        out = _segmentation_summary(lib.kinematics)
        # the monomial basis would need its symbolic derivation
        if type(lib).__name__ in ("PhysicalPCSLibrary", "SpatialPhysicalPCSLibrary"):
            units = (str(u) for u in lib.coefficient_units())
            out["coefficient_units"] = dict(zip(lib.coefficient_names(), units, strict=True))
    except (ValueError, TypeError):
        return None
    return out


def _actuation_summary(act: Any) -> dict[str, Any]:
    """The map's type and, when fitted, its description (with units) and identified parameters by name."""
    out: dict[str, Any] = {"type": act.layout().get("type")}
    state = vars(act)
    if "gains_" in state and "offsets_" in state:
        out["description"] = act.describe()
        for key, names, values in (
            ("gains", state.get("gain_names_", []), act.gains_),
            ("offsets", state.get("offset_names_", []), act.offsets_),
        ):
            if len(names):
                out[key] = {nm: _number(v) for nm, v in zip(names, np.asarray(values).reshape(-1))}
    return out


def _regressor_summary(model: Any) -> dict[str, Any]:
    kin, lib = model.kinematics_, model.library_
    # an identified model lives in its base frame (no base pose): gravity is given in that frame
    out: dict[str, Any] = {"about": _ABOUT, **_segmentation_summary(kin, base=False)}
    gravity = lib.get_params().get("gravity")
    if gravity is not None and np.ndim(gravity) == 1 and not lib.get_params().get("identify_gravity", False):
        out["gravity"] = _quantity(gravity, "m/s^2")
    out["removed_strains"] = list(getattr(model, "removed_strains_", []))
    units = lib.coefficient_units()
    out["coefficients"] = {
        nm: _quantity(v, u) for nm, v, u in zip(lib.coefficient_names(), model.model_coef_, units, strict=True)
    }
    names = kin.strain_names()
    mask = np.asarray(model.active_strains_, dtype=bool).reshape(-1)
    for attr, key, unit_of in (
        ("stiffness_", "stiffness", lambda s: generalised_force_unit(s) / strain_unit(s)),
        ("damping_", "damping", lambda s: generalised_force_unit(s) / strain_rate_unit(s)),
        ("rest_strain_", "rest_strain", strain_unit),
    ):
        values = vars(model).get(attr)
        if values is not None:
            out[key] = {nm: _quantity(v, unit_of(nm)) for nm, v, a in zip(names, values, mask) if a}
    act = vars(model).get("actuation_")
    if act is not None and act.layout().get("type") != "identity":
        out["actuation"] = _actuation_summary(act)
    conv = vars(model).get("scale_convention_")
    if conv:
        out["scale_convention"] = conv
    out["equations"] = model.equations()
    return out


def _spatial_model_summary(model: Any) -> dict[str, Any]:
    """A spatial forward model's parameters by name, with units (per segment, then per modelled strain)."""
    kin = model.kinematics
    out: dict[str, Any] = {"about": _ABOUT, **_segmentation_summary(kin)}
    out["rhoA"] = _quantity(model.rhoA, "kg/m")
    out["rhoI"] = _quantity(model.rhoI, "kg·m")
    out["rhoAg"] = {f"segment_{i + 1}": _quantity(g, "N/m") for i, g in enumerate(np.asarray(model.rhoAg))}
    names = kin.strain_names(active_only=True)
    for attr, unit_of in (
        ("stiffness", lambda s: generalised_force_unit(s) / strain_unit(s)),
        ("damping", lambda s: generalised_force_unit(s) / strain_rate_unit(s)),
        ("rest_force", generalised_force_unit),
    ):
        out[attr] = {nm: _quantity(v, unit_of(nm)) for nm, v in zip(names, getattr(model, attr), strict=True)}
    act = model.actuation
    if act is not None:
        out["actuation"] = _actuation_summary(act)
    return out


def _summary(obj: Any, name: str) -> dict[str, Any] | None:
    """The readable summary of a registered object (None when there is nothing to say)."""
    state = vars(obj) if hasattr(obj, "__dict__") else {}
    if name == "EulerLagrangeRegressor":
        return _regressor_summary(obj) if "coef_" in state else None
    if name in ("PhysicalPCSLibrary", "PCSLagrangianLibrary", "SpatialPhysicalPCSLibrary"):
        return _library_summary(obj)
    if name in _PIPELINES:
        steps = {str(k): _summary(est, _name_of(est) or "") for k, est in obj.steps}
        return {"steps": {k: v for k, v in steps.items() if v is not None}} if any(steps.values()) else None
    if name == "KinematicFusion" and "segment_lengths_" in state:
        # a file of an earlier release may lack some of them
        out = {"segment_lengths": _quantity(state["segment_lengths_"], "m")}
        for key in ("marker_arc_lengths_", "total_length_"):
            if state.get(key) is not None:
                out[key[:-1]] = _quantity(state[key], "m")
        if state.get("threshold_") is not None:
            out["threshold"] = _number(state["threshold_"])
        return out
    if name in ("PlanarPCS", "StrainTrajectory", "SpatialPCS", "SpatialStrainTrajectory"):
        kin = obj if name in ("PlanarPCS", "SpatialPCS") else obj.kinematics
        out = _segmentation_summary(kin)
        if name.endswith("StrainTrajectory"):
            out["n_frames"] = int(obj.n_frames)
            out["duration"] = _quantity(obj.t[-1] - obj.t[0] if obj.n_frames else 0.0, "s")
        return out
    if name == "SpatialPCSModel":
        return _spatial_model_summary(obj)
    if name in REGISTRY.members(loaded_only=True) and not getattr(obj, "is_identity", False):
        return _actuation_summary(obj)  # every actuation kind but the identity (which has nothing to say)
    return None


# --------------------------------------------------------------------------
# Bounds: what a model file may ask of the machine
# --------------------------------------------------------------------------
#: Inclusive range of every integer constructor parameter a model file may set (by class); a value
#: outside it is refused at load (a huge ``n_quadrature`` allocates gigabytes when the model is used).
PARAMETER_RANGES: dict[str, dict[str, tuple[int, int]]] = {
    "KinematicFusion": {
        "min_segment_markers": (1, 10_000),
        "max_refine_frames": (1, 10_000_000),
        "n_jobs": (-64, 1024),
    },
    "EulerLagrangeRegressor": {
        "window_length": (1, 100_001),
        "polyorder": (0, 20),
        "weak_window": (1, 10_000_000),
        "weak_stride": (1, 10_000_000),
    },
    "StiffnessThresholdOptimizer": {"max_iter": (1, 100_000)},
    "PhysicalPCSLibrary": {"n_quadrature": (1, 256)},
    "SpatialPhysicalPCSLibrary": {"n_quadrature": (1, 256)},
    "SpatialPCSModel": {"n_quadrature": (1, 256)},
    "MarkerPoseExtractor": {
        "n_markers": (1, 1000),
        "blur": (0, 1001),
        "reference_frame": (0, 100_000_000),
        "n_jobs": (-64, 1024),
    },
    "FiniteDifference": {"order": (1, 10), "d": (1, 4), "axis": (-8, 8)},
}
#: Most segments of any segmentation in a model file.
MAX_SEGMENTS = 64
#: Most segments of a monomial (``PCSLagrangianLibrary(basis="monomial")``) library: its symbolic
#: derivation grows steeply with the segment count (22 terms for one segment, 252 for two).
MAX_MONOMIAL_SEGMENTS = 2
#: Constructor parameters that may hold a path, with the strings a file may store instead (a path in a
#: model file would make loading read a file the model file chooses: a device, a FIFO).
_NO_PATHS = {"MarkerPoseExtractor": {"camera": ("auto",)}}


def _integer(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def _segments(kin: Any) -> tuple[float, ...]:
    return tuple(float(v) for v in kin.segment_lengths)


def _library_segments(lib: Any) -> Any:
    """The fitted segmentation of a library (None when unfitted or given by its parameters only)."""
    return vars(lib).get("segmentation_")


def _check_library(lib: Any, fail: Any) -> None:
    """A fitted library's sizes agree with its segmentation; a monomial one is small enough to derive."""
    kin = _library_segments(lib)
    lengths = getattr(lib, "segment_lengths", None)
    m = kin.n_segments if kin is not None else (None if lengths is None else len(np.atleast_1d(lengths)))
    if getattr(lib, "basis", None) == "monomial" and m is not None and m > MAX_MONOMIAL_SEGMENTS:
        fail(
            f"a monomial library of {m} segments (model files hold monomial libraries of at most "
            f"{MAX_MONOMIAL_SEGMENTS}; the symbolic derivation of larger ones does not finish in reasonable time)"
        )
    if kin is None:
        return
    if lengths is not None and not np.array_equal(np.atleast_1d(np.asarray(lengths, dtype=float)), kin.segment_lengths):
        fail(f"segment_lengths {lengths!r} differ from the fitted segmentation {_segments(kin)}")
    n_active = int(np.count_nonzero(kin.active_mask))
    width = vars(lib).get("n_features_in_")
    if width is not None and width != 2 * n_active:
        fail(
            f"n_features_in_ = {width!r}, but the segmentation has {n_active} active strains (expected {2 * n_active})"
        )
    n_out = vars(lib).get("n_output_features_")
    if n_out is not None and not (_integer(n_out) and 0 < n_out <= 1_000_000):
        fail(f"n_output_features_ = {n_out!r} is not a basis size")
    if n_out is not None and getattr(lib, "basis", "physical") != "monomial":
        # the physical layout is cheap to rebuild: its size must be the stored one
        expected = int(lib.n_coefficients_) - int(np.asarray(lib.damping_index_).size)
        if n_out != expected:
            fail(f"n_output_features_ = {n_out} but this library has {expected} basis terms")


def _columns(lib: Any, kin: Any) -> int | None:
    """Columns of a library's ``Psi`` when known without a symbolic derivation (None: not knowable cheaply)."""
    if getattr(lib, "basis", "physical") != "monomial":
        return int(lib.n_coefficients_)  # the physical layout is built from tables, in milliseconds
    n_out = vars(lib).get("n_output_features_")
    return None if n_out is None else int(n_out) + int(np.count_nonzero(kin.active_mask))


def _check_regressor(obj: Any, fail: Any) -> None:
    """A fitted regressor: one segmentation, coefficients of the libraries' sizes, model_coef_ = coef_[column_map_]."""
    state = vars(obj)
    if "coef_" not in state:
        return
    needed = ("kinematics_", "library_", "full_library_", "column_map_", "model_coef_", "active_strains_")
    missing = [k for k in needed if k not in state]
    if missing:
        fail(f"a fitted regressor (it has coef_) lacks {missing}")
    kin = obj.kinematics_
    if type(kin).__name__ not in ("PlanarPCS", "SpatialPCS"):
        fail(f"kinematics_ must be a PlanarPCS or a SpatialPCS; got {type(kin).__name__}")
    lengths, m = _segments(kin), kin.n_segments
    per = kin.n_q // m  # strains per segment: 3 in the plane, 6 in 3-D
    columns = {}
    for label in ("library_", "full_library_"):
        lib = state[label]
        if not hasattr(lib, "n_coefficients_"):
            fail(f"{label} must be a Lagrangian library; got {type(lib).__name__}")
        _check_library(lib, lambda msg, label=label: fail(f"{label}: {msg}"))
        try:
            seg = lib.kinematics
        except (ValueError, TypeError, AttributeError) as err:  # NotFittedError is a ValueError
            fail(f"{label} has no segmentation: {err}")
        if _segments(seg) != lengths:
            fail(f"{label} has segments {_segments(seg)}, kinematics_ {lengths}")
        if type(seg) is not type(kin):
            fail(f"{label} describes a {type(seg).__name__}, kinematics_ is a {type(kin).__name__}")
        columns[label] = _columns(lib, seg)
    for label, other in (("actuation_", state.get("actuation_")), ("optimizer_", state.get("optimizer_"))):
        kin_other = vars(other).get("kinematics_") if other is not None and hasattr(other, "__dict__") else None
        if kin_other is not None and _segments(kin_other) != lengths:
            fail(f"{label}.kinematics_ has segments {_segments(kin_other)}, kinematics_ {lengths}")
    for name_ in ("coef_", "model_coef_"):
        arr = state[name_]
        if not (isinstance(arr, np.ndarray) and arr.ndim == 1 and arr.dtype.kind == "f"):
            fail(f"{name_} must be a 1-d float array; got {type(arr).__name__} {getattr(arr, 'shape', '')}")
    coef, model_coef, cmap = obj.coef_, obj.model_coef_, obj.column_map_
    for name_, arr, label in (("coef_", coef, "full_library_"), ("model_coef_", model_coef, "library_")):
        if columns[label] is not None and arr.size != columns[label]:
            fail(f"{name_} has {arr.size} entries; {label} has {columns[label]} columns")
    if not (
        isinstance(cmap, np.ndarray)
        and cmap.ndim == 1
        and cmap.dtype.kind in "iu"
        and cmap.size == model_coef.size
        and (cmap.size == 0 or (cmap.min() >= 0 and cmap.max() < coef.size and np.all(np.diff(cmap) > 0)))
    ):
        fail(f"column_map_ must be {model_coef.size} increasing column indices below {coef.size}")
    if not np.array_equal(coef[cmap], model_coef, equal_nan=True):
        fail("model_coef_ differs from coef_[column_map_]: the coefficients were altered")
    active = obj.active_strains_
    if not (isinstance(active, np.ndarray) and active.shape == (m, per) and np.array_equal(active, kin.active_strains)):
        fail(f"active_strains_ must be the ({m}, {per}) active strains of kinematics_")
    if not np.array_equal(obj.library_.kinematics.active_strains, kin.active_strains):
        fail("library_'s active strains differ from kinematics_'s")
    for name_ in ("stiffness_", "damping_", "rest_strain_"):
        arr = state.get(name_)
        if arr is not None and np.shape(arr) != (per * m,):
            fail(f"{name_} must have shape ({per * m},); got {np.shape(arr)}")
    if state.get("n_features_in_", per * m) != per * m:
        fail(f"n_features_in_ = {state['n_features_in_']!r}; kinematics_ has {per * m} strains")


#: per-class checks run on a rebuilt object (after its learned state is set)
_CONSISTENCY = {
    "EulerLagrangeRegressor": _check_regressor,
    "PCSLagrangianLibrary": _check_library,
    "PhysicalPCSLibrary": _check_library,
    "SpatialPhysicalPCSLibrary": _check_library,
}


# --------------------------------------------------------------------------
# Decoding
# --------------------------------------------------------------------------
class _Decoder:
    def __init__(self, arrays: dict[str, np.ndarray], source: str, cache_dir: Any) -> None:
        self.arrays = arrays
        self.source = source
        self.cache_dir = cache_dir
        self.objects: dict[int, Any] = {}

    def error(self, where: str, msg: str) -> ValueError:
        return ValueError(f"model file {self.source}: {where or 'root'}: {msg}")

    def decode(self, data: Any, where: str) -> Any:
        if data is None or isinstance(data, (bool, str)):
            return data
        if isinstance(data, int):
            return data
        if isinstance(data, float):
            return data
        if isinstance(data, list):
            return [self.decode(v, f"{where}[{k}]") for k, v in enumerate(data)]
        if not isinstance(data, dict):
            raise self.error(where, f"unexpected JSON value of type {type(data).__name__}")
        tags = [t for t in _TAGS if t in data]
        if len(tags) != 1:
            raise self.error(
                where, f"a JSON object must carry exactly one of the tags {_TAGS}; got keys {sorted(data)[:8]}"
            )
        tag = tags[0]
        if tag == "$float":
            self._keys(data, {"$float"}, where)
            text = data["$float"]
            if text not in ("inf", "-inf", "nan"):
                raise self.error(where, f"$float must be 'inf', '-inf' or 'nan'; got {text!r}")
            return float(text)
        if tag == "$complex":
            self._keys(data, {"$complex"}, where)
            parts = data["$complex"]
            if not (isinstance(parts, list) and len(parts) == 2):
                raise self.error(where, "$complex must be [real, imag]")
            re_, im_ = (self.decode(p, where) for p in parts)
            if not all(isinstance(p, float) or (isinstance(p, int) and not isinstance(p, bool)) for p in (re_, im_)):
                raise self.error(where, "$complex parts must be numbers")
            return complex(re_, im_)
        if tag == "$tuple":
            self._keys(data, {"$tuple"}, where)
            if not isinstance(data["$tuple"], list):
                raise self.error(where, "$tuple must hold a list")
            return tuple(self.decode(v, f"{where}[{k}]") for k, v in enumerate(data["$tuple"]))
        if tag == "$dict":
            self._keys(data, {"$dict"}, where)
            items = data["$dict"]
            if not isinstance(items, list) or not all(isinstance(p, list) and len(p) == 2 for p in items):
                raise self.error(where, "$dict must hold a list of [key, value] pairs")
            out = {}
            for k, v in items:
                key = self.decode(k, f"{where} key")
                try:
                    hash(key)
                except TypeError:
                    raise self.error(where, f"dict key of type {type(key).__name__} is not hashable") from None
                out[key] = self.decode(v, f"{where}[{key!r}]")
            return out
        if tag == "$array":
            self._keys(data, {"$array"}, where)
            key = data["$array"]
            if not isinstance(key, str) or key not in self.arrays:
                raise self.error(where, f"refers to array {key!r}, which the npz file does not hold")
            return self.arrays[key]
        if tag == "$ndarray":
            return self._inline_array(data, where)
        if tag == "$scalar":
            self._keys(data, {"$scalar", "value"}, where)
            name = data["$scalar"]
            if name not in _SCALAR_DTYPES:
                raise self.error(where, f"numpy scalar dtype must be one of {_SCALAR_DTYPES}; got {name!r}")
            value = self.decode(data["value"], where)
            if isinstance(value, (list, tuple, dict, str)) or value is None or isinstance(value, np.ndarray):
                raise self.error(where, f"numpy scalar value must be a number; got {type(value).__name__}")
            try:
                return np.dtype(name).type(value)
            except (TypeError, ValueError, OverflowError) as err:
                raise self.error(where, f"invalid {name} value {value!r}: {err}") from None
        if tag == "$ref":
            self._keys(data, {"$ref"}, where)
            ref = data["$ref"]
            if isinstance(ref, bool) or not isinstance(ref, int) or ref not in self.objects:
                raise self.error(where, f"refers to object {ref!r}, which is not defined before this point")
            return self.objects[ref]
        return self._object(data, where)

    def _inline_array(self, data: dict, where: str) -> np.ndarray:
        """An array written in place: a known dtype, a shape, and nested lists of exactly that shape."""
        if set(data) != {"$ndarray", "shape", "values", "id"}:
            self._keys(data, {"$ndarray", "shape", "values"}, where)
        oid = data.get("id")
        if oid is not None and (isinstance(oid, bool) or not isinstance(oid, int) or oid in self.objects):
            raise self.error(where, f"$ndarray id must be a new integer; got {oid!r}")
        name, shape = data["$ndarray"], data["shape"]
        unicode = _INLINE_UNICODE.match(name) if isinstance(name, str) else None
        if not (name in _INLINE_DTYPES or unicode):
            raise self.error(where, f"$ndarray dtype must be one of {_INLINE_DTYPES} or U<n>; got {name!r}")
        if not (
            isinstance(shape, list)
            and len(shape) <= _MAX_INLINE_NDIM
            and all(isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in shape)
        ):
            raise self.error(
                where, f"$ndarray shape must be a list of at most {_MAX_INLINE_NDIM} sizes >= 0; got {shape!r}"
            )
        dtype = np.dtype(name)
        kind = dtype.kind

        def leaf(v: Any) -> Any:
            if kind == "b":
                ok = isinstance(v, bool)
            elif kind in "iu":
                ok = isinstance(v, int) and not isinstance(v, bool)
            elif kind == "f":
                if isinstance(v, dict):
                    if set(v) != {"$float"} or v["$float"] not in ("inf", "-inf", "nan"):
                        raise self.error(where, f"$ndarray element {v!r} is not a number or a $float")
                    return float(v["$float"])
                ok = isinstance(v, (int, float)) and not isinstance(v, bool)
            else:
                ok = isinstance(v, str)
            if not ok:
                raise self.error(where, f"$ndarray of dtype {name} holds the element {v!r}")
            return v

        def walk(v: Any, depth: int) -> Any:
            if depth == len(shape):
                return leaf(v)
            if not (isinstance(v, list) and len(v) == shape[depth]):
                raise self.error(where, f"$ndarray values do not have the shape {shape}")
            return [walk(x, depth + 1) for x in v]

        values = walk(data["values"], 0)
        try:
            arr = np.array(values, dtype=dtype)
            if arr.size == 0:
                arr = arr.reshape(shape)
        except (ValueError, OverflowError) as err:
            raise self.error(where, f"$ndarray values do not fit dtype {name}: {err}") from None
        if list(arr.shape) != shape:
            raise self.error(where, f"$ndarray values have shape {list(arr.shape)}, not {shape}")
        if oid is not None:
            self.objects[oid] = arr  # referred to by a later {"$ref": id}: one array, shared
        return arr

    def _keys(self, data: dict, expected: set[str], where: str) -> None:
        if set(data) != expected:
            raise self.error(where, f"expected the keys {sorted(expected)}; got {sorted(data)}")

    def _object(self, data: dict, where: str) -> Any:
        self._keys(data, {"$object", "id", "params", "state"}, where)
        name = data["$object"]
        if not isinstance(name, str) or name not in REGISTRY:
            raise self.error(
                where,
                f"class {name!r} is not allowed in model files (allowed: {', '.join(REGISTRY)}); "
                "the file was not written by pcs_sindy.io.model_files.save or was altered",
            )
        spec = REGISTRY[name]
        label = f"{where}<{name}>" if where else name
        cls = _resolve(name)
        oid = data["id"]
        if isinstance(oid, bool) or not isinstance(oid, int) or oid in self.objects:
            raise self.error(label, f"object id must be a new integer; got {oid!r}")
        params, state = data["params"], data["state"]
        if not isinstance(params, dict) or not isinstance(state, dict):
            raise self.error(label, "params and state must be JSON objects")
        allowed = self._param_names(cls, spec)
        unknown = sorted(k for k in params if k not in allowed)
        if unknown:
            raise self.error(label, f"unknown constructor parameter(s) {unknown}; {name} takes {sorted(allowed)}")
        kwargs = {k: self.decode(v, f"{label}.{k}") for k, v in params.items()}
        self._check_kinds(cls, kwargs, label)
        self._check_bounds(name, kwargs, label)
        if "cache_dir" in allowed:
            kwargs["cache_dir"] = self._cache_dir(kwargs.get("cache_dir"), label)
        if spec.kind == "init" and set(kwargs) != set(spec.fields):
            raise self.error(label, f"needs exactly the fields {list(spec.fields)}; got {sorted(kwargs)}")
        try:
            obj = cls(**kwargs)
            if name in _PIPELINES:
                _check_pipeline(obj)
            elif hasattr(cls, "_parameter_constraints"):
                validate_parameters(obj)
        except (
            ValueError,
            TypeError,
            ArithmeticError,
            KeyError,
            IndexError,
            AttributeError,
            OSError,
            MemoryError,
            RecursionError,
        ) as err:
            raise self.error(label, f"invalid parameters: {type(err).__name__}: {err}") from None
        if state and (spec.kind != "estimator" or spec.params_only):
            raise self.error(label, f"{name} has no learned state in model files; got {sorted(state)}")
        fresh_public = {k for k in vars(obj) if not k.startswith("_")}
        for key, raw in state.items():
            if not isinstance(key, str) or not (_STATE_NAME.match(key) or (key in fresh_public and key not in allowed)):
                raise self.error(label, f"attribute {key!r} is not a learned attribute of {name}")
            static = inspect.getattr_static(cls, key, None)
            if key in spec.skip_state or callable(static) or hasattr(static, "__set__") or hasattr(static, "__get__"):
                raise self.error(
                    label, f"attribute {key!r} cannot be set on {name} (a method, property or skipped attribute)"
                )
            value = self.decode(raw, f"{label}.{key}")
            try:
                setattr(obj, key, value)
            except (AttributeError, TypeError, ValueError) as err:
                raise self.error(label, f"cannot set {key}: {err}") from None
        check = _CONSISTENCY.get(name)
        if check is not None:

            def fail(msg: str) -> None:
                raise self.error(label, f"inconsistent file: {msg}")

            try:
                check(obj, fail)
            except ValueError:
                raise
            except (TypeError, ArithmeticError, KeyError, IndexError, AttributeError, MemoryError) as err:
                raise self.error(label, f"inconsistent file: {type(err).__name__}: {err}") from None
        self.objects[oid] = obj
        return obj

    def _check_bounds(self, name: str, kwargs: dict[str, Any], label: str) -> None:
        """Integer parameters in :data:`PARAMETER_RANGES`, no paths, at most :data:`MAX_SEGMENTS` segments."""
        for key, (lo, hi) in PARAMETER_RANGES.get(name, {}).items():
            value = kwargs.get(key)
            if _integer(value) and not lo <= value <= hi:
                raise self.error(label, f"parameter {key} = {value!r} is outside its range [{lo}, {hi}] in model files")
        for key, allowed in _NO_PATHS.get(name, {}).items():
            value = kwargs.get(key)
            if isinstance(value, (str, os.PathLike)) and value not in allowed:
                raise self.error(
                    label,
                    f"parameter {key} = {str(value)!r} is a path; model files store it by value (save the object "
                    f"with the loaded {key}, e.g. a Camera), never a path to read",
                )
        lengths = kwargs.get("segment_lengths")
        if isinstance(lengths, (tuple, list, np.ndarray)) and np.size(lengths) > MAX_SEGMENTS:
            raise self.error(label, f"{np.size(lengths)} segments (model files hold at most {MAX_SEGMENTS})")

    def _check_kinds(self, cls: type, kwargs: dict[str, Any], label: str) -> None:
        """Numbers where the constructor's default is a number, booleans where it is a boolean.

        The classes' own checks run later but may fail with messages that do
        not name the parameter (``int('x')``); this names it.
        """
        try:
            defaults = {
                p.name: p.default for p in inspect.signature(cls).parameters.values() if p.default is not p.empty
            }
        except (TypeError, ValueError):
            return
        for key, value in kwargs.items():
            default = defaults.get(key)
            if value is None:
                continue  # an optional value (e.g. a camera's open base frame): the class's own checks decide
            if isinstance(default, bool):
                if not isinstance(value, (bool, np.bool_)):
                    raise self.error(label, f"parameter {key} must be a boolean like its default; got {value!r}")
            elif isinstance(default, (int, float)):
                number = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
                    value, (bool, np.bool_)
                )
                # several numeric parameters also take one value per segment
                if not (number or isinstance(value, (list, tuple, np.ndarray))):
                    raise self.error(
                        label, f"parameter {key} must be a number like its default {default!r}; got {value!r}"
                    )

    @staticmethod
    def _param_names(cls: type, spec: ClassSpec) -> set[str]:
        if spec.kind == "dataclass":
            return {f.name for f in dataclasses.fields(cls) if f.init}
        if spec.kind == "init":
            return set(spec.fields)
        return set(cls._get_param_names())

    def _cache_dir(self, stored: Any, label: str) -> Any:
        if self.cache_dir is not _UNSET:
            return self.cache_dir
        if stored is None or stored is False:
            return stored
        raise self.error(
            label,
            f"the file sets cache_dir={stored!r}; a derivation cache holds generated code that the library "
            "executes, so a model file may not choose it. Pass load(..., cache_dir=None) for your default "
            "cache, or a directory you trust",
        )


# --------------------------------------------------------------------------
# Paths and files
# --------------------------------------------------------------------------
def _paths(path: str | os.PathLike) -> tuple[Path, Path]:
    if isinstance(path, bytes) or not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a str or path-like; got {type(path).__name__}")
    p = Path(path)
    if p.name in ("", ".", ".."):
        raise ValueError(f"path must name a file; got {str(path)!r}")
    if p.suffix in (".json", ".npz"):
        stem = p.with_suffix("")
    else:
        stem = p
    return stem.with_name(stem.name + ".json"), stem.with_name(stem.name + ".npz")


def _package_version() -> str:
    return __version__


def save(obj: Any, path: str | os.PathLike, *, into: FileSet | None = None) -> Path:
    """Write a fitted estimator (or pipeline) to ``path`` as JSON plus ``.npz``.

    Parameters
    ----------
    obj : object
        An instance of a registered class (:data:`REGISTRY`): ``KinematicFusion``,
        ``EulerLagrangeRegressor``, ``MarkerPoseExtractor`` (parameters only),
        the libraries and optimizer, ``Camera``, ``PlanarPCS``, trajectories, the spatial (3-D)
        ``SpatialPCS``, ``SpatialStrainTrajectory``, ``SpatialPhysicalPCSLibrary`` and
        ``SpatialPCSModel``, every actuation kind, an sklearn ``Pipeline`` / ``PCSPipeline`` of
        such steps; fitted or not.
    path : str or path-like
        ``model``, ``model.json`` or ``model.npz``: writes ``model.json`` and
        ``model.npz`` side by side (replacing existing files).
    into : FileSet, optional
        A :class:`~pcs_sindy.core.atomic.FileSet` the pair joins (written when the set
        commits, with the other files of the set); default: the pair is its own set.

    The pair is written atomically as a set: a failure (disk full, ``ulimit -f``) or a
    crash leaves the previous pair loadable, never a new ``.npz`` beside an old JSON.

    Returns
    -------
    pathlib.Path
        The JSON file (pass it, or the stem, to :func:`load`).

    Raises
    ------
    ValueError
        If ``obj`` or one of its parameters or learned attributes has a type
        that model files cannot hold; the message names the attribute.
    OSError
        If the files cannot be written.
    """
    json_path, npz_path = _paths(path)
    if _name_of(obj) is None:
        raise ValueError(
            f"obj must be an instance of a class in pcs_sindy.io.model_files.REGISTRY ({', '.join(REGISTRY)}); "
            f"got {type(obj).__module__}.{type(obj).__qualname__}"
        )
    enc = _Encoder()
    root = enc.encode(obj, "")
    if enc.repeated:  # again, with ids on the arrays met twice (written once, shared when loaded)
        enc = _Encoder(shared=frozenset(enc.repeated))
        root = enc.encode(obj, "")
    summary = _summary(obj, root["$object"])
    buf = io.BytesIO()
    np.savez(buf, **enc.arrays)
    npz_bytes = buf.getvalue()
    doc = {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "package_version": _package_version(),
        "class": root["$object"],
        **({"summary": summary} if summary is not None else {}),
        "arrays": {
            "sha256": hashlib.sha256(npz_bytes).hexdigest(),
            "entries": {k: {"dtype": a.dtype.str, "shape": list(a.shape)} for k, a in enc.arrays.items()},
        },
        "object": root,
    }
    text = json.dumps(doc, indent=1, allow_nan=False, ensure_ascii=False)
    text = _QUANTITY.sub(_one_line_quantity, _FLAT_LIST.sub(_one_line, text)) + "\n"
    if not json_path.parent.is_dir():
        raise OSError(f"cannot save to path={str(path)!r}: directory {str(json_path.parent)!r} does not exist")
    # npz first: the JSON, written last, names the npz content it belongs to (sha256)
    if into is not None:
        into.write_bytes(npz_path, npz_bytes)
        into.write_bytes(json_path, text.encode("utf-8"))
        return json_path
    with FileSet() as pair:
        pair.write_bytes(npz_path, npz_bytes)
        pair.write_bytes(json_path, text.encode("utf-8"))
    return json_path


# a JSON list of numbers, booleans, nulls or strings spread over lines by indent=1 (strings never hold
# raw newlines): written on one line
_FLAT_ITEM = r'(?:-?[0-9][0-9.eE+-]*|true|false|null|"(?:[^"\\\n]|\\.)*")'
_FLAT_LIST = re.compile(r"\[\n\s*((?:" + _FLAT_ITEM + r",\n\s*)*" + _FLAT_ITEM + r")\n\s*\]")


# a summary's {"value": ..., "unit": ...} once its value list is on one line
_QUANTITY = re.compile(
    r'\{\n\s*("value": (?:' + _FLAT_ITEM + r'|\[[^\n\[\]]*\]),\n\s*"unit": (?:null|"[^"\\\n]*"))\n\s*\}'
)


def _one_line(match: re.Match) -> str:
    line = "[" + re.sub(r",\n\s*", ", ", match.group(1)) + "]"
    if len(line) > 120 and '"' in line:
        return match.group(0)  # long text (the equations) stays one string per line
    return line


def _one_line_quantity(match: re.Match) -> str:
    return "{" + re.sub(r",\n\s*", ", ", match.group(1)) + "}"


def _reject_constant(name: str) -> Any:
    raise ValueError(f"non-standard JSON constant {name}")


def _read_regular(path: Path, limit: int, source: str, what: str) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes, read without blocking on a FIFO or device.

    A symbolic link is followed only to a file in the same folder (or below it).
    """
    if path.is_symlink():
        target = Path(os.path.realpath(path))
        folder = Path(os.path.realpath(path.parent))
        if folder != target.parent and folder not in target.parents:
            raise ValueError(
                f"model file {source}: {what} {str(path)!r} is a symbolic link out of its folder (to "
                f"{str(target)!r}); copy the file instead"
            )
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        raise OSError(f"model file {source}: {what} {str(path)!r} is missing (does not exist)") from None
    except IsADirectoryError:
        raise OSError(f"model file {source}: {what} {str(path)!r} is a directory") from None
    except OSError as err:
        raise OSError(f"model file {source}: cannot read {what} {str(path)!r}: {err.strerror or err}") from None
    with os.fdopen(fd, "rb") as fh:
        info = os.fstat(fh.fileno())
        if not stat.S_ISREG(info.st_mode):
            raise ValueError(
                f"model file {source}: {what} {str(path)!r} is not a regular file (a device, FIFO or socket); "
                "model files are plain files"
            )
        if info.st_size > limit:
            raise ValueError(f"model file {source}: {what} {str(path)!r} is {info.st_size} bytes (at most {limit})")
        data = fh.read(limit + 1)
    if len(data) > limit:
        raise ValueError(f"model file {source}: {what} {str(path)!r} is over {limit} bytes")
    return data


def load(path: str | os.PathLike, *, cache_dir: Any = _UNSET) -> Any:
    """Read an object written by :func:`save`.

    Parameters
    ----------
    path : str or path-like
        ``model``, ``model.json`` or ``model.npz``.
    cache_dir : path, None or False, optional
        Derivation cache for the symbolic libraries of the model (sets the
        ``cache_dir`` parameter of every object that has one).  By default the
        stored value is kept if it is None (your default cache) or False (no
        cache); a file storing a directory is refused, because the cache holds
        generated code that is executed and a model file must not choose it.

    Returns
    -------
    object
        The saved object, with its parameters and learned attributes.

    Raises
    ------
    OSError
        If a file is missing or unreadable.
    ValueError
        If the files are not a pcs_sindy model of a supported format version,
        are inconsistent, name a class outside :data:`REGISTRY`, hold object
        (pickled) arrays, or hold invalid parameters.
    """
    json_path, npz_path = _paths(path)
    source = repr(str(json_path))
    recover(json_path.parent)  # finish a save a crash interrupted (the pair is then the new one)
    raw = _read_regular(json_path, _MAX_JSON_BYTES, source, "the JSON file")
    try:
        doc = json.loads(raw.decode("utf-8"), parse_constant=_reject_constant)
    except (UnicodeDecodeError, ValueError, RecursionError) as err:
        raise ValueError(f"model file {source} is not valid JSON (truncated or corrupt?): {err}") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT_NAME:
        got = doc.get("format") if isinstance(doc, dict) else type(doc).__name__
        raise ValueError(f"model file {source} is not a {FORMAT_NAME} file (format {got!r})")
    version = doc.get("format_version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise ValueError(f"model file {source} has an invalid format_version {version!r}")
    if version > FORMAT_VERSION:
        raise ValueError(
            f"model file {source} has format_version {version}, written by a newer pcs_sindy "
            f"({doc.get('package_version')!r}); this version ({_package_version()}) reads format versions up to "
            f"{FORMAT_VERSION}"
        )
    missing = [k for k in ("class", "arrays", "object") if k not in doc]
    if missing:
        raise ValueError(f"model file {source} lacks {missing}")
    meta = doc["arrays"]
    if (
        not isinstance(meta, dict)
        or not isinstance(meta.get("entries"), dict)
        or not isinstance(meta.get("sha256"), str)
    ):
        raise ValueError(f"model file {source}: 'arrays' must hold 'sha256' and 'entries'")
    data = _read_regular(npz_path, _MAX_NPZ_BYTES, source, "its array file")
    if hashlib.sha256(data).hexdigest() != meta["sha256"]:
        raise ValueError(
            f"model file {source}: {str(npz_path)!r} does not belong to it (sha256 mismatch; "
            "the npz was replaced or the pair was saved separately)"
        )
    arrays = _parse_npz(data, meta["entries"], source)
    root = doc["object"]
    if not isinstance(root, dict) or root.get("$object") != doc["class"]:
        raise ValueError(f"model file {source}: 'object' must be the stored {doc['class']!r} object")
    try:
        return _Decoder(arrays, source, cache_dir).decode(root, "")
    except RecursionError:
        raise ValueError(f"model file {source} is nested too deeply") from None
    except (TypeError, KeyError, IndexError, AttributeError, ArithmeticError, MemoryError) as err:
        raise ValueError(f"model file {source} is invalid: {type(err).__name__}: {err}") from None


def _parse_npz(data: bytes, entries: dict, source: str) -> dict[str, np.ndarray]:
    try:
        npz = np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, OSError, EOFError) as err:
        raise ValueError(f"model file {source}: the array file is not a valid npz archive: {err}") from None
    if not isinstance(npz, np.lib.npyio.NpzFile):
        raise ValueError(f"model file {source}: the array file is not an npz archive")
    arrays = {}
    with npz:
        unpacked = sum(info.file_size for info in npz.zip.infolist())
        if unpacked > _MAX_ARRAY_BYTES:
            raise ValueError(f"model file {source}: the npz unpacks to {unpacked} bytes (at most {_MAX_ARRAY_BYTES})")
        check_npz_headers(npz, f"model file {source}", limit=_MAX_ARRAY_BYTES)
        if sorted(npz.files) != sorted(entries):
            raise ValueError(
                f"model file {source}: the npz holds arrays {sorted(npz.files)[:10]}, "
                f"the JSON lists {sorted(entries)[:10]}"
            )
        for key, info in entries.items():
            try:
                arr = npz[key]
            except (ValueError, OSError, EOFError) as err:  # object arrays need pickle, which we never allow
                raise ValueError(f"model file {source}: array {key!r} cannot be read safely: {err}") from None
            if arr.dtype.kind not in _ALLOWED_DTYPE_KINDS or arr.dtype.fields is not None:
                raise ValueError(f"model file {source}: array {key!r} has unsupported dtype {arr.dtype}")
            if not isinstance(info, dict) or info.get("dtype") != arr.dtype.str or info.get("shape") != list(arr.shape):
                raise ValueError(
                    f"model file {source}: array {key!r} is {arr.dtype.str} {list(arr.shape)}, the JSON says {info!r}"
                )
            arrays[key] = arr
    return arrays
