"""Pretrain seconds and adapt ms per 5-way-5-shot episode of each method, measured the
same way for all (the closed-set protocol's split, ``evaluate`` timing over a batch).

    python3 scripts/bench_methods.py --data PATH [--methods ...] [--episodes 500] [--compare]

Also times the feature pool on the whole dataset (target: 2,160 trials < 5 s), and prints
what each method chose on its training split (validated settings, MAML's meta-training
curve, CWT-ResNet-ML's epoch curve). "adapt ms/ep" is the batched throughput: the wall
time of the whole batch of episodes divided by their number (episodes are adapted
together, features precomputed). "latency ms" is the single-episode latency: the mean
wall time of adapting one episode at a time on a pool of its own trials
(:func:`benchmark.evaluate.single_episode_latency`, the first ``--latency`` episodes).

``--compare`` also adapts the same episodes by the earlier path of the adapted cosine
head (512 episodes per chunk, :data:`models.prototypes.EPISODE_CHUNK`, instead of the
cache-sized chunks of :func:`models.prototypes.head_chunk`) for every method that uses
the head, and a 36-way 5-shot batch beside the 5-way 5-shot one (the head's chunks
differ most on the largest episodes): old and new ms per episode and whether the
predictions are identical.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch
from script_args import check_methods, description, fail, load_data

import models.prototypes as prototypes
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
    parser.add_argument(
        "--latency", type=int_arg, default=10, help="episodes timed one at a time (0: none)"
    )
    parser.add_argument(
        "--compare", action="store_true", help="also time the head's earlier chunking"
    )
    args = parser.parse_args(argv)
    if args.episodes < 1:
        fail(parser, f"--episodes must be >= 1; got {args.episodes}")
    if args.latency < 0:
        fail(parser, f"--latency must be >= 0; got {args.latency}")
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
    wide = None
    if args.compare and np.count_nonzero(per_class >= 10) >= 36:
        wide = sample_episodes(
            data.label[test], n_way=36, k_shot=5, n_query=5, episodes=args.episodes, seed=1
        )
    print(
        f"{'method':16s} {'pretrain s':>10s} {'adapt ms/ep':>12s} {'latency ms':>10s} "
        f"{'5w5s acc':>9s}"
    )
    for name in methods:
        model = make_method(name, seed=args.seed)
        t0 = time.perf_counter()
        model.fit(data.signals[train], data.label[train], features=feats[train])
        pretrain = time.perf_counter() - t0
        r = evaluate(
            model, data.signals[test], batch, features=feats[test], latency_episodes=args.latency
        )
        latency = "-" if r.latency_ms_per_episode is None else f"{r.latency_ms_per_episode:.2f}"
        print(
            f"{name:16s} {pretrain:10.2f} {r.adapt_ms_per_episode:12.2f} {latency:>10s} "
            f"{100 * r.accuracy:6.2f} ± {100 * r.ci95:.2f}",
            flush=True,
        )
        if args.compare:
            for b in (batch, wide):
                if b is not None:
                    _compare(name, model, data.signals[test], b, feats[test])
        for attr in CHOICES:
            value = getattr(model, attr, None)
            if value is not None:
                if attr == "schedule_":  # the settings; the curves are long
                    value = [vars(setting) for setting in value.settings]
                text = np.array2string(value, precision=3) if hasattr(value, "ndim") else value
                print(f"    {attr}: {text}", flush=True)


#: The methods whose episodes the adapted cosine head labels (what ``--compare`` times).
HEAD_METHODS = ("AFOP-ML", "Direct-Prot-ML", "CWT-ResNet-ML")
#: Alternating rounds of each path in ``--compare``.
ROUNDS = 2


def _compare(name, model, signals, batch, feats) -> None:
    """Time ``batch`` by the head's earlier chunking (512 episodes) and by the current one,
    in turn on the same episodes, and say whether the predictions are identical."""
    if name not in HEAD_METHODS:
        return
    timed: dict[str, list] = {"old": [], "new": []}
    saved = prototypes.HEAD_FLOATS
    # Old and new alternate, ROUNDS times each, and each is read at its fastest round: a
    # burst of load on a shared machine then slows one round, not one path.
    for _ in range(ROUNDS):
        for path, floats in (("old", 2**62), ("new", saved)):
            # With no cache budget (old), head_chunk gives EPISODE_CHUNK episodes per chunk.
            prototypes.HEAD_FLOATS = floats
            try:
                timed[path].append(evaluate(model, signals, batch, features=feats))
            finally:
                prototypes.HEAD_FLOATS = saved
    old_ms = min(r.adapt_ms_per_episode for r in timed["old"])
    new_ms = min(r.adapt_ms_per_episode for r in timed["new"])
    old, new = timed["old"][0], timed["new"][0]
    same = np.array_equal(old.predictions, new.predictions)
    print(
        f"    compare {batch.n_way}-way {batch.k_shot}-shot, {batch.episodes} episodes: "
        f"head in chunks of {prototypes.EPISODE_CHUNK} {old_ms:.2f} ms/ep, cache-sized "
        f"chunks {new_ms:.2f} ms/ep ({old_ms / new_ms:.2f}x, fastest of {ROUNDS} "
        f"alternating rounds); predictions {'identical' if same else 'differ'} "
        f"({100 * old.accuracy:.2f} % vs {100 * new.accuracy:.2f} %)",
        flush=True,
    )


if __name__ == "__main__":
    main()
