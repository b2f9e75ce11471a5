"""``tactile-synth shapes`` sub-commands: export, preview, info; each for the 12 built-in
shapes or, with ``--experiment FILE``, for the specimens the file's ``[[specimen]]``
tables name (``docs/specimens.md``)."""

from __future__ import annotations

import argparse
import errno
import sys
from collections.abc import Iterator
from contextlib import contextmanager

from shapes.outlines import SHAPE_NAMES

_EXPERIMENT_HELP = (
    "experiment file (TOML): use the specimens its [[specimen]] tables name instead of "
    "the 12 built-ins (its other sections are read by generate)"
)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``shapes`` command group; each sub-command sets ``handler=callable(args) -> int``."""
    parser = subparsers.add_parser(
        "shapes",
        help="build, export and preview the 12 specimen shapes or an experiment's specimens",
        description="The 12 raised specimen outlines (S1..S12) built with build123d, or "
        "the specimens of an experiment file (--experiment).",
    )
    sub = parser.add_subparsers(dest="shapes_command", metavar="SUBCOMMAND", required=True)

    exp = sub.add_parser("export", help="write specimens as STL, OBJ or STEP files")
    exp.add_argument("--out", required=True, help="output directory (created if missing)")
    exp.add_argument("--format", default="stl", help="stl (default), obj or step")
    exp.add_argument("--shape", help="one shape name (default: all 12, or all the file's)")
    exp.add_argument(
        "--unit", default="m", help="length unit of STL/OBJ numbers: m (default) or mm"
    )
    exp.add_argument("--experiment", metavar="FILE", help=_EXPERIMENT_HELP)
    exp.set_defaults(handler=_export)

    prev = sub.add_parser("preview", help="draw the outlines in a labelled grid (PNG)")
    prev.add_argument("--out", required=True, help="PNG file to write")
    prev.add_argument("--experiment", metavar="FILE", help=_EXPERIMENT_HELP)
    prev.set_defaults(handler=_preview)

    info = sub.add_parser("info", help="print each shape's size, area and convex pieces")
    info.add_argument("--experiment", metavar="FILE", help=_EXPERIMENT_HELP)
    info.set_defaults(handler=_info)


def _specimens(args: argparse.Namespace) -> tuple | None:
    """The experiment file's specimens (all checked), or None without ``--experiment``."""
    experiment = getattr(args, "experiment", None)
    if experiment is None:
        return None
    from shapes.experiment import load_specimens

    return load_specimens(experiment)


