"""Triangle meshes with cell labels: PLY (ASCII, binary little and big endian) and OBJ, read and written.

What MorphoGraphX and tissue-cartography tools write: a triangle mesh of the
tissue's surface with the cell of every face (or of every vertex) as an
integer property.  :func:`read_mesh` reads one into a :class:`LabelledMesh`
(vertices, triangles, one cell label per face; 0 = no cell);
:func:`write_ply` and :func:`write_obj` write one.  The readers are the
package's own (no dependency); ``tests/test_surface_mesh.py`` checks the PLY
reader against plyfile.

PLY
    Elements ``vertex`` (properties ``x``, ``y``, ``z``) and ``face`` (a list
    property ``vertex_indices`` or ``vertex_index`` of 3 entries per face:
    triangles only).  The cell label is an integer property (a float one
    holding whole numbers is accepted) of the faces or of the vertices,
    named by ``label=`` or found among :data:`LABEL_NAMES` (faces first).
    Labels of vertices go to the faces by :func:`face_labels_from_vertices`.
OBJ
    ``v x y z`` lines (extra values such as colours ignored) and triangular
    ``f`` lines (``f 1 2 3``, ``f 1/1 2/2 3/3``, ``f 1//1 ...``; negative
    indices count back from the last vertex).  Labels: the ``labels=``
    array (one per face, or one per vertex), else the groups: a face belongs
    to the cell of the last ``g`` line before it whose name ends in an
    integer (``g 12``, ``g cell_12``, ``g cell12`` -> 12); a group name
    without one, and faces before any ``g``, are cell 0 (no cell).
    ``usemtl``, ``o``, ``s`` and other statements are ignored.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import atomic_path

__all__ = ["LabelledMesh", "read_mesh", "read_ply", "read_obj", "write_ply", "write_obj", "check_mesh",
           "face_labels_from_vertices", "LABEL_NAMES"]

#: Property names taken as the cell label when ``label=None``, in this order (faces first, then vertices).
LABEL_NAMES = ("label", "labels", "cell", "cell_id", "cellid", "cell_label", "parent", "segment", "segment_id",
               "region")

_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
_FORMATS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}


@dataclass
class LabelledMesh:
    """A triangle mesh with one cell label per face.

    Attributes
    ----------
    vertices : (n, 3) float array
        x, y, z of every vertex (the file's unit; px for the tables).
    faces : (m, 3) int64 array
        Vertex indices of every triangle, 0-based.
    labels : (m,) int64 array
        Cell of every face; 0 = no cell (background).
    path : str or None
        The file read, for messages.
    """

    vertices: np.ndarray
    faces: np.ndarray
    labels: np.ndarray
    path: str | None = None


def _fail(path, what):
    raise InputError(f"mesh file {str(path)!r}: {what}")


def check_mesh(vertices, faces, labels, name="mesh") -> LabelledMesh:
    """Vertices, triangles and face labels checked and converted (float64, int64, int64); else :class:`InputError`.

    Refused, naming ``name``: vertices that are not ``(n, 3)`` or not finite,
    faces that are not triangles or index outside ``[0, n)``, faces repeating
    a vertex, labels not one integer per face or negative.
    """
    try:
        v = np.asarray(vertices, dtype=float)
        f = np.asarray(faces)
        lab = np.asarray(labels)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: vertices, faces and labels must be numeric arrays ({exc})") from None
    if v.ndim != 2 or v.shape[1] != 3:
        raise InputError(f"{name}: vertices must have shape (n, 3) (x, y, z); got {v.shape}")
    bad = ~np.isfinite(v).all(axis=1)
    if bad.any():
        raise InputError(f"{name}: {int(bad.sum())} vertex coordinate row(s) are NaN or infinite "
                         f"(first: vertex {int(np.flatnonzero(bad)[0])})")
    if f.ndim != 2 or f.shape[1] != 3:
        raise InputError(f"{name}: faces must be triangles, shape (m, 3); got {f.shape}")
    if f.size and (f.dtype.kind not in "iu" and not np.array_equal(f, np.round(f))):
        raise InputError(f"{name}: face vertex indices must be integers")
    f = f.astype(np.int64)
    if f.size and (f.min() < 0 or f.max() >= len(v)):
        k = int(np.flatnonzero((f < 0).any(axis=1) | (f >= len(v)).any(axis=1))[0])
        raise InputError(f"{name}: face {k} has vertex indices {f[k].tolist()} out of range: there are {len(v)} "
                         f"vertices (indices 0 to {len(v) - 1})")
    repeat = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])
    if repeat.any():
        k = int(np.flatnonzero(repeat)[0])
        raise InputError(f"{name}: {int(repeat.sum())} face(s) repeat a vertex (first: face {k}, {f[k].tolist()}); "
                         f"a triangle needs three distinct vertices")
    if lab.shape != (len(f),):
        raise InputError(f"{name}: labels must hold one cell per face ({len(f)}); got shape {lab.shape}")
    lab = _integer_labels(lab, name)
    return LabelledMesh(v, f, lab)


def _integer_labels(lab, name):
    lab = np.asarray(lab)
    if lab.dtype.kind == "f":
        if not np.isfinite(lab).all() or not np.array_equal(lab, np.round(lab)):
            raise InputError(f"{name}: cell labels must be whole numbers; got non-integer values")
    elif lab.dtype.kind not in "iub":
        raise InputError(f"{name}: cell labels must be integers; got dtype {lab.dtype}")
    lab = lab.astype(np.int64)
    if lab.size and lab.min() < 0:
        raise InputError(f"{name}: cell labels must be >= 0 (0 = no cell); got {int(lab.min())}")
    return lab


def face_labels_from_vertices(faces, vertex_labels) -> np.ndarray:
    """One cell label per face from labels of the vertices: the majority of the face's three vertices.

    Only positive vertex labels vote (MorphoGraphX marks boundary vertices
    with -1 or 0); the label held by most of the voting vertices wins, a tie
    (three different labels, or two with one vote each) goes to the
    smallest; a face with no positive vertex label is 0 (no cell).
    """
    faces = np.asarray(faces, dtype=np.int64)
    lab = np.asarray(vertex_labels)
    if lab.dtype.kind == "f":
        if not np.isfinite(lab).all() or not np.array_equal(lab, np.round(lab)):
            raise InputError("vertex labels must be whole numbers")
    lab = lab.astype(np.int64)[faces]  # (m, 3)
    lab = np.where(lab > 0, lab, 0)
    big = np.iinfo(np.int64).max
    a, b, c = lab[:, 0], lab[:, 1], lab[:, 2]
    out = np.minimum(np.minimum(np.where(a > 0, a, big), np.where(b > 0, b, big)), np.where(c > 0, c, big))
    out[out == big] = 0
    pair = np.where((a > 0) & ((a == b) | (a == c)), a, np.where((b > 0) & (b == c), b, 0))
    return np.where(pair > 0, pair, out)


# --------------------------------------------------------------------------------------------------- reading


def read_mesh(path, label=None, labels=None) -> LabelledMesh:
    """Read a triangle mesh with cell labels from a PLY or OBJ file.

    Parameters
    ----------
    path : str or Path
        ``.ply`` (ASCII or binary) or ``.obj``.
    label : str, optional
        The PLY property holding the cell label (of the faces or, if the
        faces have none of that name, of the vertices); default: the first of
        :data:`LABEL_NAMES` found.
    labels : array, optional
        OBJ only: one label per face or per vertex, instead of the groups.

    Returns
    -------
    LabelledMesh

    Raises
    ------
    InputError
        Naming the file and what is wrong: not PLY/OBJ, a truncated or
        malformed file, faces that are not triangles, no label property (PLY)
        or no labelled group (OBJ), indices out of range, non-finite
        coordinates, negative labels.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"mesh file {str(p)!r} does not exist or is not a file")
    suffix = p.suffix.lower()
    if suffix == ".ply":
        if labels is not None:
            raise InputError(f"mesh file {str(p)!r}: labels= is for OBJ files; a PLY file holds its labels "
                             f"(name the property with label=)")
        return read_ply(p, label=label)
    if suffix == ".obj":
        if label is not None:
            raise InputError(f"mesh file {str(p)!r}: label= names a PLY property; an OBJ file takes labels= or "
                             f"its groups")
        return read_obj(p, labels=labels)
    raise InputError(f"mesh file {str(p)!r}: expected a .ply or .obj file; got {suffix or 'no suffix'!r}")


