"""``tactile-synth import``: real recordings (CSV/NPZ files written here) into a dataset
store that load_dataset, inspect, diagnose and benchmark read like a simulated one; every
bad input named by file and line, and nothing half-imported left behind."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import zarr

import synth.generation as generation
from benchmark.cli import main
from synth import CHANNELS, CLASS_NAMES, N_SAMPLES, load_dataset, store
from synth.importer import (
    RecordingError,
    RecordingWarning,
    contact_phase,
    import_recordings,
    read_labels,
)
from synth.summary import summarize

SHAPES = ("circle", "square", "triangle")
MATERIALS = ("resin", "wood")
TRIALS = 4  # per class: the closed-set split leaves 2 test trials per class


def class_signal(
    shape: str,
    material: str,
    k: int,
    rate_hz: float,
    duration_s: float = 2.0,
    contact_s: tuple[float, float] | None = None,
) -> np.ndarray:
    """``(4, n)`` volts: PVDF vibration at a material's frequencies, strain gauges at a
    shape's level with a slow wave (content below 200 Hz, so 1 and 2 kHz sample the same
    signal). ``contact_s``: the finger touches only between these times (strain gauges at
    0 V and PVDF silent outside, 50 ms ramps)."""
    si, mi = SHAPES.index(shape), MATERIALS.index(material)
    t = np.arange(round(rate_hz * duration_s)) / rate_hz
    fast, slow = 40.0 + 45.0 * mi, 1.0 + 0.8 * si
    phase = 0.7 * k
    x = np.stack(
        [
            0.5 * np.sin(2 * np.pi * fast * t + phase),
            0.3 * np.sin(2 * np.pi * 1.3 * fast * t + phase),
            0.4 + 0.25 * si + 0.1 * np.sin(2 * np.pi * slow * t + phase),
            0.2 + 0.15 * mi + 0.1 * np.cos(2 * np.pi * slow * t + phase),
        ]
    )
    if contact_s is not None:
        a, b = contact_s
        on = np.clip(np.minimum(t - a, b - t) / 0.05, 0.0, 1.0)  # 50 ms ramps
        x = x * on
    return x


def write_csv(path: Path, x: np.ndarray, *, header=CHANNELS, time_s=None) -> None:
    cols = [x[CHANNELS.index(h)] if h in CHANNELS else time_s for h in header]
    rows = np.stack(cols, axis=1)
    lines = [",".join(header)] + [",".join(f"{v:.9g}" for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")


def as_written(path: Path) -> np.ndarray:
    """The channels of a CSV written by :func:`write_csv`, as float32 ``(4, n)``: the
    values its 9-digit text holds, which the import stores unchanged."""
    values = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return values.T.astype(np.float32)


def write_labels(folder: Path, rows: list[dict], name: str = "labels.csv") -> Path:
    keys = list(rows[0])
    text = [",".join(keys)] + [",".join(str(r[k]) for k in keys) for r in rows]
    path = folder / name
    path.write_text("\n".join(text) + "\n")
    return path


def make_recordings(folder: Path) -> dict[str, dict]:
    """6 classes x 4 trials: CSV for even trials, NPZ for odd ones, all 2 s at 1 kHz
    except square/wood trial 1 (NPZ at 2 kHz) and triangle/resin trial 2 (a 5 s CSV
    with contact from 1.3 to 3.7 s)."""
    folder.mkdir(parents=True, exist_ok=True)
    rows, special = [], {}
    for shape in SHAPES:
        for material in MATERIALS:
            for k in range(TRIALS):
                name = f"{shape}_{material}_{k}"
                if (shape, material, k) == ("square", "wood", 1):
                    x = class_signal(shape, material, k, 2000.0)
                    np.savez(folder / f"{name}.npz", signals=x, sample_rate_hz=2000.0)
                    file = f"{name}.npz"
                    special["resampled"] = {"file": file}
                elif (shape, material, k) == ("triangle", "resin", 2):
                    x = class_signal(shape, material, k, 1000.0, 5.0, contact_s=(1.3, 3.7))
                    write_csv(folder / f"{name}.csv", x)
                    file = f"{name}.csv"
                    special["long"] = {"file": file}
                elif k % 2 == 0:
                    write_csv(folder / f"{name}.csv", class_signal(shape, material, k, 1000.0))
                    file = f"{name}.csv"
                else:
                    x = class_signal(shape, material, k, 1000.0)
                    np.savez(folder / f"{name}.npz", **dict(zip(CHANNELS, x, strict=True)))
                    file = f"{name}.npz"
                rows.append(
                    {
                        "file": file,
                        "shape": shape,
                        "material": material,
                        "force_n": 1,
                        "speed_mm_s": 10,
                        # empty: the 2 kHz NPZ states its own rate
                        "sample_rate_hz": ""
                        if "resampled" in special and special["resampled"]["file"] == file
                        else 1000,
                    }
                )
    write_labels(folder, rows)
    return special


def quiet_import(*args, **kw):
    with pytest.warns(RecordingWarning):
        return import_recordings(*args, progress=False, **kw)


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    root = tmp_path_factory.mktemp("import")
    special = make_recordings(root / "recs")
    with pytest.warns(RecordingWarning, match=r"resampled 1 of 24 recordings .* 1 at 2000 Hz"):
        summary = import_recordings(root / "recs", root / "data", progress=False)
    return root, summary, special


PROGRESS_LINE = re.compile(r"\[tactile-synth\] import: (\d+)/(\d+) trials? \((\d+)%\) in .* s")


def progress_lines(err: str) -> list[tuple[int, int, int]]:
    """``(done, total, percent)`` of the import's progress lines in ``err`` (stderr not
    a terminal)."""
    found = [PROGRESS_LINE.fullmatch(x.split(", about ")[0]) for x in err.splitlines()]
    return [(int(m[1]), int(m[2]), int(m[3])) for m in found if m]


def last_line(err: str) -> str:
    """The one line a failed or interrupted import ends with, after the progress lines of
    the recordings it read (as generate's and export's tests take it)."""
    lines = err.strip().splitlines()
    assert len(progress_lines(err)) == len(lines) - 1 and "\r" not in err, err
    return lines[-1]


def leftovers(folder: Path, out: Path) -> list[str]:
    """What an import to ``out`` left in ``folder``: the dataset, its hidden siblings."""
    return sorted(p.name for p in folder.iterdir() if out.name in p.name)


# -- the happy path ------------------------------------------------------------------------
def test_import_loads_like_a_simulated_dataset(imported):
    root, summary, _ = imported
    assert summary.n_trials == 24 and summary.n_classes == 6
    assert summary.formats == {"csv": 12, "npz": 12}
    assert summary.windows == {"whole": 23, "contact": 1}
    data = load_dataset(root / "data")
    # The class list is what the table holds, in the paper's order.
    names = tuple(
        c for c in CLASS_NAMES if c.split("/")[0] in SHAPES and c.split("/")[1] in MATERIALS
    )
    assert data.classes == names and data.signals.shape == (24, 4, N_SAMPLES)
    assert data.signals.dtype == np.float32
    assert {data.classes[i] for i in data.label} == set(names)
    assert all(
        f"{s}/{m}" == data.classes[i]
        for s, m, i in zip(data.shape, data.material, data.label, strict=True)
    )
    assert np.all(data.force_n == 1.0) and np.all(data.speed_mm_s == 10.0)
    assert data.attrs["kind"] == "imported" and data.attrs["complete"]
    assert len(set(data.seed.tolist())) == 24  # every window its own id
    # store order is the simulator's: condition, class, trial
    assert np.all(np.diff(data.label) >= 0)
    prov = data.attrs["import"]["trials"]
    assert len(prov["file"]) == 24 and set(prov["window"]) == {"whole", "contact"}
    # a 1 kHz CSV of exactly 2 s is stored as written (float32)
    i = prov["file"].index("circle_resin_0.csv")
    assert np.array_equal(data.signals[i], as_written(root / "recs" / "circle_resin_0.csv"))
    want = class_signal("circle", "resin", 0, 1000.0)
    assert np.max(np.abs(data.signals[i] - want)) < 1e-7


def test_resampled_recording_matches_the_signal_at_1_khz(imported):
    root, _, special = imported
    data = load_dataset(root / "data")
    prov = data.attrs["import"]["trials"]
    i = prov["file"].index(special["resampled"]["file"])
    assert prov["sample_rate_hz"][i] == 2000.0 and prov["samples"][i] == 4000
    want = class_signal("square", "wood", 1, 1000.0)
    got = data.signals[i].astype(np.float64)
    # away from the ends the anti-aliased 2 kHz -> 1 kHz signal equals the 1 kHz one
    assert np.max(np.abs(got[:, 50:-50] - want[:, 50:-50])) < 2e-3
    assert np.max(np.abs(got - want)) < 0.05


def test_long_recording_window_is_centred_on_the_contact_phase(imported):
    root, _, special = imported
    data = load_dataset(root / "data")
    prov = data.attrs["import"]["trials"]
    i = prov["file"].index(special["long"]["file"])
    assert prov["window"][i] == "contact"
    # contact 1.3-3.7 s: centre 2.5 s, so the 2 s window starts at 1.5 s
    assert abs(prov["window_start_s"][i] - 1.5) <= 0.01
    full = as_written(root / "recs" / special["long"]["file"])
    first = round(prov["window_start_s"][i] * 1000)
    assert np.array_equal(data.signals[i], full[:, first : first + N_SAMPLES])


def test_inspect_diagnose_and_closed_set_benchmark_run_unchanged(imported, capsys):
    from benchmark.diagnose import diagnose

    root, _, _ = imported
    text = summarize(root / "data")
    assert "imported   from" in text and "integrity  ok" in text
    assert "23 x whole, 1 x contact" in text
    diag = diagnose(load_dataset(root / "data"))
    assert diag.n_trials == 24 and len(diag.classes) == 6
    # the fixture puts the shape in the strain gauges only and the material in the PVDF
    # channels only: each is told apart in its own group, so the channels kept their order
    assert diag.accuracy["shape"]["sg"] == 1.0 and diag.accuracy["material"]["pvdf"] == 1.0
    assert diag.accuracy["shape"]["pvdf"] < 0.5  # chance is 0.30: no shape in the PVDF
    out = root / "bench"
    argv = ["benchmark", "closed-set", "--data", str(root / "data"), "--out", str(out)]
    rc = main([*argv, "--methods", "AFOP-ML", "--episodes", "5"])
    assert rc == 0, capsys.readouterr().err
    doc = json.loads((out / "results.json").read_text())
    records = doc["records"] if isinstance(doc, dict) else doc
    acc = [r for r in records if r.get("method") == "AFOP-ML" and "accuracy" in r]
    assert acc and all(0.0 <= r["accuracy"] <= 1.0 for r in acc)
    # 6 classes with 2 test trials each hold only the 1-shot 5-way column of Table I
    assert {(r["way"], r["shot"]) for r in acc} == {(5, 1)}


def test_import_is_deterministic(imported, tmp_path):
    root, _, _ = imported
    quiet_import(root / "recs", tmp_path / "again")
    a, b = load_dataset(root / "data"), load_dataset(tmp_path / "again")
    assert np.array_equal(a.signals, b.signals) and np.array_equal(a.seed, b.seed)
    assert a.attrs["store_id"] != b.attrs["store_id"]


def test_cli_import_prints_one_summary_and_the_warning(imported, tmp_path, capsys):
    root, _, _ = imported
    out = tmp_path / "cli"
    assert main(["import", str(root / "recs"), "--out", str(out)]) == 0
    cap = capsys.readouterr()
    assert cap.out.startswith(f"wrote {out}: 24 trials (6 classes x 1 condition)")
    warnings = [x for x in cap.err.strip().splitlines() if not PROGRESS_LINE.match(x)]
    assert progress_lines(cap.err) == [(24, 24, 100)]
    assert len(warnings) == 1 and warnings[0].startswith("tactile-synth import: warning: resampled")
    # a second import onto it needs --overwrite
    assert main(["import", str(root / "recs"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--overwrite" in err
    assert main(["import", str(root / "recs"), "--out", str(out), "--overwrite"]) == 0
    assert leftovers(tmp_path, out) == ["cli"]


# -- the store's imported kind -------------------------------------------------------------
def test_generate_resume_and_repair_refuse_an_imported_store(imported, capsys):
    root, _, _ = imported
    path = root / "data"
    for extra in ([], ["--repair"]):
        assert main(["generate", "--resume", *extra, "--out", str(path)]) == 2
        err = capsys.readouterr().err
        assert "holds imported recordings" in err and "cannot re-simulate" in err
        assert f"tactile-synth import {(root / 'recs').resolve()}" in err
    with pytest.raises(store.DatasetError, match="no generation configuration"):
        store.stored_config(path)
    with pytest.raises(ValueError, match="holds imported recordings"):
        generation.generate(None, path, resume=True, progress=False)


def test_edits_to_an_imported_store_are_caught(imported, tmp_path):
    import shutil

    root, _, _ = imported
    path = tmp_path / "copy"
    shutil.copytree(root / "data", path)
    group = zarr.open_group(path, mode="r+")
    label = group["label"][:]
    label[3] += 1
    group["label"][:] = label
    with pytest.raises(store.DatasetDamaged, match=r"label \(file .*\) fails its checksum") as exc:
        load_dataset(path)
    assert "tactile-synth import" in str(exc.value) and "--overwrite" in str(exc.value)
    shutil.rmtree(path)
    shutil.copytree(root / "data", path)
    (path / "signals" / "c" / "0" / "0" / "0").unlink()
    with pytest.raises(store.DatasetDamaged, match=r"chunk 0 .* is missing"):
        load_dataset(path)


# -- windows -------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", range(10))
def test_contact_phase_found_in_noisy_strain_gauges(seed):
    rng = np.random.default_rng(seed)
    a = rng.uniform(0.5, 2.0)
    b = a + rng.uniform(1.0, 3.0)
    x = class_signal("circle", "wood", seed, 1000.0, b + rng.uniform(0.5, 2.0), contact_s=(a, b))
    x += 0.005 * rng.standard_normal(x.shape)  # 5 mV of noise
    first, last = contact_phase(x[2:4])
    assert abs(first / 1000 - a) < 0.03 and abs(last / 1000 - b) < 0.03


def test_contact_phase_none_without_contact():
    rng = np.random.default_rng(0)
    assert contact_phase(0.002 * rng.standard_normal((2, 5000))) is None


# -- bad inputs ----------------------------------------------------------------------------
def small(folder: Path, n: int = 3, **row_changes) -> list[dict]:
    """``n`` good CSV recordings (2 s at 1 kHz) of circle/resin and their labels."""
    folder.mkdir(parents=True, exist_ok=True)
    rows = []
    for k in range(n):
        write_csv(folder / f"t{k}.csv", class_signal("circle", "resin", k, 1000.0))
        rows.append(
            {"file": f"t{k}.csv", "shape": "circle", "material": "resin", "force_n": 1,
             "speed_mm_s": 10, **row_changes}
        )  # fmt: skip
    write_labels(folder, rows)
    return rows


def _bad_channels(d):
    x = class_signal("circle", "resin", 1, 1000.0)
    write_csv(d / "t1.csv", x[:3], header=CHANNELS[:3])


def _nan(d):
    x = class_signal("circle", "resin", 1, 1000.0)
    x[2, 811] = np.nan
    write_csv(d / "t1.csv", x)


def _non_numeric(d):
    lines = (d / "t1.csv").read_text().splitlines()
    cells = lines[4].split(",")
    cells[1] = "abc"
    lines[4] = ",".join(cells)
    (d / "t1.csv").write_text("\n".join(lines) + "\n")


def _underscored_sample(d):
    lines = (d / "t1.csv").read_text().splitlines()
    cells = lines[4].split(",")
    cells[1] = "1_0"  # float("1_0") is 10.0
    lines[4] = ",".join(cells)
    (d / "t1.csv").write_text("\n".join(lines) + "\n")


def _underscored_seed(d):
    lines = (d / "labels.csv").read_text().splitlines()
    seeds = ["seed", "1", "2_000", "3"]  # int("2_000") is 2000
    (d / "labels.csv").write_text(
        "\n".join(f"{line},{seed}" for line, seed in zip(lines, seeds, strict=True)) + "\n"
    )


def _short_row(d):
    lines = (d / "t1.csv").read_text().splitlines()
    lines[9] = ",".join(lines[9].split(",")[:3])
    (d / "t1.csv").write_text("\n".join(lines) + "\n")


def _too_short(d):
    write_csv(d / "t1.csv", class_signal("circle", "resin", 1, 1000.0, 1.5))


def _npz_channels(d):
    (d / "t1.csv").unlink()
    x = class_signal("circle", "resin", 1, 1000.0)
    np.savez(d / "t1.npz", pvdf1=x[0], pvdf2=x[1], sg1=x[2])
    labels = (d / "labels.csv").read_text().replace("t1.csv", "t1.npz")
    (d / "labels.csv").write_text(labels)


def _npz_inf(d):
    (d / "t1.csv").unlink()
    x = class_signal("circle", "resin", 1, 1000.0)
    x[0, 5] = np.inf
    np.savez(d / "t1.npz", signals=x, sample_rate_hz=1000.0)
    labels = (d / "labels.csv").read_text().replace("t1.csv", "t1.npz")
    (d / "labels.csv").write_text(labels)


def _beyond_float32(d):
    x = class_signal("circle", "resin", 1, 1000.0)
    x[1, 40] = 1e300  # finite in float64, inf in the store's float32
    write_csv(d / "t1.csv", x)


def _npz_beyond_float32(d):
    (d / "t1.csv").unlink()
    x = class_signal("circle", "resin", 1, 1000.0)
    x[3, 9] = -1e39
    np.savez(d / "t1.npz", signals=x, sample_rate_hz=1000.0)
    labels = (d / "labels.csv").read_text().replace("t1.csv", "t1.npz")
    (d / "labels.csv").write_text(labels)


def _npz_rate_in_khz(d):
    """A rate of 1e-3 Hz would resample 2000 samples to two thousand million."""
    (d / "t1.csv").unlink()
    np.savez(d / "t1.npz", signals=class_signal("circle", "resin", 1, 1000.0), sample_rate_hz=1e-3)
    labels = (d / "labels.csv").read_text().replace("t1.csv", "t1.npz")
    (d / "labels.csv").write_text(labels)


def _slow_time_column(d):
    x = class_signal("circle", "resin", 1, 1000.0)
    write_csv(d / "t1.csv", x, header=("time_s", *CHANNELS), time_s=np.arange(x.shape[1]) * 5.0)


def _replace_in_labels(line: int, old: str, new: str):
    def edit(d):
        lines = (d / "labels.csv").read_text().splitlines()
        assert old in lines[line - 1]
        lines[line - 1] = lines[line - 1].replace(old, new)
        (d / "labels.csv").write_text("\n".join(lines) + "\n")

    return edit


def _duplicate_file(d):
    lines = (d / "labels.csv").read_text().splitlines()
    lines.append(lines[2])
    (d / "labels.csv").write_text("\n".join(lines) + "\n")


def _missing_file(d):
    (d / "t2.csv").unlink()


def _same_content(d):
    (d / "t2.csv").write_bytes((d / "t0.csv").read_bytes())


def _time_gap(d):
    x = class_signal("circle", "resin", 1, 1000.0, 2.5)
    t = np.arange(x.shape[1]) / 1000.0
    t[700:] += 0.003  # three samples lost
    write_csv(d / "t1.csv", x, header=("time_s", *CHANNELS), time_s=t)


BAD_CASES = {
    # name: (edit of the fixture, words the one-line message holds)
    "wrong channel count": (_bad_channels, ["t1.csv line 1 names 3 channels", "missing: sg2"]),
    "NaN sample": (_nan, ["t1.csv line 813, column sg1: nan"]),
    "non-numeric cell": (_non_numeric, ["t1.csv line 5, column pvdf2: 'abc' is not a number"]),
    "underscore in a sample": (
        _underscored_sample,
        ["t1.csv line 5, column pvdf2: '1_0' is not a number (underscores are not accepted"],
    ),
    "row with too few values": (_short_row, ["t1.csv line 10 has 3 values"]),
    "too short": (_too_short, ["t1.csv is 1.500 s long", "window of 2 s"]),
    "NPZ channel count": (_npz_channels, ["t1.npz holds 3 of the 4 channel arrays"]),
    "NPZ inf sample": (_npz_inf, ["t1.npz: channel pvdf1 at sample index 5 is inf"]),
    "sample beyond float32": (_beyond_float32, ["t1.csv line 42, column pvdf2: 1e+300 V"]),
    "NPZ sample beyond float32": (
        _npz_beyond_float32,
        ["t1.npz: channel sg2 at sample index 9 is -1e+39 V"],
    ),
    "NPZ rate in another unit": (
        _npz_rate_in_khz,
        ["t1.npz: array 'sample_rate_hz' 0.001 Hz is below 10 Hz"],
    ),
    "unknown label column": (
        _replace_in_labels(1, "material", "materal"),
        ["labels.csv line 1: column must be one of", "did you mean 'material'"],
    ),
    "bad shape name": (
        _replace_in_labels(3, "circle", "circle!"),
        ["labels.csv line 3: column shape must hold only lower-case letters, digits"],
    ),
    "bad material name": (
        _replace_in_labels(4, "resin", "res in"),
        ["labels.csv line 4: column material must hold only lower-case letters, digits"],
    ),
    "non-numeric force": (
        _replace_in_labels(2, ",1,10", ",heavy,10"),
        ["labels.csv line 2: column force_n: 'heavy' is not a number"],
    ),
    "underscore in a speed": (
        _replace_in_labels(2, ",1,10", ",1,1_0"),
        ["labels.csv line 2: column speed_mm_s: '1_0' is not a number (underscores are not"],
    ),
    "underscore in a seed": (
        _underscored_seed,
        ["labels.csv line 3: column seed: '2_000' is not a whole number (underscores are not"],
    ),
    "duplicate file": (_duplicate_file, ["labels.csv line 5: file t1.csv is listed again"]),
    "missing file": (_missing_file, ["labels.csv line 4: file t2.csv does not exist"]),
    "same recording twice": (_same_content, ["t2.csv (labels line 4) holds the same window"]),
    "time column gap": (_time_gap, ["t1.csv line 702: time_s steps by 0.004 s"]),
}


def test_a_recording_hours_long_is_refused_before_resampling(tmp_path, capsys):
    recs = tmp_path / "recs"
    small(recs, n=1)
    _slow_time_column(recs)  # the time column in another unit: 2000 samples, 10,000 s
    (recs / "t1.csv").rename(recs / "t0.csv")
    rc = main(["import", str(recs), "--out", str(tmp_path / "data")])
    err = last_line(capsys.readouterr().err)
    assert rc == 2
    assert "t0.csv: 2000 samples at 0.2 Hz last 10,000 s" in err
    assert not (tmp_path / "data").exists()


@pytest.mark.parametrize("case", list(BAD_CASES))
def test_bad_input_is_named_by_file_and_line_and_leaves_nothing(tmp_path, capsys, case):
    edit, words = BAD_CASES[case]
    recs = tmp_path / "recs"
    small(recs)
    edit(recs)
    out = tmp_path / "sub" / "data"
    rc = main(["import", str(recs), "--out", str(out), "--sample-rate", "1000"])
    err = last_line(capsys.readouterr().err)
    assert rc == 2 and err.startswith("tactile-synth import: error:")
    for w in words:
        assert w in err, err
    assert not (tmp_path / "sub").exists()  # not even the directory made for the lock


@pytest.mark.parametrize(
    ("option", "value", "words"),
    [
        ("--sample-rate", "1_000", "'1_000' is not a number (underscores are not accepted: "
         "write '1000' if that is the number meant)"),
        ("--window-start", "0_5", "'0_5' is not a number (underscores are not accepted"),
        ("--chunk-trials", "1_0", "'1_0' is not a whole number (underscores are not accepted"),
        ("--chunk-trials", "ten", "invalid int value: 'ten'"),  # as every integer option says
    ],
)  # fmt: skip
def test_numeric_options_refuse_underscores_naming_the_option(
    tmp_path, capsys, option, value, words
):
    recs = tmp_path / "recs"
    small(recs)
    out = tmp_path / "data"
    with pytest.raises(SystemExit) as exc:
        main(["import", str(recs), "--out", str(out), option, value])
    assert exc.value.code == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith(f"tactile-synth import: error: argument {option}: {words}"), last
    assert not out.exists()


def test_failed_overwrite_keeps_the_previous_dataset(tmp_path):
    recs = tmp_path / "recs"
    small(recs)
    out = tmp_path / "data"
    import_recordings(recs, out, sample_rate_hz=1000, progress=False)
    before = load_dataset(out)
    _nan(recs)
    with pytest.raises(RecordingError, match=r"t1\.csv line 813"):
        import_recordings(recs, out, sample_rate_hz=1000, overwrite=True, progress=False)
    after = load_dataset(out)
    assert np.array_equal(before.signals, after.signals)
    assert after.attrs["store_id"] == before.attrs["store_id"]
    assert leftovers(tmp_path, out) == ["data"]


def test_every_bad_line_is_listed(tmp_path):
    recs = tmp_path / "recs"
    small(recs, n=5)
    _replace_in_labels(3, "circle", "circle!")(recs)
    _replace_in_labels(5, ",10", ",fast")(recs)
    with pytest.raises(RecordingError) as exc:
        read_labels(recs / "labels.csv", recs)
    assert len(exc.value.problems) == 2
    assert "line 3" in exc.value.problems[0] and "line 5" in exc.value.problems[1]
    assert str(exc.value).startswith("2 problems: ")


@pytest.mark.parametrize(
    ("options", "column", "words"),
    [
        ({}, None, "states no sample rate"),
        ({"sample_rate_hz": 1000}, "1000", None),  # the column alone
        ({"sample_rate_hz": 500}, "1000", None),  # the column wins over the option
        ({"sample_rate_hz": -5}, None, "--sample-rate must be a finite number > 0"),
        (
            {"sample_rate_hz": 1e3, "window_start_s": 0.5},
            None,
            "ends after the recording's 2.000 s",
        ),
        ({"sample_rate_hz": 1e3, "chunk_trials": 0}, None, "--chunk-trials must be >= 1"),
    ],
)
def test_sample_rate_and_window_options(tmp_path, options, column, words):
    recs = tmp_path / "recs"
    small(recs, **({"sample_rate_hz": column} if column else {}))
    out = tmp_path / "data"
    if words is None:
        import_recordings(recs, out, progress=False, **options)
        assert load_dataset(out).attrs["import"]["trials"]["sample_rate_hz"] == [1000.0] * 3
        return
    with pytest.raises(ValueError, match=words):
        import_recordings(recs, out, progress=False, **options)
    assert leftovers(tmp_path, out) == []


def test_rates_that_disagree_are_refused(tmp_path):
    recs = tmp_path / "recs"
    small(recs, sample_rate_hz=2000)
    x = class_signal("circle", "resin", 0, 1000.0, 2.0)
    write_csv(recs / "t0.csv", x, header=("time_s", *CHANNELS), time_s=np.arange(2000) / 1000)
    with pytest.raises(RecordingError, match=r"t0.csv \(labels line 2\): labels line 2 says 2000"):
        import_recordings(recs, tmp_path / "data", progress=False)


def test_refuses_a_foreign_out_and_one_holding_the_recordings(tmp_path, capsys):
    recs = tmp_path / "recs"
    small(recs)
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep me")
    with pytest.raises(FileExistsError, match="not a tactile-synth dataset"):
        import_recordings(recs, foreign, sample_rate_hz=1000, overwrite=True, progress=False)
    assert (foreign / "notes.txt").read_text() == "keep me"
    assert main(["import", str(recs), "--out", str(foreign), "--sample-rate", "1000"]) == 2
    err = capsys.readouterr().err
    assert f"--out {foreign} exists and is not a tactile-synth dataset" in err
    assert "choose another --out" in err and "pass --overwrite" not in err
    assert (foreign / "notes.txt").read_text() == "keep me"
    with pytest.raises(ValueError, match="replacing it would delete them"):
        import_recordings(recs, tmp_path, sample_rate_hz=1000, overwrite=True, progress=False)
    data = tmp_path / "data"
    import_recordings(recs, data, sample_rate_hz=1000, progress=False)
    before = load_dataset(data).signals
    with pytest.raises(ValueError, match=rf"^--out {data / 'signals'} lies inside the dataset"):
        import_recordings(
            recs, data / "signals", sample_rate_hz=1000, overwrite=True, progress=False
        )
    assert np.array_equal(load_dataset(data).signals, before)


def test_an_import_with_damaged_metadata_is_sent_to_import_again(tmp_path, capsys):
    recs = tmp_path / "recs"
    small(recs)
    data = tmp_path / "data"
    import_recordings(recs, data, sample_rate_hz=1000, progress=False)
    meta = data / "zarr.json"
    meta.write_bytes(meta.read_bytes()[:-40])  # cut short: no longer JSON
    assert main(["inspect", str(data)]) == 2
    err = capsys.readouterr().err
    assert f"{meta} is damaged" in err and len(err.strip().splitlines()) == 1
    assert "`tactile-synth import` command plus --overwrite" in err and "generate" not in err


def test_unlisted_recordings_are_named_in_a_warning(tmp_path):
    recs = tmp_path / "recs"
    small(recs)
    write_csv(recs / "extra.csv", class_signal("circle", "resin", 9, 1000.0))
    write_labels(recs, [{"file": "t0.csv", "shape": "square"}], name="labels_old.csv")
    # another labels table beside the recordings is not one of them
    with pytest.warns(RecordingWarning, match=r"^1 recording file.*: extra\.csv$"):
        import_recordings(recs, tmp_path / "data", sample_rate_hz=1000, progress=False)


def test_a_lab_s_own_classes_import_with_their_names(tmp_path):
    # Any specimen and material name: the class list is what the table holds, the paper's
    # names in the paper's order first, then the others sorted by name.
    recs = tmp_path / "recs"
    recs.mkdir()
    rows = []
    for k, (shape, material) in enumerate(
        [("gear", "cork"), ("circle", "wood"), ("gear", "resin"), ("circle", "cork"),
         ("l_bracket", "resin"), ("circle", "resin")]
    ):  # fmt: skip
        write_csv(recs / f"t{k}.csv", class_signal("circle", "resin", k, 1000.0))
        rows.append({"file": f"t{k}.csv", "shape": shape, "material": material,
                     "force_n": 1, "speed_mm_s": 10})  # fmt: skip
    write_labels(recs, rows)
    import_recordings(recs, tmp_path / "data", sample_rate_hz=1000, progress=False)
    data = load_dataset(tmp_path / "data")
    assert data.classes == (
        "circle/resin", "circle/wood", "circle/cork", "gear/resin", "gear/cork",
        "l_bracket/resin",
    )  # fmt: skip
    assert [data.classes[i] for i in data.label] == list(data.classes)
    assert data.specimens == ("circle", "gear", "l_bracket")
    assert data.materials == ("resin", "wood", "cork")
    meta = store.read_meta(tmp_path / "data")
    assert meta["shapes"] == ["circle", "gear", "l_bracket"]
    assert meta["materials"] == ["resin", "wood", "cork"]


def test_a_name_close_to_the_paper_s_is_imported_with_a_warning(tmp_path):
    recs = tmp_path / "recs"
    small(recs)
    _replace_in_labels(3, "circle", "circel")(recs)
    with pytest.warns(RecordingWarning, match=r"shape 'circel' \(labels line 3\).*'circle'"):
        import_recordings(recs, tmp_path / "data", sample_rate_hz=1000, progress=False)
    assert load_dataset(tmp_path / "data").classes == ("circle/resin", "circel/resin")


# -- interruptions -------------------------------------------------------------------------
def interrupt_at_chunk(monkeypatch, chunk: int) -> None:
    """Make the import raise KeyboardInterrupt (Ctrl-C) just before it writes ``chunk``."""
    write = store.write_chunk

    def write_or_stop(path, k, *args, **kw):
        if k == chunk:
            raise KeyboardInterrupt
        return write(path, k, *args, **kw)

    monkeypatch.setattr(store, "write_chunk", write_or_stop)


def test_ctrl_c_leaves_nothing(tmp_path, monkeypatch, capsys):
    recs = tmp_path / "recs"
    small(recs)
    out = tmp_path / "sub" / "data"
    interrupt_at_chunk(monkeypatch, 1)
    argv = ["import", str(recs), "--out", str(out), "--sample-rate", "1000", "--chunk-trials", "1"]
    assert main(argv) == 130
    err = last_line(capsys.readouterr().err)
    assert "interrupted; nothing was written" in err
    assert not (tmp_path / "sub").exists()  # chunk 0 was written, yet nothing is left


def test_progress_is_plain_lines_off_a_terminal_and_none_before_a_recording_is_read(
    tmp_path, capsys
):
    recs = tmp_path / "recs"
    small(recs)
    argv = ["import", str(recs), "--out", str(tmp_path / "data"), "--sample-rate", "1000"]
    assert main([*argv, "--chunk-trials", "1"]) == 0
    err = capsys.readouterr().err
    assert progress_lines(err) == [(1, 3, 33), (2, 3, 66), (3, 3, 100)]
    assert len(err.strip().splitlines()) == 3 and "\r" not in err
    # a bad labels table stops the import before any recording is read: its line alone
    small(tmp_path / "bad", shape="circle!")
    assert main(["import", str(tmp_path / "bad"), "--out", str(tmp_path / "other")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "column shape must hold only" in err


def test_progress_on_a_terminal_stays_a_bar(tmp_path, monkeypatch):
    import io
    import sys

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    recs = tmp_path / "recs"
    small(recs)
    term = Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    argv = ["import", str(recs), "--out", str(tmp_path / "data"), "--sample-rate", "1000"]
    assert main(argv) == 0
    text = term.getvalue()
    assert "\r" in text and "3/3" in text and "[tactile-synth]" not in text


def test_ctrl_c_during_overwrite_keeps_the_previous_dataset(tmp_path, monkeypatch):
    recs = tmp_path / "recs"
    small(recs)
    out = tmp_path / "data"
    import_recordings(recs, out, sample_rate_hz=1000, progress=False)
    before = load_dataset(out)
    interrupt_at_chunk(monkeypatch, 2)
    with pytest.raises(KeyboardInterrupt):
        import_recordings(
            recs, out, sample_rate_hz=1000, chunk_trials=1, overwrite=True, progress=False
        )
    after = load_dataset(out)
    assert after.attrs["store_id"] == before.attrs["store_id"]
    assert np.array_equal(after.signals, before.signals)
    assert leftovers(tmp_path, out) == ["data"]


CTRL_C_IN_A_ZARR_WRITE = """
import asyncio, os, signal, sys, threading, time
from pathlib import Path
from zarr.storage import LocalStore
from synth import store
from tactile_synth.entry import main

