"""Check the docstrings and type hints of lieint's public API; exit 1 on any finding.

The public API is every name in ``lieint.__all__`` (for the modules among them, every name in
their ``__all__``), the public methods and properties of the system classes and of
:class:`lieint.Solution`. A method that overrides one of the system contract without a docstring
of its own is checked through the docstring it inherits (what ``help()`` and the API pages show).

Enforced ``numpydoc.validate`` codes (:data:`ENFORCED`), chosen to catch drift between a
docstring and its signature and missing documentation, not the house style of summaries:

* GL06, GL07, GL10 — unknown section, sections out of order, a malformed directive;
* GL08 — no docstring (after inheritance, above);
* SS01 — no summary;
* PR01, PR02, PR03 — a parameter not documented, a documented parameter that does not exist,
  parameters documented in another order than the signature's;
* PR04, PR07, PR10 — a documented parameter without a type, without a description, or without
  the space around its colon;
* RT01, RT03 — a function that returns a value without a Returns section, or without a
  description of the value;
* EX01 — no Examples section, for the objects in :data:`NEEDS_EXAMPLES` (and every system
  class).

Not enforced: GL01/GL02 (where the quotes sit), SS02–SS06 and PR05/PR06/PR08/PR09, RT02/RT04/RT05
(summary and description style: capitals, periods, verb forms), ES01 (extended summary), SA01
(See Also) and EX01 elsewhere.

Type hints (codes of this script): TH01 a parameter without a type hint, TH02 a function without
a return type hint (``__init__`` excepted), for every function, method and property in scope.

Usage: ``python .ci/check_api_docs.py`` (prints each finding as ``name: CODE message``).
"""

from __future__ import annotations

import inspect
import sys
from collections.abc import Iterator

ENFORCED = frozenset(
    {"GL06", "GL07", "GL08", "GL10", "SS01", "PR01", "PR02", "PR03", "PR04", "PR07", "PR10", "RT01", "RT03", "EX01"}
)

#: objects that must show an Examples section (besides every system class)
NEEDS_EXAMPLES = frozenset(
    {
        "lieint.integrate",
        "lieint.run",
        "lieint.sweep",
        "lieint.Solution",
        "lieint.method_names",
        "lieint.get_method",
        "lieint.rotations.to_scipy",
        "lieint.rotations.from_scipy",
        "lieint.rotations.to_quaternion",
        "lieint.rotations.from_quaternion",
        "lieint.rotations.from_solution",
        "lieint.euler_top_flip_times",
    }
)


def public_api() -> Iterator[tuple[str, object, object]]:
    """``(name, object, documented)`` of everything checked, each object once: ``documented`` is
    the definition whose docstring applies (an override without a docstring of its own: the
    definition it overrides), ``object`` the one whose signature is checked."""
    import lieint
    from lieint.systems.base import LieGroupSystem

    seen: set[int] = set()

    def once(name: str, obj: object, documented: object) -> Iterator[tuple[str, object, object]]:
        if id(obj) not in seen:
            seen.add(id(obj))
            yield name, obj, documented

    for name in lieint.__all__:
        obj = getattr(lieint, name)
        if name.startswith("__"):
            continue
        if inspect.ismodule(obj):
            for inner in getattr(obj, "__all__", ()):
                yield from once(f"lieint.{name}.{inner}", getattr(obj, inner), getattr(obj, inner))
            continue
        yield from once(f"lieint.{name}", obj, obj)
        if inspect.isclass(obj) and (issubclass(obj, LieGroupSystem) or obj is lieint.Solution):
            for member, raw, documented in _public_members(obj):
                yield from once(f"lieint.{name}.{member}", raw, documented)


