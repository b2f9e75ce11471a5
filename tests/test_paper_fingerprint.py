"""The paper's grids give the same bits for the same seed: fingerprints (SHA-256) of the
presets' trial plans and of a few simulated trials, taken when the presets were the only
grids the generator made. A change that moves a paper trial's randomness, geometry or
path fails here."""

from __future__ import annotations

import dataclasses
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
        "14dcfb0dcfc99eb53b5daf0e915ca86c7155a03e6e5f2d7f82d30d0a4b144b13",
    ),
    ("paper", 725): (
        "moon/resin",
        "9acd84b5732e98316e98048c62bf67a5fafae6ed9b140421aed616954d93f5a0",
    ),
    ("paper", 2159): (
        "triangle/aluminum",
        "dddbf5be21b1cbb6baf0cb043710c96b8197b286b682e4cbd52fdc9c3a928019",
    ),
    ("perturbation", 2879): (
        "triangle/aluminum",
        "5221bf35b088a59fee0bcebef372e3225657a97045708f18d0516067508f4f49",
    ),
}


#: The same trials' SHA-256 with the fingerprint's ridges averaging over flat boxes of one
#: width (both ridge exponents 0), the idealisation the docs measure beside the default.
BOX_SIGNALS_SHA256 = {
    ("paper", 0): (
        "circle/resin",
        "69085576aea4b63dd46e9ee81a6e19a3c3504d77f0b691de6f3365464a03fb35",
    ),
    ("paper", 725): (
        "moon/resin",
        "f0c62a6617e5a479f2b0dc4ddfe191ea39a6b54c007bc21c6c1204d32a0210ed",
    ),
    ("paper", 2159): (
        "triangle/aluminum",
        "a971e986a875bf71a3916e6291e1ee59609cf04038748f0f2ec2cfed16736166",
    ),
    ("perturbation", 2879): (
        "triangle/aluminum",
        "df2fd2a0d58c84a64a64b6c25e5d61a156897a9080d9c63c2116af65fc0c40aa",
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


def _box_ridges() -> SynthConfig:
    config = SynthConfig()
    finger = dataclasses.replace(
        config.finger, ridge_profile_exponent=0.0, ridge_width_pressure_exponent=0.0
    )
    return dataclasses.replace(config, finger=finger)


@pytest.mark.parametrize(
    ("config", "known"),
    [(SynthConfig(), SIGNALS_SHA256), (_box_ridges(), BOX_SIGNALS_SHA256)],
    ids=["defaults", "box ridges"],
)
def test_preset_trials_keep_their_bits(config, known):
    specs = []
    for name, row in known:
        spec = presets.plan(presets.PRESETS[name]).specs(row, row + 1)[0]
        specs.append(spec)
    trials = simulator.simulate_batch(specs, config=config, threads=2)
    for (key, (cls, digest)), trial in zip(known.items(), trials, strict=True):
        assert f"{trial.spec.shape}/{trial.spec.material}" == cls, key
        assert hashlib.sha256(trial.signals.tobytes()).hexdigest() == digest, key
