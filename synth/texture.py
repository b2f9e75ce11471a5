"""Surface texture of a specimen, as the height and slope the skin feels along the
sliding direction.

A 0.1 mm height field steps ~200x slower than convex meshes, so the texture does not
live in the collision geometry. Instead each trial draws the specimen's surface profile
along the sliding direction (roughness and periodic marks, random phase: the stroke
passes over a different stretch of surface each time), and the robot controller's loop
(:mod:`synth.closed_loop`) looks up, every control period, the height and slope under
the *simulated* contact position: the specimen (a mocap body) is moved vertically by the
height under the contact, and the slope's tangential push acts on the pad. A pad that
sticks feels a constant height; a pad that slows down feels the texture slow down.

The skin touches the surface only with its fingerprint ridges (parallel springs), so the
pad follows the *mean* height under the ridges inside the skin's contact circle, each
weighted by its chord of the circle (a longer line contact is a stiffer spring) and
each averaging across its own contact width with the pressure a rounded ridge pressed
on a flat carries there (elliptical, a Hertzian line contact: :func:`ridge_taps`); the
ridges narrow towards the contact's rim, where the pad presses them less
(:func:`ridge_widths_m`). A larger load widens the contact and brings more ridges in.
The contact is the simulated load's: a trial's surface is tabulated under a few loads
around the set force (:func:`loaded_surface`) and read under the load the contact
carries (:class:`LayeredTable`). That comb of rounded ridges is the fingerprint's role
in the contact model: it passes wavelengths near the ridge spacing and averages finer
ones down. Across the path each ridge touches the surface along a
chord of the contact circle and feels the mean height along it: random roughness is
averaged down, and periodic marks are felt in full only when they run parallel to the
ridges; a specimen turned in its fixture turns its marks against the ridges and they
fade (:func:`mark_gains`).

The felt surface is also inclined by its local slope ``dh/ds``: the contact normal tilts,
so the contact force gains a tangential component ``-slope * F_n`` (pointing downhill)
that a flat collision surface does not produce; the controller applies it to the skin at
the contact point from the simulated normal force, and the films read it as part of the
skin's traction (:func:`synth.recording._process`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from . import contact, kernels
from .config import Finger
from .materials import Texture

#: Spatial resolution of generated profiles (finest material feature is ~20 um).
GRID_M = 5e-6

#: Normal loads at which a load-following felt surface is tabulated: the set-point force
#: times ``LOAD_RATIO ** j`` for ``j`` in ``LOAD_LAYERS``, 0.5-2 times it. In the
#: window, the simulated load stays within 0.5-1.7 times the set point in 999 samples
#: of 1000 from 0.6 to 1.4 N and 5 to 20 mm/s (0.46-2.1 at the extremes); a load beyond
#: the layers feels the outermost one. Hertz's contact radius grows as the load's cube
#: root, so the layers' radii are 12 % apart. Between layers the felt surface is
#: interpolated linearly in the load's logarithm: a ridge entering the contact adds a
#: chord that grows from 0, so the surface changes continuously with the load, and the
#: interpolated ridge weights stay within about 2 % of their total.
LOAD_RATIO = math.sqrt(2.0)
LOAD_LAYERS = range(-2, 3)
_PER_LOG_RATIO = 1.0 / math.log(LOAD_RATIO)  # a load's layer position per unit of its log


def contact_radius_m(finger: Finger, force_n):
    """Hertz contact radius ``a = sqrt(R delta)`` of the skin under ``force_n`` (elementwise)."""
    delta = contact.hertz_indentation_m(
        force_n, finger.pad_radius_m, finger.skin_modulus_pa, finger.skin_poisson
    )
    return np.sqrt(finger.pad_radius_m * delta)


def line_average_variance(correlation_length_m: float, line_length_m: float) -> float:
    """Variance factor of an exponentially correlated random height averaged along a line.

    The mean of a field with autocorrelation ``exp(-|u| / l)`` over a segment of length
    ``L`` has variance ``2 (l / L)^2 (L / l - 1 + exp(-L / l))`` times the field's: 1 for
    ``L << l``, about ``2 l / L`` for ``L >> l``.
    """
    if line_length_m <= 0:
        return 1.0
    r = line_length_m / correlation_length_m
    return float(2.0 * (r - 1.0 + math.exp(-r)) / (r * r))


def profile(
    texture: Texture,
    length_m: float,
    rng: np.random.Generator,
    *,
    line_length_m: float = 0.0,
) -> np.ndarray:
    """Height samples (m) on a ``GRID_M`` grid over ``length_m``: roughness + periodic.

    ``line_length_m`` is the length of the ridge's line contact across the sliding
    direction: the random roughness (isotropic, measured on a line along the path) is
    averaged over it, the periodic marks (running across the path) are not.
    """
    rough, marks = _profile_parts(texture, length_m, rng, line_length_m)
    return rough + marks.sum(axis=0)


def _profile_parts(
    texture: Texture, length_m: float, rng: np.random.Generator, line_length_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """The random roughness ``(n,)`` and each periodic component ``(k, n)`` of a profile,
    drawn in that order from ``rng``."""
    n = math.ceil(length_m / GRID_M) + 1
    s = np.arange(n) * GRID_M
    h = np.zeros(n)
    if texture.roughness_rms_m > 0:
        # Gaussian process with exponential autocorrelation = AR(1) on the grid.
        rms = texture.roughness_rms_m * math.sqrt(
            line_average_variance(texture.correlation_length_m, line_length_m)
        )
        a = math.exp(-GRID_M / texture.correlation_length_m)
        eps = rng.standard_normal(n)
        h0 = rng.standard_normal() * rms
        h, _ = signal.lfilter([rms * math.sqrt(1 - a * a)], [1.0, -a], eps, zi=[a * h0])
    marks = np.empty((len(texture.periodic), n))
    for row, comp in zip(marks, texture.periodic, strict=True):
        phase = rng.uniform(0, 2 * math.pi)
        row[:] = comp.amplitude_m * np.cos(2 * math.pi * s / comp.wavelength_m + phase)
    return h, marks


def mark_gains(chords_m: np.ndarray, wavelengths_m: np.ndarray, angle_rad: float) -> np.ndarray:
    """How much of each periodic mark each ridge feels, ``(ridges, marks)``.

    A ridge touches the surface along a chord of length ``L`` across the sliding
    direction. Marks of wavelength ``lambda`` running at ``angle_rad`` to the ridge cross
    that line over ``L tan(angle)`` of their period, and the ridge feels their mean along
    it: ``sinc(L tan(angle) / lambda)`` (normalised sinc) times the mark at the chord's
    centre. 1 for marks parallel to the ridges; 0 where the chord spans whole periods.
    """
    x = np.multiply.outer(np.asarray(chords_m) * math.tan(angle_rad), 1.0 / wavelengths_m)
    return np.sinc(x)


def ridge_offsets(finger: Finger) -> np.ndarray:
    """Positions of the fingerprint's ridges relative to the contact centre (m): the
    ridges covering the pad (``Finger.ridges_in_contact`` null) or the given number of
    ridges around the centre.

    The fingerprint is the same in every trial: its irregularity comes from a fixed seed.
    """
    n = finger.ridges_in_contact
    if n is None:
        n = int(2 * finger.pad_radius_m / finger.ridge_spacing_m) + 1
    # Every trial's plan needs them: computed once per fingerprint.
    return _ridge_offsets(n, finger.ridge_spacing_m, finger.ridge_jitter).copy()


def touching_ridges(
    finger: Finger, contact_radius_m: float, offsets: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """``(offsets, weights)`` of the ridges that touch the surface in a contact of radius
    ``contact_radius_m``; the pad follows ``sum(weights * height) / sum(weights)``.

    With ``Finger.ridges_in_contact`` null, the ridges inside the contact circle, each
    weighted by its chord (the nearest ridge alone, weight 1, if the circle holds none);
    else the fixed number of ridges, weighted equally. ``offsets``: the ridges' positions
    (default the finger's own, :func:`ridge_offsets`; another draw, :func:`ridge_draw`).
    """
    offsets = ridge_offsets(finger) if offsets is None else offsets
    if finger.ridges_in_contact is not None:
        return offsets, np.ones(offsets.size)
    inside = np.abs(offsets) < contact_radius_m
    if not inside.any():
        return offsets[[np.argmin(np.abs(offsets))]], np.ones(1)
    offsets = offsets[inside]
    return offsets, 2.0 * np.sqrt(contact_radius_m**2 - offsets**2)


#: The seed of the finger's fingerprint: its ridges' irregularity is one fixed draw.
FINGERPRINT_SEED = 0x5EED_F1


@functools.lru_cache(maxsize=8)
def _ridge_offsets(n: int, spacing_m: float, jitter: float) -> np.ndarray:
    return ridge_draw(n, spacing_m, jitter, FINGERPRINT_SEED)


def ridge_draw(n: int, spacing_m: float, jitter: float, seed: int) -> np.ndarray:
    """Positions of ``n`` ridges ``spacing_m`` apart, each gap scattered uniformly by
    +-``jitter`` of it (the draw of ``seed``), centred on 0."""
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    gaps = spacing_m * (1 + jitter * rng.uniform(-1, 1, size=n - 1))
    pos = np.concatenate([[0.0], np.cumsum(gaps)])
    return pos - pos.mean()


@dataclass(frozen=True)
class FeltSurface:
    """Felt height and slope of one trial's specimen on a regular grid along the sliding
    direction: ``height_m[i]`` and ``slope[i]`` at path coordinate ``origin_m + i * GRID_M``."""

    origin_m: float
    height_m: np.ndarray
    slope: np.ndarray


def felt_surface(
    texture: Texture,
    finger: Finger,
    start_m: float,
    stop_m: float,
    rng: np.random.Generator,
    *,
    contact_radius_m: float = 0.0,
    mark_angle_rad: float = 0.0,
) -> FeltSurface:
    """The felt surface over path coordinates ``start_m..stop_m`` (plus the fingerprint's
    half-width on each side).

    ``contact_radius_m`` is the radius of the skin's contact: the ridges inside it
    (:func:`touching_ridges`) touch the surface along chords of that circle across the
    sliding direction, and the random roughness is averaged along their mean chord (0: a
    point contact on the ridge nearest its centre, no averaging).
    ``mark_angle_rad`` is the angle between the specimen's periodic marks and the ridges
    (the specimen's yaw in its fixture): each ridge feels a mark scaled by
    :func:`mark_gains` over its own chord.
    """
    offsets, weights = touching_ridges(finger, contact_radius_m)
    margin = float(np.abs(offsets).max()) + finger.ridge_width_m + 4 * GRID_M
    length = stop_m - start_m + 2 * margin
    chords = 2.0 * np.sqrt(np.maximum(contact_radius_m**2 - offsets**2, 0.0))
    rough, marks = _profile_parts(texture, length, rng, float(chords.mean()))
    gains = mark_gains(chords, np.array([c.wavelength_m for c in texture.periodic]), mark_angle_rad)
    widths = (
        ridge_widths_m(finger, offsets, contact_radius_m)
        if chords.any()
        else np.full(offsets.size, finger.ridge_width_m)
    )
    bank, bank_of = _ridge_bank(finger, widths, rough, marks)
    grid = np.arange(rough.size) * GRID_M
    shifted = np.empty((offsets.size, rough.size))
    marked = np.empty(rough.size)
    for row, o, gain, b in zip(shifted, offsets, gains, bank_of, strict=True):
        kernels.weighted_rows(gain, bank[b, 1:], marked)
        row[:] = np.interp(grid + o, grid, bank[b, 0] + marked)
    if finger.ridges_in_contact is None:
        felt = np.empty(rough.size)
        kernels.weighted_rows(weights, shifted, felt)
        felt /= weights.sum()
    else:
        # Equal weights, summed as a plain mean: a store made with a fixed ridge count
        # regenerates bit for bit.
        felt = np.mean(shifted, axis=0)
    slope = np.gradient(felt, GRID_M)
    return FeltSurface(origin_m=start_m - margin, height_m=felt, slope=slope)


def ridge_widths_m(finger: Finger, offsets: np.ndarray, contact_radius_m: float) -> np.ndarray:
    """Each ridge's contact width (m) at ``offsets`` in a contact of radius
    ``contact_radius_m``: ``ridge_width_m`` at the centre, narrowing towards the rim as
    the pad's Hertz pressure there, ``sqrt(1 - (r / a)^2)``, to the power
    ``Finger.ridge_width_pressure_exponent`` (0 outside the contact); every ridge
    ``ridge_width_m`` wide in a point contact (radius 0) or with the exponent 0."""
    offsets = np.asarray(offsets, dtype=float)
    exponent = finger.ridge_width_pressure_exponent
    if contact_radius_m <= 0 or exponent == 0:
        return np.full(offsets.shape, finger.ridge_width_m)
    rel = offsets / contact_radius_m
    pressure = np.sqrt(np.maximum(1.0 - rel * rel, 0.0))
    return finger.ridge_width_m * kernels.power(pressure, exponent)


def ridge_taps(finger: Finger, width_m: float) -> np.ndarray:
    """The weights (summing to 1) with which a ridge of contact width ``width_m`` averages
    the surface on the ``GRID_M`` grid: the pressure across its width,
    ``(1 - (2 x / w)^2) ** Finger.ridge_profile_exponent``, sampled on the grid
    (exponent 0: ``round(w / GRID_M)`` equal weights, a box); one weight for a ridge
    narrower than two cells."""
    exponent = finger.ridge_profile_exponent
    if exponent == 0:
        cells = max(1, round(width_m / GRID_M))
        return np.full(cells, 1.0 / cells)
    half = round(width_m / (2 * GRID_M))
    if half <= 1:
        return np.ones(1)
    t = np.arange(-(half - 1), half, dtype=float) / half
    taps = kernels.power(1.0 - t * t, exponent)
    return taps / math.fsum(taps.tolist())


def ridge_gains(finger: Finger, widths_m: np.ndarray, wavelength_m: float) -> np.ndarray:
    """How much of a mark of ``wavelength_m`` each ridge of contact width ``widths_m``
    passes through its average across its width (:func:`ridge_taps`): the taps' transfer
    at that wavelength, ``sum taps * cos(2 pi x / lambda)``."""
    out = np.empty(np.size(widths_m))
    for i, w in enumerate(np.ravel(widths_m).tolist()):
        taps = ridge_taps(finger, w)
        x = (np.arange(taps.size) - (taps.size - 1) / 2) * GRID_M
        out[i] = float(np.sum(taps * np.cos(2 * math.pi * x / wavelength_m)))
    return out


def _ridge_bank(
    finger: Finger, widths_m: np.ndarray, rough: np.ndarray, marks: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(bank, bank_of)``: the roughness and marks ``(1 + k, n)`` as each distinct ridge
    width averages them (:func:`ridge_taps`), ``(banks, 1 + k, n)``, and the bank each
    entry of ``widths_m`` reads (-1 for a negative width: a ridge not in contact)."""
    widths = np.asarray(widths_m, dtype=float)
    bank_of = np.full(widths.shape, -1, dtype=np.intp)
    taps_of: dict[int, np.ndarray] = {}
    keys = np.full(widths.shape, -1, dtype=np.intp)
    for idx, w in np.ndenumerate(widths):
        if w < 0:
            continue
        taps = ridge_taps(finger, float(w))
        taps_of.setdefault(taps.size, taps)
        keys[idx] = taps.size
    order = sorted(taps_of, reverse=True)
    stack = np.vstack([rough, marks])
    bank = np.empty((len(order), *stack.shape))
    for b, size in enumerate(order):
        bank_of[keys == size] = b
        for row, out in zip(stack, bank[b], strict=True):
            if size == 1:
                out[:] = row
            else:
                kernels.taps_mean(row, taps_of[size], out)
    return bank, bank_of


@dataclass(frozen=True)
class LoadedSurface:
    """One trial's felt surface under several normal loads: ``height_m[j, i]`` and
    ``slope[j, i]`` at path coordinate ``origin_m + i * GRID_M`` under the load
    ``loads_n[j]`` (a contact of radius ``radii_m[j]``). The loads grow geometrically by
    ``LOAD_RATIO``; a single layer is a surface felt the same under any load."""

    origin_m: float
    loads_n: np.ndarray
    radii_m: np.ndarray
    height_m: np.ndarray
    slope: np.ndarray

    @classmethod
    def fixed(cls, surface: FeltSurface) -> LoadedSurface:
        """``surface`` felt the same whatever the load."""
        nan = np.array([np.nan])
        return cls(surface.origin_m, nan, nan, surface.height_m[None], surface.slope[None])

    def at(self, load_n: float) -> FeltSurface:
        """The surface felt under ``load_n`` (interpolated between layers)."""
        j, u = layer_position(self.loads_n[0], self.loads_n.size, np.array([load_n]))
        j, u = int(j[0]), float(u[0])
        above = min(j + 1, self.loads_n.size - 1)
        height = self.height_m[j] + (self.height_m[above] - self.height_m[j]) * u
        slope = self.slope[j] + (self.slope[above] - self.slope[j]) * u
        return FeltSurface(self.origin_m, height, slope)

    def height_at(self, load_n: float, coordinate_m: float) -> float:
        """The height felt under ``load_n`` at the path coordinate ``coordinate_m``:
        :func:`look_up` of :meth:`at`'s heights there, from the two grid points around
        it only (the same bits)."""
        n = self.height_m.shape[-1]
        pos = (np.array([[coordinate_m]]) - np.array([self.origin_m])[:, None]) / GRID_M
        pos = np.clip(pos, 0.0, n - 1.000001)
        i0 = int(pos.astype(np.intp)[0, 0])
        w = pos[0, 0] - i0
        j, u = layer_position(self.loads_n[0], self.loads_n.size, np.array([load_n]))
        j, u = int(j[0]), float(u[0])
        above = min(j + 1, self.loads_n.size - 1)
        below_h = self.height_m[j, i0 : i0 + 2]
        h = below_h + (self.height_m[above, i0 : i0 + 2] - below_h) * u
        return float(h[0] * (1.0 - w) + h[1] * w)


def as_loaded(surface: FeltSurface | LoadedSurface) -> LoadedSurface:
    """``surface`` as a :class:`LoadedSurface` (a :class:`FeltSurface` as one layer)."""
    return surface if isinstance(surface, LoadedSurface) else LoadedSurface.fixed(surface)


def layer_position(
    first_load_n: np.ndarray | float, layers: int, load_n: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(j, u)``: for each normal load ``load_n``, the layer below it among ``layers``
    geometric layers from ``first_load_n`` and the fraction of the way (in the load's
    logarithm) to the next one; clamped to the outermost layers, ``j`` is at most
    ``layers - 2`` (0 with one layer)."""
    load_n = np.asarray(load_n, dtype=float)
    j, u = np.zeros(load_n.shape, dtype=np.intp), np.zeros(load_n.shape)
    if layers == 1:
        return j, u
    first = np.broadcast_to(np.asarray(first_load_n, dtype=float), load_n.shape)
    kernels.layer_position(
        first.ravel(), layers, _PER_LOG_RATIO, load_n.ravel(), j.ravel(), u.ravel()
    )
    return j, u


def loaded_surface(
    texture: Texture,
    finger: Finger,
    start_m: float,
    stop_m: float,
    rng: np.random.Generator,
    *,
    force_n: float,
    mark_angle_rad: float = 0.0,
) -> LoadedSurface:
    """The felt surface over path coordinates ``start_m..stop_m`` under the loads of
    ``LOAD_LAYERS`` around the set-point force ``force_n``, for a closed loop that reads
    it at the simulated load.

    The specimen's surface is one realisation (drawn once from ``rng``); each layer is
    that surface as :func:`felt_surface` describes it for its radius: the ridges inside
    the contact circle, weighted by their chords, each feeling the marks scaled by
    :func:`mark_gains` over its chord, the roughness averaged along their mean chord. With
    a fixed number of ridges (``Finger.ridges_in_contact`` an integer) the contact does
    not change what the pad feels: one layer, :func:`felt_surface` at the set-point
    force's radius.
    """
    if finger.ridges_in_contact is not None:
        surface = felt_surface(
            texture,
            finger,
            start_m,
            stop_m,
            rng,
            contact_radius_m=float(contact_radius_m(finger, force_n)),
            mark_angle_rad=mark_angle_rad,
        )
        return LoadedSurface.fixed(surface)
    loads = force_n * kernels.power(LOAD_RATIO, np.array(LOAD_LAYERS, dtype=float))
    radii = contact_radius_m(finger, loads)
    offsets = ridge_offsets(finger)
    # Every ridge that touches in the widest layer (or the nearest one in a point contact).
    near = np.abs(offsets) < radii[-1]
    near[np.argmin(np.abs(offsets))] = True
    offsets = offsets[near]
    margin = float(np.abs(offsets).max()) + finger.ridge_width_m + 4 * GRID_M
    length = stop_m - start_m + 2 * margin
    # The roughness at unit averaging; each layer scales it for its own mean chord.
    rough, marks = _profile_parts(texture, length, rng, 0.0)
    n = rough.size
    # What each ridge is under: every profile read offset / GRID_M cells further on.
    cells = np.array([o / GRID_M for o in offsets.tolist()])
    whole = np.floor(cells)
    frac = cells - whole
    whole = whole.astype(np.intp)
    wavelengths = np.array([c.wavelength_m for c in texture.periodic])
    rough_weights = np.empty((radii.size, offsets.size))
    mark_weights = np.empty((radii.size, offsets.size * wavelengths.size))
    totals = np.empty(radii.size)
    # Each ridge's contact width in each layer (-1: not in that layer's contact).
    widths = np.full((radii.size, offsets.size), -1.0)
    for layer, a in enumerate(radii):
        chords = 2.0 * np.sqrt(np.maximum(a * a - offsets**2, 0.0))
        inside = chords > 0
        if inside.any():
            weights = chords
            mean_chord = float(chords[inside].mean())
            widths[layer, inside] = ridge_widths_m(finger, offsets[inside], float(a))
        else:
            weights = np.zeros(offsets.size)
            weights[np.argmin(np.abs(offsets))] = 1.0
            mean_chord = 0.0
            widths[layer, np.argmin(np.abs(offsets))] = finger.ridge_width_m
        scale = 0.0
        if texture.roughness_rms_m > 0:
            scale = math.sqrt(line_average_variance(texture.correlation_length_m, mean_chord))
        rough_weights[layer] = scale * weights
        mark_weights[layer] = (
            mark_gains(chords, wavelengths, mark_angle_rad) * weights[:, None]
        ).ravel()
        totals[layer] = weights.sum()
    bank, bank_of = _ridge_bank(finger, widths, rough, marks)
    heights = np.empty((radii.size, n))
    slopes = np.empty((radii.size, n))
    kernels.felt_layers(
        bank,
        bank_of,
        whole,
        frac,
        rough_weights,
        mark_weights,
        totals,
        GRID_M,
        heights,
        slopes,
    )
    return LoadedSurface(start_m - margin, loads, radii, heights, slopes)


def stack_surfaces(surfaces: list[FeltSurface]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(origins (b,), heights (b, n), slopes (b, n))``, shorter profiles padded with
    their last value, for vectorised look-ups across a batch."""
    n = max(s.height_m.size for s in surfaces)
    heights = np.empty((len(surfaces), n))
    slopes = np.empty((len(surfaces), n))
    for i, s in enumerate(surfaces):
        heights[i, : s.height_m.size] = s.height_m
        heights[i, s.height_m.size :] = s.height_m[-1]
        slopes[i, : s.slope.size] = s.slope
        slopes[i, s.slope.size :] = 0.0
    return np.array([s.origin_m for s in surfaces]), heights, slopes


def look_up(origins: np.ndarray, table: np.ndarray, coordinate_m: np.ndarray) -> np.ndarray:
    """Linear interpolation of each trial's ``table`` row at ``coordinate_m`` ``(b, k)``
    (clamped to the row's ends); elementwise per trial, so batch-independent."""
    pos = (coordinate_m - origins[:, None]) / GRID_M
    n = table.shape[1]
    pos = np.clip(pos, 0.0, n - 1.000001)
    i0 = pos.astype(np.intp)
    w = pos - i0
    rows = np.arange(table.shape[0])[:, None]
    return table[rows, i0] * (1.0 - w) + table[rows, i0 + 1] * w


class TextureTable:
    """A batch's felt surfaces, ready for many look-ups: per grid cell the height at its
    start and its rise over the cell, the slope at its start and its rise, so that one
    gather reads both quantities.

    origins, heights, slopes: as :func:`stack_surfaces` returns them. Calling the table
    with path coordinates ``(b, k)`` gives each trial's ``(height, slope)`` there, by
    linear interpolation between grid points as in :func:`look_up` (clamped to the rows'
    ends, elementwise per trial) written as ``start + rise * w``, so values can differ
    from :func:`look_up`'s in the last bit. The surfaces are felt the same under any load:
    a load, if given, is ignored.
    """

    layers = 1

    def __init__(self, origins: np.ndarray, heights: np.ndarray, slopes: np.ndarray) -> None:
        b, n = heights.shape
        cells = np.empty((b, n - 1, 4))
        cells[..., 0] = heights[:, :-1]
        cells[..., 1] = heights[:, 1:] - heights[:, :-1]
        cells[..., 2] = slopes[:, :-1]
        cells[..., 3] = slopes[:, 1:] - slopes[:, :-1]
        self._cells = cells.reshape(-1, 4)
        self._origins = np.asarray(origins, dtype=float)
        self._row_start = np.arange(b) * (n - 1)  # first cell of each row
        self._last = n - 1.000001  # clamp just inside the last cell

    def __call__(
        self, coordinate_m: np.ndarray, load_n: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        pos = (coordinate_m - self._origins[:, None]) * (1.0 / GRID_M)
        np.maximum(pos, 0.0, out=pos)
        np.minimum(pos, self._last, out=pos)
        i0 = pos.astype(np.intp)
        w = pos - i0
        i0 += self._row_start[:, None]
        c = self._cells[i0]
        return c[..., 0] + c[..., 1] * w, c[..., 2] + c[..., 3] * w

    def felt_into(
        self,
        s_m: np.ndarray,
        v_m_s: np.ndarray,
        ahead_s: np.ndarray,
        load_n: np.ndarray,
        height_out: np.ndarray,
        slope_out: np.ndarray,
    ) -> None:
        """The table called at the coordinates ``s_m[i] + v_m_s[i] * ahead_s[t]``
        (positions ``(b,)`` extrapolated over the times ``(k,)`` by their velocities),
        written into ``height_out`` and ``slope_out`` ``(b, k)``: the same bits, compiled
        (:mod:`synth.kernels`)."""
        kernels.table_felt(
            self._cells,
            self._origins,
            self._row_start,
            self._last,
            1.0 / GRID_M,
            s_m,
            v_m_s,
            ahead_s,
            height_out,
            slope_out,
        )


class LayeredTable:
    """A batch's :class:`LoadedSurface` s (every trial with as many layers), ready for
    look-ups under each trial's normal load: ``(height, slope)`` pairs per grid point,
    interpolated linearly along the path (clamped to the rows' ends) and then between the
    two layers around the load (:func:`layer_position`). Elementwise per trial, so
    batch-independent."""

    def __init__(self, surfaces: list[LoadedSurface]) -> None:
        b, m = len(surfaces), surfaces[0].loads_n.size
        n = max(s.height_m.shape[-1] for s in surfaces)
        # Single precision: heights of micrometres keep ~1e-13 m, slopes ~1e-9, far below
        # any mechanical effect, and the table (the batch's largest array) halves.
        points = np.empty((b, m, n, 2), dtype=np.float32)
        for row, s in zip(points, surfaces, strict=True):
            size = s.height_m.shape[-1]
            row[:, :size, 0] = s.height_m
            row[:, size:, 0] = s.height_m[:, -1:]
            row[:, :size, 1] = s.slope
            row[:, size:, 1] = 0.0
        self._points = points.reshape(-1, 2)
        self._origins = np.array([s.origin_m for s in surfaces])
        self._first_load = np.array([s.loads_n[0] for s in surfaces])
        self._row_start = np.arange(b) * m * n  # first point of each trial
        self._layer = n  # points from one layer to the next
        # The four points around a reading: this grid point and the next, in the layer
        # below the load and in the one above.
        self._corners = np.array([0, 1, n, n + 1])
        self._last = n - 1.000001  # clamp just inside the last interval
        self.layers = m
        self._j, self._u = np.zeros(b, dtype=np.intp), np.zeros(b)

    def __call__(
        self, coordinate_m: np.ndarray, load_n: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        pos = (coordinate_m - self._origins[:, None]) * (1.0 / GRID_M)
        np.maximum(pos, 0.0, out=pos)
        np.minimum(pos, self._last, out=pos)
        i0 = pos.astype(np.intp)
        w = (pos - i0)[..., None]
        j, u = layer_position(self._first_load, self.layers, load_n)
        i0 += (self._row_start + j * self._layer)[:, None]
        q = self._points[i0[..., None] + self._corners]  # (b, k, 4, 2)
        below = q[..., 0, :] + (q[..., 1, :] - q[..., 0, :]) * w
        above = q[..., 2, :] + (q[..., 3, :] - q[..., 2, :]) * w
        felt = below + (above - below) * u[:, None, None]
        return felt[..., 0], felt[..., 1]

    def felt_into(
        self,
        s_m: np.ndarray,
        v_m_s: np.ndarray,
        ahead_s: np.ndarray,
        load_n: np.ndarray,
        height_out: np.ndarray,
        slope_out: np.ndarray,
    ) -> None:
        """The table called at the coordinates ``s_m[i] + v_m_s[i] * ahead_s[t]``
        (positions ``(b,)`` extrapolated over the times ``(k,)`` by their velocities) under
        the loads ``load_n`` ``(b,)``, written into ``height_out`` and ``slope_out`` ``(b,
        k)``: the same bits, compiled (:mod:`synth.kernels`)."""
        j, u = self._j, self._u  # layer_position's, into the table's own buffers
        if self.layers > 1:
            kernels.layer_position(self._first_load, self.layers, _PER_LOG_RATIO, load_n, j, u)
        kernels.layered_felt(
            self._points,
            self._origins,
            self._row_start,
            self._layer,
            self._last,
            1.0 / GRID_M,
            j,
            u,
            s_m,
            v_m_s,
            ahead_s,
            height_out,
            slope_out,
        )


def texture_table(surfaces: list[LoadedSurface]) -> TextureTable | LayeredTable:
    """The look-up table of a batch's surfaces: a :class:`TextureTable` when they are felt
    the same under any load (one layer each), else a :class:`LayeredTable`."""
    if all(s.loads_n.size == 1 for s in surfaces):
        origins, heights, slopes = stack_surfaces(
            [FeltSurface(s.origin_m, s.height_m[0], s.slope[0]) for s in surfaces]
        )
        return TextureTable(origins, heights, slopes)
    return LayeredTable(surfaces)
