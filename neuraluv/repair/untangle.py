"""Untangling a folded layout, and polishing it, with the rest of the layout held fixed.

:func:`untangle` is the method of Garanzha, Kaporin, Kudryavtseva, Protais, Ray
and Sokolov, *Foldover-free maps in 50 lines of code* (ACM TOG 40(4), 2021),
written here from the paper: it minimises a regularised distortion whose
regularisation ``ε`` shrinks as the map untangles, so it accepts a folded start
and ends, when it succeeds, with every triangle positively oriented.
:func:`polish` then lowers the paper's stable symmetric Dirichlet objective from
that valid map with L-BFGS and a flip-free line search (no step may take a
triangle through ``det J = 0``). Both move only the ``free`` texture
coordinates: every other row of ``UV`` is returned bit-identical.

Both work on per-corner layouts (``UV (p,2)`` indexed by ``FUV (m,3)``), measure
each face's Jacobian against its own 3D triangle, and are plain NumPy/SciPy
(no torch), so repairing a small fold costs milliseconds; with numba installed
their loops run compiled (:mod:`neuraluv.repair.kernels`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from neuraluv.jacobian import local_frames
from neuraluv.lazy import HAS_NUMBA
from neuraluv.repair.kernels import polish_kernels, untangle_kernels

__all__ = ["RegionEnergy", "untangle", "untangle_energy", "polish", "stable_energy_terms", "budget_spent"]


#: Regions of at least this many faces are untangled and polished by compiled loops (numba, the ``fast`` extra,
#: when installed; :mod:`neuraluv.repair.kernels`): a real asset's folds evaluate the energies some 10⁵ times,
#: where NumPy's and SciPy's per-call costs dominate (the authored Duck's damaged layouts: 40 s → 7 s for the
#: untangle; a fold of the Duck, seed 12: 11.2 → 7.3 s with the polish compiled too), while a fold of a few faces
#: costs less in NumPy than loading numba into the process (0.6 s; 1 s with the kernels' cache). Compiling every
#: region took that Duck fold to 4.5 s but a repair of one small fold (the mirrored Suzanne) from 5.0 to 6.4 s.
COMPILED_FROM = 16


def _compiled(R):
    """Whether the region ``R`` runs compiled (numba installed and at least :data:`COMPILED_FROM` faces)."""
    return HAS_NUMBA and len(R.T) >= COMPILED_FROM


def _stop_at(deadline):
    """A scipy ``minimize`` callback that ends the minimisation (its best point so far) once ``deadline`` passed."""
    def callback(intermediate_result):
        if budget_spent(deadline):
            raise StopIteration
    return callback


def budget_spent(deadline):
    """Whether the time budget's ``deadline`` (a ``time.perf_counter()`` value, or None: none) has passed."""
    return deadline is not None and time.perf_counter() > deadline


def stable_energy_terms(fro2, det, eps_J=1e-4):
    """NumPy twin of :func:`neuraluv.solver.energy.face_terms`'s stable energy, with derivatives.

    Returns ``s = ‖J‖²(1 + q(det))``, ``∂s/∂‖J‖² = 1 + q`` and ``∂s/∂det = ‖J‖² q'`` per face,
    where ``q`` is :func:`neuraluv.solver.energy.inv_det_sq` (``det⁻²`` above ``ε_J``, its C²
    Taylor polynomial below).

    Examples
    --------
    >>> s, ds_df, ds_dd = stable_energy_terms(np.array([2.0]), np.array([1.0]))
    >>> float(s[0]), float(ds_df[0]), float(ds_dd[0])
    (4.0, 2.0, -4.0)
    """
    d = np.asarray(det, float)
    big = d > eps_J
    safe = np.where(big, d, 1.0)
    t = d - eps_J
    q = np.where(big, safe**-2.0, eps_J**-2 - 2.0 * t * eps_J**-3 + 3.0 * t * t * eps_J**-4)
    dq = np.where(big, -2.0 * safe**-3.0, -2.0 * eps_J**-3 + 6.0 * t * eps_J**-4)
    return fro2 * (1.0 + q), 1.0 + q, fro2 * dq


