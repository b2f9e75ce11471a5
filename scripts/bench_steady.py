"""Where the diagnosis's steady-sliding stretches lie against the simulated truth.

    python3 scripts/bench_steady.py [--seeds 5] [--force 1.0] [--speed 10]

``tactile-synth diagnose`` finds each trial's steady stretch from its signals alone
(:func:`benchmark.diagnose.steady.steady_stretch`: at least 0.3 s from every sample where
the films reach 5 % of the trial's largest magnitude). This script simulates every shape x
material at ``--force`` newtons and ``--speed`` mm/s for ``--seeds`` seeds, finds the
stretches the same way, and compares them with where the pad's axis was (the simulated
truth a dataset does not store). Per material it prints:

- the trials with a stretch, and the stretches' mean length;
- the shortest time from a stretch to an edge crossing, where the pad's axis passes over
  the outline (0.3 s or more if the finder keeps its gap from the edges' transients);
- the stretches that overlap an edge's contact, where the skin's contact circle (its
  Hertz radius at the force) reaches an edge from the top, or the skin touches a wall
  from the base (its touch distance): how many, how many of them at their end, and the
  median overlap.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np
import shapely
from script_args import description, fail

import shapes
import synth
from benchmark.diagnose import steady
from synth import planning, texture
from synth.trial import SAMPLE_RATE_HZ, TrialSpec
from tactile_synth.validation import float_arg, int_arg


def edge_truth(trial: synth.Trial, config: synth.SynthConfig) -> tuple[np.ndarray, np.ndarray]:
    """``(crossing, touching)`` per window sample of ``trial``: where the pad's axis
    crosses the outline, and where the skin's contact reaches an edge (the contact
    circle over an edge from the top, the skin against a wall from the base)."""
    radius = float(texture.contact_radius_m(config.finger, trial.spec.force_n))
    reach = planning.touch_distance_m(config, trial.spec.force_n)
    poly = shapes.outline(trial.spec.shape)
    pts = shapely.points(trial.truth["finger_x_m"], trial.truth["finger_y_m"])
    inside = shapely.contains(poly, pts)
    distance = shapely.distance(pts, poly.exterior)
    crossing = np.zeros(inside.size, dtype=bool)
    flips = np.flatnonzero(np.diff(inside.astype(np.int8)))
    crossing[flips] = crossing[flips + 1] = True
    touching = np.where(inside, distance <= radius, distance <= reach)
    return crossing, touching


def _gap_s(mask: np.ndarray, stretch: slice) -> float:
    """Shortest time from ``stretch`` to a sample of ``mask`` (inf if there is none)."""
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return math.inf
    inner = idx[(idx >= stretch.start) & (idx < stretch.stop)]
    if inner.size:
        return 0.0
    before, after = idx[idx < stretch.start], idx[idx >= stretch.stop]
    gaps = [stretch.start - before.max() if before.size else math.inf]
    gaps.append(after.min() - (stretch.stop - 1) if after.size else math.inf)
    return min(gaps) / SAMPLE_RATE_HZ


def measure(seeds: int, force_n: float, speed_mm_s: float) -> dict[str, dict]:
    """Per material: ``trials``, ``found``, ``mean_length_s``, ``min_crossing_gap_s``,
    ``overlapping``, ``overlapping_at_end`` and ``median_overlap_s`` (see the module's
    description)."""
    config = synth.SynthConfig()
    specs = [
        TrialSpec(s, m, force_n=force_n, speed_mm_s=speed_mm_s, seed=k)
        for s in shapes.SHAPE_NAMES
        for m in synth.MATERIAL_NAMES
        for k in range(seeds)
    ]
    rows: dict[str, dict] = {}
    for trial in synth.simulate_batch(specs, config=config):
        row = rows.setdefault(
            trial.spec.material,
            {"trials": 0, "lengths": [], "gaps": [], "overlaps": [], "at_end": 0},
        )
        row["trials"] += 1
        stretch = steady.steady_stretch(trial.signals)
        if stretch is None:
            continue
        crossing, touching = edge_truth(trial, config)
        row["lengths"].append((stretch.stop - stretch.start) / SAMPLE_RATE_HZ)
        row["gaps"].append(_gap_s(crossing, stretch))
        overlap = int(touching[stretch].sum())
        if overlap:
            row["overlaps"].append(overlap / SAMPLE_RATE_HZ)
            row["at_end"] += bool(touching[stretch.stop - 1])
    return {
        m: {
            "trials": r["trials"],
            "found": len(r["lengths"]),
            "mean_length_s": float(np.mean(r["lengths"])) if r["lengths"] else math.nan,
            "min_crossing_gap_s": min(r["gaps"], default=math.nan),
            "overlapping": len(r["overlaps"]),
            "overlapping_at_end": r["at_end"],
            "median_overlap_s": float(np.median(r["overlaps"])) if r["overlaps"] else 0.0,
        }
        for m, r in rows.items()
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--seeds", type=int_arg, default=5, help="trials per class")
    parser.add_argument("--force", type=float_arg, default=1.0, help="newtons")
    parser.add_argument("--speed", type=float_arg, default=10.0, help="mm/s")
    args = parser.parse_args(argv)
    if args.seeds < 1:
        fail(parser, "--seeds must be at least 1")
    if args.force <= 0 or args.speed <= 0:
        fail(parser, "--force and --speed must be > 0")
    res = measure(args.seeds, args.force, args.speed)
    print(
        f"steady stretches (diagnose's finder) against the pad's simulated position, "
        f"{args.force:g} N, {args.speed:g} mm/s, {args.seeds} seeds per class"
    )
    print(
        "material    stretches   mean length   nearest edge crossing   "
        "overlapping an edge's contact (at their end; median overlap)"
    )
    for m, r in res.items():
        print(
            f"{m:<11} {r['found']:>4} / {r['trials']:<4} {r['mean_length_s']:>9.2f} s "
            f"{r['min_crossing_gap_s']:>16.2f} s   {r['overlapping']:>14} "
            f"({r['overlapping_at_end']}; {r['median_overlap_s'] * 1e3:.0f} ms)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
