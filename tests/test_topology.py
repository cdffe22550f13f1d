"""Topology scan, the disk-like test and its reasons, repair."""
import numpy as np

from neuraluv.datasets import disk, glove, several_components, sphere, spherical_cap
from neuraluv.meshfix import repair_mesh
from neuraluv.topology import is_disk_like, split_components, topology_scan


def annulus():
    V, F = disk(4)
    r = np.linalg.norm(V[:, :2], axis=1)
    keep = np.all(r[F] > 0.3, axis=1)
    V2, F2, _, _ = repair_mesh(V, F[keep])
    return V2, F2


def test_disk_and_cap_are_disks():
    for V, F in (disk(5), spherical_cap(5), glove(res=2)):
        r = topology_scan(V, F)
        assert (r.components, r.boundary_loops, r.euler_characteristic, r.genus) == (1, 1, 1, 0)
        assert r.manifold and r.oriented
        assert is_disk_like(V, F) == (True, "disk")


def test_sphere_is_closed():
    V, F = sphere(1)
    r = topology_scan(V, F)
    assert r.boundary_loops == 0 and r.euler_characteristic == 2 and r.genus == 0
    ok, why = is_disk_like(V, F)
    assert not ok and "closed" in why


def test_annulus_two_loops():
    ok, why = is_disk_like(*annulus())
    assert not ok and "2 boundary loops" in why


def test_components():
    V, F = several_components(3)
    r = topology_scan(V, F)
    assert r.components == 3 and r.boundary_loops == 3
    ok, why = is_disk_like(V, F)
    assert not ok and "3 connected components" in why
    parts = split_components(V, F)
    assert sum(len(f) for _, f in parts) == len(F)


def test_nonmanifold_edge_and_vertex_and_winding():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]])
    F = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])  # edge (0,1) in three faces
    r = topology_scan(V, F)
    assert r.nonmanifold_edges == 1
    assert "non-manifold edges" in is_disk_like(V, F)[1]
    # bow-tie: two triangles sharing only vertex 0
    V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [-1, 0, 0], [-1, -1, 0]])
    F = np.array([[0, 1, 2], [0, 3, 4]])
    r = topology_scan(V, F)
    assert r.nonmanifold_vertices == 1 and r.nonmanifold_edges == 0
    assert "non-manifold vertices" in is_disk_like(V, F)[1]
    # inconsistent winding: flip one face of a disk
    V, F = disk(2)
    F = F.copy()
    F[0] = F[0, ::-1]
    r = topology_scan(V, F)
    assert r.inconsistent_edges > 0
    assert "winding" in is_disk_like(V, F)[1]


def test_graph_components_and_unique_rows_match_scipy_and_numpy():
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    from neuraluv.topology import SMALL_GRAPH, graph_components, unique_rows

    rng = np.random.default_rng(0)
    for t in range(300):
        n = int(rng.integers(1, 200)) if t % 30 else SMALL_GRAPH + 10  # the NumPy path, and scipy's
        e = int(rng.integers(0, 2 * n))
        i, j = rng.integers(0, n, e), rng.integers(0, n, e)
        k, lab = graph_components(n, i, j)
        k2, lab2 = connected_components(sp.coo_matrix((np.ones(e), (i, j)), shape=(n, n)), directed=False)
        assert k == k2 and np.array_equal(lab, lab2)
        A = rng.integers(-3 if t % 2 else 0, 30, (e + 1, 2))
        rows, idx, inv, cnt = unique_rows(A, return_index=True, return_inverse=True, return_counts=True)
        r2, idx2, inv2, cnt2 = np.unique(A, axis=0, return_index=True, return_inverse=True, return_counts=True)
        assert np.array_equal(rows, r2) and np.array_equal(idx, idx2) and np.array_equal(cnt, cnt2)
        assert inv.shape == (len(A),) and np.array_equal(inv, inv2.reshape(-1))


def test_boundary_loops_walk_as_libigl():
    import igl

    from neuraluv.topology import boundary_loop, boundary_loops

    V, F = spherical_cap(8)
    rng = np.random.default_rng(1)
    for t in range(200):  # face subsets: strips, holes, several pieces, bow-ties (where libigl decides)
        keep = np.sort(rng.choice(len(F), int(rng.integers(1, len(F))), replace=False))
        Fs = np.searchsorted(np.unique(F[keep]), F[keep])
        ours, theirs = boundary_loops(Fs), igl.boundary_loop_all(np.ascontiguousarray(Fs))
        assert len(ours) == len(theirs) and all(np.array_equal(a, b) for a, b in zip(ours, theirs))
        assert np.array_equal(boundary_loop(Fs), igl.boundary_loop(np.ascontiguousarray(Fs)))
