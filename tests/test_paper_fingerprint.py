"""The paper's grids give the same bits for the same seed: fingerprints (SHA-256) of the
presets' trial plans and of a few simulated trials, taken when the presets were the only
grids the generator made. A change that moves a paper trial's randomness, geometry or
path fails here."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from synth import presets, simulator
from synth.config import SynthConfig

#: SHA-256 of the plan's per-trial arrays (label, condition, trial index, force, speed,
#: seed), in store order.
PLAN_SHA256 = {
    "paper": "a2ca4f3d7ec059a651cbad0f6afad5f055c4571064882d0714f9aff7acfb5cc0",
    "perturbation": "468758f63970080899046ecdfed265e3cfee92c83794f364eb52b01ff3a6cf93",
}
#: (preset, plan row) -> (class, SHA-256 of the trial's float32 signals).
SIGNALS_SHA256 = {
    ("paper", 0): (
        "circle/resin",
        "9988e443ccf057a7a64bc1b9e7b9bc42eb97a16a48705b966bd6a4dfa18da55d",
    ),
    ("paper", 725): (
        "moon/resin",
        "a458b2d4035d28b0890d64594f3a0b0885e96a4859f339ca56ffae4a3dc3cb8d",
    ),
    ("paper", 2159): (
        "triangle/aluminum",
        "926f6c3bc50ee658521edf9d485ee48d1d0f90e41b24eac9601b7ee9962ee8fb",
    ),
    ("perturbation", 2879): (
        "triangle/aluminum",
        "a67099a4a034c621fee5fa96c68aeb287d4f3ed42d5efef96e437be4dca025a9",
    ),
}


def _plan_sha(plan: presets.TrialPlan) -> str:
    h = hashlib.sha256()
    for a in (plan.label, plan.condition, plan.trial_index, plan.force_n, plan.speed_mm_s):
        h.update(np.ascontiguousarray(a).tobytes())
    h.update(np.ascontiguousarray(plan.seed).tobytes())
    return h.hexdigest()


@pytest.mark.parametrize("name", sorted(PLAN_SHA256))
def test_preset_plans_keep_their_bits(name):
    assert _plan_sha(presets.plan(presets.PRESETS[name])) == PLAN_SHA256[name]


def test_preset_trials_keep_their_bits():
    specs = []
    for name, row in SIGNALS_SHA256:
        spec = presets.plan(presets.PRESETS[name]).specs(row, row + 1)[0]
        specs.append(spec)
    trials = simulator.simulate_batch(specs, config=SynthConfig(), threads=2)
    for (key, (cls, digest)), trial in zip(SIGNALS_SHA256.items(), trials, strict=True):
        assert f"{trial.spec.shape}/{trial.spec.material}" == cls, key
        assert hashlib.sha256(trial.signals.tobytes()).hexdigest() == digest, key