@dataclass
class RegionEnergy:
    """The faces of a region, their reference frames, and which texture rows may move.

    Build with :meth:`build`; ``x`` vectors are the free rows' UVs flattened ``(2k,)``.

    Attributes
    ----------
    T : (r,3) int array, texture rows of the region's faces (``FUV[faces]``).
    K : (r,2,2) float array, inverse edge matrices of the 3D triangles, divided by the scale.
    w : (r,) float array, area weights summing to 1.
    free : (k,) int array, the movable rows.
    slot : (r,3) int array, position of each corner's row in ``free`` (-1: fixed).
    """

    T: np.ndarray
    K: np.ndarray
    w: np.ndarray
    free: np.ndarray
    slot: np.ndarray

    @classmethod
    def build(cls, V, F, FUV, faces, free, scale, sign=None):
        """Region of ``faces`` (indices into ``F``) with movable rows ``free``, measured at ``scale``.

        ``sign`` ((m,) array over all faces, optional): -1 where a face is valid reversed (a face of a mirrored
        shell), measured against its 3D triangle reflected in its plane (``K``'s second column negated: the
        same singular values, ``det J`` negated), so that one region may hold faces of both orientations.
        """
        faces = np.asarray(faces, np.int64)
        P3 = np.asarray(V, float)[np.asarray(F, np.int64)[faces].reshape(-1)]
        K, A = local_frames(P3, np.arange(3 * len(faces)).reshape(-1, 3))
        if sign is not None:
            K = K.copy()
            K[:, :, 1] *= np.where(np.asarray(sign)[faces] < 0, -1.0, 1.0)[:, None]
        if not (np.isfinite(K).all() and (A > 0).all()):
            bad = int((~(np.isfinite(K).all(axis=(1, 2)) & (A > 0))).sum())
            raise ValueError(f"{bad} degenerate 3D faces in the region: nothing to measure distortion against")
        T = np.asarray(FUV, np.int64)[faces]
        free = np.unique(np.asarray(free, np.int64))
        pos = {int(r): i for i, r in enumerate(free)}
        slot = np.array([pos.get(int(r), -1) for r in T.reshape(-1)], np.int64).reshape(T.shape)
        return cls(T=T, K=K / float(scale), w=A / A.sum(), free=free, slot=slot)

    def entries(self, U):
        """``(a, b, c, d)`` of every face's Jacobian for the full UV array ``U (p,2)``."""
        P = U[self.T]
        e1, e2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
        K = self.K
        return (e1[:, 0] * K[:, 0, 0] + e2[:, 0] * K[:, 1, 0], e1[:, 0] * K[:, 0, 1] + e2[:, 0] * K[:, 1, 1],
                e1[:, 1] * K[:, 0, 0] + e2[:, 1] * K[:, 1, 0], e1[:, 1] * K[:, 0, 1] + e2[:, 1] * K[:, 1, 1])

    def gradient(self, Ea, Eb, Ec, Ed):
        """Chain rule from per-face ``∂E/∂(a, b, c, d)`` to the free rows, flattened ``(2k,)``."""
        K = self.K
        g1x, g2x = Ea * K[:, 0, 0] + Eb * K[:, 0, 1], Ea * K[:, 1, 0] + Eb * K[:, 1, 1]
        g1y, g2y = Ec * K[:, 0, 0] + Ed * K[:, 0, 1], Ec * K[:, 1, 0] + Ed * K[:, 1, 1]
        gx = np.stack([-(g1x + g2x), g1x, g2x], 1).reshape(-1)
        gy = np.stack([-(g1y + g2y), g1y, g2y], 1).reshape(-1)
        s = self.slot.reshape(-1)
        ok = s >= 0
        k = len(self.free)
        G = np.empty((k, 2))
        G[:, 0] = np.bincount(s[ok], weights=gx[ok], minlength=k)
        G[:, 1] = np.bincount(s[ok], weights=gy[ok], minlength=k)
        return G.reshape(-1)

    def place(self, U, x):
        """A copy of ``U`` with the free rows set from ``x``."""
        out = np.array(U, float, copy=True)
        out[self.free] = np.asarray(x).reshape(-1, 2)
        return out

    def dets(self, U):
        a, b, c, d = self.entries(U)
        return a * d - b * c

    def max_step(self, U, dx):
        """Largest ``t`` in ``(0, ∞]`` such that ``U + t·dx`` flips no face of the region (``det`` stays > 0)."""
        D = np.zeros_like(U)
        D[self.free] = dx.reshape(-1, 2)
        P, Q = U[self.T], D[self.T]
        e1, e2, f1, f2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0], Q[:, 1] - Q[:, 0], Q[:, 2] - Q[:, 0]

        def cross(p, q):
            return p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]

        c0, c1, c2 = cross(e1, e2), cross(e1, f2) + cross(f1, e2), cross(f1, f2)
        sign = np.sign(np.linalg.det(self.K))  # orientation of the reference frames (positive)
        c0, c1, c2 = c0 * sign, c1 * sign, c2 * sign
        t = np.full(len(c0), np.inf)
        lin = np.abs(c2) <= 1e-300
        with np.errstate(divide="ignore", invalid="ignore"):
            r = -c0[lin] / c1[lin]
            t[lin] = np.where(r > 0, r, np.inf)
            disc = c1[~lin] ** 2 - 4 * c2[~lin] * c0[~lin]
            sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
            r1 = (-c1[~lin] - sq) / (2 * c2[~lin])
            r2 = (-c1[~lin] + sq) / (2 * c2[~lin])
            r1 = np.where(np.isfinite(r1) & (r1 > 0), r1, np.inf)
            r2 = np.where(np.isfinite(r2) & (r2 > 0), r2, np.inf)
            t[~lin] = np.minimum(r1, r2)
        return float(t.min()) if len(t) else float("inf")