def _parse_header(path, data):
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        _fail(path, "not a PLY file (no 'ply' magic line or no 'end_header')")
    stop = data.find(b"\n", end)
    body = stop + 1 if stop >= 0 else len(data)
    lines = data[:end].decode("ascii", "replace").splitlines()[1:]
    fmt, elements = None, []
    for raw in lines:
        words = raw.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format":
            if len(words) < 2 or words[1] not in _FORMATS:
                _fail(path, f"unknown PLY format line {raw.strip()!r}; expected ascii, binary_little_endian or "
                            f"binary_big_endian")
            fmt = words[1]
        elif words[0] == "element":
            if len(words) != 3 or not words[2].isdigit():
                _fail(path, f"malformed PLY element line {raw.strip()!r}")
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property":
            if not elements:
                _fail(path, f"PLY property before any element: {raw.strip()!r}")
            if len(words) == 5 and words[1] == "list":
                if words[2] not in _PLY_TYPES or words[3] not in _PLY_TYPES:
                    _fail(path, f"unknown PLY type in {raw.strip()!r}")
                elements[-1][2].append((words[4], _PLY_TYPES[words[2]], _PLY_TYPES[words[3]]))
            elif len(words) == 3 and words[1] in _PLY_TYPES:
                elements[-1][2].append((words[2], _PLY_TYPES[words[1]], None))
            else:
                _fail(path, f"malformed or unknown PLY property line {raw.strip()!r}")
        else:
            _fail(path, f"unexpected PLY header line {raw.strip()!r}")
    if fmt is None:
        _fail(path, "PLY header has no format line")
    return fmt, elements, body


