"""Methods by name: the paper's seven, the variants beyond the paper, methods other
packages install, and any ``FewShotMethod`` subclass named as ``module:Class``.

A method is named in one of three ways (``docs/methods.md``):

- a built-in name: one of :data:`METHOD_NAMES` (AFOP-ML and the six baselines, each as
  the paper ran it) or of :data:`VARIANT_NAMES` (stronger ideas beside them, each with a
  one-line note of what differs from the paper, :data:`VARIANT_NOTES`);
- the name of an entry point in the group :data:`ENTRY_POINT_GROUP` that an installed
  distribution declares (``[project.entry-points."tactile_synth.methods"]`` in its
  ``pyproject.toml``, value ``"module:Class"``); a built-in name always wins;
- ``"module:Class"`` (an importable module, looked up from the current directory too)
  or ``"path/to/file.py:Class"``.

Results carry the name exactly as given. Modules are imported on first use so that
importing ``models`` stays cheap (torch is only loaded by the methods that need it).
"""

from __future__ import annotations

import inspect
import json
from collections.abc import Mapping, Sequence

from tactile_synth import plugins

from .base import FewShotMethod

#: Paper name -> "module:Class". Order is the paper's Table I order.
_METHODS: dict[str, str] = {
    "AFOP-ML": "models.afop:AFOPML",
    "AFO-MLP-ML": "models.afo_mlp:AFOMLPML",
    "Direct-Prot-ML": "models.direct_prot:DirectProtML",
    "MAML": "models.maml:MAML",
    "CWT-ResNet-ML": "models.cwt_resnet:CWTResNetML",
    "CNN": "models.cnn:CNNBaseline",
    "BiLSTM": "models.bilstm:BiLSTMBaseline",
}

#: Variant name -> ("module:Class", what differs from the paper's method, in one line).
_VARIANTS: dict[str, tuple[str, str]] = {
    "AFO-MLP-ML+meta": (
        "models.afo_mlp:AFOMLPMLMeta",
        "AFO-MLP-ML's D -> 64 -> 32 MLP meta-trained on prototypical episodes of the "
        "training classes, then fine-tuned per episode (the paper fits a fresh MLP on each "
        "episode's support set only, with no meta-training)",
    ),
}

#: The paper's seven methods, in Table I's order.
METHOD_NAMES: tuple[str, ...] = tuple(_METHODS)
#: Built-in variants beyond the paper, in the order reports list them.
VARIANT_NAMES: tuple[str, ...] = tuple(_VARIANTS)
#: Variant name -> one line saying what differs from the paper's method.
VARIANT_NOTES: dict[str, str] = {name: note for name, (_, note) in _VARIANTS.items()}
#: What ``run`` and ``benchmark`` evaluate by default: the paper's seven, then the variants.
DEFAULT_METHODS: tuple[str, ...] = (*METHOD_NAMES, *VARIANT_NAMES)
#: Entry-point group through which installed distributions contribute methods.
ENTRY_POINT_GROUP = "tactile_synth.methods"
#: Every built-in name (the paper's, then the variants) -> "module:Class".
_BUILTINS: dict[str, str] = {
    **_METHODS,
    **{name: spec for name, (spec, _) in _VARIANTS.items()},
}


class PluginError(Exception):
    """A plug-in method (or protocol) failed inside its own code: the message names the
    plug-in as it was given and the stage (fit, predict), and the plug-in's exception is
    the cause. A failure of the plug-in's code, not of tactile-synth's."""


def is_builtin(name: str) -> bool:
    """Whether ``name`` is one of tactile-synth's own methods (:data:`METHOD_NAMES` or
    :data:`VARIANT_NAMES`)."""
    return name in _BUILTINS


def is_paper_method(name: str) -> bool:
    """Whether ``name`` is one of the paper's seven methods (:data:`METHOD_NAMES`)."""
    return name in _METHODS


def beyond_the_paper_note(name: str) -> str:
    """One line on what a method beyond the paper is: a variant's note, or that it is a
    method plugged in by the user (a plug-in name or ``module:Class``)."""
    if name in _VARIANTS:
        return VARIANT_NOTES[name]
    return "a method plugged in by name (module:Class or entry point), not in the paper"


def paper_first(names: Sequence[str]) -> tuple[list[str], list[str]]:
    """``(paper, beyond)``: the paper's methods among ``names`` in Table I's order, then
    the others (the variants in :data:`VARIANT_NAMES` order, then plug-ins as given).
    Every table of the report lists the first group, then the second under the heading
    "Beyond the paper"."""
    given = list(dict.fromkeys(names))
    paper = [m for m in METHOD_NAMES if m in given]
    variants = [m for m in VARIANT_NAMES if m in given]
    others = [m for m in given if not is_builtin(m)]
    return paper, [*variants, *others]


def plugin_methods() -> dict[str, str]:
    """Entry-point name -> ``"module:Class"`` of every installed plug-in method (names of
    built-in methods are left out: the built-in wins)."""
    return plugins.entry_points(ENTRY_POINT_GROUP, _BUILTINS)


