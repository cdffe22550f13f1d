"""Atlas step 2: disk-like chart candidates (components, xatlas seams, bisection)."""
from __future__ import annotations

import threading

import igl
import numpy as np
import xatlas

from neuraluv.layout.overlap import boundary_is_simple
from neuraluv.layout.rigid import rigid_fit
from neuraluv.meshfix import normalize_unit_box
from neuraluv.metrics import distortion_metrics
from neuraluv.topology import (bisect_faces, boundary_loop, boundary_loops, components, face_components, is_disk_like,
                               submesh, topology_scan)

__all__ = ["Candidate", "seam_charts", "split_into_disks", "chart_candidates", "merge_small_charts",
           "congruent_components", "chart_mesh"]


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


def chart_mesh(V, F, fidx):
    """The local mesh of a chart, made a disk where that needs no cut.

    A chart cut from a scan often touches itself at a vertex (a bow-tie: two fans
    of the chart meet there) or encloses small holes. Instead of bisecting such a
    chart into pieces, the bow-tie vertex is split into one copy per fan (the
    island's UVs may then differ at the two copies) and every hole but the
    longest boundary loop is closed by a fan of *filler* triangles around a new
    vertex at the hole's centroid. The solver maps the filled disk; the fillers are
    then dropped, and a map that is injective on the filled disk is injective on
    the chart.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    fidx : (k,) int array, the chart's faces

    Returns
    -------
    vi : (p,) int array, the global vertex of each local vertex (repeated for a split bow-tie)
    Fl : (k,3) int array, the chart's faces in local indices (row ``i`` is face ``fidx[i]``)
    Vx : (e,3) float array, positions of the filler vertices (local indices ``p, p+1, …``)
    Fx : (h,3) int array, the filler triangles (local indices, oriented like ``Fl``)

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> Vd, Fd = disk(n_rings=3)
    >>> keep = np.array([f for f in range(len(Fd)) if 0 not in Fd[f]])  # a ring: the centre's fan removed
    >>> vi, Fl, Vx, Fx = chart_mesh(Vd, Fd, keep)
    >>> len(Vx), len(Fx) > 0, is_disk_like(np.vstack([Vd[vi], Vx]), np.vstack([Fl, Fx]))[0]
    (1, True, True)
    """
    return _chart_mesh(V, F, fidx)[:4]


