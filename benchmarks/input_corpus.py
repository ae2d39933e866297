"""Is it a segmentation?  The label-ness test of ``hexatissue analyze`` on a corpus built from real data.

Every case is one 2-D image given to :func:`hexatissue.open_source` and, when its frame is accepted,
to :func:`hexatissue.mesh_from_labels`, exactly as ``analyze`` reads a frame. Segmentations must be
accepted; everything else must be refused with an ``InputError`` (a traceback or a hang would fail
the run).  The cases come from the public data sets in the folder named by ``HEXATISSUE_REAL_DATA``
(the one the tests read; docs/input.md lists them):

- segmentations: every frame of every label image, membrane labelling and skeleton held there;
- raw planes: every frame or z-plane of every raw microscopy image, as stored (8, 16 bit, float);
  the first plane of each file also rescaled to 8 bit, 16 bit, float in [0, 1], and dim 8 bit
  (0-35 and 0-10 grey values, as a plane of a z-stack far from the tissue is);
- classifier maps: a 2-class map (1 = cell, 2 = membrane) of the smoothed first plane, as a pixel
  classifier's "simple segmentation" exports it;
- overlays and renders: coloured junction lines (one colour per junction, on black, as
  vertex-extraction tools draw them; Ishihara's ``Vertex.png`` and one made from each segmentation),
  the segmentation's lines drawn in red over the raw plane (RGB), the labels drawn with a repeating
  20-colour map, the raw plane through a colour map.

Usage::

    PYTHONPATH=. python benchmarks/input_corpus.py             # writes benchmarks/results_input.md

The result file lists the confusion table (truth against outcome) per class and every wrong case.
"""
from __future__ import annotations

import argparse
import gzip
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np

# the real data the tests read (tests/conftest.py): the folder named by HEXATISSUE_REAL_DATA
REAL = Path(os.environ.get("HEXATISSUE_REAL_DATA", Path(__file__).resolve().parents[2] / "shared" / "data" / "real"))
HERE = Path(__file__).resolve().parent

SEGMENTATION, NOT = "segmentation", "not a segmentation"


def _tif(path):
    import tifffile

    return tifffile.imread(path)


def _frames(arr, axes_before=1):
    """The 2-D planes of an array whose last two axes are rows and columns."""
    arr = np.asarray(arr)
    return [arr] if arr.ndim == 2 else [p for p in arr.reshape(-1, *arr.shape[-2:])]


def _segmentations():
    """(name, frame) of every segmentation held in the real-data folder."""
    r = REAL
    sources = [
        ("epicure_notum/013_crop_labels.tif", _tif),
        ("epicure_notum/static_image_cellpose.tif", _tif),
        ("epicure_notum/003_crop_epyseg.tif", _tif),
        ("epicure_notum/area3_Composite_epyseg.tif", _tif),
        ("epitools_wingdisc/test_image-projected-segmented.tif", _tif),
        ("epitools_wingdisc/SegResults_CLabels_RegIm_TYX.npz", lambda p: np.load(p)["CLabels"]),
        ("ishihara_bfi_sample/sample.tif", _tif),
        ("mouse_epidermis_laptrack/labels.npy", np.load),
        ("tissue_analyzer_single/1/handCorrection.tif", _tif),
    ]
    sources += [(f"itasc_micropattern/pos0{k}/{what}_labels.tif", _tif)
                for k in range(3) for what in ("cell", "nucleus")]
    sources += [(f"skeletor_pupal_abdomen/Final_Skeleton/Final_Skeleton_Frame_{k}.tif", _tif) for k in range(1, 5)]
    sources += [(f"forsys_skeletons/{n}.tif.gz", lambda p: _tif(gzip.open(p)))
                for n in ["exp_1"] + [f"in_vivo_t_{k}" for k in range(5)]]
    for rel, read in sources:
        path = r / rel
        if not path.exists():
            continue
        arr = np.asarray(read(path))
        if arr.ndim == 3 and arr.shape[-1] in (3, 4):  # an RGB(A) picture: one frame
            yield f"{rel}", arr
            continue
        for t, frame in enumerate(_frames(arr)):
            yield f"{rel}[{t}]", frame