def available_methods() -> tuple[str, ...]:
    """Built-in names (the paper's, then the variants), then installed plug-in names
    (sorted)."""
    return (*DEFAULT_METHODS, *sorted(plugin_methods()))


def method_class(name: str, *, arg: str = "method") -> type[FewShotMethod]:
    """The class of method ``name`` (a built-in name, a plug-in name or ``module:Class``,
    see :func:`tactile_synth.plugins.resolve`); ``ValueError`` naming ``arg`` when it
    cannot be found or is no complete FewShotMethod.

    Examples
    --------
    >>> method_class("AFOP-ML").__name__
    'AFOPML'
    >>> method_class("examples.nearest_mean:NearestClassMean").name
    'nearest-class-mean'
    """
    return plugins.resolve(
        name,
        builtins=_BUILTINS,
        group=ENTRY_POINT_GROUP,
        base=FewShotMethod,
        kind="method",
        doc="docs/methods.md",
        example="examples.nearest_mean:NearestClassMean",
        arg=arg,
    )


def check_methods(methods: Sequence[str], *, arg: str = "methods") -> tuple[str, ...]:
    """Validate method names (each resolved to its class, so a bad plug-in fails here and
    not mid-run); keep order, drop repeats."""
    if isinstance(methods, str) or not methods:
        raise ValueError(
            f"{arg} must be a non-empty list of method names ({', '.join(available_methods())}) "
            "or module:Class"
        )
    for m in methods:
        method_class(m, arg=arg)
    return tuple(dict.fromkeys(methods))


def make_method(name: str, *, seed: int = 0, **params: object) -> FewShotMethod:
    """A new, unfitted instance of the method ``name`` (see :func:`method_class`)."""
    method = method_class(name)(seed=seed, **params)
    if not isinstance(method, FewShotMethod):  # a __new__ returning something else
        raise ValueError(f"method {name!r} did not construct a FewShotMethod")
    return method


#: A method's constructor options: method name -> {parameter: value}.
MethodOptions = Mapping[str, Mapping[str, object]]


def parse_method_option(text: str, *, arg: str = "--method-option") -> tuple[str, str, object]:
    """``"METHOD:NAME=VALUE"`` -> ``(METHOD, NAME, value)``. METHOD is any method name
    (``module:Class`` specs too: the last ``:`` before the first ``=`` ends it); VALUE is
    read as a JSON literal when it is one (``10``, ``1e-3``, ``true``, ``null``,
    ``"text"``), else kept as text (a path). ValueError naming ``arg`` when malformed."""
    if not isinstance(text, str):
        raise ValueError(f"{arg} must be METHOD:NAME=VALUE; got {text!r}")
    left, eq, raw = text.partition("=")
    method, colon, name = left.rpartition(":")
    if not eq or not colon or not method or not name.isidentifier():
        raise ValueError(
            f"{arg} {text!r} is not METHOD:NAME=VALUE (e.g. CWT-ResNet-ML:weights=resnet18.pth)"
        )
    try:
        value: object = json.loads(raw)
    except ValueError:
        value = raw
    return method, name, value


def check_method_options(
    options: MethodOptions, methods: Sequence[str], *, arg: str = "--method-option"
) -> dict[str, dict[str, object]]:
    """Validate constructor options of ``methods``: each names one of ``methods`` and a
    keyword parameter of its class's ``__init__`` (not ``seed``), and the method builds
    with them (its own checks run). Returns a plain copy; ValueError naming ``arg``, the
    method and the option when one is wrong."""
    out: dict[str, dict[str, object]] = {}
    for method, params in (options or {}).items():
        if method not in methods:
            raise ValueError(
                f"{arg} {method}:...: {method!r} is not among the methods of this run "
                f"({', '.join(methods)})"
            )
        cls = method_class(method, arg=arg)
        accepted = [
            p.name
            for p in inspect.signature(cls.__init__).parameters.values()
            if p.kind is inspect.Parameter.KEYWORD_ONLY and p.name != "seed"
        ]
        for name in params:
            if name not in accepted:
                raise ValueError(
                    f"{arg} {method}:{name}: {method} has no option {name!r} (its options: "
                    f"{', '.join(accepted) or 'none'})"
                )
        try:
            make_method(method, seed=0, **params)
        except (TypeError, ValueError) as exc:
            shown = ", ".join(f"{k}={v!r}" for k, v in params.items())
            raise ValueError(f"{arg} {method}:{shown}: {exc}") from None
        out[method] = dict(params)
    return out


def options_from_args(
    texts: Sequence[str] | None, methods: Sequence[str], *, arg: str = "--method-option"
) -> dict[str, dict[str, object]]:
    """The checked options of ``METHOD:NAME=VALUE`` texts (:func:`parse_method_option`,
    :func:`check_method_options`); a later text for the same option wins."""
    options: dict[str, dict[str, object]] = {}
    for text in texts or ():
        method, name, value = parse_method_option(text, arg=arg)
        options.setdefault(method, {})[name] = value
    return check_method_options(options, methods, arg=arg)
