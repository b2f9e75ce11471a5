"""MuJoCo collides each mesh as its convex hull: check that a probe dropped over a
concave region reaches the plate with the convex pieces, and would not with one mesh."""

from __future__ import annotations

import math

import mujoco
import pytest

import shapes
from shapes import SPECIMEN, cache


@pytest.fixture(autouse=True, scope="module")
def _private_cache(tmp_path_factory):
    # shapes.mesh writes its cache: keep it out of the user's cache directory.
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(cache.CACHE_ENV, str(tmp_path_factory.mktemp("mujoco-shape-cache")))
        yield


def _rest_height(pieces, xy, radius_m: float) -> float:
    """Drop a small sphere (vertical slide joint only) at xy onto plate + pieces;
    return its final centre height (m)."""
    spec = mujoco.MjSpec()
    spec.option.timestep = 0.0005
    world = spec.worldbody
    half = [SPECIMEN.base_length_m / 2, SPECIMEN.base_width_m / 2, SPECIMEN.base_thickness_m / 2]
    world.add_geom(
        type=mujoco.mjtGeom.mjGEOM_BOX, size=half, pos=[0, 0, -SPECIMEN.base_thickness_m / 2]
    )
    for i, piece in enumerate(pieces):
        spec.add_mesh(
            name=f"piece{i}",
            uservert=piece.vertices.ravel().tolist(),
            userface=piece.faces.ravel().tolist(),
        )
        world.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"piece{i}")
    probe = world.add_body(pos=[xy[0], xy[1], SPECIMEN.height_m + 2 * radius_m])
    probe.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1])
    probe.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[radius_m, 0, 0], mass=0.001)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=2000)
    assert all(w.number == 0 for w in data.warning)
    return float(data.xpos[model.nbody - 1, 2])  # the probe is the last body


def _star_gap_xy() -> tuple[float, float]:
    # Between two points of the star: at an inner vertex's angle, beyond the vertex.
    ro = 8.5e-3
    shift = ro * (1 - math.cos(math.radians(36))) / 2
    ang = math.radians(90 + 36)
    return 5.0e-3 * math.cos(ang), 5.0e-3 * math.sin(ang) - shift


@pytest.mark.parametrize(
    ("name", "xy", "radius_m"),
    [("moon", (0.0, 0.0), 1.5e-3), ("moon", (4e-3, 0.0), 1.5e-3), ("pentagram", None, 0.5e-3)],
)
def test_probe_falls_into_concavity_only_with_convex_pieces(name, xy, radius_m):
    xy = _star_gap_xy() if xy is None else xy
    h = SPECIMEN.height_m
    with_pieces = _rest_height(shapes.convex_pieces(name), xy, radius_m)
    as_one_mesh = _rest_height([shapes.mesh(name)], xy, radius_m)
    # Resting on the plate (centre about one radius up) vs on top of the hull.
    assert with_pieces < radius_m + 0.5e-3
    assert as_one_mesh > h
    assert as_one_mesh - with_pieces > 0.75 * h


def test_probe_rests_on_the_raised_shape_where_it_is_solid():
    z = _rest_height(shapes.convex_pieces("moon"), (0.0, -5.5e-3), 1.5e-3)
    assert z > SPECIMEN.height_m
