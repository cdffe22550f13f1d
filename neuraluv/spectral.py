"""Laplace–Beltrami features: cotangent Laplacian, eigenfunctions, sign fix, scaling.

The network input of the paper's Eq. (2) is ``x_i = [p̃_i ‖ ψ̃_1(v_i) … ψ̃_k(v_i)]``:
normalised positions concatenated with the first ``k`` non-trivial LBO
eigenfunctions, each scaled to comparable variance (Sec. 4).
"""
from __future__ import annotations

import igl
import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg

__all__ = ["cotangent_laplacian", "laplacian", "lbo_eigenfunctions", "fix_signs", "chart_features", "FEATURE_STD"]

#: Standard deviation every feature column is scaled to: that of U(-1, 1), the
#: input range SIREN's initialisation assumes.
FEATURE_STD = 1.0 / np.sqrt(3.0)


def cotangent_laplacian(V, F):
    """libigl's cotangent matrix ``L`` (symmetric, negative semi-definite, rows sum to 0).

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array

    Returns
    -------
    L : (n,n) scipy sparse CSC matrix

    Notes
    -----
    ``L_ij = ½ (cot α_ij + cot β_ij)`` for an edge ``ij`` with opposite angles
    ``α_ij, β_ij``; ``L_ii = −Σ_j L_ij`` (Pinkall & Polthier 1993).
    """
    return sp.csc_matrix(igl.cotmatrix(np.ascontiguousarray(V, dtype=np.float64), np.ascontiguousarray(F, dtype=np.int64)))


def laplacian(V, F):
    """Cotangent Laplacian and lumped (Voronoi) mass matrix.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array

    Returns
    -------
    L : (n,n) scipy sparse matrix
        libigl's cotangent matrix: symmetric, negative semi-definite, rows sum to 0.
    M : (n,n) scipy sparse diagonal matrix
        Lumped mass; its trace is the surface area.

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> V, F = disk(n_rings=3)
    >>> L, M = laplacian(V, F)
    >>> bool(abs(L.sum(axis=1)).max() < 1e-12)
    True
    """
    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    M = igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_VORONOI)
    return cotangent_laplacian(V, F), sp.csc_matrix(M)


