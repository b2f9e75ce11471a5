"""scripts/calibrate.py: argument checks and the selection-share measurement of its sweep."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from tests.synthetic_data import make_dataset

ROOT = Path(__file__).resolve().parents[1]


def _calibrate_module():
    spec = importlib.util.spec_from_file_location(
        "calibrate_script", ROOT / "scripts" / "calibrate.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_sweep_refuses_an_unknown_parameter_by_name():
    calibrate = _calibrate_module()
    with pytest.raises(SystemExit, match="--only must name a swept parameter"):
        calibrate.main(["sweep", "--only", "finger.no_such_field"])


@pytest.mark.parametrize("seed", [0, 6])
def test_selection_shares_follow_where_the_planted_information_lies(seed):
    # Shapes live only in the strain-gauge channels of this dataset, materials in the PVDF
    # ones: a one-material training split (cross-material) needs SG features only, a
    # three-material split (cross-shape) needs PVDF features for the materials as well.
    calibrate = _calibrate_module()
    data = make_dataset(trials_per_class=6, noise=0.3, seed=seed)
    shares = calibrate._selection_shares(data)
    assert shares["pvdf_share_cross_material"] < 0.35
    assert shares["pvdf_share_cross_shape"] > shares["pvdf_share_cross_material"] + 0.10
