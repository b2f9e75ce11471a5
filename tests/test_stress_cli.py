"""``tactile-synth stress`` end to end (--quick), ``benchmark stress`` on its test sets,
and the refusals that come before anything is simulated."""

from __future__ import annotations

import json

import pytest

from benchmark.cli import main
from benchmark.results import RECORD_TYPES, read_results, select
from benchmark.stress import families
from benchmark.stress.suite import READINGS, check_values, clean_set_config
from synth.presets import PRESETS


def _cli(args, capsys):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.slow
def test_quick_suite_end_to_end_then_benchmark_stress_on_its_test_sets(tmp_path, capsys):
    out = tmp_path / "stress"
    code, _, err = _cli(["stress", "--quick", "--out", out, "--workers", "1"], capsys)
    assert code == 0, err
    records = read_results(out / "results.json", typed=True)
    stress = select(records, "stress")
    fams = set(families.QUICK_FAMILIES)
    assert {r.family for r in stress} == fams | {None}
    assert {r.reading for r in stress} == set(READINGS)
    assert {r.severity for r in stress if r.family} == {3, 5}
    assert {r.method for r in stress} == {"AFOP-ML", "AFO-MLP-ML", "Direct-Prot-ML"}
    kinds = {r.family: r.family_kind for r in stress if r.family}
    assert kinds == {"yaw": "physical", "offset": "physical", "pvdf-noise": "sensor",
                     "dead-channel": "sensor"}  # fmt: skip
    assert all(set(r) == set(RECORD_TYPES["stress"].names()) for r in stress)
    scores = select(records, "stress_score")
    assert len(scores) == 2 * 3 and all(r.reference == "Direct-Prot-ML" for r in scores)
    assert len(select(records, "stress_family")) == 2 * 3 * len(fams)
    report = (out / "stress.md").read_text()
    assert "### Ranking" in report and "signal-level" in report
    for name in ("stress_heatmap.png", *(f"stress_{f}.png" for f in fams)):
        assert (out / name).stat().st_size > 1000
    # a sensor fault is labelled as such, and every family's test set was simulated
    assert (out / "data" / "stress" / "yaw" / "5").is_dir()
    assert not (out / "data" / "stress" / "pvdf-noise").exists()
    # benchmark stress evaluates the same test sets without simulating anything
    again = tmp_path / "again"
    code, _, err = _cli(
        ["benchmark", "stress", "--data", out / "data" / "nominal", "--stress-data",
         out / "data" / "stress", "--out", again, "--methods", "AFOP-ML", "Direct-Prot-ML",
         "--families", *families.QUICK_FAMILIES, "--severities", "3,5", "--episodes", "100",
         "--workers", "1"],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    first = {(r.family, r.severity, r.reading, r.method): r.accuracy for r in stress}
    second = read_results(again / "results.json", typed=True)
    for r in select(second, "stress"):
        assert first[(r.family, r.severity, r.reading, r.method)] == r.accuracy


def test_bad_families_and_severities_are_refused_naming_the_valid_ones(tmp_path, capsys):
    code, _, err = _cli(["stress", "--out", tmp_path / "s", "--families", "yawn"], capsys)
    assert code == 2 and "--families must be one of" in err and "did you mean 'yaw'" in err
    code, _, err = _cli(["stress", "--out", tmp_path / "s", "--severities", "0,6"], capsys)
    assert code == 2 and "--severities takes severities from 1, 2, 3, 4, 5" in err
    assert not (tmp_path / "s").exists()


def test_a_severity_beyond_the_physical_range_is_refused_before_simulating(monkeypatch):
    import benchmark.guards

    def no_simulation(*args, **kwargs):
        raise AssertionError("a test set was simulated")

    monkeypatch.setattr(benchmark.guards, "generate_for_run", no_simulation)
    base = clean_set_config(PRESETS["quick"].replace(forces_n=(1.4,)), trials_per_class=2, seed=0)
    with pytest.raises(ValueError, match=r"^force x2.5: 3.5 N lies outside 0.4..3 N"):
        check_values([families.get("force")], (4,), base)
    with pytest.raises(ValueError, match=r"needs a nominal dataset of one force/speed"):
        clean_set_config(PRESETS["perturbation"], trials_per_class=2, seed=0)
    with pytest.raises(ValueError, match=r"physical family is simulated from the nominal"):
        check_values([families.get("yaw")], (1,), None)
    check_values([families.get("gain")], (5,), None)  # sensor faults need no simulation


def test_stress_records_round_trip_through_results_json(tmp_path):
    from benchmark.results import StressRecord, write_results

    rec = StressRecord(protocol="stress", family="yaw", family_kind="physical", severity=3,
                       value=4.0, unit="deg", reading="all-perturbed", method="AFOP-ML",
                       way=5, shot=1, query=5, episodes=10, accuracy=0.5, ci95=0.1,
                       pretrain_s=1.0, adapt_ms_per_episode=2.0)  # fmt: skip
    path = write_results(tmp_path / "r.json", [rec])
    back = read_results(path, typed=True)
    assert back[0] == rec or dict(back[0]) == dict(rec)
    assert json.loads(path.read_text())[0]["family"] == "yaw"


@pytest.mark.slow
def test_the_full_suite_on_the_paper_preset_passes_its_own_checks():
    """Every shipped family at every severity is valid on the paper preset (the full
    suite's default): each physical severity plans a slide of every specimen that stays
    on the plate, each sensor severity passes its family's check."""
    base = clean_set_config(PRESETS["paper"], trials_per_class=30, seed=0)
    check_values([families.get(n) for n in families.FAMILY_NAMES], [1, 2, 3, 4, 5], base)


def test_a_severity_off_the_plate_is_refused_before_anything_is_simulated(tmp_path):
    """A family's severity whose slides would run off the plate is one line naming the
    family, the severity and the specimen; the speed family reaches the top of the
    simulator's range (22 mm/s, which every built-in's slide fits) and no further."""
    base = clean_set_config(PRESETS["paper"], trials_per_class=2, seed=0)

    class Turned(families.get("yaw").__class__):
        levels = (30.0,) * 5  # the specimen turned by 30 deg: the path crosses the plate

    with pytest.raises(
        ValueError, match=r"--families yaw severity 1 .*pentagram runs .*beyond the 30 mm wide"
    ):
        check_values([Turned()], [1], base)

    class Fastest(families.get("speed").__class__):
        levels = (2.2, 2.2, 2.2, 2.2, 2.25)  # 22 mm/s (as 10 x 2.2 rounds), then 22.5

    check_values([Fastest()], [1], base)
    with pytest.raises(ValueError, match=r"22\.5 mm/s lies outside 0\.1\.\.22 mm/s"):
        check_values([Fastest()], [5], base)
