"""Timing of AFOP-ML's stages against their targets.

    python3 scripts/bench_afop.py [--data PATH] [--threads 1] [--episodes 500] [--repeat 3]

1. feature pool on 2,160 trials x 4 channels x 2,000 samples (target < 5 s on one core);
2. pretrain = z-scoring + NCA ranking (fscnca, the tuned lambda and L-BFGS iterations) +
   D-scan on the closed-set training half (target < 2 s, the paper's ~2 s);
3. single-episode latency of a 5-way-5-shot episode (one episode at a time, as the paper's
   Table I "Adapt/episode" of 391 ms), without and with extracting the episode's features;
4. batched throughput: 500 episodes adapted in one call, wall time / 500 (target <= 3.9
   ms, 100x below the paper's per-episode 391 ms; an amortised figure, not a latency).

Without ``--data`` the signals come from ``tests/synthetic_data.make_dataset`` (60 trials
per class, 36 classes = 2,160 trials; timings do not depend on the signal content except
the NCA's L-BFGS iteration count). ``--threads`` caps BLAS/OpenMP and torch threads
(``tactile_synth.threads.configure``); the minimum over ``--repeat`` runs is reported.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from tactile_synth import threads
from tactile_synth.validation import int_arg


def _parse() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", help="dataset (default: synthetic 2,160 trials)")
    parser.add_argument("--threads", type=int_arg, default=1, help="BLAS/torch threads (default 1)")
    parser.add_argument(
        "--episodes", type=int_arg, default=500, help="adapt episodes (default 500)"
    )
    parser.add_argument("--repeat", type=int_arg, default=3, help="runs per stage; min reported")
    parser.add_argument("--seed", type=int_arg, default=0)
    return parser.parse_args()


def main() -> None:
    args = _parse()
    # numpy is loaded already (the option parser's tactile_synth.validation): configure resizes
    # its BLAS pool and sets every pool loaded later.
    threads.configure(threads=args.threads)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

    import torch

    from benchmark.episodes import sample_episodes
    from benchmark.evaluate import evaluate
    from benchmark.protocols.closed_set import split_halves
    from models.afop import AFOPML
    from models.features import extract

    torch.set_num_threads(args.threads)
    if args.data:
        from synth import load_dataset

        data = load_dataset(args.data)
        source = args.data
    else:
        from tests.synthetic_data import make_dataset

        data = make_dataset(trials_per_class=60, seed=args.seed)
        source = "tests/synthetic_data.make_dataset(trials_per_class=60)"
    print(f"data: {source}: signals {data.signals.shape} {data.signals.dtype}")
    print(f"threads: {args.threads} (torch {torch.get_num_threads()}), repeat {args.repeat}")

    times = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        feats = extract(data.signals)
        times.append(time.perf_counter() - t0)
    print(f"features  : {min(times):7.2f} s   -> {feats.shape} (target < 5 s)")

    train, test = split_halves(data.label, seed=args.seed)
    times = []
    for _ in range(args.repeat):
        model = AFOPML(seed=args.seed)
        t0 = time.perf_counter()
        model.fit(data.signals[train], data.label[train], features=feats[train])
        times.append(time.perf_counter() - t0)
    print(
        f"pretrain  : {min(times):7.2f} s   on {len(train)} trials, D = {model.D_}, NCA "
        f"{model.ncfs_.n_iter_} L-BFGS iterations (target < 2 s)"
    )

    batch = sample_episodes(
        data.label[test], n_way=5, k_shot=5, n_query=5, episodes=args.episodes, seed=1
    )
    best = None
    for _ in range(args.repeat):
        r = evaluate(model, data.signals[test], batch, features=feats[test], latency_episodes=20)
        if best is None or r.batch_ms_per_episode < best.batch_ms_per_episode:
            best = r
    print(
        f"latency   : {best.latency_ms_per_episode:7.2f} ms per 5-way-5-shot episode, one at a "
        f"time, features precomputed; {best.latency_with_features_ms_per_episode:.2f} ms "
        f"including the episode's feature extraction (mean of {best.latency_episodes}; paper "
        "391 ms)"
    )
    print(
        f"batched   : {best.batch_ms_per_episode:7.2f} ms/episode, {best.episodes} 5-way-5-shot "
        f"episodes adapted in one call (throughput, target <= 3.9 ms); accuracy "
        f"{100 * best.accuracy:.2f} +- {100 * best.ci95:.2f} %"
    )


if __name__ == "__main__":
    main()
