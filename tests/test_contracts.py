"""The shared data contracts: Dataset validation and the episode checks of FewShotMethod."""

import numpy as np
import pytest
from synthetic_data import make_dataset

from models.base import check_episodes
from synth import CLASS_NAMES, TrialSpec


def test_dataset_fixture_is_aligned() -> None:
    ds = make_dataset(trials_per_class=2, shapes=("moon", "square"))
    assert ds.signals.shape == (12, 4, 2000) and ds.signals.dtype == np.float32
    assert {CLASS_NAMES[i] for i in ds.label} == {
        f"{s}/{m}" for s in ("moon", "square") for m in ("resin", "wood", "aluminum")
    }
    sub = ds.subset(ds.material == "wood")
    assert len(sub) == 4 and set(sub.material) == {"wood"}


def test_trial_spec_rejects_bad_input() -> None:
    # Any specimen and material names (the simulator resolves them), but class-name parts.
    assert TrialSpec("star", "cork").shape == "star"
    with pytest.raises(ValueError, match="shape must hold only lower-case letters"):
        TrialSpec("Star", "wood")
    with pytest.raises(ValueError, match="material must hold only lower-case letters"):
        TrialSpec("star", "wood/resin")
    with pytest.raises(ValueError, match="force_n"):
        TrialSpec("moon", "wood", force_n=0.0)
    with pytest.raises(ValueError, match="speed_mm_s"):
        TrialSpec("moon", "wood", speed_mm_s=-5)


def test_check_episodes_rejects_malformed() -> None:
    support = np.array([[[0, 1], [2, 3]]])
    query = np.array([[4, 5]])
    check_episodes(support, query, 6)
    with pytest.raises(ValueError, match="same trial twice"):
        check_episodes(np.array([[[0, 1], [1, 3]]]), query, 6)
    with pytest.raises(ValueError, match="also in its episode's support"):
        check_episodes(support, np.array([[0, 5]]), 6)
    with pytest.raises(ValueError, match="N >= 2"):
        check_episodes(np.array([[[0, 1]]]), query, 6)
    with pytest.raises(ValueError, match=r"values must lie in 0\.\.5"):
        check_episodes(support, np.array([[4, 9]]), 6)
