"""``tactile-synth plot-trial`` and ``tactile-synth view``: look at one simulated trial."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from shapes import SHAPE_NAMES
from tactile_synth.validation import float_arg, int_arg

from .materials import MATERIAL_NAMES


def _trial_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--shape", required=True, help=f"one of: {', '.join(SHAPE_NAMES)}")
    p.add_argument("--material", required=True, help=f"one of: {', '.join(MATERIAL_NAMES)}")
    p.add_argument("--force", type=float_arg, default=1.0, metavar="N", help="normal force (N)")
    p.add_argument("--speed", type=float_arg, default=10.0, metavar="MM_S", help="speed (mm/s)")
    p.add_argument("--seed", type=int_arg, default=0, help="trial seed (default 0)")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "plot-trial",
        help="simulate one trial and plot its channels, true forces and finger path",
    )
    _trial_args(p)
    p.add_argument("--out", required=True, metavar="PNG")
    p.set_defaults(handler=_plot_trial)

    p = subparsers.add_parser(
        "view", help="open MuJoCo's interactive viewer on one trial's scene (needs a display)"
    )
    _trial_args(p)
    p.set_defaults(handler=_view)


def check_trial_args(args: argparse.Namespace) -> None:
    """The checks ``generate`` applies to a grid, on one trial's options, before anything is
    simulated: names, the force and speed bounds, a seed >= 0 and a slide on the plate."""
    from tactile_synth.validation import check_choice, check_int

    from .presets import check_forces, check_speeds
    from .simulator import check_grid

    check_choice("--shape", args.shape, SHAPE_NAMES)
    check_choice("--material", args.material, MATERIAL_NAMES)
    (force,) = check_forces("--force", [args.force])
    (speed,) = check_speeds("--speed", [args.speed])
    check_int("--seed", args.seed, minimum=0)
    check_grid([args.shape], [(force, speed)], args.material)


def _plot_trial(args: argparse.Namespace) -> int:
    from .config import SynthConfig
    from .generation import simulate_trials
    from .store import check_not_inside_a_store
    from .trial import TrialSpec
    from .trial_plot import plot_trial

    check_not_inside_a_store(args.out)  # before simulating
    if Path(args.out).suffix.lower() != ".png":
        raise ValueError(f"--out {args.out} must end in .png (plot-trial writes a PNG)")
    check_trial_args(args)
    spec = TrialSpec(args.shape, args.material, args.force, args.speed, args.seed)
    (trial,) = simulate_trials([spec], SynthConfig(), threads=1)
    out = plot_trial(trial, args.out)
    truth = trial.truth
    print(
        f"wrote {out}: {args.shape}/{args.material} at {args.force:g} N, {args.speed:g} mm/s; "
        f"normal force {truth['normal_force_n'].mean():.3f} N mean, tangential "
        f"{truth['tangential_force_n'].mean():.3f} N mean"
    )
    return 0


def display_available() -> bool:
    """Whether an interactive window can open (X11/Wayland on Linux; macOS and Windows
    always have a window server)."""
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def _view(args: argparse.Namespace) -> int:
    import time

    import mujoco

    from .simulator import replay

    if not display_available():
        print(
            "tactile-synth view: no display (DISPLAY/WAYLAND_DISPLAY unset), so MuJoCo's "
            "viewer cannot open here. Run it on a machine with a desktop session, or use "
            f"'tactile-synth plot-trial --shape {args.shape} --material {args.material} "
            "--out trial.png' to see the trial as a plot.",
            file=sys.stderr,
        )
        return 2
    import mujoco.viewer

    from .trial import TrialSpec

    check_trial_args(args)
    spec = TrialSpec(args.shape, args.material, args.force, args.speed, args.seed)
    model, qpos, specimen_z = replay(spec, _config())
    data = mujoco.MjData(model)
    with mujoco.viewer.launch_passive(model, data) as viewer:
        step = 0
        while viewer.is_running():  # replay the simulated trial in real time, in a loop
            start = time.perf_counter()
            data.qpos[:] = qpos[step]
            data.mocap_pos[0, 2] = specimen_z[step]
            mujoco.mj_forward(model, data)
            viewer.sync()
            step = (step + 1) % len(qpos)
            time.sleep(max(0.0, model.opt.timestep - (time.perf_counter() - start)))
    return 0


def _config():
    from .config import SynthConfig

    return SynthConfig()
