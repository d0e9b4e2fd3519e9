"""Least-squares weights of a model linear in them, with Newey-West standard errors: what
the variants on the absolute footing (:mod:`fingerfriction.fit.load`,
:mod:`fingerfriction.fit.pressure`) solve per trial once the rest of the model is fixed."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["hac_se", "hac_cov", "column_weights", "column_weights_se", "MIN_COLUMN"]


def hac_se(b: np.ndarray, e: np.ndarray, lags: int) -> float:
    """Newey-West standard error of the slope of ``y = p1 b + e`` (Bartlett kernel)."""
    g = b * e
    n = g.size
    lags = int(min(max(lags, 0), n - 1))
    # autocovariances of g up to `lags` through the FFT (O(n log n))
    m = 1 << int(math.ceil(math.log2(2 * n)))
    f = np.fft.rfft(g, m)
    acov = np.fft.irfft(f * np.conj(f), m)[: lags + 1]
    w = 1.0 - np.arange(lags + 1) / (lags + 1.0)
    s = acov[0] + 2.0 * float(np.sum(w[1:] * acov[1:]))
    bb = float(b @ b)
    return math.sqrt(max(s, 0.0)) / bb if bb > 0 else math.nan


def hac_cov(X: np.ndarray, e: np.ndarray, lags: int) -> np.ndarray:
    """Newey-West covariance of the least-squares weights of ``y = X p + e`` (Bartlett
    kernel), ``(m, m)`` for ``X`` of shape ``(n, m)``: ``(X'X)^-1 S (X'X)^-1``."""
    g = X * e[:, None]
    n = g.shape[0]
    lags = int(min(max(lags, 0), n - 1))
    S = g.T @ g
    for k in range(1, lags + 1):
        G = g[k:].T @ g[:-k]
        S += (1.0 - k / (lags + 1.0)) * (G + G.T)
    inv = np.linalg.inv(X.T @ X)
    return inv @ S @ inv


#: A column whose norm is below this share of the largest column's is not identified by
#: the trial (e.g. the descending slopes' weight on a Step Up).
MIN_COLUMN = 1e-4


def column_weights(b: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares weights of the columns of ``b`` (``(n, m)``) for ``y``, and which
    columns are identified: a column too small to pin its weight gets 0 (and False)."""
    norms = np.sqrt(np.sum(b * b, axis=0))
    ok = norms > MIN_COLUMN * max(float(norms.max(initial=0.0)), 1e-300)
    p = np.zeros(b.shape[1])
    if ok.any():
        p[ok] = np.linalg.lstsq(b[:, ok], y, rcond=None)[0]
    return p, ok


def column_weights_se(X: np.ndarray, y: np.ndarray, lags: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`column_weights` with the weights' Newey-West standard errors (``lags``
    samples, :func:`hac_cov`): ``(p, se, ok)``, each ``(m,)``; a weight the trial does not
    identify is 0 with SE NaN."""
    p, ok = column_weights(X, y)
    se = np.full(p.size, np.nan)
    if ok.any():
        se[ok] = np.sqrt(np.maximum(np.diag(hac_cov(X[:, ok], y - X @ p, lags)), 0.0))
    return p, se, ok