out = Path(sys.argv[sys.argv.index("--out") + 1])
pending = store.pending_path(out)
real_set = LocalStore.set
written = threading.Event()

async def set_interrupted(self, key, value):
    # Ctrl-C while zarr's IO thread writes chunk 1's signals. The file is written once
    # the import has removed its unfinished copy, or after 2 s if it keeps it.
    if key.startswith("signals/c/1/") and not written.is_set():
        os.kill(os.getpid(), signal.SIGINT)
        deadline = time.monotonic() + 2
        while pending.exists() and time.monotonic() < deadline:
            await asyncio.sleep(0.01)
        try:
            return await real_set(self, key, value)
        finally:
            written.set()
    return await real_set(self, key, value)

LocalStore.set = set_interrupted
sys.argv[0] = "tactile-synth"
code = main()
written.wait(30)  # what zarr's IO thread still does for the interrupted import
sys.exit(code)
"""


def _recordings_and_previous(tmp_path: Path, previous: bool):
    """Recordings in ``tmp_path/recs`` and an ``--out`` at ``tmp_path/data`` that holds
    an earlier import of them when ``previous``: ``(recs, out, that dataset or None)``."""
    recs = tmp_path / "recs"
    small(recs)
    out = tmp_path / "data"
    before = None
    if previous:
        import_recordings(recs, out, sample_rate_hz=1000, progress=False)
        before = load_dataset(out)
    return recs, out, before


@pytest.mark.slow
@pytest.mark.parametrize("previous", [False, True])
def test_ctrl_c_in_a_zarr_write_leaves_no_unfinished_copy(tmp_path, previous):
    """A real SIGINT while zarr writes a chunk: the import stops after that write, so
    the unfinished copy beside ``--out`` is removed after zarr's last file, not before."""
    import os
    import signal
    import subprocess
    import sys

    recs, out, before = _recordings_and_previous(tmp_path, previous)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    argv = ["import", str(recs), "--out", str(out), "--sample-rate", "1000", "--chunk-trials",
            "1", "--overwrite"]  # fmt: skip
    proc = subprocess.run(
        [sys.executable, "-c", CTRL_C_IN_A_ZARR_WRITE, *argv],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        # a background job of a non-interactive shell inherits SIGINT ignored
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert proc.returncode == 130, proc.stderr
    assert proc.stderr.strip().splitlines()[-1] == (
        f"tactile-synth import: interrupted; nothing was written ({out} is as it was); run "
        f"the same command again"
    )
    assert leftovers(tmp_path, out) == (["data"] if previous else [])
    if previous:
        after = load_dataset(out)
        assert after.attrs["store_id"] == before.attrs["store_id"]


KILLED_IMPORT = """
import os, signal, sys
from synth import importer, store
write = store.write_chunk
def write_or_die(path, k, *args, **kw):
    if k == 2:
        os.kill(os.getpid(), signal.SIGKILL)
    return write(path, k, *args, **kw)
store.write_chunk = write_or_die
importer.import_recordings(sys.argv[1], sys.argv[2], sample_rate_hz=1000, chunk_trials=1,
                           overwrite=True, progress=False)
"""


@pytest.mark.parametrize("previous", [False, True])
def test_killed_import_leaves_no_dataset_and_the_next_one_cleans_up(tmp_path, previous):
    """A SIGKILL half-way (after two of three chunks) leaves ``--out`` as it was: absent,
    or the previous dataset; the next import removes the unfinished copy beside it."""
    import os
    import signal
    import subprocess
    import sys

    recs, out, before = _recordings_and_previous(tmp_path, previous)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    proc = subprocess.run(
        [sys.executable, "-c", KILLED_IMPORT, str(recs), str(out)],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    pending = store.pending_path(out)
    assert pending.exists()  # the unfinished copy, hidden beside --out
    if previous:
        after = load_dataset(out)
        assert after.attrs["store_id"] == before.attrs["store_id"]
        assert np.array_equal(after.signals, before.signals)
    else:
        assert not out.exists()
        with pytest.raises(FileNotFoundError, match=r"interrupted import .* run your"):
            load_dataset(out)
    with pytest.warns(RecordingWarning, match=r"^removed .*, the unfinished copy an interr"):
        import_recordings(recs, out, sample_rate_hz=1000, overwrite=True, progress=False)
    assert load_dataset(out).signals.shape == (3, len(CHANNELS), N_SAMPLES)
    assert leftovers(tmp_path, out) == ["data"]


def test_the_inspect_example_in_docs_shows_the_current_format_version():
    doc = (Path(__file__).resolve().parents[1] / "docs" / "recordings.md").read_text()
    shown = re.findall(r"^format +(\d+) \(", doc, flags=re.MULTILINE)
    assert shown and all(int(v) == store.FORMAT_VERSION for v in shown), shown