def _ascii_element(path, name, count, props, tokens, pos):
    """Columns of one ASCII element from the token stream at ``pos``; returns (columns, new pos)."""
    lists = [q for q in props if q[2] is not None]
    if not lists:
        k = len(props)
        chunk = tokens[pos:pos + k * count]
        if len(chunk) < k * count:
            _fail(path, f"truncated: element {name!r} needs {count} rows of {k} values")
        try:
            table = np.asarray(chunk, dtype=float).reshape(count, k)
        except ValueError:
            _fail(path, f"element {name!r} holds a value that is not a number")
        return {q[0]: table[:, j] for j, q in enumerate(props)}, pos + k * count
    if len(lists) == 1 and name == "face":
        # the fast path: every list of 3 entries (triangles); verified below
        k = len(props) + 3
        chunk = tokens[pos:pos + k * count]
        j_list = next(j for j, q in enumerate(props) if q[2] is not None)
        if len(chunk) == k * count:
            try:
                table = np.asarray(chunk, dtype=float).reshape(count, k)
            except ValueError:
                table = None
            if table is not None and (table[:, j_list] == 3).all():
                out, col = {}, 0
                for q in props:
                    if q[2] is None:
                        out[q[0]] = table[:, col]
                        col += 1
                    else:
                        out[q[0]] = table[:, col + 1:col + 4]
                        col += 4
                return out, pos + k * count
    # the general path: row by row
    out = {q[0]: [] for q in props}
    for row in range(count):
        for q in props:
            if pos >= len(tokens):
                _fail(path, f"truncated: element {name!r} ends at row {row} of {count}")
            try:
                if q[2] is None:
                    out[q[0]].append(float(tokens[pos]))
                    pos += 1
                else:
                    n = int(tokens[pos])
                    out[q[0]].append([float(t) for t in tokens[pos + 1:pos + 1 + n]])
                    pos += 1 + n
            except ValueError:
                _fail(path, f"element {name!r} row {row} holds a value that is not a number")
    return {k: (np.asarray(v) if k not in {q[0] for q in lists} else v) for k, v in out.items()}, pos


