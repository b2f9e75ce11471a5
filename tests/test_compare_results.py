"""scripts/compare_results.py: the cells of two results.json files that moved outside the
reference's 95 % CI, and its exit status."""

from __future__ import annotations

import pytest

from benchmark.results import AccuracyRecord, selection_record, write_results
from tests.support import SCRIPTS, load_script


def _script(monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPTS))
    return load_script("compare_results")


def _cell(method="AFOP-ML", way=5, shot=1, accuracy=0.80, ci95=0.02, protocol="closed-set"):
    return AccuracyRecord(
        protocol=protocol,
        fold=None,
        condition=None,
        method=method,
        way=way,
        shot=shot,
        query=5,
        episodes=500,
        accuracy=accuracy,
        ci95=ci95,
        pretrain_s=1.0,
        adapt_ms_per_episode=1.0,
        latency_ms_per_episode=None,
        latency_with_features_ms_per_episode=None,
        latency_episodes=0,
        feature_dim=None,
    )


def _write(tmp_path, name, records):
    extra = selection_record(protocol="closed-set", fold=None, D=2, pvdf_share=0.5, sg_share=0.5)
    return str(write_results(tmp_path / name / "results.json", [*records, extra]))


def test_only_a_cell_outside_the_references_interval_is_printed_and_fails(
    tmp_path, monkeypatch, capsys
):
    main = _script(monkeypatch).main
    a = _write(tmp_path, "a", [_cell(shot=1, accuracy=0.80), _cell(shot=5, accuracy=0.90)])
    # shot 1 moves by 1.9 pp (inside +-2), shot 5 by 2.1 pp (outside).
    b = _write(tmp_path, "b", [_cell(shot=1, accuracy=0.819), _cell(shot=5, accuracy=0.879)])
    assert main([a, b]) == 1
    out = capsys.readouterr().out
    assert "moved: protocol=closed-set method=AFOP-ML way=5 shot=5:" in out
    assert "shot=1:" not in out
    assert "2 cells in both files, 1 moved" in out


def test_identical_files_pass(tmp_path, monkeypatch, capsys):
    main = _script(monkeypatch).main
    records = [_cell(shot=1), _cell(method="CNN", shot=1, accuracy=0.5)]
    assert main([_write(tmp_path, "a", records), _write(tmp_path, "b", records)]) == 0
    assert "2 cells in both files, 0 moved" in capsys.readouterr().out


def test_a_cell_in_one_file_only_fails(tmp_path, monkeypatch, capsys):
    main = _script(monkeypatch).main
    a = _write(tmp_path, "a", [_cell(shot=1), _cell(shot=5)])
    b = _write(tmp_path, "b", [_cell(shot=1)])
    assert main([a, b]) == 1
    assert "only in A: protocol=closed-set method=AFOP-ML way=5 shot=5" in capsys.readouterr().out


def test_a_zero_interval_falls_back_to_the_binomial_interval_of_the_queries(monkeypatch):
    compare = _script(monkeypatch).compare
    # 500 episodes x 5 ways x 5 queries = 12,500 queries at 100 %: half-width about 0.03 pp.
    a = [_cell(accuracy=1.0, ci95=0.0)]
    assert compare(a, [_cell(accuracy=0.9999)])[0] == []
    moved = compare(a, [_cell(accuracy=0.998)])[0]
    assert len(moved) == 1 and 0 < moved[0].ci < 0.001


def test_a_missing_file_is_one_line_naming_it(tmp_path, monkeypatch, capsys):
    main = _script(monkeypatch).main
    a = _write(tmp_path, "a", [_cell()])
    with pytest.raises(SystemExit) as exit_info:
        main([a, str(tmp_path / "nope.json")])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error: B " in err
