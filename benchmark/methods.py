"""Methods as the engine builds and calls them: names checked, instances built with a
seed and options, a plug-in's failure named as the plug-in's, and the width of the
space a method's prototypes live in."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager

from models import registry
from models.base import FewShotMethod


def check_methods(methods: Sequence[str]) -> tuple[str, ...]:
    """Validate method names, plug-in names or ``module:Class`` specs (unknown names
    raise with the valid list, see :func:`models.registry.check_methods`); keep order."""
    return registry.check_methods(methods, arg="method")


def make_method(name: str, seed: int = 0, **options: object) -> FewShotMethod:
    """A new, unfitted method ``name`` built with ``seed`` and its constructor ``options``
    (:func:`models.registry.make_method`)."""
    return registry.make_method(name, seed=seed, **options)


@contextmanager
def plugin_stage(name: str, stage: str) -> Iterator[None]:
    """Run a ``stage`` (fit, predict) of method ``name``; an exception a plug-in method
    raises there becomes a :class:`models.registry.PluginError` naming the method as given
    on --methods and the stage (its exception the cause, for --debug's traceback), so
    that the user reads it as the plug-in's failure, not tactile-synth's. Built-in methods'
    exceptions, running out of memory and interrupts pass unchanged."""
    try:
        yield
    except (MemoryError, registry.PluginError):
        raise
    except Exception as exc:
        if registry.is_builtin(name):
            raise
        raise registry.PluginError(
            f"--methods {name}: the plug-in method failed in {stage}: "
            f"{type(exc).__name__}: {exc or 'no message'}"
        ) from exc


def feature_dim(method: FewShotMethod) -> int | None:
    """Width of the embedding the method's prototypes live in, if it exposes one:
    ``feature_dim_`` when set (AFO-MLP-ML: its 32-wide projection, Direct-Prot-ML: 386),
    else ``D_`` (AFOP-ML: the top-D features)."""
    for attr in ("feature_dim_", "D_"):
        value = getattr(method, attr, None)
        if value is not None:
            return int(value)
    return None