def _chi(D, eps):
    """``(D + √(ε² + D²)) / 2``, written without cancellation for ``D < 0`` (there it equals ``ε² / (2(√(ε² + D²) − D))``)."""
    r = np.sqrt(eps * eps + D * D)
    with np.errstate(divide="ignore", invalid="ignore"):  # the unused branch of np.where may divide by 0
        return np.where(D >= 0, 0.5 * (D + r), eps * eps / (2.0 * (r - D)))


def untangle_energy(R, U0, x, theta, eps):
    """:func:`untangle`'s energy at the free rows ``x``: ``(E, ∂E/∂x, smallest det J)`` (NumPy; see :func:`untangle`).

    Parameters
    ----------
    R : RegionEnergy
    U0 : (p,2) float array, the layout (its fixed rows)
    x : (2k,) float array, the free rows' UVs
    theta, eps : float, the area term's weight and the regularisation

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> V, F = disk(2); R = RegionEnergy.build(V, F, F, np.arange(len(F)), [0], 1.0)
    >>> E, g, dmin = untangle_energy(R, V[:, :2], V[0, :2], 0.5, 1e-9)   # the flat disk itself: J = I
    >>> round(E, 6), bool(np.allclose(g, 0)), round(dmin, 6)
    (2.0, True, 1.0)
    """
    a, b, c, d = R.entries(R.place(U0, x))
    D = a * d - b * c
    chi = _chi(D, eps)
    dchi = chi / np.sqrt(eps * eps + D * D)  # ∂χ/∂D = (1 + D/√(ε²+D²))/2 = χ/√(ε²+D²)
    N = (1 - theta) * (a * a + b * b + c * c + d * d) + theta * (D * D + 1.0)
    f = N / chi
    dF = (1 - theta) / chi * R.w  # ∂/∂‖J‖²
    dD = (2 * theta * D * chi - N * dchi) / (chi * chi) * R.w  # ∂/∂det
    g = R.gradient(2 * a * dF + d * dD, 2 * b * dF - c * dD, 2 * c * dF - b * dD, 2 * d * dF + a * dD)
    return float((R.w * f).sum()), g, float(D.min())