def _binary_element(path, name, count, props, data, pos, order):
    lists = [q for q in props if q[2] is not None]
    if not lists:
        dtype = np.dtype([(q[0], order + q[1]) for q in props])
        need = dtype.itemsize * count
        if pos + need > len(data):
            _fail(path, f"truncated: element {name!r} needs {need} bytes, {len(data) - pos} left")
        table = np.frombuffer(data, dtype=dtype, count=count, offset=pos)
        return {q[0]: table[q[0]] for q in props}, pos + need
    # lists of 3 entries as a fixed record, then verified
    fields = []
    for q in props:
        if q[2] is None:
            fields.append((q[0], order + q[1]))
        else:
            fields.append((q[0] + "\0n", order + q[1]))
            fields.append((q[0], order + q[2], (3,)))
    dtype = np.dtype(fields)
    fixed_ok = False
    if pos + dtype.itemsize * count <= len(data):
        table = np.frombuffer(data, dtype=dtype, count=count, offset=pos)
        fixed_ok = all((table[q[0] + "\0n"] == 3).all() for q in lists)
    if fixed_ok:
        return {q[0]: table[q[0]] for q in props}, pos + dtype.itemsize * count
    # row by row (lists of other lengths)
    out = {q[0]: [] for q in props}
    for row in range(count):
        for q in props:
            if q[2] is None:
                dt = np.dtype(order + q[1])
                if pos + dt.itemsize > len(data):
                    _fail(path, f"truncated: element {name!r} ends at row {row} of {count}")
                out[q[0]].append(np.frombuffer(data, dt, 1, pos)[0])
                pos += dt.itemsize
            else:
                dn, dv = np.dtype(order + q[1]), np.dtype(order + q[2])
                if pos + dn.itemsize > len(data):
                    _fail(path, f"truncated: element {name!r} ends at row {row} of {count}")
                n = int(np.frombuffer(data, dn, 1, pos)[0])
                pos += dn.itemsize
                if pos + n * dv.itemsize > len(data):
                    _fail(path, f"truncated: element {name!r} ends at row {row} of {count}")
                out[q[0]].append(np.frombuffer(data, dv, n, pos))
                pos += n * dv.itemsize
    return {k: (np.asarray(v) if k not in {q[0] for q in lists} else v) for k, v in out.items()}, pos


def read_ply(path, label=None) -> LabelledMesh:
    """Read a PLY triangle mesh with a cell label property (:func:`read_mesh`)."""
    path = Path(path)
    data = path.read_bytes()
    fmt, elements, pos = _parse_header(path, data)
    names = [e[0] for e in elements]
    for need in ("vertex", "face"):
        if need not in names:
            _fail(path, f"no element {need!r} in the PLY header (elements: {names})")
    wanted = {"vertex", "face"}
    tables = {}
    if fmt == "ascii":
        tokens = data[pos:].split()
        tpos = 0
        for name, count, props in elements:
            if wanted <= set(tables):
                break
            tables[name], tpos = _ascii_element(path, name, count, props, tokens, tpos)
    else:
        for name, count, props in elements:
            if wanted <= set(tables):
                break
            tables[name], pos = _binary_element(path, name, count, props, data, pos, _FORMATS[fmt])
    vertex, face = tables["vertex"], tables["face"]
    missing = [c for c in "xyz" if c not in vertex]
    if missing:
        _fail(path, f"the vertices have no {', '.join(missing)} property")
    index_name = next((k for k in ("vertex_indices", "vertex_index") if k in face), None)
    if index_name is None:
        _fail(path, f"the faces have no vertex_indices (or vertex_index) list property (properties: {list(face)})")
    idx = face[index_name]
    if isinstance(idx, list):
        sizes = np.array([len(r) for r in idx])
        bad = np.flatnonzero(sizes != 3)
        if len(bad):
            _fail(path, f"faces must be triangles: {len(bad)} face(s) are not (first: face {int(bad[0])} has "
                        f"{int(sizes[bad[0]])} vertices); triangulate the mesh first")
        idx = np.asarray(idx).reshape(-1, 3) if len(idx) else np.zeros((0, 3))
    idx = np.asarray(idx)
    if idx.dtype.kind == "f" and not np.array_equal(idx, np.round(idx)):
        _fail(path, "face vertex indices must be integers")
    vertices = np.column_stack([np.asarray(vertex[c], dtype=float) for c in "xyz"])
    face_props = [q[0] for e in elements if e[0] == "face" for q in e[2] if q[2] is None]
    vertex_props = [q[0] for e in elements if e[0] == "vertex" for q in e[2] if q[2] is None]
    if label is not None:
        if label in face_props:
            where = "face"
        elif label in vertex_props:
            where = "vertex"
        else:
            _fail(path, f"label property {label!r} missing: the faces have {face_props}, the vertices "
                        f"{vertex_props}")
        name = label
    else:
        lower_f = {q.lower(): q for q in face_props}
        lower_v = {q.lower(): q for q in vertex_props}
        hit_f = next((lower_f[n] for n in LABEL_NAMES if n in lower_f), None)
        hit_v = next((lower_v[n] for n in LABEL_NAMES if n in lower_v), None)
        if hit_f is None and hit_v is None:
            _fail(path, f"label property missing: none of {list(LABEL_NAMES)} among the faces' properties "
                        f"{face_props} or the vertices' {vertex_props}; name it with label= (--label)")
        where, name = ("face", hit_f) if hit_f is not None else ("vertex", hit_v)
    if where == "face":
        lab = _integer_labels(np.asarray(face[name]), f"mesh file {str(path)!r}: face property {name!r}")
    else:
        v_lab = np.asarray(vertex[name])
        _integer_labels(np.where(v_lab > 0, v_lab, 0), f"mesh file {str(path)!r}: vertex property {name!r}")
        lab = None
    mesh = check_mesh(vertices, idx, np.zeros(len(idx), np.int64), f"mesh file {str(path)!r}")
    if lab is None:
        lab = face_labels_from_vertices(mesh.faces, v_lab)
    mesh.labels = lab
    mesh.path = str(path)
    return mesh


