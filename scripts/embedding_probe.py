"""What a fitted method's embedding tells apart: leave-one-out 1-NN of class, shape and
material on its embedding of the closed-set test half, for each method that has one.

    python3 scripts/embedding_probe.py --data data/paper
    python3 scripts/embedding_probe.py --data data/paper --methods MAML --seed 1

Each method is fitted as the closed-set protocol fits it (on the seeded 50:50 training
half of every class, ``benchmark.splits.split_halves``) and embeds the test half:
AFOP-ML its top-D z-scored features, MAML its meta-learned body's pooled channels (what
a test episode's zero head first reads, before any adaptation step). Each dimension of
the embedding is z-scored over the test half, and every trial's nearest other trial
(Euclidean, ``benchmark.diagnose.nearest``) votes for its class, its shape and its
material; chance is what a uniformly random other trial would score. An episode of all
36 classes needs both the shape and the material: an embedding that holds the shapes
but not the materials leaves a 36-way row near a third.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from script_args import check_methods, description, fail, load_data

from tactile_synth.validation import int_arg

#: The built-in methods with an ``embed`` method, in Table I's order.
EMBEDDING_METHODS = ("AFOP-ML", "MAML")


def probe(embedding: np.ndarray, classes: np.ndarray) -> dict[str, tuple[float, float]]:
    """``{label: (accuracy, chance)}`` of leave-one-out 1-NN on ``embedding`` ``(n, d)``
    for the class names ``classes`` ``(n,)`` ("<specimen>/<material>"), their specimen
    and their material."""
    from benchmark.diagnose.nearest import loo_nearest, loo_score

    z = np.asarray(embedding, dtype=np.float64)
    spread = z.std(axis=0)
    z = (z - z.mean(axis=0)) / np.where(spread > 0, spread, 1.0)
    nearest = loo_nearest(z)
    names = np.asarray(classes, dtype=str)
    parts = np.char.partition(names, "/")
    labels = {"class": names, "shape": parts[:, 0], "material": parts[:, 2]}
    out = {}
    for key, lab in labels.items():
        score = loo_score(nearest, lab)
        out[key] = (score.accuracy, score.chance)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--data", required=True, help="a dataset (tactile-synth generate)")
    parser.add_argument(
        "--methods",
        nargs="+",
        default=list(EMBEDDING_METHODS),
        help=f"methods with an embedding: {', '.join(EMBEDDING_METHODS)} (default: both)",
    )
    parser.add_argument("--seed", type=int_arg, default=0, help="the split's and fits' seed")
    args = parser.parse_args(argv)
    if args.seed < 0:
        fail(parser, f"--seed must be at least 0; got {args.seed}")
    methods = check_methods(parser, args.methods)
    without = [m for m in methods if m not in EMBEDDING_METHODS]
    if without:
        fail(
            parser,
            f"--methods {', '.join(without)} has no embedding to probe; "
            f"choose from {', '.join(EMBEDDING_METHODS)}",
        )
    data = load_data(parser, args.data)

    from benchmark.splits import split_halves
    from models.registry import make_method

    train, test = split_halves(data.label, seed=args.seed)
    if test.size < 2 or np.unique(data.label[train]).size < 2:
        fail(parser, f"--data {args.data} is too small: each half needs trials of 2 classes")
    classes = np.asarray(data.classes)[data.label[test]]
    print(f"{args.data}: {train.size} training trials, {test.size} test trials, seed {args.seed}")
    print("| method | dim | class 1-NN (chance) | shape 1-NN (chance) | material 1-NN (chance) |")
    print("|---|---|---|---|---|")
    for name in methods:
        method = make_method(name, seed=args.seed)
        method.fit(data.signals[train], data.label[train])
        embedding = method.embed(data.signals[test])
        scores = probe(embedding, classes)
        cells = " | ".join(f"{acc:.3f} ({chance:.3f})" for acc, chance in scores.values())
        print(f"| {name} | {embedding.shape[1]} | {cells} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
