"""The repair's loops compiled by numba (the optional extra ``fast``): the untangle's energy and L-BFGS, and the
polish's energy, flip-free step bound and L-BFGS.

Each kernel is the loop form of a NumPy function of :mod:`neuraluv.repair.untangle` (which runs when numba
is not installed): the same sums in another order, so results agree to rounding, not bit for bit. A repair
evaluates these energies some 10⁵ times on a real asset, where NumPy's per-call cost dominates.
Compiled on first use (:func:`untangle_kernels`, :func:`polish_kernels`) and cached on disk by numba.
"""
from __future__ import annotations

import functools

import numpy as np

from neuraluv.lazy import jit

__all__ = ["untangle_kernels", "polish_kernels"]


def _entries(U0, T, K, slot, x, t, P):  # pragma: no cover - run compiled by numba
    """Face ``t``'s corners into ``P (3,2)`` (a free row's from ``x``, the others' from ``U0``) and the entries
    ``(a, b, c, d)`` of its Jacobian."""
    for j in range(3):
        s = slot[t, j]
        if s >= 0:
            P[j, 0] = x[2 * s]
            P[j, 1] = x[2 * s + 1]
        else:
            P[j, 0] = U0[T[t, j], 0]
            P[j, 1] = U0[T[t, j], 1]
    e1x, e1y = P[1, 0] - P[0, 0], P[1, 1] - P[0, 1]
    e2x, e2y = P[2, 0] - P[0, 0], P[2, 1] - P[0, 1]
    k00, k01, k10, k11 = K[t, 0, 0], K[t, 0, 1], K[t, 1, 0], K[t, 1, 1]
    return e1x * k00 + e2x * k10, e1x * k01 + e2x * k11, e1y * k00 + e2y * k10, e1y * k01 + e2y * k11


def _scatter(G, K, slot, t, Ea, Eb, Ec, Ed):  # pragma: no cover - run compiled by numba
    """Add face ``t``'s ``∂E/∂(a, b, c, d)`` to the gradient ``G`` of the free rows (through its three corners)."""
    k00, k01, k10, k11 = K[t, 0, 0], K[t, 0, 1], K[t, 1, 0], K[t, 1, 1]
    g1x, g2x = Ea * k00 + Eb * k01, Ea * k10 + Eb * k11
    g1y, g2y = Ec * k00 + Ed * k01, Ec * k10 + Ed * k11
    for j, gx, gy in ((0, -(g1x + g2x), -(g1y + g2y)), (1, g1x, g1y), (2, g2x, g2y)):
        s = slot[t, j]
        if s >= 0:
            G[2 * s] += gx
            G[2 * s + 1] += gy


def _untangle_energy(U0, T, K, w, slot, k, x, theta, eps):  # pragma: no cover - run compiled by numba
    """:func:`~neuraluv.repair.untangle.untangle_energy` in one loop over the faces, for numba (``k``: the number
    of free rows): the same sums."""
    G = np.zeros(2 * k)
    E = 0.0
    dmin = np.inf
    P = np.empty((3, 2))
    for t in range(T.shape[0]):
        a, b, c, d = _entries(U0, T, K, slot, x, t, P)
        D = a * d - b * c
        r = np.sqrt(eps * eps + D * D)
        chi = 0.5 * (D + r) if D >= 0 else eps * eps / (2.0 * (r - D))
        N = (1 - theta) * (a * a + b * b + c * c + d * d) + theta * (D * D + 1.0)
        E += w[t] * (N / chi)
        dF = (1 - theta) / chi * w[t]
        dD = (2 * theta * D * chi - N * (chi / r)) / (chi * chi) * w[t]
        _scatter(G, K, slot, t, 2 * a * dF + d * dD, 2 * b * dF - c * dD, 2 * c * dF - b * dD, 2 * d * dF + a * dD)
        dmin = min(dmin, D)
    return E, G, dmin


