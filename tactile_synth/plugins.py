"""One loader for every kind of plug-in: methods, protocols and stress families.

A plug-in is named in one of three ways, whatever its kind:

- a built-in name (each kind's own table of ``"module:Class"`` specs);
- the name of an entry point that an installed distribution declares in the kind's group
  (``[project.entry-points."tactile_synth.methods"]`` in its ``pyproject.toml``, value
  ``"module:Class"``); a built-in name always wins;
- ``"module:Class"`` (an importable module, looked up from the current directory too,
  after the installed ones) or ``"path/to/file.py:Class"``; ``Class`` may be a dotted
  attribute path (``module:Outer.Inner``).

:func:`resolve` returns the class behind a name, checked to be a complete subclass of the
kind's base class with a string ``name`` attribute; every failure is one ``ValueError``
naming the argument as the user gave it. Modules are imported on first use, so that
importing a package that lists plug-ins stays cheap.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import inspect
import os
import sys
import zlib
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType

from .validation import check_choice


def entry_points(group: str, builtins: Mapping[str, str] = {}) -> dict[str, str]:
    """Entry-point name -> ``"module:Class"`` of every installed plug-in of ``group``
    (names of built-ins are left out: the built-in wins)."""
    eps = importlib.metadata.entry_points(group=group)
    return {ep.name: ep.value for ep in eps if ep.name not in builtins}


def one_line(exc: BaseException) -> str:
    """``"TypeName: message"`` of an exception on one line (messages from user code may
    hold newlines)."""
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _try_import(who: str, module: str) -> ModuleType | None:
    """The imported module, or None if it does not exist (a failure inside it raises)."""
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name is not None and (module == exc.name or module.startswith(exc.name + ".")):
            return None
        raise ValueError(f"{who}: importing {module} failed: {one_line(exc)}") from exc
    except ImportError as exc:
        raise ValueError(f"{who}: importing {module} failed: {one_line(exc)}") from exc


def _import_file(who: str, path: Path, prefix: str) -> ModuleType:
    if not path.is_file():
        raise ValueError(f"{who}: file {path} does not exist")
    resolved = str(path.resolve())
    name = f"_tactile_synth_{prefix}_{path.stem}_{zlib.crc32(resolved.encode()):08x}"
    if name in sys.modules:
        return sys.modules[name]
    loader_spec = importlib.util.spec_from_file_location(name, resolved)
    if loader_spec is None or loader_spec.loader is None:
        raise ValueError(f"{who}: cannot load {path} as a Python module")
    mod = importlib.util.module_from_spec(loader_spec)
    sys.modules[name] = mod  # before executing: dataclasses and typing look it up
    try:
        loader_spec.loader.exec_module(mod)
    except ImportError as exc:
        del sys.modules[name]
        raise ValueError(f"{who}: importing {path} failed: {one_line(exc)}") from exc
    except BaseException:
        del sys.modules[name]
        raise
    return mod


def import_module(
    spec: str,
    module: str,
    arg: str,
    *,
    prefix: str = "plugin",
    search_dir: Path | None = None,
    who: str | None = None,
) -> ModuleType:
    """The module of a ``module:attr`` spec: a ``.py`` file path, or a module importable
    from ``sys.path`` or else from the current directory (as ``python -m`` would find
    it). ``prefix`` names the kind in the private module name a file is loaded under.

    ``search_dir`` replaces the current directory: a relative file path is taken from it,
    and a module not found on ``sys.path`` is looked up there (for that import only).
    Errors are ``ValueError`` starting with ``who`` (default ``"{arg}: {spec!r}"``); an
    exception other than an import error raised while the module runs is passed on."""
    who = who or f"{arg}: {spec!r}"
    if module.endswith(".py"):
        path = Path(module)
        if search_dir is not None and not path.is_absolute():
            path = search_dir / path
        return _import_file(who, path, prefix)
    mod = _try_import(who, module)
    if mod is None and search_dir is not None:
        where = str(Path(search_dir).resolve())
        sys.path.append(where)  # searched last: installed modules win
        try:
            mod = _try_import(who, module)
        finally:
            sys.path.remove(where)
    elif mod is None and os.getcwd() not in sys.path:
        sys.path.append(os.getcwd())  # searched last: installed modules win
        mod = _try_import(who, module)
    if mod is None:
        raise ValueError(f"{who}: no module named {module!r}")
    return mod


def load_attribute(spec: str, arg: str, *, example: str, prefix: str = "plugin") -> object:
    """The object behind ``"module:attr"`` (``attr`` may be dotted); ``ValueError`` naming
    ``arg`` when the spec is malformed or the module or attribute is missing. ``example``
    shows a well-formed spec in the error."""
    module, sep, attr = spec.rpartition(":")
    if not sep or not module or not attr or not attr.replace(".", "_").isidentifier():
        raise ValueError(f"{arg}: {spec!r} is not module:Class (e.g. {example})")
    obj: object = import_module(spec, module, arg, prefix=prefix)
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise ValueError(f"{arg}: {spec!r}: {module} has no attribute {attr!r}")
        obj = getattr(obj, part)
    return obj


def load_class(spec: str, arg: str, *, base: type, kind: str, doc: str, example: str) -> type:
    """The class behind ``"module:Class"``, checked to be a complete ``base`` subclass
    with a string ``name`` attribute. ``kind`` names the plug-in kind (``"method"``) and
    ``doc`` the page that documents it, in the errors."""
    obj = load_attribute(spec, arg, example=example, prefix=kind.replace(" ", "_"))
    if not (inspect.isclass(obj) and issubclass(obj, base)):
        raise ValueError(
            f"{arg}: {spec!r} is not a {base.__name__} subclass (see {doc}); got {obj!r}"
        )
    if inspect.isabstract(obj):
        missing = ", ".join(sorted(obj.__abstractmethods__))
        raise ValueError(f"{arg}: {spec!r} does not implement {missing}")
    if not isinstance(getattr(obj, "name", None), str):
        raise ValueError(f"{arg}: {spec!r} must set the class attribute name (a string)")
    return obj


def resolve(
    name: object,
    *,
    builtins: Mapping[str, str],
    group: str,
    base: type,
    kind: str,
    doc: str,
    example: str,
    arg: str,
) -> type:
    """The class of the plug-in ``name`` of one kind: a built-in name (``builtins``:
    name -> ``"module:Class"``), an entry-point name of ``group``, or ``module:Class``;
    ``ValueError`` naming ``arg`` (with the valid names, and a close match, for an
    unknown name)."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"{arg} must be a {kind} name or module:Class; got {name!r}")
    if name in builtins:
        module, cls = builtins[name].split(":")
        return getattr(importlib.import_module(module), cls)
    plugins = entry_points(group, builtins)
    checks = {"base": base, "kind": kind, "doc": doc, "example": example}
    if name in plugins:
        return load_class(
            plugins[name], f"{arg} {name!r} (entry point {plugins[name]!r})", **checks
        )
    if ":" in name:
        return load_class(name, arg, **checks)
    check_choice(arg, name, (*builtins, *sorted(plugins)))  # raises, with a close match
    raise AssertionError("unreachable")
