"""NTK–LBO spectral probes: does gradient descent move the chart along mesh harmonics?

The paper's spectral-bias diagnostic (Sec. 3, Table 4, tab:ntk_compact_controls): sample 256 vertices by
farthest-point sampling, compute the empirical neural tangent kernel ``Θ`` of
the chart network on them, and compare its top-``r`` eigenspace ``Q_r`` with
the first ``r`` Laplace–Beltrami eigenfunctions ``Ψ_r`` restricted to the same
vertices::

    s_r = ‖Q_rᵀ Ψ_r‖²_F / r        (paper, Sec. 3 and Table 4, tab:ntk_compact_controls)

``s_r`` is the mean squared cosine of the principal angles between the two
``r``-dimensional subspaces: 1 when they coincide, ``r/s`` in expectation for a
random subspace of ``R^s``, 0 when orthogonal.

Conventions (the paper leaves them open; these are ours):

* **Samples**: greedy farthest-point sampling in the *geodesic* (edge-graph,
  Dijkstra) metric when faces are given, Euclidean otherwise; deterministic
  given the start vertex (default 0). Geodesic spreading keeps samples from
  bunching where a chart folds close to itself in 3D (fingers of a hand).
* **Two outputs**: ``Θ = Σ_c J_c J_cᵀ`` with ``J_c = ∂u_c/∂θ`` on the samples,
  i.e. the trace of the ``(s,2,s,2)`` NTK over the UV output index — an
  ``(s,s)`` symmetric PSD matrix. Parameters only: the residual Siren's Tutte
  base is a buffer, constant in ``θ``, so it does not enter ``Θ``.
* **LBO basis**: ``Ψ`` is the constant mode followed by the first non-trivial
  eigenfunctions (``lbo_eigenfunctions`` on the full chart), restricted to the
  samples and orthonormalised with the *plain Euclidean* inner product on the
  samples (thin QR). ``Q_r`` comes from ``eigh`` of ``Θ`` and is orthonormal in
  that same inner product, so both bases live in one Hilbert space and
  ``0 ≤ s_r ≤ 1`` holds exactly; FPS samples are close to area-uniform, so the
  mass weights would change little. ``constant=False`` drops the constant
  mode (``Ψ_r = ψ_1..ψ_r``).

Size: the probes (Gram matrix, eigenvectors, alignment, trajectories) share one chart preparation and the sampling; Table 4's (tab:ntk_compact_controls) runner uses them all.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.csgraph
import torch
from torch.func import functional_call, jacrev, vmap

from neuraluv.solver.config import get_config

__all__ = [
    "farthest_point_sampling",
    "chart_inputs",
    "ntk_gram",
    "top_eigenspace",
    "lbo_basis",
    "subspace_alignment",
    "alignment_curve",
    "NTKProbe",
    "make_probe",
    "TrajectoryRecorder",
    "RANKS",
]

#: The ranks of Table 4 (tab:ntk_compact_controls).
RANKS = (4, 8, 16)


def _edge_graph(V, F):
    F = np.asarray(F, np.int64)
    E = np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    E = np.unique(np.sort(E, axis=1), axis=0)
    w = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    w = np.maximum(w, 1e-300)  # csgraph drops explicit zeros
    n = len(V)
    G = sp.coo_matrix((np.r_[w, w], (np.r_[E[:, 0], E[:, 1]], np.r_[E[:, 1], E[:, 0]])), shape=(n, n))
    return G.tocsr()


def farthest_point_sampling(V, n_samples=256, *, F=None, start=0):
    """Greedy farthest-point sample of mesh vertices.

    Parameters
    ----------
    V : (n,3) float array
    n_samples : int
        Number of samples ``s`` (paper: 256); clipped to ``n``.
    F : (m,3) int array, optional
        Faces. When given, distances are geodesic along mesh edges (Dijkstra on
        the edge graph); otherwise Euclidean.
    start : int
        First sample (the sampling is deterministic given it).

    Returns
    -------
    idx : (s,) int array
        Distinct vertex indices in selection order.

    Notes
    -----
    ``i_{j+1} = argmax_v min_{l≤j} d(v, i_l)``: each sample is the vertex
    farthest from those already chosen, so the samples form a 2-approximate
    minimum covering of the chart (Gonzalez 1985). Vertices unreachable from the
    samples (other components) have infinite distance and are taken first.

    Examples
    --------
    >>> V = np.c_[np.arange(10.0), np.zeros(10), np.zeros(10)]
    >>> farthest_point_sampling(V, 3).tolist()
    [0, 9, 4]
    >>> from neuraluv.datasets import disk
    >>> V, F = disk(n_rings=4)
    >>> idx = farthest_point_sampling(V, 8, F=F)
    >>> len(set(idx.tolist())), int(idx[0])
    (8, 0)
    """
    V = np.asarray(V, float)
    n = len(V)
    s = int(min(max(n_samples, 1), n))
    if not 0 <= start < n:
        raise ValueError(f"start vertex {start} out of range for {n} vertices")
    G = _edge_graph(V, F) if F is not None else None

    def dist_from(i):
        if G is None:
            return np.linalg.norm(V - V[i], axis=1)
        return scipy.sparse.csgraph.dijkstra(G, directed=False, indices=int(i))

    idx = np.empty(s, np.int64)
    idx[0] = start
    d = dist_from(start)
    for j in range(1, s):
        d[idx[:j]] = -1.0  # never re-pick a sample (also covers duplicate points)
        nxt = int(np.argmax(d))
        idx[j] = nxt
        d = np.minimum(d, dist_from(nxt))
    return idx


def chart_inputs(V, F, k=16, n_eig=16):
    """The solver's network input and the chart's LBO eigenpairs.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    k : int
        Spectral rank of the input (the solver config's ``k``).
    n_eig : int
        Number of non-trivial eigenfunctions to return (at least ``k``).

    Returns
    -------
    X : (n, 3+k) float32 array
        Exactly what :func:`neuraluv.solver.solve_chart` feeds the SIREN
        (:func:`neuraluv.solver.prepare_chart`).
    eig : tuple (evals (n_eig,), phi (n, n_eig))
        :func:`neuraluv.spectral.lbo_eigenfunctions` of the normalised chart.

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> X, (lam, phi) = chart_inputs(*disk(n_rings=4), k=2, n_eig=5)
    >>> X.shape, phi.shape
    ((61, 5), (61, 5))
    """
    from neuraluv.solver.chart import prepare_chart

    prep = prepare_chart(V, F, get_config("paper", k=k, start_relax=0), check=False, n_eig=max(k, n_eig))
    return prep.X, prep.eig


def ntk_gram(model, X):
    """Empirical NTK Gram matrix of a chart network on sample inputs.

    Parameters
    ----------
    model : torch.nn.Module
        Maps ``(s, d)`` features to ``(s, 2)`` UVs (a :class:`neuraluv.solver.siren.Siren`).
    X : (s, d) array or tensor
        Inputs of the sampled vertices (rows of the solver's feature matrix).

    Returns
    -------
    Theta : (s,s) float64 array
        ``Θ_ij = Σ_c ⟨∂u_c(x_i)/∂θ, ∂u_c(x_j)/∂θ⟩``, symmetric PSD.

    Notes
    -----
    Jacot et al.'s NTK, traced over the two UV outputs:
    ``Θ = Σ_{c=1,2} J_c J_cᵀ`` with ``J_c = ∂u_c/∂θ ∈ R^{s×P}``. Under gradient
    flow on a loss of the outputs, ``du/dt = -Θ ∂ℒ/∂u`` per output channel,
    so Θ's top eigenvectors are the directions training moves the map most.
    Per-sample Jacobians with ``torch.func.vmap(jacrev(...))``, one parameter
    tensor at a time (``Θ = Σ_p J_p J_pᵀ``), so the peak memory is one
    tensor's ``(s, 2, |p|)`` Jacobian (134 MB for a 256×256 layer).
    Derivatives are taken w.r.t. ``model.named_parameters()`` only; a buffer
    named ``base`` (the residual Siren's Tutte map, one row per chart vertex)
    is constant in θ and is replaced by zeros of the sample count.

    Examples
    --------
    >>> from neuraluv.solver.siren import Siren
    >>> _ = torch.manual_seed(0)
    >>> net = Siren(3, width=8, n_layers=3)
    >>> T = ntk_gram(net, torch.randn(5, 3))
    >>> T.shape, bool(np.allclose(T, T.T)), bool(np.linalg.eigvalsh(T).min() > -1e-6)
    ((5, 5), True, True)
    """
    params = {n: p.detach() for n, p in model.named_parameters()}
    if not params:
        raise ValueError("model has no parameters")
    p0 = next(iter(params.values()))
    x = torch.as_tensor(X, device=p0.device)
    x = x.to(p0.dtype) if x.is_floating_point() else x
    s = x.shape[0]
    buffers = {n: b.detach() for n, b in model.named_buffers()}
    if buffers.get("base") is not None:  # one row per chart vertex; constant in θ
        b = buffers["base"]
        buffers["base"] = torch.zeros((1,) + tuple(b.shape[1:]), dtype=b.dtype, device=b.device)
    theta = torch.zeros(s, s, dtype=torch.float64, device=p0.device)
    for name, p in params.items():
        def f(q, xi, name=name):  # one sample: (d,) -> (2,)
            out = functional_call(model, ({**params, name: q}, buffers), (xi[None],))
            return out[0].to(q.dtype)

        J = vmap(jacrev(f), in_dims=(None, 0))(p, x).reshape(s, -1)  # (s, 2·|p|): per-sample rows
        theta += (J @ J.T).to(torch.float64)
    theta = theta.cpu().numpy()
    return 0.5 * (theta + theta.T)


def top_eigenspace(Theta, r):
    """Orthonormal basis of the top-``r`` eigenspace of a symmetric matrix.

    Parameters
    ----------
    Theta : (s,s) float array, symmetric
    r : int

    Returns
    -------
    Q : (s,r) float array
        Eigenvectors of the ``r`` largest eigenvalues, descending.
    evals : (s,) float array
        All eigenvalues, descending.

    Examples
    --------
    >>> Q, w = top_eigenspace(np.diag([1.0, 3.0, 2.0]), 2)
    >>> np.abs(Q).round(6).tolist(), w.tolist()
    ([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], [3.0, 2.0, 1.0])
    """
    T = torch.as_tensor(np.asarray(Theta, dtype=np.float64))
    # torch's LAPACK honours torch.set_num_threads; a multi-threaded OpenBLAS
    # eigh of this small matrix can be 100x slower on a loaded machine.
    w, U = torch.linalg.eigh(0.5 * (T + T.T))
    w, U = w.numpy()[::-1], U.numpy()[:, ::-1]
    return np.ascontiguousarray(U[:, :r]), np.ascontiguousarray(w)


def lbo_basis(phi, idx, r, *, constant=True):
    """First ``r`` LBO modes restricted to the samples, orthonormalised.

    Parameters
    ----------
    phi : (n,k) float array
        Non-trivial LBO eigenfunctions on the whole chart (ascending).
    idx : (s,) int array
        Sample vertices.
    r : int
        Number of modes.
    constant : bool
        Prepend the constant mode ``ψ_0`` (default), so ``Ψ_r`` spans
        ``ψ_0..ψ_{r-1}``; otherwise ``ψ_1..ψ_r``.

    Returns
    -------
    Psi : (s,r) float array
        Euclidean-orthonormal on the samples (thin QR of the restricted modes,
        which keeps the nesting ``span Ψ_r ⊂ span Ψ_{r+1}``).

    Examples
    --------
    >>> phi = np.eye(6)[:, :3] * 2.0
    >>> lbo_basis(phi, np.arange(6), 2, constant=False).T @ lbo_basis(phi, np.arange(6), 2, constant=False)
    array([[1., 0.],
           [0., 1.]])
    """
    idx = np.asarray(idx)
    cols = phi[idx]
    if constant:
        cols = np.c_[np.ones(len(idx)), cols]
    if cols.shape[1] < r:
        raise ValueError(f"need {r} modes, have {cols.shape[1]}: compute more eigenfunctions")
    Q, R = np.linalg.qr(cols[:, :r])
    return Q * np.where(np.diag(R) < 0, -1.0, 1.0)


def subspace_alignment(A, B):
    """``s_r = ‖AᵀB‖²_F / r`` for two orthonormal ``(s,r)`` bases.

    Parameters
    ----------
    A, B : (s,r) float arrays with orthonormal columns

    Returns
    -------
    float in [0, 1]
        Mean squared cosine of the principal angles between the subspaces;
        invariant to any orthogonal change of basis within ``A`` or ``B``.

    Notes
    -----
    Paper Sec. 3: ``s_r = (1/r) ‖Q_rᵀ Ψ_r‖²_F``.

    Examples
    --------
    >>> I = np.eye(4)
    >>> subspace_alignment(I[:, :2], I[:, :2]), subspace_alignment(I[:, :2], I[:, 2:])
    (1.0, 0.0)
    """
    A, B = np.asarray(A, float), np.asarray(B, float)
    if A.shape != B.shape:
        raise ValueError(f"bases must have the same shape, got {A.shape} and {B.shape}")
    r = A.shape[1]
    return float(np.sum((A.T @ B) ** 2) / r) if r else float("nan")


def alignment_curve(Theta, Psi, r_max=None):
    """``s_r`` for ``r = 1..r_max`` from the NTK and a nested LBO basis.

    Parameters
    ----------
    Theta : (s,s) float array
        NTK Gram matrix (:func:`ntk_gram`).
    Psi : (s,R) float array
        Nested orthonormal LBO basis (:func:`lbo_basis` with ``r = R``).
    r_max : int, optional
        Largest rank (default ``R``).

    Returns
    -------
    curve : (r_max,) float array
        ``curve[r-1] = s_r``.

    Examples
    --------
    >>> Psi = np.eye(5)[:, :3]
    >>> alignment_curve(np.diag([5.0, 4, 3, 2, 1]), Psi).tolist()
    [1.0, 1.0, 1.0]
    """
    r_max = Psi.shape[1] if r_max is None else int(r_max)
    Q, _ = top_eigenspace(Theta, r_max)
    return np.array([subspace_alignment(Q[:, :r], Psi[:, :r]) for r in range(1, r_max + 1)])


@dataclass
class NTKProbe:
    """Precomputed samples and LBO basis for probing one chart's networks.

    Attributes
    ----------
    idx : (s,) int array — FPS sample vertices.
    X : (s, 3+k) float32 array — the solver's input rows at the samples.
    psi : (s, r_max) float array — nested orthonormal LBO basis on the samples.
    k : int — spectral rank of the input features.

    Call it on a network to get the alignment curve ``s_1..s_{r_max}``.
    """

    idx: np.ndarray
    X: np.ndarray
    psi: np.ndarray
    k: int
    psi_nonconst: np.ndarray = field(default=None, repr=False)

    @property
    def r_max(self):
        return self.psi.shape[1]

    def gram(self, model):
        """NTK Gram ``(s,s)`` of ``model`` on the samples."""
        return ntk_gram(model, self.X)

    def __call__(self, model, *, constant=True):
        """Alignment curve ``(r_max,)`` of ``model``'s NTK with the LBO modes."""
        psi = self.psi if constant or self.psi_nonconst is None else self.psi_nonconst
        return alignment_curve(self.gram(model), psi)

    def curves(self, model):
        """Both conventions from one Gram: ``{"const": curve, "nonconst": curve}``."""
        T = self.gram(model)
        out = {"const": alignment_curve(T, self.psi)}
        if self.psi_nonconst is not None:
            out["nonconst"] = alignment_curve(T, self.psi_nonconst)
        return out


def make_probe(V, F, k=16, *, n_samples=256, r_max=16, start=0):
    """Build an :class:`NTKProbe` for a chart and a feature rank ``k``.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    k : int
        Spectral rank of the solver's input (``SolverConfig.k``).
    n_samples : int
        FPS samples (paper: 256).
    r_max : int
        Largest rank of the alignment curve (paper: 16).
    start : int
        FPS start vertex.

    Returns
    -------
    NTKProbe

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> from neuraluv.solver.siren import Siren
    >>> V, F = disk(n_rings=5)
    >>> probe = make_probe(V, F, k=4, n_samples=32, r_max=4)
    >>> _ = torch.manual_seed(0)
    >>> curve = probe(Siren(7, width=16, n_layers=3))
    >>> curve.shape, bool(np.all((curve >= 0) & (curve <= 1 + 1e-12)))
    ((4,), True)
    """
    from neuraluv.solver.chart import prepare_chart

    prep = prepare_chart(V, F, get_config("paper", k=k, start_relax=0), check=False, n_eig=max(k, r_max))
    X, phi = prep.X, prep.eig[1]
    idx = farthest_point_sampling(prep.Vn, n_samples, F=F, start=start)
    r_max = min(r_max, len(idx))
    return NTKProbe(
        idx=idx,
        X=X[idx],
        psi=lbo_basis(phi, idx, r_max, constant=True),
        k=k,
        psi_nonconst=lbo_basis(phi, idx, r_max, constant=False),
    )


class TrajectoryRecorder:
    """A ``solve_chart`` callback that records the alignment curve at milestones.

    Parameters
    ----------
    probe : NTKProbe
    milestones : iterable of int
        Optimisation steps at which to probe (``"step"`` events); the
        ``"warmup_end"`` (step 0) and ``"end"`` events are always probed.

    Attributes
    ----------
    records : list of dict
        ``{"attempt", "event", "step", "curve", "curve_nc"}`` in call order
        (``curve_nc``: the constant-free LBO basis); ``attempt`` counts the
        solver's attempts from 0 (one ``warmup_end`` each).

    Examples
    --------
    >>> from neuraluv.datasets import spherical_cap
    >>> from neuraluv.solver import get_config, solve_chart
    >>> V, F = spherical_cap(n_rings=4)
    >>> cfg = get_config("test", iterations=10, k=4)
    >>> rec = TrajectoryRecorder(make_probe(V, F, cfg.k, n_samples=24, r_max=4), [5])
    >>> res = solve_chart(V, F, cfg, device="cpu", callback=rec)
    >>> [(r["event"], r["step"]) for r in rec.records][:3]
    [('warmup_end', 0), ('step', 5), ('end', 10)]
    """

    def __init__(self, probe, milestones=()):
        self.probe = probe
        self.milestones = set(int(m) for m in milestones)
        self.records = []
        self._attempt = -1

    def __call__(self, event, step, model):
        if event == "warmup_end":
            self._attempt += 1
        elif event == "step" and step not in self.milestones:
            return
        c = self.probe.curves(model)
        self.records.append({"attempt": self._attempt, "event": event, "step": int(step),
                             "curve": c["const"], "curve_nc": c.get("nonconst")})

    def of_attempt(self, attempt):
        """The records of one attempt (``ChartResult.seed - seed`` is the returned one)."""
        return [r for r in self.records if r["attempt"] == attempt]
