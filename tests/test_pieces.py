"""Contacts of multi-piece specimens: one contact per region of the surface, not per piece."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import shapely

import synth
from shapes import outline
from shapes.partition import convex_partition
from synth import pieces
from synth.config import SynthConfig

NOMINAL = SynthConfig(variability=SynthConfig().variability.nominal())
REACH_M = NOMINAL.finger.pad_radius_m


def _seam_point(shape: str) -> np.ndarray:
    """A point on the top of ``shape`` where two of its convex pieces meet."""
    polys = [shapely.Polygon(r) for r in convex_partition(outline(shape))]
    for i, a in enumerate(polys):
        for b in polys[i + 1 :]:
            seam = a.boundary.intersection(b.buffer(1e-9))  # edges meet to rounding
            if seam.length > 1e-4:
                return np.asarray(seam.interpolate(0.5, normalized=True).coords[0])
    raise AssertionError(f"{shape} has no seam")


@pytest.mark.parametrize("shape", ["moon", "pentagram"])
def test_a_seam_on_the_top_is_touched_through_one_piece(shape):
    seam = _seam_point(shape)
    inward = seam - np.asarray(outline(shape).centroid.coords[0])
    points = np.stack([seam, seam + 1e-6 * inward, seam - 1e-6 * inward])
    chosen = pieces.touchable(pieces.outline_pieces(shape), points, REACH_M)
    assert chosen.sum(axis=1).tolist() == [1, 1, 1]


def test_pieces_are_touched_only_within_the_pads_reach():
    moon = pieces.outline_pieces("moon")
    far = np.array([[0.0, 0.05], [0.05, 0.0]])  # 50 mm from a 14 mm wide specimen
    assert not pieces.touchable(moon, far, REACH_M).any()
    west = np.array([[-0.0065 - 0.5 * REACH_M, 0.0]])  # beside the moon's outer wall
    assert pieces.touchable(moon, west, REACH_M).sum() >= 1


def test_single_piece_outlines_need_no_selector():
    assert pieces.outline_pieces("square") is None
    assert pieces.outline_pieces("moon").n_pieces > 2


@pytest.mark.parametrize("shape", ["moon", "pentagram"])
def test_the_skin_sinks_into_a_multi_piece_top_as_into_a_single_piece_one(shape):
    """The same load indents the skin as deep on the moon's or pentagram's flat top as
    on the square's (one Hertz contact), not a fraction of it (one contact per piece)."""
    config = dataclasses.replace(
        NOMINAL,
        motion=dataclasses.replace(NOMINAL.motion, path_y_m=-0.003),  # across the moon's body
    )

    def top_indentation(name: str) -> float:
        truth = synth.simulate(name, "resin", seed=1, config=config).truth
        on_top = truth["finger_z_m"] > 1.0e-3  # skin bottom on the 2 mm top
        assert on_top.sum() > 100, f"the pad must cross the {name}'s top"
        return float(np.median(truth["indentation_m"][on_top]))

    assert top_indentation(shape) == pytest.approx(top_indentation("square"), rel=0.12)
