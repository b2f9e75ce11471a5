"""Time the per-episode networks' training with the gradient written out (as shipped)
against autograd's path of the same method on the same episodes, and count the
predictions that differ.

    python3 scripts/bench_trainers.py
    python3 scripts/bench_trainers.py --episodes 256 --rounds 3 --json

Networks: the BiLSTM baseline (backpropagation through time written out,
:func:`models.bilstm.bilstm_grads`) and AFO-MLP-ML's MLP with the cosine head
(:func:`models.afo_mlp.mlp_head_grads`). Both paths train every chunk of episodes as one
stacked problem from the same initialisation (:func:`models.nets.train_per_episode`,
the same seed): the shipped path steps the written-out gradient with torch.optim's fused
Adam kernel, the autograd path (the network with ``grads=None``) differentiates
``forward`` and steps ``torch.optim.Adam``. Inputs are Gaussian class clusters of the
networks' input shapes (25 frames x 60 frame features; 64 features for the MLP), the
episodes 5- and 36-way, 1 and 5 shots, at the validated step counts the paper preset's
schedules pick for those cells. Adam divides each gradient by its own running scale, so
the two paths' rounding can flip a prediction near a tie; the rows give the number and
both paths' accuracies. Rounds alternate the paths and the fastest round of each is
reported, in one process with one torch thread (as in a benchmark's worker processes).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time

import numpy as np
import torch
from bench_head import compared
from script_args import description, fail

from tactile_synth.validation import int_arg

#: (way, shot, Adam steps, learning rate) of the episodes.
CELLS = ((5, 1, 10, 3e-2), (5, 5, 10, 3e-2), (36, 1, 40, 3e-2), (36, 5, 40, 3e-2))


def networks():
    """``name -> (EpisodeNet, input shape of one trial)`` of the networks timed."""
    from models import afo_mlp, bilstm

    frame_dim = 4 * (1 + len(bilstm.BANDS))
    return {
        "BiLSTM": (bilstm._net(frame_dim), (bilstm.FRAMES, frame_dim)),
        "AFO-MLP-ML": (afo_mlp.episode_net(64, alpha=10.0, lam=0.10), (64,)),
    }


def episodes_of(shape: tuple[int, ...], n_way: int, k_shot: int, episodes: int, seed: int):
    """Clustered inputs (36 classes x 10 trials) and episodes drawn from them."""
    from models.episodes import sample_episodes

    rng = np.random.default_rng(seed)
    labels = np.repeat(np.arange(36), 10)
    centres = rng.normal(size=(36, *shape))
    x = (centres[labels] + 2.0 * rng.normal(size=(labels.size, *shape))).astype(np.float32)
    batch = sample_episodes(
        labels, n_way=n_way, k_shot=k_shot, n_query=2, episodes=episodes, seed=seed
    )
    return torch.as_tensor(x), batch


def measure(episodes: int, rounds: int, seed: int, cells=CELLS) -> list[dict]:
    from models.nets import train_per_episode

    rows = []
    for name, (net, shape) in networks().items():
        paths = {"autograd": dataclasses.replace(net, grads=None), "shipped": net}
        for n_way, k_shot, steps, lr in cells:
            x, batch = episodes_of(shape, n_way, k_shot, episodes, seed)
            best = dict.fromkeys(paths, np.inf)
            out = {}
            for _ in range(rounds):
                for path, path_net in paths.items():
                    t0 = time.perf_counter()
                    out[path] = train_per_episode(
                        path_net, x, batch.support, batch.query, steps=steps, lr=lr, seed=seed
                    )
                    best[path] = min(best[path], time.perf_counter() - t0)
            rows.append(
                {
                    "network": name,
                    "way": n_way,
                    "shot": k_shot,
                    "steps": steps,
                    "episodes": episodes,
                    **compared(best, out, batch.query_labels, episodes),
                }
            )
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--episodes", type=int_arg, default=256, help="episodes per cell")
    parser.add_argument("--rounds", type=int_arg, default=3, help="alternating rounds")
    parser.add_argument("--seed", type=int_arg, default=0)
    parser.add_argument("--json", action="store_true", help="print the rows as JSON")
    args = parser.parse_args(argv)
    for name in ("episodes", "rounds"):
        if getattr(args, name) < 1:
            fail(parser, f"--{name} must be at least 1, got {getattr(args, name)}")
    torch.set_num_threads(1)
    rows = measure(args.episodes, args.rounds, args.seed)
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    print(
        "network      way shot steps  autograd ms/ep  shipped ms/ep  speed-up"
        "  differing predictions  accuracy % autograd / shipped"
    )
    for r in rows:
        print(
            f"{r['network']:<11} {r['way']:>4} {r['shot']:>4} {r['steps']:>5}"
            f"  {r['autograd_ms_per_episode']:>14.2f}  {r['shipped_ms_per_episode']:>13.2f}"
            f"  {r['speedup']:>7.2f}x  {r['predictions_differing']:>9} of {r['predictions']:<9}"
            f"  {r['autograd_accuracy_pct']:.2f} / {r['shipped_accuracy_pct']:.2f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