def untangle(V, F, UV, FUV, faces, free, *, scale, theta=0.5, max_outer=40, inner=300, deadline=None, sign=None):
    """Untangle a folded region by moving only the ``free`` rows (Garanzha et al. 2021).

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
        May contain flipped or degenerate triangles (finite values).
    FUV : (m,3) int array
    faces : (r,) int array
        The region: every face that has a free row (other faces do not change).
    free : (k,) int array
        Rows of ``UV`` that may move.
    scale : float
        Target texel density (UV length per 3D length, :func:`~neuraluv.layout.facts.texel_density`).
    theta : float
        Weight of the area term (the paper's ½).
    max_outer, inner : int
        ε-steps, and L-BFGS iterations per step (SciPy's L-BFGS-B on the NumPy energy; for regions of at least
        :data:`COMPILED_FROM` faces with numba installed, a compiled L-BFGS with a backtracking line search on
        the compiled energy: the same minimisation, other iterates).
    deadline : float, optional
        ``time.perf_counter()`` value after which no further ε-step starts (``ok`` tells whether the map so far
        is fold-free).
    sign : (m,) float array, optional
        -1 for faces that are to be valid reversed (:meth:`RegionEnergy.build`).

    Returns
    -------
    UV : (p,2) float array
        A copy with the free rows moved; every region face has ``det J > 0`` when it succeeded.
    info : dict
        ``outer`` steps taken, ``min_det`` (relative to ``scale``), ``ok``.

    Notes
    -----
    With ``J`` measured against the 3D triangle at ``scale`` and
    ``χ(D, ε) = (D + √(ε² + D²)) / 2``, minimises over the free rows

    .. math:: \\sum_t A_t \\frac{(1-θ)\\operatorname{tr}(J_t^\\top J_t) + θ(\\det^2 J_t + 1)}{χ(\\det J_t, ε)}

    for a decreasing sequence of ``ε``: after each minimisation with energy
    ``E`` (previously ``E'``), ``σ = max(1 − E/E', 0.1)``, ``μ = (1−σ) χ(d_min, ε)``
    and ``ε ← 2√(μ(μ − d_min))`` while ``d_min < μ`` (the paper's update). As
    ``ε → 0``, ``χ → max(D, 0)``: an inverted triangle's cost grows without bound.

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> from neuraluv.tutte import tutte
    >>> from neuraluv.metrics import face_dets
    >>> from neuraluv.layout.facts import texel_density
    >>> V, F = disk(3); UV = tutte(V, F); UV[0] += [0.6, 0.1]        # fold the centre over
    >>> faces = np.flatnonzero((F == 0).any(1))
    >>> out, info = untangle(V, F, UV, F, faces, [0], scale=texel_density(V, F, tutte(V, F)))
    >>> int((face_dets(V, F, UV) <= 0).sum()) > 0, info["ok"], int((face_dets(V, F, out) <= 0).sum())
    (True, True, 0)
    >>> bool(np.array_equal(np.delete(out, 0, 0), np.delete(UV, 0, 0)))      # nothing else moved
    True
    """
    U0 = np.asarray(UV, float)
    R = RegionEnergy.build(V, F, FUV, faces, free, scale, sign)

    def energy(x, eps):
        if compiled is not None:
            return compiled[0](U0, R.T, R.K, R.w, R.slot, len(R.free), x, float(theta), float(eps))
        return untangle_energy(R, U0, x, theta, eps)

    def minimise(x, eps):
        """The inner minimisation at ``eps``: compiled L-BFGS, or SciPy's L-BFGS-B on the NumPy energy."""
        if compiled is not None:
            return compiled[1](U0, R.T, R.K, R.w, R.slot, len(R.free), x, float(theta), float(eps), int(inner), 10,
                               1e-13, 1e-11)
        return minimize(lambda z, e: energy(z, e)[:2], x, args=(eps,), jac=True, method="L-BFGS-B",
                        options={"maxiter": int(inner), "maxcor": 10, "ftol": 1e-13, "gtol": 1e-11},
                        callback=None if deadline is None else _stop_at(deadline)).x

    compiled = untangle_kernels() if _compiled(R) else None
    x = U0[R.free].reshape(-1).copy()
    E, _, dmin = energy(x, 1.0)
    if dmin > 0:
        return U0.copy(), {"outer": 0, "min_det": dmin, "ok": True}
    eps, E_prev, outer = 1.0, None, 0
    for outer in range(1, max_outer + 1):
        if outer > 1 and budget_spent(deadline):  # the time budget: the map so far (checked for folds below)
            break
        x = minimise(x, eps)
        E, _, dmin = energy(x, eps)
        if E_prev is not None and dmin > 0 and abs(E_prev - E) <= 1e-5 * abs(E):
            break
        sigma = max(1.0 - E / E_prev, 0.1) if E_prev else 0.1
        mu = (1.0 - sigma) * float(_chi(np.float64(dmin), eps))
        eps = 2.0 * np.sqrt(mu * (mu - dmin)) if dmin < mu else 1e-10
        E_prev = E
    out = R.place(U0, x)
    dmin = float(R.dets(out).min())
    return out, {"outer": outer, "min_det": dmin, "ok": bool(dmin > 0 and np.isfinite(out[R.free]).all())}