_GROUP_INT = re.compile(r"(\d+)$")


def read_obj(path, labels=None) -> LabelledMesh:
    """Read an OBJ triangle mesh; labels from ``labels`` (per face or per vertex) or from ``g`` groups."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"mesh file {str(path)!r} cannot be read ({exc})") from None
    verts, faces, groups = [], [], []
    current, seen_group = 0, False
    for number, raw in enumerate(text.splitlines(), 1):
        words = raw.split()
        if not words or words[0].startswith("#"):
            continue
        key = words[0]
        if key == "v":
            if len(words) < 4:
                _fail(path, f"line {number}: a vertex needs x y z; got {raw.strip()!r}")
            try:
                verts.append([float(w) for w in words[1:4]])
            except ValueError:
                _fail(path, f"line {number}: vertex coordinates are not numbers: {raw.strip()!r}")
        elif key == "f":
            corners = words[1:]
            if len(corners) != 3:
                _fail(path, f"faces must be triangles: line {number} has a face of {len(corners)} vertices "
                            f"(face {len(faces)}); triangulate the mesh first")
            try:
                ids = [int(c.split("/")[0]) for c in corners]
            except ValueError:
                _fail(path, f"line {number}: face vertex indices are not integers: {raw.strip()!r}")
            n = len(verts)
            faces.append([i - 1 if i > 0 else n + i for i in ids])  # 1-based; negative: from the last vertex
            groups.append(current)
        elif key == "g":
            seen_group = True
            match = _GROUP_INT.search(words[-1]) if len(words) > 1 else None
            current = int(match.group(1)) if match else 0
    if not faces:
        _fail(path, "no triangular faces ('f' lines)")
    faces = np.asarray(faces, dtype=np.int64)
    name = f"mesh file {str(path)!r}"
    if labels is not None:
        lab = np.asarray(labels)
        if lab.shape == (len(faces),):
            mesh = check_mesh(np.asarray(verts, float).reshape(-1, 3), faces, lab, name)
        elif lab.shape == (len(verts),):
            mesh = check_mesh(np.asarray(verts, float).reshape(-1, 3), faces, np.zeros(len(faces), np.int64), name)
            mesh.labels = face_labels_from_vertices(mesh.faces, lab)
        else:
            _fail(path, f"labels= must hold one label per face ({len(faces)}) or per vertex ({len(verts)}); got "
                        f"shape {lab.shape}")
    else:
        if not seen_group or not any(groups):
            _fail(path, "label missing: no 'g' group whose name ends in an integer (g 12, g cell_12) and no "
                        "labels= array")
        mesh = check_mesh(np.asarray(verts, float).reshape(-1, 3), faces, np.asarray(groups, np.int64), name)
    mesh.path = str(path)
    return mesh


# --------------------------------------------------------------------------------------------------- writing


def write_ply(path, vertices, faces, labels=None, vertex_labels=None, fmt="binary_little_endian",
              label="label") -> Path:
    """Write a triangle mesh with cell labels as PLY, atomically; returns the path.

    Parameters
    ----------
    vertices, faces : arrays
        ``(n, 3)`` float coordinates and ``(m, 3)`` vertex indices.
    labels : (m,) int array, optional
        Cell per face, written as the face property ``label`` (int32).
    vertex_labels : (n,) int array, optional
        Cell per vertex, written as the vertex property ``label``.
    fmt : {"binary_little_endian", "binary_big_endian", "ascii"}
    label : str
        The name of the label property.
    """
    if fmt not in _FORMATS:
        raise InputError(f"fmt must be one of {list(_FORMATS)}; got {fmt!r}")
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
        raise InputError(f"write_ply needs vertices (n, 3) and triangles (m, 3); got {v.shape} and {f.shape}")
    header = ["ply", f"format {fmt} 1.0", "comment written by hexatissue", f"element vertex {len(v)}",
              "property double x", "property double y", "property double z"]
    if vertex_labels is not None:
        header.append(f"property int {label}")
    header += [f"element face {len(f)}", "property list uchar int vertex_indices"]
    if labels is not None:
        header.append(f"property int {label}")
    header.append("end_header")
    order = _FORMATS[fmt]
    with atomic_path(path) as tmp, open(tmp, "wb") as out:
        out.write(("\n".join(header) + "\n").encode("ascii"))
        if order is None:
            vcols = [v[:, 0], v[:, 1], v[:, 2]] + ([np.asarray(vertex_labels)] if vertex_labels is not None else [])
            for row in zip(*vcols):
                out.write((" ".join(repr(float(x)) for x in row[:3])
                           + ("".join(f" {int(x)}" for x in row[3:])) + "\n").encode())
            for k, tri in enumerate(f):
                tail = f" {int(labels[k])}" if labels is not None else ""
                out.write(f"3 {tri[0]} {tri[1]} {tri[2]}{tail}\n".encode())
        else:
            vd = [("x", order + "f8"), ("y", order + "f8"), ("z", order + "f8")]
            if vertex_labels is not None:
                vd.append(("l", order + "i4"))
            vrec = np.empty(len(v), dtype=vd)
            vrec["x"], vrec["y"], vrec["z"] = v[:, 0], v[:, 1], v[:, 2]
            if vertex_labels is not None:
                vrec["l"] = np.asarray(vertex_labels)
            out.write(vrec.tobytes())
            fd = [("n", "u1"), ("i", order + "i4", (3,))]
            if labels is not None:
                fd.append(("l", order + "i4"))
            frec = np.empty(len(f), dtype=fd)
            frec["n"], frec["i"] = 3, f
            if labels is not None:
                frec["l"] = np.asarray(labels)
            out.write(frec.tobytes())
    return Path(path)


def write_obj(path, vertices, faces, labels=None) -> Path:
    """Write a triangle mesh as OBJ, atomically, the faces of each cell label under ``g cell_<label>``."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    lab = np.zeros(len(f), np.int64) if labels is None else np.asarray(labels, np.int64)
    order = np.argsort(lab, kind="stable")
    lines = ["# written by hexatissue: faces grouped by cell (g cell_<label>; g background = no cell)"]
    lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in v.tolist()]
    previous = None
    for k in order:
        if lab[k] != previous:
            previous = lab[k]
            lines.append(f"g cell_{previous}" if previous > 0 else "g background")
        a, b, c = f[k] + 1
        lines.append(f"f {a} {b} {c}")
    with atomic_path(path) as tmp:
        Path(tmp).write_text("\n".join(lines) + "\n", encoding="utf-8")
    return Path(path)

