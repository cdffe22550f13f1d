"""Atlas step 2: disk-like chart candidates (components, xatlas seams, bisection)."""
from __future__ import annotations

import numpy as np

from neuraluv.meshfix import normalize_unit_box
from neuraluv.topology import components, face_components, is_disk_like, submesh

__all__ = ["seam_charts", "bisect_faces", "split_into_disks", "chart_candidates"]


def seam_charts(V, F, *, max_cost=4.0, max_iterations=2):
    """Partition a (non-disk) component into xatlas charts.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    max_cost : float
        xatlas ``ChartOptions.max_cost`` (larger: fewer, bigger charts).
    max_iterations : int

    Returns
    -------
    charts : list of (k_i,) int arrays of face indices into ``F``; faces xatlas
        left out (zero area in float32) come back as their own groups.
    """
    import xatlas

    at = xatlas.Atlas()
    at.add_mesh(normalize_unit_box(V)[0].astype(np.float32), F.astype(np.uint32))
    co = xatlas.ChartOptions()
    co.max_cost = float(max_cost)
    co.max_iterations = int(max_iterations)
    po = xatlas.PackOptions()
    po.resolution = 256  # packing result unused; keep it cheap
    _interruptible(at.generate, co, po)
    out, seen = [], np.zeros(len(F), bool)
    for i in range(at.get_mesh_chart_count(0)):
        f = np.asarray(at.get_mesh_chart(0, i).faces, np.int64)
        f = f[~seen[f]]
        if len(f):
            seen[f] = True
            out.append(f)
    rest = np.flatnonzero(~seen)
    if len(rest):
        n, lab = face_components(F[rest])
        out += [rest[lab == c] for c in range(n)]
    return out


def _interruptible(fn, *args):
    """Run a long C++ call in a worker thread so Ctrl-C / SIGTERM still reach the main thread within 0.1 s."""
    import threading

    box = {}

    def work():
        try:
            box["out"] = fn(*args)
        except BaseException as exc:  # noqa: BLE001 - re-raised in the caller's thread
            box["exc"] = exc

    t = threading.Thread(target=work, daemon=True)
    t.start()
    while t.is_alive():
        t.join(0.1)
    if "exc" in box:
        raise box["exc"]
    return box.get("out")


def bisect_faces(V, F, fidx):
    """Split a face set in two along its longest principal axis.

    Returns the edge-connected pieces of the two halves (at least two pieces
    when ``len(fidx) > 1``).

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> V, F = disk(n_rings=3)
    >>> parts = bisect_faces(V, F, np.arange(len(F)))
    >>> len(parts) >= 2, sum(len(p) for p in parts) == len(F)
    (True, True)
    """
    fidx = np.asarray(fidx, np.int64)
    if len(fidx) < 2:
        return [fidx]
    c = V[F[fidx]].mean(1)
    c0 = c - c.mean(0)
    _, _, vt = np.linalg.svd(c0, full_matrices=False)
    t = c0 @ vt[0]
    order = np.argsort(t, kind="stable")
    halves = [fidx[order[: len(fidx) // 2]], fidx[order[len(fidx) // 2:]]]
    parts = []
    for h in halves:
        n, lab = face_components(F[h])
        parts += [h[lab == k] for k in range(n)]
    return parts


def split_into_disks(V, F, fidx, note="split"):
    """Bisect a face set until every piece is disk-like.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    fidx : (k,) int array
    note : str
        Source note of the pieces.

    Returns
    -------
    list of (fidx, source) pairs covering ``fidx`` exactly once; a disk-like input
    is halved once (callers split a chart that failed as a whole).

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> V, F = disk(n_rings=4)
    >>> parts = split_into_disks(V, F, np.arange(len(F)))
    >>> len(parts) >= 2, sum(len(p) for p, _ in parts) == len(F)
    (True, True)
    """
    out = []
    for p in bisect_faces(V, F, np.asarray(fidx, np.int64)):
        _make_disks(V, F, p, note, out)
    return out


def _make_disks(V, F, fidx, note, out, depth=0):
    vi, Fc = submesh(F, fidx)
    ok, why = is_disk_like(V[vi], Fc)
    if ok:
        out.append((fidx, note))
        return
    for p in bisect_faces(V, F, fidx):
        _make_disks(V, F, p, f"{note}; split (not disk-like: {why})" if depth == 0 else note, out, depth + 1)


def chart_candidates(V, F, *, max_cost=4.0):
    """Disk-like chart candidates covering every face exactly once.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array (a repaired mesh, see :func:`prepare_mesh`)
    max_cost : float
        xatlas charting cost for components that need seams.

    Returns
    -------
    list of (fidx, source) pairs
        ``source`` says how the candidate arose (``"component"``,
        ``"xatlas seams (closed surface ...)"``, ``"...; split (...)"``).

    Examples
    --------
    >>> from neuraluv.datasets import several_components
    >>> V, F = several_components(3)
    >>> [s for _, s in chart_candidates(V, F)]
    ['component', 'component', 'component']
    """
    out = []
    for vi, fi, Fc in components(V, F):
        ok, why = is_disk_like(V[vi], Fc)
        if ok:
            out.append((fi, "component"))
            continue
        if len(fi) <= 2:
            _make_disks(V, F, fi, "component", out)
            continue
        try:
            pieces = seam_charts(V[vi], Fc, max_cost=max_cost)
        except Exception as exc:  # xatlas refuses some inputs: bisect instead
            _make_disks(V, F, fi, f"component; xatlas failed ({type(exc).__name__})", out)
            continue
        for ch in pieces:
            _make_disks(V, F, fi[ch], f"xatlas seams ({why})", out)
    return out