def polish(V, F, UV, FUV, faces, free, *, scale, max_iter=500, history=10, eps_J=1e-4, eps=1e-3, alpha=1.0,
           tol=1e-9, deadline=None, sign=None):
    """Lower the stable symmetric Dirichlet objective by moving only the ``free`` rows, never folding a face.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
        A map whose region faces are all valid (``det J > 0``), e.g. from :func:`untangle`.
    FUV : (m,3) int array
    faces, free : int arrays
        As in :func:`untangle`.
    scale : float
        Texel density at which an isometry has ``J = I``.
    max_iter, history : int
        L-BFGS iterations and memory (for regions of at least :data:`COMPILED_FROM` faces with numba installed,
        the same iterations run compiled: the same steps to rounding).
    deadline : float, optional
        ``time.perf_counter()`` value after which the polish stops (every accepted step is valid).
    sign : (m,) float array, optional
        -1 for faces valid reversed (:meth:`RegionEnergy.build`).
    eps_J, eps, alpha : float
        The paper's C² switch point, barrier margin and barrier weight.
    tol : float
        Stop when an iteration lowers the objective by less than ``tol`` (relative).

    Returns
    -------
    UV : (p,2) float array
        The polished copy (``UV`` itself, copied, if the region was not valid to begin with).
    info : dict
        ``iterations``, ``energy_before``, ``energy_after`` (the objective), ``converged``.

    Notes
    -----
    Minimises the paper's objective over the region,
    ``Σ_t A_t ‖J_t‖²(1 + q(det J_t)) + α Σ_t [ε − det J_t]₊²`` (area weights
    normalised), with L-BFGS. Every line search starts below the largest step
    that keeps all ``det J_t > 0`` (a quadratic in the step per face, solved
    exactly; Smith & Schaefer 2015), then backtracks until the Armijo condition
    holds, so each accepted iterate is valid — the validity-checked step of the
    paper's Algorithm 1 without its network.

    Examples
    --------
    >>> from neuraluv.datasets import spherical_cap
    >>> from neuraluv.tutte import tutte
    >>> from neuraluv.metrics import distortion_metrics
    >>> from neuraluv.layout.facts import texel_density
    >>> V, F = spherical_cap(4); UV = tutte(V, F); s = texel_density(V, F, UV)
    >>> out, info = polish(V, F, UV, F, np.arange(len(F)), np.arange(len(V)), scale=s)
    >>> bool(info["energy_after"] < info["energy_before"]), distortion_metrics(V, F, out)["flips"]
    (True, 0)
    """
    U0 = np.asarray(UV, float)
    R = RegionEnergy.build(V, F, FUV, faces, free, scale, sign)
    if not (R.dets(U0) > 0).all() or not len(R.free):
        return U0.copy(), {"iterations": 0, "energy_before": None, "energy_after": None, "converged": False}

    def energy(x):
        U = R.place(U0, x)
        a, b, c, d = R.entries(U)
        fro2, D = a * a + b * b + c * c + d * d, a * d - b * c
        s, ds_df, ds_dd = stable_energy_terms(fro2, D, eps_J)
        gap = np.maximum(eps - D, 0.0)
        dF = ds_df * R.w
        dD = ds_dd * R.w - 2.0 * alpha * gap
        g = R.gradient(2 * a * dF + d * dD, 2 * b * dF - c * dD, 2 * c * dF - b * dD, 2 * d * dF + a * dD)
        return float((R.w * s).sum() + alpha * (gap * gap).sum()), g

    x = U0[R.free].reshape(-1).copy()
    if _compiled(R):
        return _polish_compiled(R, U0, x, max_iter, history, eps_J, eps, alpha, tol, deadline)
    E, g = energy(x)
    E0 = E
    S, Y = [], []
    it = 0
    converged = False
    for it in range(1, max_iter + 1):
        if it % 5 == 0 and budget_spent(deadline):  # every step keeps the map valid: stop where it is
            break
        # two-loop recursion
        q = -g.copy()
        al = []
        for s_, y_ in reversed(list(zip(S, Y))):
            a_ = (s_ @ q) / (y_ @ s_)
            al.append(a_)
            q -= a_ * y_
        if S:
            q *= (S[-1] @ Y[-1]) / (Y[-1] @ Y[-1])
        for (s_, y_), a_ in zip(zip(S, Y), reversed(al)):
            q += s_ * (a_ - (y_ @ q) / (y_ @ s_))
        p = q
        gp = float(g @ p)
        if not gp < 0:
            S, Y = [], []
            p, gp = -g, -float(g @ g)
        t = min(1.0, 0.8 * R.max_step(R.place(U0, x), p))
        if not t > 0:
            break
        accepted = False
        for _ in range(40):
            xn = x + t * p
            En, gn = energy(xn)
            if np.isfinite(En) and En <= E + 1e-4 * t * gp:
                accepted = True
                break
            t *= 0.5
        if not accepted:
            converged = True  # no descent left at machine precision
            break
        s_, y_ = xn - x, gn - g
        if s_ @ y_ > 1e-300:
            S.append(s_)
            Y.append(y_)
            if len(S) > history:
                S.pop(0)
                Y.pop(0)
        drop = E - En
        x, E, g = xn, En, gn
        if drop <= tol * abs(E):
            converged = True
            break
    return _polished(R, U0, x, it, E0, E, converged)