def fix_signs(phi, V, M=None):
    """Deterministic sign convention for eigenfunctions.

    Each column is flipped so that its (mass-weighted) correlation with the
    spatial coordinate it correlates with most strongly is positive; columns
    uncorrelated with every coordinate get their largest-magnitude entry positive.

    Parameters
    ----------
    phi : (n,k) float array
    V : (n,3) float array
    M : (n,n) sparse mass matrix, optional

    Returns
    -------
    phi : (n,k) float array, signs fixed

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [2, 0, 0]])
    >>> (fix_signs(np.array([[1.0], [0.0], [-1.0]]), V).ravel() + 0.0).tolist()
    [-1.0, 0.0, 1.0]
    """
    phi = np.array(phi, dtype=float, copy=True)
    w = np.ones(len(V)) if M is None else np.asarray(M.diagonal()).ravel()
    P = np.asarray(V, float) - np.average(V, axis=0, weights=w)
    corr = (P * w[:, None]).T @ phi  # (3,k)
    scale = np.linalg.norm(P * np.sqrt(w)[:, None], axis=0)[:, None] * np.linalg.norm(phi * np.sqrt(w)[:, None], axis=0)[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(scale > 0, np.abs(corr) / scale, 0.0)
    for j in range(phi.shape[1]):
        a = int(np.argmax(rel[:, j]))
        if rel[a, j] > 1e-6:
            s = np.sign(corr[a, j])
        else:
            s = np.sign(phi[int(np.argmax(np.abs(phi[:, j]))), j]) or 1.0
        phi[:, j] *= s
    return phi


def lbo_eigenfunctions(V, F, k=16, *, sign_fix=True):
    """First ``k`` non-trivial eigenpairs of ``-L φ = λ M φ``.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    k : int
        Number of non-trivial eigenfunctions (the constant mode is dropped).
    sign_fix : bool
        Apply :func:`fix_signs`.

    Returns
    -------
    evals : (k,) float array
        Ascending eigenvalues (0 for padded columns).
    phi : (n,k) float array
        M-orthonormal eigenfunctions. Meshes with fewer than ``k + 2`` vertices
        get zero-padded columns so the feature width stays fixed.

    Notes
    -----
    Shift-invert Lanczos (``scipy.sparse.linalg.eigsh`` with a small negative
    shift, so the shifted operator is positive definite); a dense solver is used
    for tiny meshes.

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> lam, phi = lbo_eigenfunctions(*disk(n_rings=6), k=4)
    >>> phi.shape, bool(np.all(np.diff(lam) >= -1e-9)), bool(lam[0] > 0)
    ((127, 4), True, True)
    """
    V = np.asarray(V, float)
    n = len(V)
    if k <= 0:
        return np.zeros(0), np.zeros((n, 0))
    L, M = laplacian(V, F)
    A = -L
    # guard isolated vertices (zero mass) so M stays positive definite
    md = np.asarray(M.diagonal()).ravel()
    if np.any(md <= 0):
        md = np.where(md > 0, md, md[md > 0].min() if np.any(md > 0) else 1.0)
        M = sp.diags(md).tocsc()
    kk = min(k + 1, n)
    area = md.sum()
    if n <= max(200, 3 * kk):
        lam, phi = scipy.linalg.eigh(A.toarray(), M.toarray())
        lam, phi = lam[:kk], phi[:, :kk]
    else:
        sigma = -1e-3 / max(area, 1e-12)
        lam, phi = scipy.sparse.linalg.eigsh(A, k=kk, M=M, sigma=sigma, which="LM", v0=np.ones(n))
        order = np.argsort(lam)
        lam, phi = lam[order], phi[:, order]
    lam, phi = lam[1:], phi[:, 1:]  # drop the constant mode
    if sign_fix and phi.shape[1]:
        phi = fix_signs(phi, V, M)
    if phi.shape[1] < k:
        pad = k - phi.shape[1]
        phi = np.hstack([phi, np.zeros((n, pad))])
        lam = np.concatenate([lam, np.zeros(pad)])
    return lam, phi


def _standardize(X):
    X = X - X.mean(axis=0)
    sd = X.std(axis=0)
    return np.where(sd > 0, X / np.where(sd > 0, sd, 1.0) * FEATURE_STD, 0.0)


def chart_features(V, F, k=16, *, eig=None):
    """SIREN inputs ``[p̃ ‖ ψ̃_1..k]`` with comparable per-column variance.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    k : int
        Spectral rank (0 gives positions only).
    eig : tuple (evals, phi), optional
        Precomputed :func:`lbo_eigenfunctions` output.

    Returns
    -------
    X : (n, 3+k) float32 array

    Notes
    -----
    Positions are centred and scaled by one common factor (the shape's aspect is
    kept) so that their mean per-axis standard deviation is ``FEATURE_STD``;
    each eigenfunction is centred and scaled to standard deviation
    ``FEATURE_STD``. No feature family is privileged by the first layer's
    bandwidth ``ω₀``.

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> X = chart_features(*disk(n_rings=6), k=4)
    >>> X.shape, bool(np.allclose(X[:, 3:].std(axis=0), FEATURE_STD, atol=1e-5))
    ((127, 7), True)
    """
    V = np.asarray(V, float)
    P = V - V.mean(axis=0)
    s = np.sqrt(np.mean(P**2))  # mean per-axis variance -> s^2
    P = P / (s if s > 0 else 1.0) * FEATURE_STD
    cols = [P]
    if k > 0:
        _, phi = eig if eig is not None else lbo_eigenfunctions(V, F, k)
        cols.append(_standardize(phi[:, :k]))
    return np.hstack(cols).astype(np.float32)
