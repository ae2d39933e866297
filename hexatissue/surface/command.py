"""``hexatissue surface-mesh FILE.ply [FILE2.ply ...] --out FOLDER``: the tissue of labelled surface meshes.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import InputError

__all__ = ["add_parser"]


def add_parser(subparsers):
    """Register the ``surface-mesh`` subcommand on an argparse ``subparsers`` object."""
    p = subparsers.add_parser(
        "surface-mesh", help="cells, junctions, gamma_p and p-atic defects of labelled triangle meshes (PLY/OBJ)",
        description="Read triangle meshes whose faces (or vertices) carry cell labels (PLY: ASCII or binary, a "
                    "label property; OBJ: 'g cell_<label>' groups), as MorphoGraphX and tissue-cartography tools "
                    "write, and measure the tissue on the surface: every cell's area, perimeter, normal and "
                    "gamma_p in its tangent plane, the junctions, and the p-atic defects with the curvature they "
                    "enclose (on a closed surface the charges sum to its Euler characteristic). Several files are "
                    "frames, in the order given. Writes mesh_cells, mesh_vertices, mesh_junctions, mesh_defects and "
                    "mesh_frames to --out (lengths in the mesh's unit, called px; docs/surface.md).")
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
    p.add_argument("--format", nargs="+", default=["parquet"], choices=["parquet", "csv"],
                   help="table formats (default parquet)")
    p.set_defaults(func=_run, cli_text=cli_text)
    return p


def cli_text(text: str) -> str:
    """An error text of the library with its argument names replaced by the ``surface-mesh`` options."""
    for name, flag in (("label property", "label property (--label)"), ("reference must", "--reference must"),
                       ("p must", "--p must")):
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
    tables = mesh_tables(meshes, p=args.p, reference=args.reference)
    for name in MESH_TABLE_NAMES:
        for fmt in args.format:
            write_table(tables[name], out / f"{name}.{fmt}", schema=name)
    frames = tables["mesh_frames"]
    orders = [c[len("charge"):] for c in frames.columns if c.startswith("charge")]
    for row in frames.itertuples(index=False):
        charges = ", ".join(f"p={q}: {getattr(row, 'charge' + q):g}" for q in orders)
        print(f"frame {row.frame} ({args.files[row.frame]}): {row.n_cells} cells, Euler characteristic "
              f"{row.euler}{'' if row.closed else ' (open)'}; defect charges sum to {charges}")
    print(f"tables written to {out}")
    return 0
