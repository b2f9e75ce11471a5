"""results.json: schema version written and checked, plain-JSON readable, the query helper."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmark.evaluate import EvalResult
from benchmark.results import (
    ACCURACY_FIELDS,
    SCHEMA_VERSION,
    accuracy_record,
    dscan_record,
    read_results,
    select,
    selection_record,
    tsne_record,
    write_results,
)


def _result(acc: float) -> EvalResult:
    return EvalResult(
        accuracies=np.full(4, acc),
        accuracy=acc,
        ci95=0.0,
        episodes=4,
        seed=0,
        batch_ms_per_episode=1.0,
        predictions=np.zeros((4, 5), dtype=int),
    )


def _records() -> list[dict]:
    acc = [
        accuracy_record(
            protocol=p,
            fold=f,
            condition=None,
            method=m,
            way=w,
            shot=1,
            query=5,
            result=_result(0.1 * w),
            pretrain_s=1.0,
            feature_dim=None,
        )
        for p, f in (("closed-set", None), ("cross-shape", 0), ("cross-shape", None))
        for m in ("AFOP-ML", "Mine")
        for w in (2, 5)
    ]
    return [
        *acc,
        selection_record(protocol="closed-set", fold=None, D=12, pvdf_share=0.75, sg_share=0.25),
        tsne_record(protocol="closed-set", D=12, nn1_shape_accuracy=0.9, mix_sil=0.8, dgi=1.2),
        dscan_record(protocol="closed-set", D=[4, 8], mean=[0.5, 0.6], ci95=[0.01, float("nan")]),
    ]


def test_every_record_kind_carries_the_schema_version_and_round_trips(tmp_path):
    records = _records()
    assert all(r["schema_version"] == SCHEMA_VERSION for r in records)
    assert tuple(records[0]) == ACCURACY_FIELDS
    path = write_results(tmp_path / "results.json", records)
    plain = json.loads(path.read_text())  # any JSON reader can load it
    assert isinstance(plain, list) and plain == read_results(path)
    assert plain[-1]["ci95"] == [0.01, None]  # non-finite floats are written as null
    assert plain[:-1] == records[:-1]


def test_writer_adds_the_version_to_hand_made_records_and_refuses_another(tmp_path):
    path = write_results(tmp_path / "r.json", [{"record": "accuracy", "method": "x"}])
    assert read_results(path)[0]["schema_version"] == SCHEMA_VERSION
    with pytest.raises(ValueError, match="schema_version 99"):
        write_results(tmp_path / "s.json", [{"record": "accuracy", "schema_version": 99}])
    assert not (tmp_path / "s.json").exists()


def test_reader_refuses_another_version_in_one_line_and_unversioned_files_are_version_1(
    tmp_path,
):
    path = tmp_path / "results.json"
    path.write_text(json.dumps([{"record": "accuracy", "schema_version": SCHEMA_VERSION + 1}]))
    with pytest.raises(ValueError, match=r"results\.json: record 0 has schema_version") as e:
        read_results(path)
    assert "\n" not in str(e.value)
    path.write_text(json.dumps([{"record": "accuracy", "method": "x", "schema_version": 2}]))
    assert read_results(path) == [{"record": "accuracy", "method": "x", "schema_version": 2}]
    # A file without versions has version 1's layout, whose tsne indicators meant other
    # things (docs/results.md): refused, not misread.
    assert SCHEMA_VERSION == 2
    path.write_text(json.dumps([{"record": "accuracy", "method": "x"}]))
    with pytest.raises(ValueError, match="record 0 has schema_version 1"):
        read_results(path)


def test_select_matches_kind_and_every_field():
    records = _records()
    got = select(records, "accuracy", protocol="cross-shape", fold=None, method="Mine")
    assert [(r["fold"], r["method"], r["way"]) for r in got] == [
        (None, "Mine", 2),
        (None, "Mine", 5),
    ]
    assert len(select(records, "accuracy", way=5)) == 6
    assert select(records, "selection")[0]["D"] == 12
    assert select(records, "tsne", fold=None) == [records[-2]]
    # A field the record lacks never matches, even against None.
    assert select(records, "tsne", condition=None) == []
    with pytest.raises(ValueError, match="record must be one of"):
        select(records, "accuracies")


def test_dscan_record_needs_one_entry_per_candidate():
    with pytest.raises(ValueError, match="one entry per candidate"):
        dscan_record(protocol="closed-set", D=[1, 2], mean=[0.5], ci95=[0.1, 0.1])


def test_selection_records_carry_their_features_and_files_without_them_still_read(tmp_path):
    sel = selection_record(
        protocol="cross-shape", fold=1, D=2, pvdf_share=0.5, sg_share=0.5, selected=[7, 300]
    )
    assert sel.selected == [7, 300] and tuple(sel)[-1] == "selected"
    with pytest.raises(ValueError, match="D = 3 feature indices"):
        selection_record(
            protocol="closed-set", fold=None, D=3, pvdf_share=1, sg_share=0, selected=[1]
        )
    path = write_results(tmp_path / "results.json", [sel])
    assert read_results(path, typed=True)[0].selected == [7, 300]
    # A selection record written without the optional field reads with selected = None.
    old = {k: v for k, v in json.loads(path.read_text())[0].items() if k != "selected"}
    path.write_text(json.dumps([old]))
    (back,) = read_results(path, typed=True)
    assert (back.D, back.selected) == (2, None)
    # A required field is still required.
    path.write_text(json.dumps([{k: v for k, v in old.items() if k != "D"}]))
    with pytest.raises(ValueError, match="lacks the field"):
        read_results(path, typed=True)
