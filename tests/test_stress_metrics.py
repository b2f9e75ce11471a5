"""The stress suite's family interface, severities and scores on records with known answers."""

from __future__ import annotations

import pytest

from benchmark.stress import families
from benchmark.stress.metrics import scores


def _rec(method, reading, family, severity, accuracy):
    return {"method": method, "reading": reading, "family": family, "severity": severity,
            "accuracy": accuracy}  # fmt: skip


def test_scores_follow_their_definitions():
    recs = [
        _rec("A", "r", None, 0, 0.9),
        _rec("A", "r", "yaw", 1, 0.8),
        _rec("A", "r", "yaw", 3, 0.6),
        _rec("A", "r", "gain", 1, 0.9),
        _rec("A", "r", "gain", 3, 0.7),
        _rec("B", "r", None, 0, 0.8),
        _rec("B", "r", "yaw", 1, 0.8),
        _rec("B", "r", "yaw", 3, 0.8),
        _rec("B", "r", "gain", 1, 0.6),
        _rec("B", "r", "gain", 3, 0.4),
    ]
    fam, meth = scores(recs, reference="A", families=("yaw", "gain"))
    a = {(f.method, f.family): f for f in fam}
    assert a[("A", "yaw")].mean_drop == pytest.approx(0.2)  # (0.1 + 0.3) / 2
    assert a[("A", "gain")].mean_drop == pytest.approx(0.1)
    assert a[("A", "yaw")].ce == pytest.approx(1.0) and a[("A", "gain")].relative_ce == 1.0
    assert a[("B", "yaw")].ce == pytest.approx(0.4 / 0.6)
    assert a[("B", "yaw")].relative_ce == pytest.approx(0.0)  # B's error does not rise
    assert a[("B", "gain")].ce == pytest.approx(1.0 / 0.4)
    assert a[("B", "gain")].relative_ce == pytest.approx(0.6 / 0.2)
    m = {s.method: s for s in meth}
    assert m["A"].mean_drop == pytest.approx(0.15) and m["A"].worst_family == "yaw"
    assert m["A"].mce == pytest.approx(1.0) and m["A"].relative_mce == pytest.approx(1.0)
    assert m["B"].worst_family == "gain" and m["B"].worst_drop == pytest.approx(0.3)
    assert m["B"].mce == pytest.approx((0.4 / 0.6 + 1.0 / 0.4) / 2)
    assert m["B"].clean == 0.8 and m["B"].reference == "A"


def test_a_family_the_reference_shrugs_off_leaves_the_relative_score_undefined():
    recs = [_rec("A", "r", None, 0, 0.9), _rec("A", "r", "yaw", 1, 0.9),
            _rec("B", "r", None, 0, 0.9), _rec("B", "r", "yaw", 1, 0.5)]  # fmt: skip
    fam, meth = scores(recs, reference="A", families=("yaw",))
    assert {f.method: f.relative_ce for f in fam} == {"A": None, "B": None}
    assert all(m.relative_mce is None for m in meth)


def test_scores_need_the_reference_method():
    with pytest.raises(ValueError, match="reference method 'C' has no stress records"):
        scores([_rec("A", "r", None, 0, 0.9)], reference="C", families=())


def test_every_shipped_family_has_five_graded_severities():
    for name in families.FAMILY_NAMES:
        fam = families.get(name)
        assert fam.name == name and fam.kind in ("physical", "sensor")
        assert [fam.value(s) for s in range(1, 6)] == list(fam.levels)
        assert fam.value(0) == fam.nominal
        assert fam.describe(0).startswith(name)


@pytest.mark.parametrize(
    ("text", "expect"),
    [("1,3,5", (1, 3, 5)), ("5,1", (1, 5)), ([2, 2], (2,))],
)
def test_severities_parse(text, expect):
    assert families.parse_severities(text) == expect


@pytest.mark.parametrize("text", ["0", "6", "1,x", ""])
def test_bad_severities_are_refused_naming_the_valid_ones(text):
    with pytest.raises(ValueError, match=r"--severities takes severities from 1, 2, 3, 4, 5"):
        families.parse_severities(text)


def test_an_unknown_family_is_refused_with_a_close_match():
    with pytest.raises(ValueError, match=r"--families must be one of .*did you mean 'yaw'"):
        families.get("yaww")


FAMILY_FILE = """
from benchmark.stress.families import SensorFamily


class Humidity(SensorFamily):
    name = "humidity"
    summary = "a user's family"
    unit = "%"
    nominal = 40.0
    levels = (50.0, 60.0, 70.0, 80.0, 90.0)

    def apply(self, signals, value, seeds):
        return signals * (1 + (value - self.nominal) / 1000)


class Backwards(Humidity):
    levels = (90.0, 80.0, 70.0, 60.0, 50.0)
"""


def test_a_users_family_loads_from_a_file_and_is_checked(tmp_path):
    path = tmp_path / "my_families.py"
    path.write_text(FAMILY_FILE)
    fam = families.get(f"{path}:Humidity")
    assert fam.name == "humidity" and fam.value(5) == 90.0
    with pytest.raises(ValueError, match="levels must move away from nominal"):
        families.get(f"{path}:Backwards")
    with pytest.raises(ValueError, match="is not a StressFamily subclass"):
        families.get(f"{path}:SensorFamily.__init__")
