"""The robot's stroke (:class:`Motion`: timing, speed profile, force loop, wrist sensor,
path) and its stroke-to-stroke scatter (:class:`Variability`), each parameter in SI units
with the unit in its name and a one-line rationale. :mod:`synth.config` bundles them into
``SynthConfig``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from . import params


@dataclass(frozen=True)
class Motion:
    """The robot's motion (path, timeline, drives, force loop) and the physics step.

    The robot is position-controlled along the path (stiff x/y servos) and holds the
    normal force with a force loop: a discrete integral controller, run every
    ``control_period_s`` on the force its wrist measures, that moves the set point of a
    stiff z servo (the way a UR arm's force mode works).
    """

    #: Physics step; 0.5 ms resolves skin vibration up to the 1 kHz DAQ's band and keeps
    #: contact time constants >= 2 steps.
    timestep_s: float = 0.0005
    #: The robot controller's period: 8 ms, the 125 Hz real-time loop of a UR5 (CB3); the
    #: force loop acts at this rate.
    control_period_s: float = 0.008
    #: How often the surface's response (texture under the contact, friction coefficient)
    #: is recomputed from the simulated state. A numerical choice, not the robot's: short
    #: enough that the contact moves a small fraction of the finest felt wavelength between
    #: updates (20 um at 10 mm/s against 85-100 um marks), with the height and slope in
    #: between extrapolated along the contact's velocity.
    surface_update_s: float = 0.002
    #: Load phase: the finger presses on the plate, clear of the raised outline, before it
    #: starts sliding (it starts at rest under load, so the force loop only trims).
    settle_s: float = 0.05
    #: Velocity ramp at the slide start (the robot's acceleration limit).
    ramp_s: float = 0.02
    #: Sliding time from the slide start to the first touch of the raised outline: the
    #: start point is placed this far (in time, at the trial's speed) ahead of the outline,
    #: so the skin crosses the entry edge as a sliding finger does.
    approach_s: float = 0.10
    #: The window starts at least this long after the robot reaches speed (the start's
    #: transient in the friction and the PDMS shear has died out by then).
    start_transient_s: float = 0.05
    #: Stiffness of the robot's x/y/z position servos: 1 N of friction deflects the tip
    #: 0.05 mm (an arm's tip is stiff; soft drives let friction creep), and the servo mode
    #: with the phalanx mass (~100 Hz) stays resolved by the physics step. Not published
    #: for the arm's tip: a free choice, plausible 10-40 kN/m (servo mode 69-138 Hz),
    #: which ``tactile-synth calibrate --sweep`` measures.
    servo_stiffness_n_m: float = 20000.0
    #: Their damping: critical for the phalanx and pad mass (2 sqrt(k m)).
    servo_damping_n_s_m: float = 65.0
    #: Closed-loop bandwidth of the force loop. Not published for UR force mode; a 125-500
    #: Hz admittance loop with a sample or two of latency is stable up to ~1/10 of its
    #: rate, and contact bouncing is reported at the upper end: 5 Hz (range 1-10 Hz,
    #: which ``tactile-synth calibrate --sweep`` measures).
    force_loop_bandwidth_hz: float = 5.0
    #: MuJoCo impratio: frictional/normal constraint impedance; 10 makes the elliptic
    #: cone's tangential/normal match the coefficient (0.83 at 1 vs 0.90 for 0.9).
    impratio: float = 100.0
    #: The force the loop regulates is a wrist force sensor's reading: the true force the
    #: z drive transmits plus white noise of this RMS on every reading. The paper's UR5
    #: (CB3) has no wrist sensor, and its joint-current force estimate is specified to
    #: +-10 N (Universal Robots' answer on its forum, "Internal Force Sensor
    #: properties"), useless at 1 N; a rig that holds 1 N reads a wrist sensor of the
    #: Robotiq FT 300 class, the usual one on UR arms: 0.1 N noise-free resolution at
    #: 100 Hz (its data sheet). A noise-free resolution is the noise's peak-to-peak span,
    #: about 6.6 standard deviations, so 0.015 N RMS (plausible 0.015-0.1 N, the latter
    #: reading the resolution as the RMS; ``tactile-synth calibrate --sweep`` measures both).
    #: Each control period reads the latest reading.
    wrist_force_noise_n: float = 0.015
    #: Wrist force sensor's output rate: 100 Hz (Robotiq FT 300).
    wrist_sensor_rate_hz: float = 100.0
    #: Lateral (y) position of the path relative to the specimen's centre line. The paper
    #: does not say where its strokes crossed the specimens; a free choice, plausible 0-3
    #: mm (a stroke aimed at the centre, up to a quarter of the smallest outline off it).
    #: 2 mm off the axis the skin crosses the edges obliquely, so the edges' lateral push
    #: has one sign in every trial instead of flipping with the placement scatter; on the
    #: axis the side gauge reads the symmetric shapes' edges with a sign that the
    #: placement scatter flips (``tactile-synth calibrate --sweep`` measures 0-3 mm).
    path_y_m: float = 0.002
    #: False: slide on the bare base plate (sensor calibration runs, physics checks).
    raised_shape: bool = True
    #: The specimen turned in its fixture by this yaw (about the vertical), on top of the
    #: stroke-to-stroke scatter (``Variability.yaw_rad``): the path crosses the outline at
    #: this angle and the surface's marks run at it to the fingerprint's ridges. 0: the
    #: specimen square to the path, as at enrolment.
    specimen_yaw_rad: float = 0.0

    def __post_init__(self) -> None:
        params.positive(
            self,
            "timestep_s",
            "control_period_s",
            "surface_update_s",
            "settle_s",
            "ramp_s",
            "approach_s",
            "start_transient_s",
            "servo_stiffness_n_m",
            "servo_damping_n_s_m",
            "force_loop_bandwidth_hz",
            "impratio",
            "wrist_sensor_rate_hz",
        )
        params.non_negative(self, "wrist_force_noise_n")
        params.below(self, "timestep_s", 0.001, "the physics must run faster than the 1 kHz DAQ")
        ratio = 1.0 / (self.timestep_s * 1000.0)
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(
                "Motion.timestep_s must divide the 1 ms DAQ period (e.g. 0.0005, 0.00025); "
                f"got {self.timestep_s!r}"
            )
        steps = self.surface_update_s / self.timestep_s
        if abs(steps - round(steps)) > 1e-9 or round(steps) < 2:
            raise ValueError(
                "Motion.surface_update_s must be a whole number (>= 2) of physics steps "
                f"({self.timestep_s} s); got {self.surface_update_s!r}"
            )
        periods = self.control_period_s / self.surface_update_s
        if abs(periods - round(periods)) > 1e-9 or round(periods) < 1:
            raise ValueError(
                "Motion.control_period_s must be a whole number of surface updates "
                f"({self.surface_update_s} s); got {self.control_period_s!r}"
            )
        if abs(params._value(self, "path_y_m")) > 0.01:
            raise ValueError(f"Motion.path_y_m must lie within +-0.01 m; got {self.path_y_m!r}")
        if not abs(params._value(self, "specimen_yaw_rad")) < math.pi / 2:
            raise ValueError(
                f"Motion.specimen_yaw_rad must lie within +-pi/2 (a specimen turned by less than "
                f"a right angle); got {self.specimen_yaw_rad!r}"
            )
        if not isinstance(self.raised_shape, bool):
            raise ValueError(
                f"Motion.raised_shape must be True or False; got {self.raised_shape!r}"
            )

    @property
    def control_steps(self) -> int:
        """Physics steps per controller period."""
        return round(self.control_period_s / self.timestep_s)

    @property
    def surface_steps(self) -> int:
        """Physics steps per surface update."""
        return round(self.surface_update_s / self.timestep_s)


@dataclass(frozen=True)
class Variability:
    """Per-trial scatter, drawn from the trial's seed (standard deviations unless noted).

    Every trial uses the same finger and the same specimen of its class; what varies is
    where and how the robot slides and how the surface behaves on that stroke.
    """

    #: Lateral (y) offset of the path: uniform within +- this. UR arms repeat to +-0.1 mm;
    #: the specimen's play in its fixture adds about as much again.
    lateral_offset_m: float = 0.25e-3
    #: Yaw of the path relative to the specimen (standard deviation): the 60 mm plate
    #: turns in its fixture pocket by up to 2 x play / length = 2 x 0.15 mm / 60 mm =
    #: 0.005 rad as friction pushes it (the play as for ``lateral_offset_m``). It also
    #: sets the angle between the specimen's periodic marks and the fingerprint's ridges
    #: (:func:`synth.texture.mark_gains`).
    yaw_rad: float = 0.005
    #: Stroke-to-stroke relative error of the normal force (standard deviation). Not
    #: measured for this rig (the paper says only that its UR5 slid "with constant
    #: contact force"); derived from the arm's pose repeatability: a UR5 returns to a
    #: pose within +-0.1 mm (data sheet; ISO 9283 repeatability, the mean distance plus
    #: 3 standard deviations), so the press depth scatters by 0.1 mm / 3 = 0.033 mm, and
    #: the load by that times the stiffness of what the press compresses in series: the
    #: arm's servo (20 kN/m), the PDMS support as simulated (21 kN/m) and the skin's
    #: Hertz contact (1.8 kN/m at 1 N, 0.82 mm deep), 1.56 kN/m in all, so 5.2 % at 1 N
    #: (4.3 % for a Gaussian scatter in three axes, 6.0 % for one along the press
    #: alone). A force loop is not known to do better at this load: a UR5e in force
    #: mode, with its wrist force/torque sensor, misses set points of 1-10 N by 0.38 N on
    #: average (Trochimczuk et al. 2026, Sensors 26, 1709). The wrist sensor's own noise
    #: within a stroke is :attr:`Motion.wrist_force_noise_n`. ``scripts/calibrate.py
    #: force`` derives this value from the configured finger (``docs/simulator.md``, "The
    #: force scatter").
    force_rel: float = 0.052
    #: Relative error of the path speed: not measured for this rig either; an assumption.
    #: A timed path whose every point repeated as a UR5's poses do (one standard deviation
    #: 0.033 mm, "The force scatter" in ``docs/simulator.md``) would change the time
    #: between a stroke's first and last touch of an outline, 19-29 mm apart, by sqrt(2)
    #: x 0.033 mm over that stretch: 0.16-0.25 % (``scripts/calibrate.py speed``). How
    #: closely UR force mode tracks its path is not published. ``tactile-synth calibrate
    #: --sweep`` measures 0, 0.25 %, 1 % and 3 %.
    speed_rel: float = 0.01
    #: Stroke-to-stroke scatter of the friction coefficient on one specimen (coefficient
    #: of variation). Two platinum-cure silicones slid 30 times over one PLA track at
    #: 10 mm/s and 62.5 kPa, the measured pressure nearest the skin's mean Hertz pressure
    #: at 1 N (55 kPa), vary by 3.2 % and 4.6 %, run-in included (Tortos-Vinocour et al.
    #: 2024, IEEE Robot. Autom. Lett., doi:10.1109/LRA.2024.3376975): this is their mean,
    #: as ``scripts/calibrate.py friction`` derives it. Human skin varies more, 6-8 %
    #: between repeated device measurements (intraclass correlation 0.91; Temel, Johnson
    #: & Lloyd 2022, Tribol. Lett. 70), as its moisture changes from stroke to stroke;
    #: contaminated or worn contacts up to 10-15 %.
    friction_rel: float = 0.039
    #: When the window is cut from the record: the contact onset is found in the signals
    #: to within this (uniform in [0, this]). A free choice; the sweep measures 0-50 ms.
    window_jitter_s: float = 0.02

    def __post_init__(self) -> None:
        names = [f.name for f in dataclasses.fields(self)]
        params.non_negative(self, *names)
        for name in ("force_rel", "speed_rel", "friction_rel"):
            params.below(self, name, 0.3, "relative scatter")

    def nominal(self) -> Variability:
        """No scatter at all (physics tests use it to compare conditions exactly)."""
        return Variability(**{f.name: 0.0 for f in dataclasses.fields(self)})
