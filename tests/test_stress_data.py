"""The stress suite's test sets: trial seeds shared across a family's severities, and
each physical family's configuration at severity 0 the nominal one."""

from __future__ import annotations

import numpy as np

from benchmark.stress import families
from synth.presets import PRESETS, GenerationConfig, plan


def test_without_seed_by_condition_every_condition_repeats_the_same_strokes():
    base = PRESETS["quick"].replace(seed_by_condition=False)
    nominal = plan(PRESETS["quick"])
    for forces, speeds in (((2.0,), (10.0,)), ((1.0,), (20.0,)), ((0.6,), (6.0,))):
        other = plan(base.replace(forces_n=forces, speeds_mm_s=speeds))
        np.testing.assert_array_equal(other.seed, nominal.seed)
    # the default keeps the condition in the seed, and the stored layout of earlier stores
    assert not np.array_equal(plan(PRESETS["quick"].replace(forces_n=(2.0,))).seed, nominal.seed)
    assert "seed_by_condition" not in PRESETS["paper"].to_dict()
    assert GenerationConfig.from_dict(base.to_dict()) == base


def test_every_physical_family_is_the_nominal_configuration_at_severity_0():
    base = PRESETS["quick"].replace(seed_by_condition=False)
    for name in families.FAMILY_NAMES:
        fam = families.get(name)
        if fam.kind == "physical":
            assert fam.configure(base, fam.value(0)) == base