def _raw_planes():
    """(name, plane, first) of every raw microscopy plane of the real-data folder (``first``: the file's first
    plane)."""
    r = REAL
    sources = ["epicure_notum/003_crop.tif", "epicure_notum/013_crop.tif", "epicure_notum/static_image.tif",
               "epicure_notum/area3_Composite.tif", "epitools_wingdisc/test_image.tif",
               "epitools_wingdisc/test_image-projected.tif", "tissue_analyzer_single/1.tif",
               "itasc_micropattern/pos00/cell_raw.tif"]
    sources += [f"skeletor_pupal_abdomen/Images/Frame_{k}.tif" for k in range(1, 5)]
    for rel in sources:
        path = r / rel
        if not path.exists():
            continue
        if rel.startswith("skeletor"):  # 1027 x 1931 px, a header promising more pages than held: the first
            import tifffile

            with tifffile.TiffFile(path) as tf:
                planes = [tf.pages[0].asarray()]
        else:
            planes = _frames(_tif(path))
        for k, plane in enumerate(planes):
            yield f"{rel}[{k}]", plane, k == 0
    npz = r / "epitools_wingdisc/SegResults_CLabels_RegIm_TYX.npz"
    if npz.exists():
        for k, plane in enumerate(np.load(npz)["RegIm"]):
            yield f"{npz.relative_to(r)}:RegIm[{k}]", plane, k == 0
    comp = r / "ishihara_bfi_sample/Comp_sample.tif"
    if comp.exists():
        yield "ishihara_bfi_sample/Comp_sample.tif[1]", _tif(comp)[1], True  # [0] is the skeleton


def _unit(plane):
    p = plane.astype(np.float64)
    lo, hi = np.percentile(p, [0.5, 99.9])
    return np.clip((p - lo) / max(hi - lo, 1e-12), 0, 1)


def _colours(n, seed):
    """``n`` distinct RGB colours, none black."""
    rng = np.random.default_rng(seed)
    codes = rng.choice(2**24 - 1, size=n, replace=False) + 1
    return np.stack([(codes >> 16) & 255, (codes >> 8) & 255, codes & 255], -1).astype(np.uint8)


def _junction_overlay(frame, seed=0):
    """Coloured junction lines on black: the segmentation's lines split at the vertices, one colour per piece."""
    from scipy import ndimage

    from hexatissue.mesh.labels import normalize_labels

    lab, _ = normalize_labels(frame)
    lines = np.zeros(lab.shape, bool)
    lines[:, 1:] |= lab[:, 1:] != lab[:, :-1]
    lines[1:] |= lab[1:] != lab[:-1]
    neighbours = ndimage.convolve(lines.astype(np.int32), np.ones((3, 3), np.int32), mode="constant") - lines
    pieces, n = ndimage.label(lines & (neighbours < 4), np.ones((3, 3), bool))
    rgb = np.zeros((*lab.shape, 3), np.uint8)
    if n:
        rgb[pieces > 0] = _colours(n, seed)[pieces[pieces > 0] - 1]
    rgb[lines & (pieces == 0)] = (255, 255, 255)  # the vertices
    return rgb


def _cmap(values01, name="viridis"):
    from matplotlib import colormaps

    return (colormaps[name](values01)[..., :3] * 255).astype(np.uint8)


def cases():
    """Yield ``(name, truth, klass, image)`` for every case of the corpus."""
    from scipy import ndimage

    segmentations = list(_segmentations())
    for name, frame in segmentations:
        yield name, SEGMENTATION, "segmentation", frame
    for name, plane, first in _raw_planes():
        yield name, NOT, "raw plane", plane
        if not first:
            continue
        u = _unit(plane)
        yield f"{name} 8 bit", NOT, "raw plane", np.round(u * 255).astype(np.uint8)
        yield f"{name} 16 bit", NOT, "raw plane", np.round(u * 65535).astype(np.uint16)
        yield f"{name} float 0-1", NOT, "raw plane", u.astype(np.float32)
        yield f"{name} dim 8 bit (3-35)", NOT, "dim raw plane", np.round(3 + u * 32).astype(np.uint8)
        yield f"{name} dim 8 bit (0-10)", NOT, "dim raw plane", np.round(u * 10).astype(np.uint8)
        smooth = ndimage.gaussian_filter(u, 1.0)
        yield f"{name} 2-class map", NOT, "classifier map", np.where(smooth > np.median(smooth) * 1.15, 2,
                                                                       1).astype(np.uint8)
        yield f"{name} colour map", NOT, "render", _cmap(u)
    overlay = REAL / "ishihara_bfi_sample" / "Vertex.png"
    if overlay.exists():
        import cv2

        yield "ishihara_bfi_sample/Vertex.png", NOT, "overlay", cv2.imread(str(overlay))[..., ::-1]
    raw_of = {"epicure_notum/013_crop_labels.tif": ("epicure_notum/013_crop.tif", _tif),
              "epicure_notum/static_image_cellpose.tif": ("epicure_notum/static_image.tif", _tif)}
    seen = set()
    for name, frame in segmentations:
        base = name.split("[")[0]
        if base in seen or frame.ndim != 2:
            continue
        seen.add(base)
        yield f"{base} junction overlay", NOT, "overlay", _junction_overlay(frame)
        if len(np.unique(frame)) <= 2:  # a skeleton drawn in one colour is still a skeleton
            continue
        ids = frame.astype(np.int64)
        tab = _colours(20, 1)
        render = tab[ids % 20]
        render[ids == 0] = 0
        yield f"{base} labels in 20 colours", NOT, "render", render
        if base in raw_of:
            raw = _frames(raw_of[base][1](REAL / raw_of[base][0]))[0]
            grey = np.round(_unit(raw) * 255).astype(np.uint8)
            rgb = np.repeat(grey[..., None], 3, -1)
            lines = np.zeros(frame.shape, bool)
            lines[:, 1:] |= frame[:, 1:] != frame[:, :-1]
            lines[1:] |= frame[1:] != frame[:-1]
            rgb[lines] = (255, 0, 0)
            yield f"{base} outlines on the raw plane", NOT, "overlay", rgb


