"""``hexatissue surface-mesh FILE.ply [FILE2.ply ...] --out FOLDER``: the tissue of labelled surface meshes;
``hexatissue height-map STACK --out HEIGHT.tif``: the height map of a z-stack, for ``analyze --surface``.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import InputError

__all__ = ["add_parser"]


def add_parser(subparsers):
    """Register the ``surface-mesh`` and ``height-map`` subcommands on an argparse ``subparsers`` object."""
    _height_parser(subparsers)
    p = subparsers.add_parser(
        "surface-mesh", help="cells, junctions, gamma_p and p-atic defects of labelled triangle meshes (PLY/OBJ)",
        description="Read triangle meshes whose faces (or vertices) carry cell labels (PLY: ASCII or binary, a "
                    "label property; OBJ: 'g cell_<label>' groups), as MorphoGraphX and tissue-cartography tools "
                    "write, and measure the tissue on the surface: every cell's area, perimeter, normal and "
                    "gamma_p in its tangent plane, the junctions, the coarse-grained field Gamma_p at every cell (the "
                    "mean gamma_p within --radius along the surface, transported into the cell's plane), and the "
                    "p-atic defects of Gamma_p and of the cells' gamma_p with the curvature they enclose (on a closed "
                    "surface the charges sum to its Euler characteristic). Several files are "
                    "frames, in the order given, whose labels are the same cells in every frame: their T1 events "
                    "(cycles, intercalations) go to mesh_events. Writes mesh_cells, mesh_vertices, mesh_junctions, "
                    "mesh_defects, mesh_frames and mesh_events to --out (lengths in the mesh's unit, called px; docs/surface.md).")
    p.add_argument("files", nargs="+", help="mesh files (.ply, .obj); several = frames")
    p.add_argument("--out", required=True, help="output folder for the tables")
    p.add_argument("--label", default=None,
                   help="PLY property holding the cell label (default: the first of label, cell, cell_id, parent, "
                        "segment, ... found on the faces, else on the vertices)")
    p.add_argument("--p", type=int, nargs="+", default=None, help="symmetry orders of gamma_p and the defects "
                                                                  "(default 6 2)")
    p.add_argument("--reference", type=float, nargs=3, default=(1.0, 0.0, 0.0), metavar=("X", "Y", "Z"),
                   help="direction whose projection on a cell's tangent plane is its frame's first axis "
                        "(default 1 0 0); changes the phases of gamma_p only")
    p.add_argument("--radius", type=float, default=None,
                   help="radius of the coarse-graining disks along the surface, in the mesh's unit (default 2.5 "
                        "R_cell: each cell and its first shell of neighbours)")
    p.add_argument("--format", nargs="+", default=["parquet"], choices=["parquet", "csv"],
                   help="table formats (default parquet)")
    p.set_defaults(func=_run, cli_text=cli_text)
    return p


def _height_parser(subparsers):
    p = subparsers.add_parser(
        "height-map", help="the height map of a z-stack of stained junctions, for 'analyze --surface'",
        description="Find the tissue's surface in a z-stack (or a movie of z-stacks) of an epithelium whose "
                    "junctions are stained: per pixel the plane where the blurred signal peaks, refined below a "
                    "plane, then a smooth surface fitted through the clear peaks (docs/surface.md). Writes the "
                    "heights, in planes, as a float32 TIFF (T x rows x cols for a movie); analyse with 'hexatissue "
                    "analyze LABELS --surface HEIGHT.tif --surface-z-step <plane spacing in px>'. Optionally writes "
                    "the surface projection (the brightest plane near the surface) to segment.")
    p.add_argument("stack", help="z-stack: .tif/.tiff (axes from its OME or ImageJ metadata, else Z x rows x cols, "
                                 "or T x Z x rows x cols) or .npy")
    p.add_argument("--out", required=True, help="height map file to write (.tif)")
    p.add_argument("--axes", default=None, help="the stack's axes when its file does not say: ZYX, TZYX, CZYX, "
                                                "TZCYX, ... (one letter per axis)")
    p.add_argument("--channel", type=int, default=None, help="channel of the junction stain (0-based)")
    p.add_argument("--sigma", type=float, default=None,
                   help="lateral blur before the peak search, px (default 4: about a quarter of a cell's diameter)")
    p.add_argument("--smooth", type=float, default=None, help="smoothing of the surface, px (default 8)")
    p.add_argument("--projection", default=None, help="also write the surface projection to this file (.tif)")
    p.add_argument("--depth", type=int, default=1,
                   help="planes on either side of the surface in the projection (default 1)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.set_defaults(func=_run_height, cli_text=cli_text)
    return p


def _read_stack(path, axes, channel):
    """The stack at ``path`` as (T, Z, rows, cols) and its axes letters."""
    import numpy as np

    path = Path(path)
    if not path.is_file():
        raise InputError(f"stack {str(path)!r} is not a file")
    suffix = path.suffix.lower()
    if suffix in (".tif", ".tiff"):
        import tifffile

        with tifffile.TiffFile(path) as tif:
            series = tif.series[0]
            found = series.axes.upper().replace("I", "Z").replace("Q", "Z")
            data = series.asarray()
    elif suffix == ".npy":
        data, found = np.load(path, allow_pickle=False), ""
    else:
        raise InputError(f"stack {str(path)!r}: expected a .tif, .tiff or .npy file")
    if data.ndim < 3:
        raise InputError(f"stack {str(path)!r} is a {data.ndim}-D image of shape {data.shape}; a height map needs a "
                         f"z-stack (planes, rows, cols)")
    if axes is None:
        axes = found if "Z" in found else {3: "ZYX", 4: "TZYX"}.get(data.ndim, "")
    axes = axes.upper()
    if len(axes) != data.ndim or set(axes) - set("TCZYX") or len(set(axes)) != len(axes) or not axes.endswith("YX"):
        raise InputError(f"stack {str(path)!r} has shape {data.shape}; its axes {axes or 'are unknown'}: pass --axes "
                         f"with one letter per axis from T, C, Z ending in YX (e.g. ZYX, TZYX, TZCYX)")
    if "Z" not in axes:
        raise InputError(f"stack {str(path)!r} has no Z axis (axes {axes}); a height map needs a z-stack")
    if "C" in axes:
        c = axes.index("C")
        if channel is None or not 0 <= channel < data.shape[c]:
            raise InputError(f"stack {str(path)!r} has {data.shape[c]} channels (axes {axes}); pass --channel with "
                             f"the junction stain's, 0 to {data.shape[c] - 1}")
        data, axes = np.take(data, channel, axis=c), axes.replace("C", "")
    elif channel is not None:
        raise InputError(f"--channel {channel} was given but stack {str(path)!r} has no channel axis (axes {axes})")
    read = axes
    if "T" not in axes:
        data, axes = data[None], "T" + axes
    return np.moveaxis(data, [axes.index(a) for a in "TZ"], [0, 1]), read


def _run_height(args) -> int:
    import numpy as np

    from ..io import check_replaceable, write_tiff
    from .stack import SIGMA, SMOOTH, height_map, project_stack

    outputs = [("--out", args.out)] + ([("--projection", args.projection)] if args.projection else [])
    for name, path in outputs:
        if Path(path).suffix.lower() not in (".tif", ".tiff"):
            raise InputError(f"{name} {path!r}: expected a .tif or .tiff file name")
        check_replaceable(path, name=name, overwrite=args.overwrite)
    stacks, axes = _read_stack(args.stack, args.axes, args.channel)
    sigma = SIGMA if args.sigma is None else args.sigma
    smooth = SMOOTH if args.smooth is None else args.smooth
    heights, projections = [], []
    for t, stack in enumerate(stacks):
        surface = height_map(stack, sigma=sigma, smooth=smooth)
        heights.append(surface.height.astype(np.float32))
        if args.projection:
            projections.append(project_stack(stack, surface.height, args.depth))
    height = np.stack(heights) if len(heights) > 1 else heights[0]
    write_tiff(args.out, height)
    if args.projection:
        write_tiff(args.projection, np.stack(projections) if len(projections) > 1 else projections[0])
    lo, mid, hi = np.percentile(height, [0, 50, 100])
    print(f"{args.stack} ({axes}, {stacks.shape[1]} planes, {len(stacks)} frame(s)): surface at planes "
          f"{lo:.1f} to {hi:.1f} (median {mid:.1f}); height map written to {args.out}"
          + (f", projection to {args.projection}" if args.projection else ""))
    print(f"analyse with: hexatissue analyze LABELS --surface {args.out} --surface-z-step <plane spacing in px> "
          f"--out RESULTS")
    return 0


def cli_text(text: str) -> str:
    """An error text of the library with its argument names replaced by the ``surface-mesh`` options."""
    for name, flag in (("label property", "label property (--label)"), ("reference must", "--reference must"),
                       ("p must", "--p must"), ("radius must", "--radius must"), ("sigma must", "--sigma must"), ("smooth must", "--smooth must")):
        if name in text and flag not in text:
            text = text.replace(name, flag, 1)
    return text


def _run(args) -> int:
    from ..io import write_table
    from .mesh import MESH_TABLE_NAMES, mesh_tables
    from .files import read_mesh

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {str(out)!r} is a file; expected a folder")
    meshes = [read_mesh(path, label=args.label) for path in args.files]
    tables = mesh_tables(meshes, p=args.p, reference=args.reference, radius=args.radius)
    for name in MESH_TABLE_NAMES:
        for fmt in args.format:
            write_table(tables[name], out / f"{name}.{fmt}", schema=name)
    frames = tables["mesh_frames"]
    orders = [c[len("charge"):] for c in frames.columns if c.startswith("charge")]
    found = tables["mesh_defects"].groupby(["frame", "field", "p"]).size() if len(tables["mesh_defects"]) else {}

    def charges(row, field, prefix):
        return ", ".join(f"p={q}: {found.get((row.frame, field, int(q)), 0)} defects summing to "
                         f"{getattr(row, prefix + 'charge' + q):g}" for q in orders)

    for row in frames.itertuples(index=False):
        print(f"frame {row.frame} ({args.files[row.frame]}): {row.n_cells} cells, Euler characteristic "
              f"{row.euler}{'' if row.closed else ' (open)'}; Gamma_p within {row.radius:.4g} px "
              f"({row.radius / row.r_cell:.3g} R_cell): {charges(row, 'coarse', 'coarse_')}; the cells' gamma_p: "
              f"{charges(row, 'cells', '')}")
    events = tables["mesh_events"]
    if len(frames) > 1:
        kinds = events["kind"].value_counts() if len(events) else {}
        print(f"T1 events (labels taken as the same cells in every frame): {len(events)}: "
              + ", ".join(f"{kinds.get(k, 0)} {k}" for k in ("cycle", "intercalation", "unresolved")))
    print(f"tables written to {out}")
    return 0
