"""Time the closed-set table (11 Table I columns) per method, and project it to 500 episodes.

    python3 scripts/bench_closed_set.py --data PATH                 # every method, 500 eps
    python3 scripts/bench_closed_set.py --data PATH --episodes 50   # measure 50, project 500

Target: the full closed-set table of every method (the paper's seven and the variants
beyond the paper; 11 columns x 500 episodes, the same budget for every method) within
15 minutes on a 2-core machine. For each method this runs the closed-set protocol alone
(fit on the training half, every column on the test half) and prints its wall time split
into pretrain (``fit``, including any validation-based choice of settings) and evaluation
(all columns), and the CPU time of this process (the same split), which a shared machine
distorts less than the wall time. With ``--episodes E`` below 500 the evaluation part is
scaled by 500 / E (episodes are evaluated in fixed-size chunks, so the cost is about
linear in the episode count); pretrain and the single-episode latency timings (a fixed
number of episodes, however many the columns hold) are not scaled. The 386-feature pool is computed
once beforehand and reported separately, as the protocol receives it. The methods run
one after the other in this process; the total is their sum.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import torch
from script_args import check_methods, description, fail, load_data

from benchmark import protocols
from benchmark.protocols.closed_set import columns_for, split_halves
from models.features import extract
from models.registry import DEFAULT_METHODS
from tactile_synth.validation import int_arg

TARGET_EPISODES = 500
TARGET_S = 15 * 60


#: CPU seconds of each method's last fit in this process (read by :func:`main`).
_FIT_CPU: dict[str, float] = {}


def _time_fits() -> None:
    """Record the CPU time of every fit (``FewShotMethod.fit``) in :data:`_FIT_CPU`."""
    from models.base import FewShotMethod

    fit = FewShotMethod.fit

    def timed(self, *args, **kwargs):
        c0 = time.process_time()
        try:
            return fit(self, *args, **kwargs)
        finally:
            _FIT_CPU[self.name] = time.process_time() - c0

    FewShotMethod.fit = timed


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--data", required=True)
    parser.add_argument("--methods", nargs="+", default=list(DEFAULT_METHODS))
    parser.add_argument("--episodes", type=int_arg, default=TARGET_EPISODES)
    parser.add_argument("--seed", type=int_arg, default=0)
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    args = parser.parse_args(argv)
    if not 1 <= args.episodes <= TARGET_EPISODES:
        fail(parser, f"--episodes must be in 1..{TARGET_EPISODES}; got {args.episodes}")
    methods = check_methods(parser, args.methods)
    _time_fits()
    data = load_data(parser, args.data)
    _, test = split_halves(data.label, seed=args.seed)
    if not columns_for(data.label[test]):
        fail(
            parser,
            f"--data {args.data} is too small: its test half holds no Table I column "
            "(each needs at least 5 classes with 2 test trials)",
        )
    t0 = time.perf_counter()
    feats = extract(data.signals)
    feat_s = time.perf_counter() - t0
    scale = TARGET_EPISODES / args.episodes
    print(
        f"{len(data)} trials; feature pool {feat_s:.1f} s; {args.episodes} episodes per column; "
        f"torch threads {torch.get_num_threads()}; wall-clock seconds"
    )
    print(
        f"{'method':16s} {'pretrain s':>10s} {'eval s':>8s} {'total s':>8s} {'at 500 eps':>10s}"
        f" {'CPU pretrain s':>14s} {'CPU eval s':>10s} {'CPU at 500':>10s}"
    )
    rows = []
    for name in methods:
        t0, c0 = time.perf_counter(), time.process_time()
        records = protocols.run(
            "closed-set",
            data,
            methods=(name,),
            episodes=args.episodes,
            seed=args.seed,
            features=feats,
        )
        wall = time.perf_counter() - t0
        cpu = time.process_time() - c0
        pretrain = next(r["pretrain_s"] for r in records if r.get("pretrain_s") is not None)
        cpu_pretrain = _FIT_CPU.pop(name, 0.0)
        evaluation = wall - pretrain
        cpu_eval = cpu - cpu_pretrain
        # The single-episode latencies (5-way 5-shot column, a fixed number of episodes
        # timed one at a time) do not grow with --episodes: only the rest is scaled.
        latency = sum(
            (
                (r.get("latency_ms_per_episode") or 0.0)
                + (r.get("latency_with_features_ms_per_episode") or 0.0)
            )
            * (r.get("latency_episodes") or 0)
            / 1e3
            for r in records
        )
        projected = pretrain + latency + max(0.0, evaluation - latency) * scale
        cols = sum(1 for r in records if r.get("accuracy") is not None)
        rows.append(
            {
                "method": name,
                "columns": cols,
                "pretrain_s": pretrain,
                "eval_s": evaluation,
                "wall_s": wall,
                "projected_500_s": projected,
                "cpu_pretrain_s": cpu_pretrain,
                "cpu_eval_s": cpu_eval,
                "cpu_projected_500_s": cpu_pretrain + cpu_eval * scale,
            }
        )
        print(
            f"{name:16s} {pretrain:10.1f} {evaluation:8.1f} {wall:8.1f} {projected:10.1f}"
            f" {cpu_pretrain:14.1f} {cpu_eval:10.1f} {cpu_pretrain + cpu_eval * scale:10.1f}",
            flush=True,
        )
    total = feat_s + sum(r["projected_500_s"] for r in rows)
    cpu_total = sum(r["cpu_projected_500_s"] for r in rows)
    kind = "measured" if scale == 1 else f"projected from {args.episodes} episodes"
    print(
        f"closed-set table, {len(rows)} methods x 11 columns x {TARGET_EPISODES} episodes: "
        f"{total / 60:.1f} min ({kind}; CPU of the methods {cpu_total / 60:.1f} min); target "
        f"{TARGET_S // 60} min"
    )
    if args.json:
        Path(args.json).write_text(
            json.dumps(
                {
                    "episodes": args.episodes,
                    "threads": torch.get_num_threads(),
                    "feature_s": feat_s,
                    "rows": rows,
                },
                indent=2,
            )
        )


if __name__ == "__main__":
    main()
