"""Defaults of the stages, read from their source code without importing them.

The estimators' constructors (and the functions the commands call) are the one place their
defaults are written, and ``pcs-sindy --help`` shows them.  Importing an estimator to read one
would load numpy, scipy, scikit-learn, OpenCV and numba, over a second before any help is
printed; so the help reads the value where it is written instead, with :mod:`ast`: a parameter
default, a class attribute (dataclass fields included) or a module constant, written as a
literal.  ``tests/test_cli.py`` checks every value read here against the imported code.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path
from typing import Any

__all__ = ["read_default", "read_options"]

#: the folder of the ``pcs_sindy`` package, whose source files are read
PACKAGE_DIR = Path(__file__).resolve().parents[1]


@functools.cache
def _module_tree(module: str) -> ast.Module:
    """The parsed source of ``pcs_sindy.<module>`` (each file is parsed once per process)."""
    path = PACKAGE_DIR.joinpath(*module.split("."))
    path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
    try:
        source = path.read_text(encoding="utf-8")
    except OSError as err:
        raise LookupError(f"module 'pcs_sindy.{module}': cannot read its source {str(path)!r} ({err})") from None
    return ast.parse(source, filename=str(path))


def _binding(body: list[ast.stmt], name: str) -> ast.expr | ast.FunctionDef | ast.ClassDef | None:
    """What ``name`` is bound to in a module or class body: an assigned value, a function or a class.

    The last binding wins, as when the body runs.
    """
    found: ast.expr | ast.FunctionDef | ast.ClassDef | None = None
    for stmt in body:
        if isinstance(stmt, ast.Assign) and any(isinstance(t, ast.Name) and t.id == name for t in stmt.targets):
            found = stmt.value
        elif isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name) and stmt.target.id == name:
            found = stmt.value  # None for an annotation without a value (a dataclass field without default)
        elif isinstance(stmt, (ast.FunctionDef, ast.ClassDef)) and stmt.name == name:
            found = stmt
    return found


def _parameter(func: ast.FunctionDef, name: str, where: str) -> ast.expr:
    """The default expression of parameter ``name`` of ``func``."""
    args = func.args
    positional = [*args.posonlyargs, *args.args]
    pairs = list(zip(positional[len(positional) - len(args.defaults) :], args.defaults))
    pairs += [(a, d) for a, d in zip(args.kwonlyargs, args.kw_defaults) if d is not None]
    for arg, default in pairs:
        if arg.arg == name:
            return default
    if any(a.arg == name for a in [*positional, *args.kwonlyargs]):
        raise LookupError(f"{where}: parameter {name!r} of {func.name}() has no default")
    raise LookupError(f"{where}: {func.name}() has no parameter {name!r}")


def read_default(where: str) -> Any:
    """The value written in the package's source at ``where``, read without importing the module.

    Parameters
    ----------
    where : str
        ``"module:dotted.name"``, ``module`` under ``pcs_sindy`` and ``dotted.name`` one of

        * a module constant: ``"identification.recordings:WEAK_WINDOW"``;
        * a class attribute or dataclass field: ``"models.forward:LumpedPCSModel.default_method"``;
        * a parameter of a class, i.e. of its ``__init__`` when the class has no attribute of
          that name: ``"fusion.kinematic_fusion:KinematicFusion.threshold"``;
        * a parameter of a function or method: ``"simulation.scenarios:Scenario.generate.seed"``.

    Returns
    -------
    object
        The value, evaluated with :func:`ast.literal_eval`.

    Raises
    ------
    LookupError
        If the module's source cannot be read, the name or parameter is not there, or its value
        is not a literal (e.g. a computed expression): the message names ``where`` and what was found.
    """
    module, sep, dotted = where.partition(":")
    if not sep or not module or not dotted:
        raise ValueError(f"where={where!r}: expected 'module:dotted.name', e.g. 'core.camera:Camera.fit_poses'")
    node: ast.AST = _module_tree(module)
    names = dotted.split(".")
    for i, name in enumerate(names):
        last = i == len(names) - 1
        if isinstance(node, ast.FunctionDef):  # after a function, only its parameter can follow
            if not last:
                raise LookupError(f"{where}: {'.'.join(names[: i + 1])} is a parameter, not a namespace")
            node = _parameter(node, name, where)
            break
        assert isinstance(node, (ast.Module, ast.ClassDef))
        found = _binding(node.body, name)
        if found is None and last and isinstance(node, ast.ClassDef):  # a constructor parameter
            init = _binding(node.body, "__init__")
            if isinstance(init, ast.FunctionDef):
                found = _parameter(init, name, where)
        if found is None:
            owner = f"class {node.name}" if isinstance(node, ast.ClassDef) else f"module {module}"
            raise LookupError(f"{where}: {owner} has no {name!r} with a value in its source")
        node = found
    if not isinstance(node, ast.expr):
        kind = "function" if isinstance(node, ast.FunctionDef) else "class"
        raise LookupError(f"{where}: names a {kind}, not a value; name one of its parameters or attributes")
    try:
        return ast.literal_eval(node)
    except (ValueError, TypeError):
        raise LookupError(
            f"{where}: the source holds {ast.unparse(node)!r}, not a literal; write a literal there or stop "
            "showing this default in the help"
        ) from None


def read_options(where: str) -> tuple[Any, ...]:
    """The fixed values (``Options``) that an estimator's ``_parameter_constraints`` accept for a parameter.

    Read from the source like :func:`read_default`: the command line passes words such as
    ``"auto"`` through to the estimator (which validates them) and lists these in its help, so a
    value added to the table reaches the command line without an edit there.

    Parameters
    ----------
    where : str
        ``"module:Class.parameter"``, e.g. ``"vision.extractor:MarkerPoseExtractor.threshold"``.

    Returns
    -------
    tuple
        The values of every ``Options(...)`` of the parameter's entry, in order (empty when it has none).

    Raises
    ------
    LookupError
        If the class, its table or the parameter's entry is not there, or an ``Options`` argument is
        neither a literal nor a module constant holding one.
    """
    module, sep, dotted = where.partition(":")
    owner, _, name = dotted.rpartition(".")
    if not sep or not owner or not name:
        raise ValueError(f"where={where!r}: expected 'module:Class.parameter'")
    tree = _module_tree(module)
    cls = _binding(tree.body, owner)
    if not isinstance(cls, ast.ClassDef):
        raise LookupError(f"{where}: module {module} has no class {owner!r}")
    table = _binding(cls.body, "_parameter_constraints")
    if not isinstance(table, ast.Dict):
        raise LookupError(f"{where}: class {owner} has no _parameter_constraints dict in its source")
    entries = [v for k, v in zip(table.keys, table.values) if isinstance(k, ast.Constant) and k.value == name]
    if not entries:
        raise LookupError(f"{where}: {owner}._parameter_constraints has no entry {name!r}")
    entry = entries[-1]
    values: list[Any] = []
    for item in entry.elts if isinstance(entry, (ast.List, ast.Tuple)) else []:
        if isinstance(item, ast.Call) and isinstance(item.func, ast.Name) and item.func.id == "Options":
            arg = item.args[0]
            if isinstance(arg, ast.Name):  # a module constant
                bound = _binding(tree.body, arg.id)
                if not isinstance(bound, ast.expr):
                    raise LookupError(f"{where}: Options({arg.id}) but {arg.id} is not a module constant")
                arg = bound
            try:
                values.extend(ast.literal_eval(arg))
            except (ValueError, TypeError):
                raise LookupError(f"{where}: Options({ast.unparse(arg)}) is not a literal") from None
    return tuple(values)
