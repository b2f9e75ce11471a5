"""``tactile-synth shapes`` sub-commands: export, preview, info."""

from __future__ import annotations

import argparse
import errno
import sys
from collections.abc import Iterator
from contextlib import contextmanager

from shapes.outlines import SHAPE_NAMES


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``shapes`` command group; each sub-command sets ``handler=callable(args) -> int``."""
    parser = subparsers.add_parser(
        "shapes",
        help="build, export and preview the 12 specimen shapes",
        description="The 12 raised specimen outlines (S1..S12) built with build123d.",
    )
    sub = parser.add_subparsers(dest="shapes_command", metavar="SUBCOMMAND", required=True)

    exp = sub.add_parser("export", help="write specimens as STL, OBJ or STEP files")
    exp.add_argument("--out", required=True, help="output directory (created if missing)")
    exp.add_argument("--format", default="stl", help="stl (default), obj or step")
    exp.add_argument("--shape", help="one shape name (default: all 12)")
    exp.add_argument(
        "--unit", default="m", help="length unit of STL/OBJ numbers: m (default) or mm"
    )
    exp.set_defaults(handler=_export)

    prev = sub.add_parser("preview", help="draw the 12 outlines in a labelled grid (PNG)")
    prev.add_argument("--out", required=True, help="PNG file to write")
    prev.set_defaults(handler=_preview)

    info = sub.add_parser("info", help="print each shape's size, area and convex pieces")
    info.set_defaults(handler=_info)


def _export(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from shapes.export import FORMATS, UNITS, export
    from tactile_synth.validation import check_choice

    fmt = check_choice("--format", args.format, FORMATS)
    unit = check_choice("--unit", args.unit, tuple(UNITS))
    names = (
        [check_choice("--shape", args.shape, SHAPE_NAMES)]
        if args.shape is not None
        else list(SHAPE_NAMES)
    )
    _check_out_not_in_a_store(args.out, itself=True)  # files among its arrays damage it
    bar = tqdm(names, desc=f"export {fmt}", unit="shape", disable=not sys.stderr.isatty())
    with _naming_out(args.out):
        for name in bar:
            path = export(name, args.out, fmt, unit=unit)
            bar.write(f"wrote {path} ({path.stat().st_size:,} bytes)", file=sys.stdout)
    return 0


def _preview(args: argparse.Namespace) -> int:
    from shapes.preview import preview

    _check_out_not_in_a_store(args.out)
    with _naming_out(args.out):
        path = preview(args.out)
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