def _chart_mesh(V, F, fidx):
    """:func:`chart_mesh`, and the topology scan of the result when no filler was added (else None): one scan of a
    chart that needs neither a split nor a filler, where the disk test would otherwise scan it again."""
    V = np.asarray(V, float)
    vi, Fl = submesh(F, np.asarray(fidx, np.int64))
    scan = topology_scan(V[vi], Fl)
    if scan.nonmanifold_vertices:
        _, SF, SVI = igl.split_nonmanifold(V[vi], Fl)
        vi, Fl = vi[np.asarray(SVI, np.int64)], np.asarray(SF, np.int64)
        scan = topology_scan(V[vi], Fl)
    Vx, Fx = np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    loops = boundary_loops(Fl) if scan.boundary_loops > 1 else []
    if len(loops) > 1 and face_components(Fl)[0] == 1:  # loops of one piece: its outline and its holes
        P = V[vi]
        length = [float(np.linalg.norm(P[L] - P[np.roll(L, -1)], axis=1).sum()) for L in loops]
        outer = int(np.argmax(length))
        directed = {(int(a), int(b)) for f in Fl for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
        xs, fs = [], []
        for k, L in enumerate(loops):
            if k == outer:
                continue
            c = len(vi) + len(xs)
            xs.append(P[L].mean(0))
            nxt = np.roll(L, -1)
            if (int(L[0]), int(nxt[0])) in directed:  # the chart runs a -> b: the filler runs b -> a
                fs += [[b, a, c] for a, b in zip(L, nxt)]
            else:
                fs += [[a, b, c] for a, b in zip(L, nxt)]
        Vx, Fx, scan = np.array(xs, float), np.array(fs, np.int64), None
    return vi, Fl, Vx, Fx, scan


def filled_chart(V, F, fidx):
    """``(Vc, Fc)``: the chart's :func:`chart_mesh` as one mesh, filler vertices and triangles appended."""
    vi, Fl, Vx, Fx = chart_mesh(V, F, fidx)
    return np.vstack([np.asarray(V, float)[vi], Vx]), np.vstack([Fl, Fx])


class Candidate(tuple):
    """A chart candidate ``(fidx, source)``; ``mesh`` is its :func:`chart_mesh` ``(vi, Fl, Vx, Fx)`` where the disk
    test already built it (else None), so that routing the candidate on the same ``V, F`` need not build it again.

    Examples
    --------
    >>> c = Candidate(np.arange(2), "component")
    >>> fidx, source = c
    >>> source, c.mesh
    ('component', None)
    """

    def __new__(cls, fidx, source, mesh=None):
        c = super().__new__(cls, (fidx, source))
        c.mesh = mesh
        return c


def chart_is_disk(V, F, fidx):
    """``(ok, why)`` of :func:`~neuraluv.topology.is_disk_like` on the chart's :func:`chart_mesh`."""
    return _chart_is_disk(V, F, fidx)[:2]


def _chart_is_disk(V, F, fidx):
    """:func:`chart_is_disk`, and the :func:`chart_mesh` it tested."""
    vi, Fl, Vx, Fx, scan = _chart_mesh(V, F, fidx)
    if scan is not None:
        ok, why = is_disk_like(None, Fl, report=scan)
    else:
        ok, why = is_disk_like(np.vstack([np.asarray(V, float)[vi], Vx]), np.vstack([Fl, Fx]))
    return ok, why, (vi, Fl, Vx, Fx)


def _make_disks(V, F, fidx, note, out):
    """Append to ``out`` the disk-like pieces of the faces ``fidx``: the set itself, or its halves
    (:func:`~neuraluv.topology.bisect_faces`) in turn, depth first (a loop, not a recursion: a long strip
    is halved many times). A single face that is not disk-like (corners on one point) is appended as it is,
    with why in its note: the router gives it a marked fallback."""
    todo = [(np.asarray(fidx, np.int64), note, 0)]
    while todo:
        f, nt, depth = todo.pop()
        ok, why, mesh = _chart_is_disk(V, F, f)
        if ok or len(f) < 2:
            out.append(Candidate(f, nt, mesh) if ok else (f, f"{nt}; not disk-like: {why}"))
            continue
        sub = f"{nt}; split (not disk-like: {why})" if depth == 0 else nt
        todo += [(p, sub, depth + 1) for p in reversed(bisect_faces(V, F, f))]


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
    list of Candidate
        ``(fidx, source)`` pairs: ``source`` says how the candidate arose (``"component"``,
        ``"xatlas seams (closed surface ...)"``, ``"...; split (...)"``); each carries the
        :func:`chart_mesh` its disk test built, for :func:`~neuraluv.atlas.routing.route_charts`.

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
            out.append(Candidate(fi, "component"))
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


def merge_small_charts(V, F, candidates, *, max_faces=64, max_curvature=0.3):
    """Merge small chart candidates into neighbours when the union stays a nearly flat disk.

    xatlas leaves many tiny charts along creases (single faces, short strips), and
    every one of them becomes an island thinner than the padding. A small chart is
    merged into the neighbour it shares a seam with when

    * the union is still disk-like (:func:`~neuraluv.topology.is_disk_like` of its
      :func:`chart_mesh`: holes it encloses filled, bow-tie vertices split),
    * the seam vertices that become interior carry little Gaussian curvature:
      ``Σ |2π − Σθ_v| ≤ max_curvature`` (radians) over those vertices, and
    * a quick conformal flattening of the union (libigl LSCM) has no flipped face
      and a boundary that does not cross itself — a flap merged at zero curvature
      can still wrap round and overlap its chart, which the neural map would then
      inherit (the chart would be split again, or become a fallback). When the
      neighbour alone does not flatten that way either, LSCM says nothing about
      the merge and the neural solve decides.

    A flap hinged on one edge adds no interior vertex, so it merges at zero cost:
    its dihedral angle is extrinsic and the flattening stays an isometry there.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    candidates : list of (fidx, source)
        Disk-like charts covering every face once (:func:`chart_candidates`).
    max_faces : int
        Charts with at most this many faces are merged (the larger chart of a
        pair may be any size).
    max_curvature : float
        Largest total |angle defect| (radians) a merge may turn into interior curvature.

    Returns
    -------
    list of (fidx, source) pairs, still covering every face exactly once; a merged
    chart's source says ``"+ N merged"``.

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> V, F = disk(n_rings=4)
    >>> parts = [(np.arange(len(F) - 1), "a"), (np.array([len(F) - 1]), "b")]
    >>> [(len(f), s) for f, s in merge_small_charts(V, F, parts)]
    [(96, 'a + 1 merged')]
    """
    F = np.asarray(F, np.int64)
    m = len(F)
    label = np.full(m, -1, np.int64)
    faces = {}
    src = {}
    for k, (f, s) in enumerate(candidates):
        f = np.asarray(f, np.int64)
        label[f] = k
        faces[k] = f
        src[k] = [s, 0]
    # Gaussian curvature (angle defect) of interior mesh vertices; boundary vertices never become interior
    theta = np.asarray(igl.internal_angles(np.asarray(V, float), F))
    defect = 2 * np.pi - np.bincount(F.ravel(), theta.ravel(), minlength=len(V))
    bnd = np.zeros(len(V), bool)
    e = np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, inv, cnt = np.unique(e, axis=0, return_inverse=True, return_counts=True)
    bnd[e[cnt[inv.ravel()] == 1].ravel()] = True
    defect[bnd] = 0.0
    ef = np.tile(np.arange(m), 3)
    order = np.argsort(inv.ravel(), kind="stable")
    inv_s = inv.ravel()[order]
    starts = np.flatnonzero(np.r_[True, inv_s[1:] != inv_s[:-1]])
    pairs = [(ef[order[s]], ef[order[s + 1]]) for s in starts if s + 1 < len(order) and inv_s[s + 1] == inv_s[s]
             and (s + 2 >= len(order) or inv_s[s + 2] != inv_s[s])]
    nbr_faces = {}
    for a, b in pairs:
        nbr_faces.setdefault(a, []).append(b)
        nbr_faces.setdefault(b, []).append(a)
    vf = {}
    for f in range(m):
        for v in F[f]:
            vf.setdefault(int(v), []).append(f)

    def neighbours(k):
        out = {}
        for f in faces[k]:
            for g in nbr_faces.get(int(f), ()):
                lg = label[g]
                if lg != k:
                    out[lg] = out.get(lg, 0) + 1
        return out

    def cost(k, j):
        verts = np.unique(F[faces[k]])
        new_interior = [v for v in verts if not bnd[v] and all(label[g] in (k, j) for g in vf[int(v)])
                        and any(label[g] == j for g in vf[int(v)])]
        return float(np.abs(defect[new_interior]).sum()) if new_interior else 0.0

    changed = True
    while changed:
        changed = False
        for k in sorted(faces, key=lambda c: len(faces[c])):
            if k not in faces or len(faces[k]) > max_faces:
                continue
            options = []
            for j, shared in neighbours(k).items():
                c = cost(k, j)
                if c <= max_curvature:
                    options.append((c, -shared, j))
            for c, _, j in sorted(options):
                union = np.concatenate([faces[j], faces[k]])
                Vc, Fc = filled_chart(V, F, union)  # a neighbour may enclose holes (filled) or touch itself
                if not is_disk_like(Vc, Fc)[0] or not (_flattens(Vc, Fc) or not _flattens(*filled_chart(V, F, faces[j]))):
                    continue
                big, small = (j, k) if len(faces[j]) >= len(faces[k]) else (k, j)
                faces[big] = union
                label[faces[small]] = big
                src[big][1] += 1 + src[small][1]
                del faces[small]
                changed = True
                break
    out = []
    for k in sorted(faces):
        s, n = src[k]
        fk = np.sort(faces[k])
        same = not n and np.array_equal(fk, candidates[k][0])
        out.append(candidates[k] if same else (fk, f"{s} + {n} merged" if n else s))  # unmerged: as it came
    return out


def _flattens(V, F):
    """True when LSCM (two boundary pins) maps the disk ``(V, F)`` without flips or a self-crossing boundary."""
    bnd = boundary_loop(F)
    if len(bnd) < 3:
        return False
    b = np.array([bnd[0], bnd[len(bnd) // 2]], np.int64)
    try:
        uv = np.asarray(igl.lscm(np.asarray(V, float), F, b, np.array([[0.0, 0.0], [1.0, 0.0]]))[0])
    except Exception:  # noqa: BLE001 - a failed solve means "do not merge"
        return False
    if uv.shape != (len(V), 2) or not np.isfinite(uv).all():
        return False
    return distortion_metrics(V, F, uv)["flips"] == 0 and boundary_is_simple(uv, F)


def congruent_components(V, F, *, rtol=1e-4):
    """Copies of a mesh component: the same triangulation, in the same face order, moved rigidly.

    Duplicated or instanced objects (bolts, wheels, leaves) are such copies. Each
    copy is matched face for face (and vertex for vertex, in order of first use) to
    the first component it copies; its 3D vertices must fit the original's after the
    best proper rotation and translation (:func:`~neuraluv.atlas.build.stack_groups`
    does the same test per island).

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    rtol : float
        Largest vertex misfit relative to the component's radius.

    Returns
    -------
    list of ``(rep_faces, copy_faces, rep_vertices, copy_vertices)``
        One entry per copy: equal-length index arrays; ``rep_faces[i]`` corresponds
        to ``copy_faces[i]`` and ``rep_vertices[j]`` to ``copy_vertices[j]``.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [5, 0, 0], [5, 1, 0], [4, 0, 0]])
    >>> [(r.tolist(), c.tolist()) for r, c, _, _ in congruent_components(V, np.array([[0, 1, 2], [3, 4, 5]]))]
    [([0], [1])]
    """
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    n, lab = face_components(F)
    order = np.argsort(lab, kind="stable")
    bounds = np.searchsorted(lab[order], np.arange(n + 1))
    groups, out = {}, []
    for c in range(n):
        fc = order[bounds[c]:bounds[c + 1]]
        verts, first = np.unique(F[fc].ravel(), return_index=True)
        vs = verts[np.argsort(first)]  # vertices in order of first use
        local = np.argsort(np.argsort(first))[np.searchsorted(verts, F[fc])]  # relabelled in that order
        key = (len(fc), len(vs), local.tobytes())
        P = V[vs] - V[vs].mean(0)
        size = float(np.sqrt((P ** 2).sum(1).max())) or 1.0
        for rf, rv, RP in groups.get(key, []):
            R, _, t = rigid_fit(RP, P)
            if np.abs(RP @ R + t - P).max() <= rtol * size:
                out.append((rf, fc, rv, vs))
                break
        else:
            groups.setdefault(key, []).append((fc, vs, P))
    return out