def _public_members(cls: type) -> Iterator[tuple[str, object, object]]:
    """Public methods and properties of ``cls`` defined in lieint: ``(name, definition, the
    definition whose docstring applies)`` (the nearest in the MRO that has one)."""
    for member in sorted(dir(cls)):
        if member.startswith("_"):
            continue
        owners = [c for c in cls.__mro__ if member in c.__dict__]
        if not owners or not owners[0].__module__.startswith("lieint"):
            continue
        raw = owners[0].__dict__[member]
        if not (inspect.isfunction(raw) or isinstance(raw, (property, classmethod, staticmethod))):
            continue  # class attributes (flags, tags) are data, not API functions
        documented = next((c.__dict__[member] for c in owners if _doc_of(c.__dict__[member])), raw)
        yield member, raw, documented


def _doc_of(raw: object) -> str:
    return getattr(_function_of(raw), "__doc__", None) or ""


def _function_of(obj: object):
    """The function whose signature and docstring a (class) attribute stands for."""
    if isinstance(obj, property):
        return obj.fget
    return getattr(obj, "__func__", obj)


def numpydoc_findings(name: str, obj: object, is_system_class: bool) -> list[str]:
    from numpydoc.docscrape import get_doc_object
    from numpydoc.validate import validate

    target = _function_of(obj)
    doc = get_doc_object(target)
    result = validate(doc)
    needs_examples = name in NEEDS_EXAMPLES or is_system_class
    # a dataclass documents its fields (its constructor's parameters) as Attributes
    attributes = _attribute_names(doc) if inspect.isclass(target) else set()
    out = []
    for code, message in result["errors"]:
        if code not in ENFORCED or (code == "EX01" and not needs_examples):
            continue
        if isinstance(obj, property) and code.startswith(("PR", "RT")):
            continue  # a property documents its value in its summary
        if code == "PR01" and attributes:
            missing = _missing_parameters(target, doc) - attributes
            if not missing:
                continue
            message = f"Parameters {sorted(missing)} not documented (as Parameters or Attributes)"
        out.append(f"{name}: {code} {message}")
    return out


def _attribute_names(doc) -> set[str]:
    names = set()
    for item in doc["Attributes"]:
        names.update(part.strip() for part in item.name.split(","))
    return names


def _missing_parameters(cls: type, doc) -> set[str]:
    documented = set()
    for item in doc["Parameters"]:
        documented.update(part.strip().lstrip("*") for part in item.name.split(","))
    try:
        signature = inspect.signature(cls)
    except (TypeError, ValueError):
        return set()
    return {p for p in signature.parameters if p not in documented}


def type_hint_findings(name: str, obj: object) -> list[str]:
    target = _function_of(obj)
    if inspect.isclass(target):
        if issubclass(target, BaseException):
            return []
        init = target.__dict__.get("__init__")
        if init is None or not inspect.isfunction(init):
            return []
        target, label = init, f"{name}.__init__"
    elif not callable(target):
        return []
    else:
        label = name
    try:
        signature = inspect.signature(target)
    except (TypeError, ValueError):
        return []
    out = []
    for i, (pname, param) in enumerate(signature.parameters.items()):
        if i == 0 and pname in ("self", "cls"):
            continue
        if param.annotation is inspect.Parameter.empty:
            out.append(f"{label}: TH01 parameter {pname!r} has no type hint")
    if signature.return_annotation is inspect.Signature.empty and target.__name__ != "__init__":
        out.append(f"{label}: TH02 no return type hint")
    return out


def findings() -> list[str]:
    """Every finding on the public API (empty: the API is documented and annotated)."""
    from lieint.systems.base import LieGroupSystem

    out = []
    for name, obj, documented in public_api():
        system_class = inspect.isclass(obj) and issubclass(obj, LieGroupSystem) and obj is not LieGroupSystem
        out.extend(numpydoc_findings(name, documented, system_class))
        out.extend(type_hint_findings(name, obj))
    return out


def main() -> int:
    found = findings()
    for line in found:
        print(line)
    count = sum(1 for _ in public_api())
    if found:
        print(f"{len(found)} findings on {count} public objects (codes: see .ci/check_api_docs.py)", file=sys.stderr)
        return 1
    print(f"public API: {count} objects documented and annotated (numpydoc codes {', '.join(sorted(ENFORCED))})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