def _untangle_minimize(U0, T, K, w, slot, k, x0, theta, eps, maxiter, m, ftol, gtol):  # pragma: no cover - numba
    """One ε-step of :func:`~neuraluv.repair.untangle.untangle`: L-BFGS (memory ``m``, backtracking Armijo line
    search) on :func:`_untangle_energy` from ``x0``, for numba; stops after ``maxiter`` iterations, when an iteration
    lowers the energy by at most ``ftol`` (relative) or when the gradient's largest entry is at most ``gtol``.
    Returns the last iterate."""
    n = x0.shape[0]
    x = x0.copy()
    f, g, _ = _untangle_energy(U0, T, K, w, slot, k, x, theta, eps)
    S = np.zeros((m, n))
    Y = np.zeros((m, n))
    rho = np.zeros(m)
    alpha = np.zeros(m)
    count, head = 0, 0
    for _ in range(maxiter):
        if np.max(np.abs(g)) <= gtol:
            break
        q = -g
        for j in range(count):  # two-loop recursion, newest pair first
            i = (head - 1 - j) % m
            alpha[i] = rho[i] * np.dot(S[i], q)
            q = q - alpha[i] * Y[i]
        if count > 0:
            i = (head - 1) % m
            q = q * (np.dot(S[i], Y[i]) / np.dot(Y[i], Y[i]))
        else:
            q = q / max(np.sqrt(np.dot(g, g)), 1e-300)  # the first step: unit length along -g
        for j in range(count - 1, -1, -1):
            i = (head - 1 - j) % m
            q = q + S[i] * (alpha[i] - rho[i] * np.dot(Y[i], q))
        gd = np.dot(g, q)
        if not gd < 0:  # not a descent direction: forget the pairs, steepest descent
            count = 0
            q = -g / max(np.sqrt(np.dot(g, g)), 1e-300)
            gd = np.dot(g, q)
        t = 1.0
        found = False
        for _ls in range(60):
            xn = x + t * q
            fn, gn, _ = _untangle_energy(U0, T, K, w, slot, k, xn, theta, eps)
            if np.isfinite(fn) and fn <= f + 1e-4 * t * gd:
                found = True
                break
            t *= 0.5
        if not found:
            break
        sv, yv = xn - x, gn - g
        sy = np.dot(sv, yv)
        if sy > 1e-10 * np.sqrt(np.dot(sv, sv) * np.dot(yv, yv)):
            S[head], Y[head], rho[head] = sv, yv, 1.0 / sy
            head = (head + 1) % m
            count = min(count + 1, m)
        drop = f - fn
        x, f, g = xn, fn, gn
        if drop <= ftol * max(abs(f), abs(f + drop), 1.0):
            break
    return x


def _polish_energy(U0, T, K, w, slot, k, x, eps_J, eps, alpha):  # pragma: no cover - run compiled by numba
    """:func:`~neuraluv.repair.untangle.polish`'s objective at the free rows ``x``: ``(E, ∂E/∂x)``, one loop over
    the faces: ``Σ_t w_t ‖J_t‖²(1 + q(det J_t)) + α Σ_t [ε − det J_t]₊²`` with ``q`` as in
    :func:`~neuraluv.repair.untangle.stable_energy_terms`."""
    G = np.zeros(2 * k)
    E = 0.0
    P = np.empty((3, 2))
    for t in range(T.shape[0]):
        a, b, c, d = _entries(U0, T, K, slot, x, t, P)
        fro2, D = a * a + b * b + c * c + d * d, a * d - b * c
        if D > eps_J:
            q, dq = D ** -2.0, -2.0 * D ** -3.0
        else:
            tt = D - eps_J
            q = eps_J ** -2 - 2.0 * tt * eps_J ** -3 + 3.0 * tt * tt * eps_J ** -4
            dq = -2.0 * eps_J ** -3 + 6.0 * tt * eps_J ** -4
        gap = max(eps - D, 0.0)
        E += w[t] * fro2 * (1.0 + q) + alpha * gap * gap
        dF = (1.0 + q) * w[t]
        dD = fro2 * dq * w[t] - 2.0 * alpha * gap
        _scatter(G, K, slot, t, 2 * a * dF + d * dD, 2 * b * dF - c * dD, 2 * c * dF - b * dD, 2 * d * dF + a * dD)
    return E, G


