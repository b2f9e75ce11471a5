"""The simulator's calibration, as ``scripts/calibrate.py`` runs it: only global,
physically meaningful parameters, each within the range its source gives; nothing is
tuned per shape, material or class.

The computations live in modules by job:

- :mod:`synth.calibration.settings`: which parameters the calibration moves, over which
  cited ranges, and the configurations a command line asks for (``--set``, ``--base``);
- :mod:`synth.calibration.finger`: the skin's soft contact fitted to Hertz's law and the
  PDMS support's stiffnesses and modes;
- :mod:`synth.calibration.scatter`: the stroke-to-stroke scatter of the friction
  coefficient (from the silicone-on-PLA measurements in ``data/``) and of the normal
  force (from the arm's pose repeatability);
- :mod:`synth.calibration.gain`: the PVDF post-amplifier gain and the films' carrier;
- :mod:`synth.calibration.update`: the surface update period's convergence (a numerical
  choice, not a calibration);
- :mod:`synth.calibration.sweep`: the sweep's candidates, its metrics over dataset seeds
  and its tables.

Measuring a configuration needs the benchmark (the leave-one-out diagnosis and AFOP-ML's
selections on training splits), so those computations live in
:mod:`benchmark.calibration`, to the right of the simulator.
"""
