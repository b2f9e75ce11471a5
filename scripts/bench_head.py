"""Time the adapted cosine head (AFOP-ML's and Direct-Prot-ML's episodic head) against a
step-by-step reference of the same method on the same episodes, and check that both
predict the same classes.

    python3 scripts/bench_head.py
    python3 scripts/bench_head.py --episodes 128 --rounds 3 --json

The reference (:func:`reference_head`) applies Adam's update by hand and differentiates
through the normalised rows of ``W``; the shipped head
(:func:`models.prototypes.adapt_cosine_head`) applies torch.optim's fused Adam and never
forms the normalised rows. Features are 386-d Gaussian class clusters (the size of the
feature pool Direct-Prot-ML reads), the episodes 5- and 36-way, 1 and 5 shots, the
paper's 250 steps. Rounds alternate the two paths and the fastest round of each is
reported, in one process with torch's default threads.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np
import torch
from script_args import description, fail

from tactile_synth.validation import int_arg

SHAPES = ((5, 1), (5, 5), (36, 1), (36, 5))


def reference_head(features, support, query, *, steps=250, lr=1.5e-3, lam=0.10, alpha=10.0):
    """The head written step by step: explicit Adam moments, the normalised rows of W."""
    from models.prototypes import normalise, prototypes

    f = torch.as_tensor(np.ascontiguousarray(features, dtype=np.float32))
    e, n_way, k_shot = support.shape
    n_support = n_way * k_shot
    onehot = torch.eye(n_way).repeat_interleave(k_shot, dim=0)
    with torch.no_grad():
        xs = normalise(f[torch.as_tensor(support)].reshape(e, n_support, -1))
        w = normalise(prototypes(f, support))
        b = torch.zeros(e, 1, n_way)
        mw, vw, mb, vb = (torch.zeros_like(t) for t in (w, w, b, b))
        for step in range(1, steps + 1):
            norm = w.norm(dim=-1, keepdim=True).clamp_min(1e-12)
            w_hat = w / norm
            logp = torch.log_softmax(alpha * torch.bmm(xs, w_hat.transpose(1, 2)) + b, dim=-1)
            p = logp.exp()
            h = -(p * logp).sum(dim=-1, keepdim=True)
            gz = (p - onehot - lam * p * (logp + h)) / n_support
            g_hat = alpha * torch.bmm(gz.transpose(1, 2), xs)
            gw = (g_hat - (g_hat * w_hat).sum(-1, keepdim=True) * w_hat) / norm
            c1, c2 = 1 - 0.9**step, 1 - 0.999**step
            for param, grad, m, v in ((w, gw, mw, vw), (b, gz.sum(1, keepdim=True), mb, vb)):
                m.mul_(0.9).add_(grad, alpha=0.1)
                v.mul_(0.999).addcmul_(grad, grad, value=0.001)
                param.addcdiv_(m / c1, (v / c2).sqrt_().add_(1e-8), value=-lr)
        xq = normalise(f[torch.as_tensor(query)])
        logits = alpha * torch.bmm(xq, normalise(w).transpose(1, 2)) + b
    return logits.argmax(dim=-1).numpy()


def episodes_of(n_way: int, k_shot: int, episodes: int, seed: int):
    """Clustered 386-d features (36 classes x 10 examples) and episodes drawn from them."""
    from models.episodes import sample_episodes
    from models.features import N_FEATURES

    rng = np.random.default_rng(seed)
    labels = np.repeat(np.arange(36), 10)
    centres = rng.normal(size=(36, N_FEATURES))
    features = (centres[labels] + 1.5 * rng.normal(size=(labels.size, N_FEATURES))).astype(
        np.float32
    )
    batch = sample_episodes(
        labels, n_way=n_way, k_shot=k_shot, n_query=2, episodes=episodes, seed=seed
    )
    return features, batch.support, batch.query


def measure(episodes: int, rounds: int, steps: int, seed: int) -> list[dict]:
    from models.prototypes import adapt_cosine_head

    rows = []
    for n_way, k_shot in SHAPES:
        features, support, query = episodes_of(n_way, k_shot, episodes, seed)
        best = {"reference": np.inf, "shipped": np.inf}
        out = {}
        for _ in range(rounds):
            for name, head in (("reference", reference_head), ("shipped", adapt_cosine_head)):
                t0 = time.perf_counter()
                out[name] = head(features, support, query, steps=steps)
                best[name] = min(best[name], time.perf_counter() - t0)
        rows.append(
            {
                "way": n_way,
                "shot": k_shot,
                "episodes": episodes,
                "reference_ms_per_episode": round(1e3 * best["reference"] / episodes, 3),
                "shipped_ms_per_episode": round(1e3 * best["shipped"] / episodes, 3),
                "speedup": round(best["reference"] / best["shipped"], 2),
                "predictions_differing": int((out["reference"] != out["shipped"]).sum()),
                "predictions": int(out["shipped"].size),
            }
        )
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--episodes", type=int_arg, default=128, help="episodes per shape")
    parser.add_argument("--rounds", type=int_arg, default=3, help="alternating rounds")
    parser.add_argument("--steps", type=int_arg, default=250, help="Adam steps (paper: 250)")
    parser.add_argument("--seed", type=int_arg, default=0)
    parser.add_argument("--json", action="store_true", help="print the rows as JSON")
    args = parser.parse_args(argv)
    for name in ("episodes", "rounds", "steps"):
        if getattr(args, name) < 1:
            fail(parser, f"--{name} must be at least 1, got {getattr(args, name)}")
    rows = measure(args.episodes, args.rounds, args.steps, args.seed)
    if args.json:
        print(json.dumps(rows, indent=2))
    else:
        print("way shot  reference ms/ep  shipped ms/ep  speed-up  differing predictions")
        for r in rows:
            print(
                f"{r['way']:>3} {r['shot']:>4}  {r['reference_ms_per_episode']:>15.2f}"
                f"  {r['shipped_ms_per_episode']:>13.2f}  {r['speedup']:>7.2f}x"
                f"  {r['predictions_differing']} of {r['predictions']}"
            )
    return 1 if any(r["predictions_differing"] for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
