"""Generate ``docs/api.md``, the API reference, from the package's layout and docstrings.

Run ``.venv/bin/python docs/build_api.py`` (or ``make docs``) after changing a
public docstring; ``tests/test_docs.py`` checks that the committed file is up
to date.  Plain ``inspect`` instead of Sphinx: the reference is a single
Markdown page readable on GitHub, and no extra dependency is needed.
"""

from __future__ import annotations

import importlib
import inspect
import sys
from pathlib import Path

#: the stage packages in pipeline order, then the packages beside them; each section lists
#: every public name the package exports (its ``__all__``), so the reference follows the layout
STAGES: list[str] = [
    "pcs_sindy.core",
    "pcs_sindy.vision",
    "pcs_sindy.fusion",
    "pcs_sindy.identification",
    "pcs_sindy.models",
    "pcs_sindy.control",
    "pcs_sindy.pipeline",
    "pcs_sindy.simulation",
    "pcs_sindy.io",
    "pcs_sindy.plotting",
]


def sections() -> list[tuple[str, str, list[str]]]:
    """(title, package, names) of every stage: the names are the package's exports that are not modules."""
    out = []
    for package in STAGES:
        module = importlib.import_module(package)
        names = [n for n in module.__all__ if not inspect.ismodule(getattr(module, n))]
        title = (inspect.getdoc(module) or package).splitlines()[0].rstrip(".")
        out.append((title, package, names))
    return out


def _signature(obj: object, name: str) -> str:
    try:
        sig = str(inspect.signature(obj))
    except (TypeError, ValueError):
        sig = "(...)"
    return f"{name}{sig}"


_ENTRY_SECTIONS = {"Parameters", "Returns", "Yields", "Raises", "Attributes", "Other Parameters", "Warns"}


def _doc(obj: object) -> str:
    """The docstring with numpydoc section underlines turned into bold headings.

    Markdown would read ``Parameters`` over a line of dashes as a heading of the
    page outline; bold text keeps the outline to the API names.
    """
    lines = (inspect.getdoc(obj) or "(no docstring)").strip().splitlines()
    out: list[str] = []
    in_list = False  # inside a numpydoc section of "name : type" entries
    k = 0
    while k < len(lines):
        line = lines[k]
        underline = lines[k + 1].strip() if k + 1 < len(lines) else ""
        if line.strip() and underline and set(underline) == {"-"} and len(underline) >= len(line.strip()) - 1:
            out += [f"**{line.strip()}**", ""]
            in_list = line.strip() in _ENTRY_SECTIONS
            k += 2
            continue
        if in_list and line and not line[0].isspace():
            name, _, kind = line.partition(" : ")
            line = f"- **{name.strip()}**" + (f" : {kind.strip()}" if kind else "")
        out.append(line)
        k += 1
    return "\n".join(out)


def _public_methods(cls: type) -> list[tuple[str, object]]:
    """The class's own documented methods, then those it inherits from the package's private modules."""
    out = []
    # A base class in a private module (e.g. simulation/_robot_base.py) is no page of its own: its
    # methods are documented on the public classes that inherit them.
    hidden = [base for base in cls.__mro__[1:] if base.__module__.startswith("pcs_sindy.") and "._" in base.__module__]
    seen = set(vars(cls))
    members = list(vars(cls).items())
    for base in hidden:
        members += [(name, member) for name, member in vars(base).items() if name not in seen]
        seen.update(vars(base))
    for name, member in members:
        if name.startswith("_") or not (inspect.isfunction(member) or isinstance(member, (classmethod, staticmethod))):
            continue
        func = member.__func__ if isinstance(member, (classmethod, staticmethod)) else member
        if func.__doc__:
            out.append((name, func))
    return out


def render() -> str:
    """The Markdown text of the API reference."""
    lines = [
        "# API reference",
        "",
        "Generated from the docstrings by `docs/build_api.py`; do not edit by hand.",
        "",
    ]
    for title, module_name, names in sections():
        module = importlib.import_module(module_name)
        intro = (inspect.getdoc(module) or "").split("\n", 1)[1:]
        lines += [f"## `{module_name}`: {title}", ""]
        if intro and intro[0].strip():
            lines += [intro[0].strip(), ""]
        for name in names:
            obj = getattr(module, name)
            kind = "class" if inspect.isclass(obj) else "function"
            lines += [f"### `{name}`", "", "```python", f"{kind} {_signature(obj, name)}", "```", "", _doc(obj), ""]
            if inspect.isclass(obj):
                for meth_name, meth in _public_methods(obj):
                    lines += [
                        f"#### `{name}.{meth_name}`",
                        "",
                        "```python",
                        _signature(meth, meth_name),
                        "```",
                        "",
                        _doc(meth),
                        "",
                    ]
    return "\n".join(lines).rstrip() + "\n"


def main() -> int:
    target = Path(__file__).with_name("api.md")
    target.write_text(render(), encoding="utf-8")
    print(f"wrote {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
