"""Pretrain seconds and adapt ms per 5-way-5-shot episode of each method, measured the
same way for all (the closed-set protocol's split, ``evaluate`` timing over a batch).

    python3 scripts/bench_methods.py --data PATH [--methods ...] [--episodes 500]

Also times the feature pool on the whole dataset (target: 2,160 trials < 5 s), and prints
what each method chose on its training split (validated settings, MAML's meta-training
curve, CWT-ResNet-ML's epoch curve). "adapt ms/ep" is the wall time of the whole batch
of episodes divided by their number (episodes are adapted together, features
precomputed), not the latency of one episode on its own.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch
from script_args import check_methods, description, fail, load_data

from benchmark.episodes import sample_episodes
from benchmark.evaluate import evaluate
from benchmark.protocols.closed_set import split_halves
from models.features import extract
from models.registry import DEFAULT_METHODS, make_method
from tactile_synth.validation import int_arg

#: Learned attributes that record what a method chose on its training split.
CHOICES = (
    "schedule_",
    "inner_lr_",
    "lr_probe_",
    "test_steps_",
    "test_step_scores_",
    "best_iteration_",
    "iterations_",
    "plateaued_",
    "meta_curve_",
    "epochs_",
    "epoch_curve_",
)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--data", required=True)
    parser.add_argument("--methods", nargs="+", default=list(DEFAULT_METHODS))
    parser.add_argument("--episodes", type=int_arg, default=500)
    parser.add_argument("--seed", type=int_arg, default=0)
    args = parser.parse_args(argv)
    if args.episodes < 1:
        fail(parser, f"--episodes must be >= 1; got {args.episodes}")
    methods = check_methods(parser, args.methods)
    data = load_data(parser, args.data)
    train, test = split_halves(data.label, seed=args.seed)
    # 5-way episodes of 5 supports and 5 queries per class, drawn from the test half.
    per_class = np.unique(data.label[test], return_counts=True)[1]
    if np.count_nonzero(per_class >= 10) < 5:
        fail(
            parser,
            f"--data {args.data} is too small: 5-way 5-shot episodes with 5 queries need 10 "
            f"trials per class in 5 classes of the test half (20 per class in the dataset); "
            f"its test half has {per_class.min()}-{per_class.max()} per class",
        )
    print(f"{len(data)} trials; torch threads {torch.get_num_threads()}")
    t0 = time.perf_counter()
    feats = extract(data.signals)
    print(f"feature pool: {time.perf_counter() - t0:.2f} s for {len(data)} trials")
    batch = sample_episodes(
        data.label[test], n_way=5, k_shot=5, n_query=5, episodes=args.episodes, seed=1
    )
    print(f"{'method':16s} {'pretrain s':>10s} {'adapt ms/ep':>12s} {'5w5s acc':>9s}")
    for name in methods:
        model = make_method(name, seed=args.seed)
        t0 = time.perf_counter()
        model.fit(data.signals[train], data.label[train], features=feats[train])
        pretrain = time.perf_counter() - t0
        r = evaluate(model, data.signals[test], batch, features=feats[test])
        print(
            f"{name:16s} {pretrain:10.2f} {r.adapt_ms_per_episode:12.2f} "
            f"{100 * r.accuracy:6.2f} ± {100 * r.ci95:.2f}",
            flush=True,
        )
        for attr in CHOICES:
            value = getattr(model, attr, None)
            if value is not None:
                if attr == "schedule_":  # the settings; the curves are long
                    value = [vars(setting) for setting in value.settings]
                text = np.array2string(value, precision=3) if hasattr(value, "ndim") else value
                print(f"    {attr}: {text}", flush=True)


if __name__ == "__main__":
    main()