def _polish_max_step(U0, T, K, slot, x, p):  # pragma: no cover - run compiled by numba
    """:meth:`~neuraluv.repair.untangle.RegionEnergy.max_step` at the free rows ``x`` along ``p``: the largest
    ``t > 0`` at which a face's ``det`` reaches 0 (``inf``: none)."""
    tmin = np.inf
    P = np.empty((3, 2))
    Q = np.zeros((3, 2))
    for t in range(T.shape[0]):
        for j in range(3):
            s = slot[t, j]
            if s >= 0:
                P[j, 0], P[j, 1] = x[2 * s], x[2 * s + 1]
                Q[j, 0], Q[j, 1] = p[2 * s], p[2 * s + 1]
            else:
                P[j, 0], P[j, 1] = U0[T[t, j], 0], U0[T[t, j], 1]
                Q[j, 0], Q[j, 1] = 0.0, 0.0
        e1x, e1y, e2x, e2y = P[1, 0] - P[0, 0], P[1, 1] - P[0, 1], P[2, 0] - P[0, 0], P[2, 1] - P[0, 1]
        f1x, f1y, f2x, f2y = Q[1, 0] - Q[0, 0], Q[1, 1] - Q[0, 1], Q[2, 0] - Q[0, 0], Q[2, 1] - Q[0, 1]
        sg = np.sign(K[t, 0, 0] * K[t, 1, 1] - K[t, 0, 1] * K[t, 1, 0])
        c0 = (e1x * e2y - e1y * e2x) * sg
        c1 = (e1x * f2y - e1y * f2x + f1x * e2y - f1y * e2x) * sg
        c2 = (f1x * f2y - f1y * f2x) * sg
        if abs(c2) <= 1e-300:
            if c1 != 0.0:
                r = -c0 / c1
                if r > 0 and r < tmin:
                    tmin = r
        else:
            disc = c1 * c1 - 4 * c2 * c0
            if disc >= 0:
                sq = np.sqrt(disc)
                for r in ((-c1 - sq) / (2 * c2), (-c1 + sq) / (2 * c2)):
                    if np.isfinite(r) and r > 0 and r < tmin:
                        tmin = r
    return tmin


def _polish_minimize(U0, T, K, w, slot, k, x, eps_J, eps, alpha, n_iter, tol, S, Y, state):  # pragma: no cover
    """Up to ``n_iter`` iterations of :func:`~neuraluv.repair.untangle.polish`'s L-BFGS from ``x`` (updated in
    place), for numba. ``S, Y`` (history × 2k) hold the curvature pairs and ``state = [count, head]`` where
    they are, both carried from one call to the next. Returns ``(code, iterations, E)``: code 0 when the
    iterations ran out, 1 converged (no descent left, or a drop below ``tol``), 2 no valid step."""
    m = S.shape[0]
    E, g = _polish_energy(U0, T, K, w, slot, k, x, eps_J, eps, alpha)
    count, head = state[0], state[1]
    al = np.zeros(m)
    it = 0
    code = 0
    while it < n_iter:
        it += 1
        q = -g
        for j in range(count):  # two-loop recursion, newest pair first
            i = (head - 1 - j) % m
            al[i] = np.dot(S[i], q) / np.dot(Y[i], S[i])
            q = q - al[i] * Y[i]
        if count > 0:
            i = (head - 1) % m
            q = q * (np.dot(S[i], Y[i]) / np.dot(Y[i], Y[i]))
        for j in range(count - 1, -1, -1):
            i = (head - 1 - j) % m
            q = q + S[i] * (al[i] - np.dot(Y[i], q) / np.dot(Y[i], S[i]))
        gp = np.dot(g, q)
        if not gp < 0:  # not a descent direction: forget the pairs, steepest descent
            count, head = 0, 0
            q = -g
            gp = -np.dot(g, g)
        t = min(1.0, 0.8 * _polish_max_step(U0, T, K, slot, x, q))
        if not t > 0:
            code = 2
            break
        accepted = False
        for _ls in range(40):
            xn = x + t * q
            En, gn = _polish_energy(U0, T, K, w, slot, k, xn, eps_J, eps, alpha)
            if np.isfinite(En) and En <= E + 1e-4 * t * gp:
                accepted = True
                break
            t *= 0.5
        if not accepted:
            code = 1
            break
        sv, yv = xn - x, gn - g
        if np.dot(sv, yv) > 1e-300:
            S[head], Y[head] = sv, yv
            head = (head + 1) % m
            count = min(count + 1, m)
        drop = E - En
        x[:] = xn
        E, g = En, gn
        if drop <= tol * abs(E):
            code = 1
            break
    state[0], state[1] = count, head
    return code, it, E


@functools.cache
def _helpers():
    """The per-face helpers compiled (once), before the energies that call them."""
    global _entries, _scatter
    _entries, _scatter = jit(_entries), jit(_scatter)


@functools.cache
def untangle_kernels():
    """``(energy, minimize)``: :func:`_untangle_energy` and :func:`_untangle_minimize` compiled by numba (once)."""
    global _untangle_energy
    _helpers()
    _untangle_energy = jit(_untangle_energy)  # the global _untangle_minimize calls, compiled before it is
    return _untangle_energy, jit(_untangle_minimize)


@functools.cache
def polish_kernels():
    """``(energy, minimize)``: :func:`_polish_energy` and :func:`_polish_minimize` compiled by numba (once)."""
    global _polish_energy, _polish_max_step
    _helpers()
    _polish_energy = jit(_polish_energy)  # the globals _polish_minimize calls, compiled before it is
    _polish_max_step = jit(_polish_max_step)
    return _polish_energy, jit(_polish_minimize)