def outcome(image):
    """``("accepted", cells)`` or ``("refused", message)``, as ``analyze`` reads and meshes one frame."""
    import hexatissue as ht

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            frame = ht.open_source(image).frame(0)
            return "accepted", f"{len(ht.mesh_from_labels(frame).cells)} cells"
        except ht.InputError as exc:
            return "refused", str(exc)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(HERE / "results_input.md"), help="result file to write")
    args = parser.parse_args(argv)
    if not REAL.is_dir():
        print(f"real data folder {REAL} is absent: nothing to measure", file=sys.stderr)
        return 1
    start = time.time()
    rows = []
    for name, truth, klass, image in cases():
        got, text = outcome(image)
        rows.append((name, truth, klass, got, text))
        print(f"{got:9s} {klass:15s} {name}: {text[:150]}", flush=True)
    write(rows, Path(args.out), time.time() - start)
    wrong = [r for r in rows if (r[1] == SEGMENTATION) != (r[3] == "accepted")]
    print(f"{len(rows)} cases, {len(wrong)} wrong; {args.out}")
    return 0


def confusion(rows):
    """``{klass: (accepted, refused)}`` and the wrong rows."""
    table = {}
    for _, truth, klass, got, _ in rows:
        acc, ref = table.get(klass, (0, 0))
        table[klass] = (acc + (got == "accepted"), ref + (got == "refused"))
    wrong = [r for r in rows if (r[1] == SEGMENTATION) != (r[3] == "accepted")]
    return table, wrong


def write(rows, out, seconds):
    table, wrong = confusion(rows)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    lines = ["# Label-ness corpus: segmentations accepted, everything else refused", "",
             f"`benchmarks/input_corpus.py`, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
             f"{platform.machine()} {os.cpu_count()} cores, Python {platform.python_version()}, 1-minute load "
             f"{load:.1f}, {seconds:.0f} s; data: the real-data folder (`HEXATISSUE_REAL_DATA`).", "",
             "| class | truth | cases | accepted | refused |", "|---|---|---|---|---|"]
    for klass, (acc, ref) in table.items():
        truth = SEGMENTATION if klass == "segmentation" else NOT
        lines.append(f"| {klass} | {truth} | {acc + ref} | {acc} | {ref} |")
    seg = table.get("segmentation", (0, 0))
    other = [v for k, v in table.items() if k != "segmentation"]
    lines += ["", f"Segmentations accepted: {seg[0]} of {sum(seg)}; non-segmentations refused: "
                  f"{sum(r for _, r in other)} of {sum(a + r for a, r in other)}.", ""]
    if wrong:
        lines += ["## Wrong outcomes", ""] + [f"- {n} ({k}): {g}, {t[:200]}" for n, _, k, g, t in wrong] + [""]
    lines += ["## Every case", "", "| case | class | outcome |", "|---|---|---|"]
    lines += [f"| {n} | {k} | {g}: {t[:120].replace('|', '/')} |" for n, _, k, g, t in rows]
    out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    sys.exit(main())