def _export(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from shapes.export import FORMATS, UNITS, export
    from shapes.specimen import specimen_name
    from tactile_synth.validation import check_choice

    fmt = check_choice("--format", args.format, FORMATS)
    unit = check_choice("--unit", args.unit, tuple(UNITS))
    specimens = _specimens(args)
    if specimens is None:
        names = list(SHAPE_NAMES)
        if args.shape is not None:
            names = [check_choice("--shape", args.shape, SHAPE_NAMES)]
    else:
        names = list(specimens)
        if args.shape is not None:
            by_name = {specimen_name(s): s for s in specimens}
            names = [by_name[check_choice("--shape", args.shape, tuple(by_name))]]
    _check_out_not_in_a_store(args.out, itself=True)  # files among its arrays damage it
    if specimens is not None:
        _build_all(names, fmt)
    bar = tqdm(names, desc=f"export {fmt}", unit="shape", disable=not sys.stderr.isatty())
    with _naming_out(args.out):
        for name in bar:
            path = export(name, args.out, fmt, unit=unit)
            bar.write(f"wrote {path} ({path.stat().st_size:,} bytes)", file=sys.stdout)
    return 0


def _build_all(names: list, fmt: str) -> None:
    """Build every user specimen's mesh (cached) or solid before the first file is
    written, so one that build123d cannot make stops the export with nothing written."""
    from shapes.cad import solid
    from shapes.meshes import mesh
    from shapes.specimen import Specimen

    for name in names:
        if isinstance(name, Specimen) and fmt == "step":
            solid(name)
        elif isinstance(name, Specimen):
            mesh(name)


def _preview(args: argparse.Namespace) -> int:
    from shapes.preview import preview

    specimens = _specimens(args)
    _check_out_not_in_a_store(args.out)
    with _naming_out(args.out):
        if specimens is None:
            path = preview(args.out)
        else:
            title = f"The {len(specimens)} specimens of {args.experiment}"
            path = preview(args.out, specimens=specimens, title=title)
    print(f"wrote {path}")
    return 0


@contextmanager
def _naming_out(out: str) -> Iterator[None]:
    """An ``--out`` that cannot be created or written (a missing or read-only place, no
    permission) is the user's input: a one-line ``ValueError`` naming ``--out`` as given,
    not the hidden temporary file that failed. Other errors (a full disk) pass unchanged."""
    from tactile_synth.atomic import NOT_WRITABLE_ERRNOS, not_writable

    # A missing place, or a file where a directory must be, is unusable here as well.
    unusable = (*NOT_WRITABLE_ERRNOS, errno.ENOENT, errno.ENOTDIR, errno.EISDIR)
    try:
        yield
    except OSError as exc:
        error = not_writable(exc, out, "choose another path", unusable)
        if error is exc:
            raise
        raise error from None


def _check_out_not_in_a_store(out: str, *, itself: bool = False) -> None:
    """Refuse an ``--out`` that a file blocks or that lies inside a dataset store (or, with
    ``itself``, is a store's own directory) in one line, before anything is built or
    written: the dataset commands' own check."""
    from tactile_synth.atomic import check_dir_path, check_not_inside_a_store, check_out_dir

    # A file standing at the path, or where one of its directories must be.
    if itself:
        check_out_dir(out)
    else:
        check_dir_path(out)
    check_not_inside_a_store(out, itself=itself)


def _info(args: argparse.Namespace) -> int:
    from shapes.dims import SPECIMEN
    from shapes.meshes import convex_pieces
    from shapes.outlines import analytic_area_m2, outline

    specimens = _specimens(args)
    if specimens is not None:
        return _info_experiment(args.experiment, specimens)
    print(
        f"specimen: outline size {SPECIMEN.outline_size_m * 1e3:g} mm, raised "
        f"{SPECIMEN.height_m * 1e3:g} mm, plate {SPECIMEN.base_length_m * 1e3:g} x "
        f"{SPECIMEN.base_width_m * 1e3:g} x {SPECIMEN.base_thickness_m * 1e3:g} mm"
    )
    print(f"{'id':<4}{'shape':<15}{'x (mm)':>8}{'y (mm)':>8}{'area (mm2)':>12}{'pieces':>8}")
    for i, name in enumerate(SHAPE_NAMES, start=1):
        x0, y0, x1, y1 = outline(name).bounds
        print(
            f"S{i:<3}{name:<15}{(x1 - x0) * 1e3:>8.2f}{(y1 - y0) * 1e3:>8.2f}"
            f"{analytic_area_m2(name) * 1e6:>12.2f}{len(convex_pieces(name)):>8}"
        )
    return 0


def _info_experiment(file: str, specimens: tuple) -> int:
    from shapes.dims import SPECIMEN
    from shapes.meshes import convex_pieces
    from shapes.outlines import analytic_area_m2, outline
    from shapes.specimen import Specimen

    print(
        f"experiment {file}: {len(specimens)} specimens on a {SPECIMEN.base_length_m * 1e3:g} "
        f"x {SPECIMEN.base_width_m * 1e3:g} x {SPECIMEN.base_thickness_m * 1e3:g} mm plate"
    )
    width = max(15, *(len(getattr(s, "name", s)) + 2 for s in specimens))
    print(
        f"{'specimen':<{width}}{'x (mm)':>8}{'y (mm)':>8}{'h (mm)':>8}{'area (mm2)':>12}"
        f"{'pieces':>8}  source"
    )
    for shape in specimens:
        x0, y0, x1, y1 = outline(shape).bounds
        if isinstance(shape, Specimen):
            name, height, source = shape.name, shape.height_m, shape.source
            source += " (curved, polygonised)" if shape.curved else ""
        else:
            name, height = shape, SPECIMEN.height_m
            source = f"built-in S{SHAPE_NAMES.index(shape) + 1}"
        print(
            f"{name:<{width}}{(x1 - x0) * 1e3:>8.2f}{(y1 - y0) * 1e3:>8.2f}{height * 1e3:>8.2f}"
            f"{analytic_area_m2(shape) * 1e6:>12.2f}{len(convex_pieces(shape)):>8}  {source}"
        )
    return 0
