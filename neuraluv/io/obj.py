"""OBJ files with per-corner texture coordinates: strict reading, atomic writing, and patching only the
``vt`` / ``f`` lines a repair changed.

One module on purpose: :func:`patch_obj` must mirror :func:`read_obj`'s line bookkeeping exactly.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from neuraluv.errors import MeshLoadError
from neuraluv.io.files import atomic_write

__all__ = ["write_obj", "ObjData", "read_obj", "patch_obj"]


def write_obj(path, V, F, UV, FUV=None):
    """Write an OBJ with per-corner texture coordinates, atomically.

    Parameters
    ----------
    path : str or path-like
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
        Texture coordinates (``vt`` lines).
    FUV : (m,3) int array, optional
        Per-corner indices into ``UV``; defaults to ``F`` (one UV per vertex).

    Notes
    -----
    Coordinates are written with 17 significant digits so that a UV layout that
    is flip-free in memory is flip-free when read back.
    """
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    UV = np.asarray(UV, float)
    FUV = F if FUV is None else np.asarray(FUV, np.int64)
    if not np.all(np.isfinite(UV)):
        raise ValueError("refusing to write non-finite UV coordinates")
    lines = ["# written by neuraluv"]
    lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(V, float).tolist()]  # shortest exact form
    lines += [f"vt {u!r} {v!r}" for u, v in np.asarray(UV, float).tolist()]
    lines += [f"f {a + 1}/{ta + 1} {b + 1}/{tb + 1} {c + 1}/{tc + 1}" for (a, b, c), (ta, tb, tc) in zip(F, FUV)]
    with atomic_write(path) as fh:
        fh.write("\n".join(lines) + "\n")


class ObjData(tuple):
    """``(V, F, UV, FUV)`` from :func:`read_obj`, with what reading changed in ``.notes``."""

    notes: dict


def read_obj(path, *, strict=True, keep_lines=False):
    r"""Read an OBJ's positions, faces and per-corner texture coordinates, exactly.

    A small parser (no vertex merging or splitting): what :func:`write_obj`
    writes reads back bit for bit, and a textured mesh keeps its seams.

    Parameters
    ----------
    path : str or path-like
    strict : bool
        Refuse what cannot be read without guessing (see Raises); otherwise
        skip such lines.
    keep_lines : bool
        Also keep the file's lines and where each ``vt`` row and each triangle
        came from (``notes["raw"]``, ``"vt_line"``, ``"face_line"``, ``"face_fan"``),
        for :func:`patch_obj`.

    Returns
    -------
    V : (n,3) float array
    F : (m,3) int array
        Polygons are fan-triangulated (counted in ``notes["polygons"]``).
    UV : (p,2) float array (empty if the file has no ``vt``)
    FUV : (m,3) int array or None
        Per-corner ``vt`` indices, or None when no face carries any; a face
        without ``vt`` (when others have them) has the row ``[-1, -1, -1]``.

    The returned tuple has a ``notes`` dict: ``polygons`` (faces with more than
    three corners), ``lines`` (lines read).

    Raises
    ------
    MeshLoadError
        A face index of 0 (OBJ counts from 1), out of range, or not an integer;
        a ``v`` or ``vt`` line with too few numbers or a non-number; a face with
        fewer than three corners; non-UTF-8 text. The message names the line.

    Notes
    -----
    Whitespace may be spaces or tabs, and anything after ``#`` is a comment. A
    line ending in a backslash continues on the next one; a UTF-8 byte-order mark
    before the first line is skipped (both are kept in ``notes["raw"]``).
    Negative indices count back from the last element defined so far.

    Examples
    --------
    >>> import tempfile, os
    >>> p = os.path.join(tempfile.mkdtemp(), "q.obj")
    >>> _ = open(p, "w").write("v\t0 0 0\nv 1 0 0 # a comment\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    >>> V, F, UV, FUV = read_obj(p)
    >>> F.tolist(), read_obj(p).notes["polygons"]
    ([[0, 1, 2], [0, 2, 3]], 1)
    >>> _ = open(p, "w").write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")
    >>> read_obj(p)
    Traceback (most recent call last):
    ...
    neuraluv.errors.MeshLoadError: q.obj, line 4: face index 0 (OBJ indices start at 1; is this a 0-based file?)
    """
    path = Path(path)
    V, UV, F, FUV = [], [], [], []
    vt_line, face_line, face_fan, raw_lines = [], [], [], []
    any_vt = False
    polygons = count = 0
    name = path.name

    def fail(n, msg):
        if strict:
            raise MeshLoadError(f"{name}, line {n}: {msg}")

    def index(tok, n_defined, n, what):
        try:
            k = int(tok)
        except ValueError:
            fail(n, f"{what} index {tok!r} is not an integer")
            return None
        if k == 0:
            fail(n, "face index 0 (OBJ indices start at 1; is this a 0-based file?)")
            return None
        k = k - 1 if k > 0 else n_defined + k
        if not 0 <= k < n_defined:
            fail(n, f"{what} index {tok} refers to element {k + 1}, but only {n_defined} are defined above it")
            return None
        return k

    try:
        fh = open(path, encoding="utf-8", newline="")  # line endings kept as they are (patch_obj)
    except OSError as exc:
        raise MeshLoadError(f"{path}: cannot read ({exc.strerror or exc})") from None
    joined = {}  # first physical line -> (the logical line it starts, its last physical line) when continued
    with fh:
        try:
            pending, start = "", 0
            for count, raw in enumerate(fh, start=1):
                if keep_lines:
                    raw_lines.append(raw)
                if count == 1 and raw.startswith("\ufeff"):  # a UTF-8 byte-order mark is not part of the first line
                    raw = raw[1:]
                body = raw.split("#", 1)[0].rstrip()
                if body.endswith("\\"):  # the line continues on the next one (OBJ's line continuation)
                    if not pending:
                        start = count
                    pending += body[:-1] + " "
                    continue
                n = count  # errors and line indices name a logical line's first physical line
                if pending:
                    body, pending, n = pending + body, "", start
                    joined[start - 1] = (body, count - 1)
                line = body.split()
                if not line:
                    continue
                key = line[0]
                if key in ("v", "vt"):
                    k = 3 if key == "v" else 2
                    try:
                        vals = [float(t) for t in line[1:1 + k]]
                    except ValueError:
                        fail(n, f"'{key}' line with a value that is not a number: {raw.strip()[:60]!r}")
                        continue
                    if len(vals) < k:
                        if key == "vt" and len(vals) == 1:
                            vals.append(0.0)
                        else:
                            fail(n, f"'{key}' line needs {k} numbers, has {len(vals)}")
                            continue
                    (V if key == "v" else UV).append(vals)
                    if key == "vt":
                        vt_line.append(n - 1)
                elif key == "f":
                    corners = line[1:]
                    if len(corners) < 3:
                        fail(n, f"face with {len(corners)} corners (at least 3 are needed)")
                        continue
                    vi, ti = [], []
                    for c in corners:
                        parts = c.split("/")
                        v = index(parts[0], len(V), n, "vertex")
                        if v is None:
                            break
                        vi.append(v)
                        if len(parts) > 1 and parts[1]:
                            t = index(parts[1], len(UV), n, "texture")
                            if t is None:
                                break
                            ti.append(t)
                    else:
                        any_vt |= len(ti) == len(vi)
                        polygons += len(vi) > 3
                        for k in range(1, len(vi) - 1):  # fan-triangulate polygons
                            F.append([vi[0], vi[k], vi[k + 1]])
                            FUV.append([ti[0], ti[k], ti[k + 1]] if len(ti) == len(vi) else [-1, -1, -1])
                            face_line.append(n - 1)
                            face_fan.append(k - 1)
            if pending:
                fail(start, "the file ends inside a continued line (a backslash at the end of the last line)")
        except UnicodeDecodeError:
            raise MeshLoadError(f"{name}: not a text OBJ file (bytes that are not UTF-8)") from None
    V = np.asarray(V, float).reshape(-1, 3)
    F = np.asarray(F, np.int64).reshape(-1, 3)
    UV = np.asarray(UV, float).reshape(-1, 2)
    FUV = np.asarray(FUV, np.int64).reshape(-1, 3) if (any_vt and len(F)) else None
    out = ObjData((V, F, UV, FUV))
    out.notes = {"polygons": int(polygons), "lines": count}
    if keep_lines:
        out.notes.update(raw=raw_lines, joined=joined, vt_line=np.asarray(vt_line, np.int64),
                         face_line=np.asarray(face_line, np.int64), face_fan=np.asarray(face_fan, np.int64))
    return out


def _ending(line):
    return line[len(line.rstrip("\r\n")):] or "\n"


def patch_obj(src, dst, UV, FUV, *, data=None):
    r"""Write ``dst`` as a copy of the OBJ ``src`` with new texture coordinates, changing only what must change.

    Every line of ``src`` is kept byte for byte — comments, groups, materials,
    normals, vertex lines — except the ``vt`` lines whose value changed and the
    ``f`` lines whose ``vt`` indices changed; new ``vt`` rows are inserted after
    the last ``vt`` line (before the first face when there is none), or before
    the first face that uses one when that comes earlier — then the face lines
    below that refer to the ``vt`` rows defined after the insertion point are
    rewritten with their shifted indices (an OBJ row must be defined above its
    first use). Written atomically.

    Parameters
    ----------
    src, dst : paths
    UV : (p',2) float array
        The input's rows first (rows equal bit for bit to the input are not rewritten), then new rows.
    FUV : (m,3) int array
        Per-triangle ``vt`` indices (triangles as :func:`read_obj` returns them).
    data : ObjData, optional
        ``read_obj(src, keep_lines=True)`` if already read.

    Returns
    -------
    dict
        ``vt_lines_changed``, ``vt_lines_added``, ``f_lines_changed``, ``polygons_split`` (polygons written
        as their triangles: the new layout cuts them).

    Notes
    -----
    A polygon whose corners still share one ``vt`` per corner keeps its line
    (with new indices); one split between different rows is written as its
    triangles. Face lines after the insertion point that use negative
    (relative) ``vt`` indices are rewritten with absolute indices, since the
    inserted rows would shift them.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp(); a, b = os.path.join(d, "a.obj"), os.path.join(d, "b.obj")
    >>> _ = open(a, "w").write("# keep me\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.1 0.1\nvt 0.5 0.1\nvt 0.1 0.5\nusemtl m\nf 1/1 2/2 3/3\n")
    >>> V, F, UV, FUV = read_obj(a)
    >>> UV2 = UV.copy(); UV2[1] = [0.6, 0.1]
    >>> patch_obj(a, b, UV2, FUV)
    {'vt_lines_changed': 1, 'vt_lines_added': 0, 'f_lines_changed': 0, 'polygons_split': 0}
    >>> open(b).read().splitlines()[4:9]
    ['vt 0.1 0.1', 'vt 0.6 0.1', 'vt 0.1 0.5', 'usemtl m', 'f 1/1 2/2 3/3']
    """
    data = read_obj(src, keep_lines=True) if data is None or "raw" not in data.notes else data
    V0, F0, UV0, FUV0 = data
    notes = data.notes
    raw = list(notes["raw"])
    joined = notes.get("joined", {})

    def text(L):  # a logical line's text (continued lines joined)
        return joined[L][0] if L in joined else raw[L]

    def ending(L):  # a logical line's line ending: that of its last physical line
        return _ending(raw[joined[L][1]] if L in joined else raw[L])
    UV = np.asarray(UV, float)
    FUV = np.asarray(FUV, np.int64)
    if not np.isfinite(UV).all():
        raise ValueError("refusing to write non-finite UV coordinates")
    p0 = len(UV0)
    if len(UV) < p0 or FUV.shape != F0.shape:
        raise ValueError("UV must extend the input's rows and FUV must have one row per triangle")
    FUV0 = -np.ones_like(F0) if FUV0 is None else FUV0
    same = (np.ascontiguousarray(UV[:p0]).view(np.int64) == np.ascontiguousarray(UV0).view(np.int64)).all(1) \
        if p0 else np.zeros(0, bool)
    new_line = {}
    for r in np.flatnonzero(~same):
        L = int(notes["vt_line"][r])
        bom = "\ufeff" if L == 0 and raw[0].startswith("\ufeff") else ""
        new_line[L] = f"{bom}vt {float(UV[r, 0])!r} {float(UV[r, 1])!r}" + ending(L)
    face_changed = (FUV != FUV0).any(1)
    added = len(UV) - p0
    if len(notes["vt_line"]):
        insert_at = int(notes["vt_line"][-1]) + 1
    elif len(notes["face_line"]):
        insert_at = int(notes["face_line"][0])
    else:
        insert_at = len(raw)
    uses_new = (FUV >= p0).any(1)
    if added and uses_new.any():  # a row must be defined above the first face that uses it
        insert_at = min(insert_at, int(notes["face_line"][uses_new].min()))
    # rows defined after the insertion point move down by the rows added there
    n_before = int(np.searchsorted(np.asarray(notes["vt_line"]), insert_at)) if p0 else 0
    index = np.r_[np.arange(n_before), np.arange(n_before, p0) + added, n_before + np.arange(added)] + 1
    lines_to_rewrite = set(notes["face_line"][face_changed].tolist())
    if added:
        shifted = ((FUV >= n_before) & (FUV < p0)).any(1)
        lines_to_rewrite |= set(notes["face_line"][shifted & (notes["face_line"] >= insert_at)].tolist())
        for L in np.unique(notes["face_line"][notes["face_line"] >= insert_at]):
            toks = text(L).split("#", 1)[0].split()[1:]
            if any(len(t.split("/")) > 1 and t.split("/")[1].startswith("-") for t in toks):
                lines_to_rewrite.add(int(L))
    split = 0  # polygons whose corners the new layout gives different rows: written as triangles
    order = np.argsort(notes["face_line"], kind="stable")
    fl_sorted = notes["face_line"][order]
    for L in sorted(lines_to_rewrite):
        tri = order[np.searchsorted(fl_sorted, L, "left"):np.searchsorted(fl_sorted, L, "right")]
        tri = tri[np.argsort(notes["face_fan"][tri])]
        body, _, comment = text(L).rstrip("\r\n").partition("#")
        toks = body.split()[1:]
        nc = len(toks)
        vt = [None] * nc
        consistent = True
        for k, t in enumerate(tri):
            for c, corner in enumerate((0, k + 1, k + 2)):
                val = int(FUV[t, c])
                if vt[corner] is None:
                    vt[corner] = val
                elif vt[corner] != val:
                    consistent = False

        def corner_token(tok, row):
            parts = tok.split("/")
            if row < 0:
                return parts[0] + ("//" + parts[2] if len(parts) > 2 and parts[2] else "")
            if len(parts) == 1:
                return f"{parts[0]}/{index[row]}"
            parts[1] = str(index[row])
            return "/".join(parts)

        end = ending(L)
        tail = (" #" + comment) if comment else ""
        if consistent and None not in vt:
            new_line[L] = "f " + " ".join(corner_token(tok, r) for tok, r in zip(toks, vt)) + tail + end
        else:
            split += 1
            new_line[L] = "".join("f " + " ".join(corner_token(toks[c], int(FUV[t, j])) for j, c in
                                                  enumerate((0, k + 1, k + 2))) + end for k, t in enumerate(tri))
    for L in [L for L in new_line if L in joined]:  # a rewritten continued line replaces all its lines
        for k in range(L + 1, joined[L][1] + 1):
            new_line[k] = ""
    ins_end = _ending(raw[insert_at - 1]) if insert_at > 0 else "\n"
    extra = [f"vt {u!r} {v!r}{ins_end}" for u, v in UV[p0:].tolist()]
    with atomic_write(dst, "wb") as fh:  # bytes: line endings exactly as chosen above, on every platform
        for L, line in enumerate(raw):
            if L == insert_at and extra:
                fh.write("".join(extra).encode("utf-8"))
            fh.write(new_line.get(L, line).encode("utf-8"))
        if insert_at >= len(raw) and extra:
            if raw and not raw[-1].endswith(("\n", "\r")):
                fh.write(b"\n")
            fh.write("".join(extra).encode("utf-8"))
    f_changed = sum(1 for L in lines_to_rewrite if L in new_line)
    return {"vt_lines_changed": int((~same).sum()), "vt_lines_added": int(added), "f_lines_changed": int(f_changed),
            "polygons_split": int(split)}
