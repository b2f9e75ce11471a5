"""Time the 386-feature pool on one core, next to tsfresh's comparable statistics.

    python3 scripts/bench_features.py --data PATH [--tsfresh-trials 216]

Target: the 2,160-trial paper dataset in under 5 s on one core. The process is
pinned to one CPU and BLAS/OpenMP pools to one thread before numpy is imported.

Speed reference: tsfresh (not a dependency; install it in a separate environment, e.g.
``python3 -m venv --system-site-packages /tmp/tsf && /tmp/tsf/bin/pip install tsfresh``
and run this script with ``/tmp/tsf/bin/python``). tsfresh computes the time-domain
statistics our pool shares with it (listed in ``TSFRESH_PARAMS``: 25 per channel, 4
channels) on the first ``--tsfresh-trials`` trials with ``n_jobs=0`` (no process pool);
its time is reported as measured and scaled linearly to the whole dataset, and its
mean/std/max values are checked against ours. tsfresh has no discrete wavelet transform
statistics, so the frequency-domain half of the pool has no reference.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"
if hasattr(os, "sched_setaffinity"):
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from script_args import description, fail, load_data  # noqa: E402

from models.features import CHANNELS, FEATURE_NAMES, extract  # noqa: E402
from tactile_synth.validation import int_arg  # noqa: E402

#: tsfresh calculators with a counterpart in our time-domain statistics (25 per channel).
TSFRESH_PARAMS: dict = {
    "mean": None,
    "standard_deviation": None,
    "variance": None,
    "root_mean_square": None,
    "minimum": None,
    "maximum": None,
    "absolute_maximum": None,
    "median": None,
    "quantile": [{"q": q} for q in (0.05, 0.1, 0.25, 0.75, 0.9, 0.95)],
    "skewness": None,
    "kurtosis": None,
    "abs_energy": None,
    "mean_abs_change": None,
    "number_crossing_m": [{"m": 0}],
    "autocorrelation": [{"lag": 1}, {"lag": 10}, {"lag": 100}],
    "first_location_of_maximum": None,
    "first_location_of_minimum": None,
    "linear_trend": [{"attr": "slope"}],
}


def bench_ours(signals: np.ndarray, repeats: int) -> float:
    extract(signals[:8])  # warm-up (imports, pywt tables)
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        feats = extract(signals)
        best = min(best, time.perf_counter() - t0)
    assert feats.shape == (len(signals), len(FEATURE_NAMES)) and np.isfinite(feats).all()
    return best


def bench_tsfresh(signals: np.ndarray) -> tuple[float, int]:
    import pandas as pd
    from tsfresh import extract_features

    n, c, t = signals.shape
    frame = pd.DataFrame(
        {
            "id": np.repeat(np.arange(n), t),
            "time": np.tile(np.arange(t), n),
            **{CHANNELS[k]: signals[:, k, :].reshape(-1) for k in range(c)},
        }
    )
    t0 = time.perf_counter()
    out = extract_features(
        frame,
        column_id="id",
        column_sort="time",
        default_fc_parameters=TSFRESH_PARAMS,
        n_jobs=0,
        disable_progressbar=True,
    )
    wall = time.perf_counter() - t0
    ours = extract(signals)
    for stat, theirs in (("mean", "mean"), ("std", "standard_deviation"), ("max", "maximum")):
        for ch in CHANNELS:
            a = ours[:, FEATURE_NAMES.index(f"{ch}.time.{stat}")]
            b = out[f"{ch}__{theirs}"].to_numpy()
            np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-9, err_msg=f"{ch} {stat}")
    return wall, out.shape[1]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--data", required=True, help="a dataset (e.g. the paper preset)")
    parser.add_argument("--repeats", type=int_arg, default=3)
    parser.add_argument("--tsfresh-trials", type=int_arg, default=216)
    args = parser.parse_args(argv)
    if args.repeats < 1 or args.tsfresh_trials < 1:
        fail(parser, "--repeats and --tsfresh-trials must be >= 1")
    data = load_data(parser, args.data)
    sig = data.signals
    n = len(sig)
    ours = bench_ours(sig, args.repeats)
    print(
        f"models.features.extract: {n} trials x {len(FEATURE_NAMES)} features in {ours:.2f} s "
        f"on one core (best of {args.repeats}) -> {1e3 * ours / n:.2f} ms/trial"
    )
    try:
        import tsfresh
    except ImportError:
        print("tsfresh not installed: no reference figure (see this script's docstring)")
        return
    m = min(args.tsfresh_trials, n)
    wall, n_feat = bench_tsfresh(sig[:m])
    per_trial = wall / m
    print(
        f"tsfresh {tsfresh.__version__} comparable statistics: {m} trials x {n_feat} features "
        f"in {wall:.2f} s -> {1e3 * per_trial:.2f} ms/trial, {per_trial * n:.1f} s scaled to "
        f"{n} trials; mean/std/max agree with ours"
    )
    print(
        f"per trial: ours {1e3 * ours / n:.2f} ms for {len(FEATURE_NAMES)} features vs tsfresh "
        f"{1e3 * per_trial:.2f} ms for {n_feat} ({per_trial / (ours / n):.0f}x)"
    )


if __name__ == "__main__":
    main()