def _polished(R, U0, x, it, E0, E, converged):
    """:func:`polish`'s result from its last iterate ``x``."""
    out = R.place(U0, x)
    if not (np.isfinite(out[R.free]).all() and (R.dets(out) > 0).all()):  # cannot happen; never return worse
        return U0.copy(), {"iterations": it, "energy_before": E0, "energy_after": E0, "converged": False}
    return out, {"iterations": it, "energy_before": E0, "energy_after": E, "converged": converged}


#: Iterations of the compiled polish between two looks at the time budget.
POLISH_CHUNK = 25


def _polish_compiled(R, U0, x, max_iter, history, eps_J, eps, alpha, tol, deadline):
    """:func:`polish`'s loop compiled by numba (:func:`~neuraluv.repair.kernels.polish_kernels`): the same
    iterations, run :data:`POLISH_CHUNK` at a time so that the time budget is looked at between them."""
    energy, minimize_ = polish_kernels()
    k = len(R.free)
    args = (U0, R.T, R.K, R.w, R.slot, k)
    E0 = E = float(energy(*args, x, eps_J, eps, alpha)[0])
    S, Y = np.zeros((history, 2 * k)), np.zeros((history, 2 * k))
    state = np.zeros(2, np.int64)
    it, converged = 0, False
    while it < max_iter:
        if it and budget_spent(deadline):  # every step keeps the map valid: stop where it is
            break
        code, n, E = minimize_(*args, x, eps_J, eps, alpha, min(POLISH_CHUNK, max_iter - it), tol, S, Y, state)
        it += int(n)
        if code:
            converged = code == 1
            break
    return _polished(R, U0, x, it, E0, float(E), converged)
