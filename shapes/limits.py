"""What the simulated finger can feel: the size and height range of a user's specimen and
the margin it needs on the plate.

Every bound below is derived from the simulator's finger and trial timing. ``shapes``
may not import the simulator (it is the leftmost package), so the few values the
bounds rest on are repeated here under the names the simulator gives them;
``tests/test_specimens.py`` recomputes every bound from the simulator's own values and
fails if the two drift apart. ``docs/specimens.md`` explains each bound at length.

The paper's 12 outlines lie inside every bound (x extents 14-18 mm, 2 mm high).
"""

from __future__ import annotations

#: Radius of the finger's skin pad (``synth.config.Finger.pad_radius_m``).
PAD_RADIUS_M = 0.007
#: Length of the recorded window (``synth.trial.WINDOW_S``).
WINDOW_S = 2.0
#: The paper's nominal sliding speed (``synth.presets.NOMINAL_SPEED_MM_S``), at which the
#: window must hold a whole crossing of the outline.
NOMINAL_SPEED_M_S = 0.010
#: How far below the set speed one stroke may run: three standard deviations of the
#: stroke-to-stroke speed error (``synth.config.Variability.speed_rel`` = 1 %), the
#: simulator's clip of every scatter.
SPEED_SCATTER_REL = 0.03
#: Full width of the window's placement jitter (``Variability.window_jitter_s``).
WINDOW_JITTER_S = 0.02
#: Diameter of the skin's Hertz contact patch at the largest normal force the simulator
#: accepts (``synth.presets.FORCE_RANGE_N``: 3 N): a 7 mm sphere of 0.29 MPa, Poisson 0.49
#: silicone on a rigid flat sinks 1.71 mm, a patch 2 sqrt(r delta) = 6.91 mm across.
CONTACT_DIAMETER_AT_MAX_FORCE_M = 6.91e-3
#: The skin's Hertz indentation at the smallest accepted force (0.4 N): 0.445 mm.
INDENTATION_AT_MIN_FORCE_M = 0.445e-3
#: The same at the largest accepted force (3 N): 1.71 mm.
INDENTATION_AT_MAX_FORCE_M = 1.71e-3

#: Smallest extent of an outline along x and along y: the contact patch at the largest
#: force, rounded up to 7 mm. A narrower outline cannot carry the whole patch on its top:
#: the pad straddles it, pressing on its edges, instead of riding onto it.
MIN_EXTENT_M = 7.0e-3
#: Largest extent along x (the sliding direction): the distance a stroke at the nominal
#: speed covers in the window, less the window's jitter and the speed scatter:
#: (2 s - 0.02 s) x 10 mm/s x (1 - 0.03) = 19.2 mm. Up to this size the 2 s window, centred
#: on the contact phase, holds the pad's crossing of both the entry and the exit edge.
MAX_X_EXTENT_M = (WINDOW_S - WINDOW_JITTER_S) * NOMINAL_SPEED_M_S * (1 - SPEED_SCATTER_REL)

#: Lowest raised height: the skin's indentation at the smallest force, rounded up to
#: 0.5 mm. A lower step lies within the skin's own deformation: the pad, already sunk
#: that deep into the plate, flows over it rather than riding up onto it.
MIN_HEIGHT_M = 0.5e-3
#: Highest raised height: half the pad radius, 3.5 mm. The edge then meets the resting
#: pad at most 60 degrees from the vertical (44 degrees at the paper's 2 mm), so the
#: slide lifts the pad onto the top rather than pushing against a wall; even with the
#: skin sunk 1.71 mm at the largest force it meets the skin below the pad's equator
#: (3.5 + 1.71 < 7 mm).
MAX_HEIGHT_M = PAD_RADIUS_M / 2

#: Plate left free beyond the outline's ends along x: the pad rests on the plate clear of
#: the outline before the entry edge and after the exit edge, its axis up to one pad
#: radius from the edge when the skin first touches it (the touch distance is less than
#: the radius), and the simulator keeps the pad's axis half a radius inside the plate's
#: edge (its check of every path): 1.5 pad radii, 10.5 mm. The simulator checks the full
#: path, whose approach and run-out grow with the speed, when it plans a trial.
PLATE_MARGIN_X_M = 1.5 * PAD_RADIUS_M
#: Plate left free beside the outline along y: a path may run along any line across the
#: outline, and the simulator keeps the pad's axis half a pad radius inside the plate's
#: edge: 3.5 mm.
PLATE_MARGIN_Y_M = 0.5 * PAD_RADIUS_M
