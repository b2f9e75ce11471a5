"""Few-shot tactile recognition methods: AFOP-ML, the paper's six baselines and the
variants beyond the paper, behind one interface.

Every method is a :class:`FewShotMethod`: ``fit`` once on the training classes' trials,
then ``predict_episodes`` adapts to each episode's support set and labels its queries
(episodes are index arrays into a pool of trials, many batched in one call). Methods are
named as the paper names them (:data:`METHOD_NAMES`, :data:`VARIANT_NAMES`), by the
entry point of an installed plug-in, or as ``module:Class`` (:func:`method_class`,
``docs/methods.md``).

What users call:

- :func:`make_method`, :func:`method_class`, :func:`available_methods`,
  :func:`check_methods`, :data:`METHOD_NAMES`, :data:`VARIANT_NAMES`,
  :data:`DEFAULT_METHODS`, :exc:`PluginError`, and constructor options from the command
  line (:func:`parse_method_option`, :func:`check_method_options`);
- the interface: :class:`FewShotMethod`, :exc:`NotFittedError`, and the hook
  :meth:`FewShotMethod.fit_details` with its :class:`FitDetails`;
- the method classes: :class:`AFOPML`, :class:`AFOMLPML`, :class:`AFOMLPMLMeta`,
  :class:`DirectProtML`, :class:`MAML`, :class:`CWTResNetML`, :class:`CNNBaseline`,
  :class:`BiLSTMBaseline`;
- the 386-feature pool: :func:`extract`, :data:`FEATURE_NAMES`, :func:`sensor_shares`;
- episodes: :func:`sample_episodes`, :class:`EpisodeBatch`.

Names are imported on first use, so ``import models`` stays cheap: torch loads only with
the methods that need it.

Examples
--------
>>> import numpy as np
>>> import models
>>> from tests.synthetic_data import make_dataset
>>> data = make_dataset(trials_per_class=4, n_samples=200, noise=0.1)
>>> method = models.make_method("Direct-Prot-ML", seed=0).fit(data.signals, data.label)
>>> batch = models.sample_episodes(data.label, n_way=5, k_shot=1, n_query=2, episodes=3,
...                                seed=0)
>>> predictions = method.predict_episodes(data.signals, batch.support, batch.query)
>>> predictions.shape
(3, 10)
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

import tactile_synth.threads  # noqa: F401  (first: sizes thread pools before numpy/torch load)

if TYPE_CHECKING:
    from .afo_mlp import AFOMLPML, AFOMLPMLMeta
    from .afop import AFOPML
    from .base import DScanCurve, FewShotMethod, FitDetails, NotFittedError
    from .bilstm import BiLSTMBaseline
    from .cnn import CNNBaseline
    from .cwt_resnet import CWTResNetML
    from .direct_prot import DirectProtML
    from .episodes import EpisodeBatch, sample_episodes, sample_split_episodes
    from .features import FEATURE_NAMES, N_FEATURES, extract, sensor_shares
    from .maml import MAML
    from .registry import (
        DEFAULT_METHODS,
        ENTRY_POINT_GROUP,
        METHOD_NAMES,
        VARIANT_NAMES,
        VARIANT_NOTES,
        MethodOptions,
        PluginError,
        available_methods,
        check_method_options,
        check_methods,
        is_builtin,
        make_method,
        method_class,
        options_from_args,
        parse_method_option,
        plugin_methods,
    )

#: Public name -> the module that defines it (imported on first use).
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("DScanCurve", "FewShotMethod", "FitDetails", "NotFittedError"), "base"),
    **dict.fromkeys(
        (
            "DEFAULT_METHODS",
            "ENTRY_POINT_GROUP",
            "METHOD_NAMES",
            "MethodOptions",
            "PluginError",
            "VARIANT_NAMES",
            "VARIANT_NOTES",
            "available_methods",
            "check_method_options",
            "check_methods",
            "is_builtin",
            "make_method",
            "method_class",
            "options_from_args",
            "parse_method_option",
            "plugin_methods",
        ),
        "registry",
    ),
    **dict.fromkeys(("FEATURE_NAMES", "N_FEATURES", "extract", "sensor_shares"), "features"),
    **dict.fromkeys(("EpisodeBatch", "sample_episodes", "sample_split_episodes"), "episodes"),
    "AFOPML": "afop",
    "AFOMLPML": "afo_mlp",
    "AFOMLPMLMeta": "afo_mlp",
    "DirectProtML": "direct_prot",
    "MAML": "maml",
    "CWTResNetML": "cwt_resnet",
    "CNNBaseline": "cnn",
    "BiLSTMBaseline": "bilstm",
}

__all__ = [
    "AFOMLPML",
    "AFOPML",
    "DEFAULT_METHODS",
    "ENTRY_POINT_GROUP",
    "FEATURE_NAMES",
    "MAML",
    "METHOD_NAMES",
    "N_FEATURES",
    "VARIANT_NAMES",
    "VARIANT_NOTES",
    "AFOMLPMLMeta",
    "BiLSTMBaseline",
    "CNNBaseline",
    "CWTResNetML",
    "DScanCurve",
    "DirectProtML",
    "EpisodeBatch",
    "FewShotMethod",
    "FitDetails",
    "MethodOptions",
    "NotFittedError",
    "PluginError",
    "available_methods",
    "check_method_options",
    "check_methods",
    "extract",
    "is_builtin",
    "make_method",
    "method_class",
    "options_from_args",
    "parse_method_option",
    "plugin_methods",
    "sample_episodes",
    "sample_split_episodes",
    "sensor_shares",
]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'models' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
