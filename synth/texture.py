"""Surface texture under the moving contact, as the specimen's vertical displacement.

A 0.1 mm height field steps ~200x slower than convex meshes (MUJOCO-NOTES), so the
texture does not live in the collision geometry. The finger's path is open-loop, so the
height of the surface under the contact is known in advance as a function of time: the
specimen (a mocap body) is moved vertically by that height at every physics step, and
the contact, the PDMS springs and the skin respond to it like to real asperities.

The skin touches the surface only with its fingerprint ridges (parallel springs), so the
pad follows the *mean* height under the ridges in contact, each ridge averaging over its
own contact width. That comb-and-box filter is the fingerprint's role in the contact
model: it passes wavelengths near the ridge spacing and averages finer ones out.

The felt surface is also inclined by its local slope ``dh/ds``. A finger sliding up an
incline with friction ``mu`` needs ``(mu + slope) / (1 - mu slope) ~ mu + (1 + mu^2) slope``
times the normal force to move, so the slope adds a texture-driven tangential contact
force ``(1 + mu^2) slope F_n``, applied at the skin's contact point (see simulator).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from .config import Finger
from .materials import Texture

#: Spatial resolution of generated profiles (finest material feature is ~20 um).
GRID_M = 5e-6


def profile(texture: Texture, length_m: float, rng: np.random.Generator) -> np.ndarray:
    """Height samples (m) on a ``GRID_M`` grid over ``length_m``: roughness + periodic."""
    n = math.ceil(length_m / GRID_M) + 1
    s = np.arange(n) * GRID_M
    h = np.zeros(n)
    if texture.roughness_rms_m > 0:
        # Gaussian process with exponential autocorrelation = AR(1) on the grid.
        a = math.exp(-GRID_M / texture.correlation_length_m)
        eps = rng.standard_normal(n)
        h0 = rng.standard_normal() * texture.roughness_rms_m
        h, _ = signal.lfilter(
            [texture.roughness_rms_m * math.sqrt(1 - a * a)], [1.0, -a], eps, zi=[a * h0]
        )
    for comp in texture.periodic:
        phase = rng.uniform(0, 2 * math.pi)
        h = h + comp.amplitude_m * np.cos(2 * math.pi * s / comp.wavelength_m + phase)
    return h


def ridge_offsets(finger: Finger) -> np.ndarray:
    """Positions of the ridges in contact relative to the contact centre (m).

    The fingerprint is the same in every trial: its irregularity comes from a fixed seed.
    """
    n = finger.ridges_in_contact
    rng = np.random.default_rng(np.random.SeedSequence(0x5EED_F1))
    gaps = finger.ridge_spacing_m * (1 + finger.ridge_jitter * rng.uniform(-1, 1, size=n - 1))
    pos = np.concatenate([[0.0], np.cumsum(gaps)])
    return pos - pos.mean()


def felt_profile(
    texture: Texture,
    finger: Finger,
    path_s_m: np.ndarray,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """Height (m) the pad follows and its slope (dh/ds) at each path coordinate
    ``path_s_m`` (m, increasing from 0)."""
    offsets = ridge_offsets(finger)
    margin = float(np.abs(offsets).max()) + finger.ridge_width_m + 2 * GRID_M
    length = float(path_s_m.max()) + 2 * margin
    h = profile(texture, length, rng)
    # Each ridge averages over its contact width (moving box filter on the grid).
    width = max(1, round(finger.ridge_width_m / GRID_M))
    if width > 1:
        h = np.convolve(h, np.ones(width) / width, mode="same")
    grid = np.arange(h.size) * GRID_M
    felt = np.mean([np.interp(grid + o, grid, h) for o in offsets], axis=0)
    slope = np.gradient(felt, GRID_M)
    s = path_s_m + margin
    return np.interp(s, grid, felt), np.interp(s, grid, slope)
