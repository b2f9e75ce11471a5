"""Methods by name. Modules are imported on first use so that importing ``models`` stays
cheap (torch is only loaded by the methods that need it)."""

from __future__ import annotations

import importlib

from shapes.validation import check_choice

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

METHOD_NAMES: tuple[str, ...] = tuple(_METHODS)


def method_class(name: str) -> type[FewShotMethod]:
    """The class registered under ``name`` (one of :data:`METHOD_NAMES`)."""
    check_choice("method", name, METHOD_NAMES)
    module, cls = _METHODS[name].split(":")
    return getattr(importlib.import_module(module), cls)


def make_method(name: str, *, seed: int = 0, **params: object) -> FewShotMethod:
    """A new, unfitted instance of the method ``name``."""
    return method_class(name)(seed=seed, **params)
