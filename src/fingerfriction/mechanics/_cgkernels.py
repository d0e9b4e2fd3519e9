"""Compiled (numba) loop bodies of the Polonsky-Keer conjugate gradient in :mod:`.bem`.

Why compiled: at the sweep's grid sizes (1024-4096 cells) one CG iteration is about 30
small vector operations around one FFT pair, and numpy's per-call overhead, not the
arithmetic, dominated. The vector work is fused into two compiled passes per iteration
(the FFTs stay in scipy's pocketfft); ``benchmarks/contact.py`` measures the sweeps, and
``docs/mechanics.md`` keeps the figures.

Work arrays are rows of one ``(7, n)`` array to keep the call overhead low:
``G_ = 0`` gap ``g``, ``GS = 1`` gap restricted to the contact set, ``T = 2`` CG direction
``t``, ``TR = 3`` unclipped trial pressure, ``4`` and ``5`` the current and the new
pressure (they swap roles each iteration), ``W = 6`` the displacement ``w = K p``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

G_, GS, T, TR, W = 0, 1, 2, 3, 6


@njit(cache=True, nogil=True)
def cg_direction(work, hs, ip, fin, delta, G_old):  # pragma: no cover - compiled
    """Gap, its contact-set mean removed, and the new conjugate direction.

    Writes ``t`` also into ``fin[:n]`` (the FFT input; ``fin[n:]`` stays zero).
    Returns ``(nS, G)``: contact-set size and ``sum_S g^2``.
    """
    n = hs.size
    p = work[ip]
    w = work[W]
    g = work[G_]
    gS = work[GS]
    t = work[T]
    nS = 0
    sg = 0.0
    for i in range(n):
        gi = w[i] - hs[i]
        g[i] = gi
        if p[i] > 0.0:
            nS += 1
            sg += gi
    mean = sg / nS
    G = 0.0
    for i in range(n):
        gi = g[i] - mean
        g[i] = gi
        if p[i] > 0.0:
            gS[i] = gi
            G += gi * gi
        else:
            gS[i] = 0.0
    if G == 0.0:
        return nS, G
    beta = delta * G / G_old
    for i in range(n):
        if p[i] > 0.0:
            ti = t[i] * beta + gS[i]
        else:
            ti = 0.0
        t[i] = ti
        fin[i] = ti
    return nS, G


@njit(cache=True, nogil=True)
def cg_step(  # pragma: no cover - compiled
    work, ip, inew, r, kfull, idx, nS, P, dx, since_refresh, sparse_max, refresh_every
):
    """Step along ``t`` given ``r = K t``: clip, add overlap pressure, rescale to the load.

    Returns ``(status, delta, err, refreshed_needed, since_refresh)``; status 0: step
    done; 1: ``t^T K t <= 0`` (lost conjugacy); 2: no pressure left. When the number of
    clipped plus overlap cells is at most ``sparse_max`` (and the displacement was
    refreshed less than ``refresh_every`` steps ago) ``w`` is updated incrementally,
    column by column; otherwise ``refresh_needed`` is 1 and the caller recomputes
    ``w = K p_new`` by FFT.
    """
    n = r.size
    c0 = (kfull.size - 1) // 2  # kfull[c0 + d] = K(|d|); n may be a window of the grid
    p = work[ip]
    pn = work[inew]
    t = work[T]
    g = work[G_]
    gS = work[GS]
    trial = work[TR]
    w = work[W]
    rt = 0.0
    rs = 0.0
    ts = 0.0
    gt = 0.0
    for i in range(n):
        rt += r[i] * t[i]
        if p[i] > 0.0:
            rs += r[i]
            ts += t[i]
            gt += gS[i] * t[i]
    den = rt - rs / nS * ts
    if not den > 0.0:
        return 1, 0.0, np.inf, 0, since_refresh
    tau = gt / den
    ncorr = 0
    nol = 0
    m = idx.size // 2
    ssum = 0.0
    for i in range(n):
        tr = p[i] - tau * t[i]
        trial[i] = tr
        v = tr if tr > 0.0 else 0.0
        if tr < 0.0:
            if ncorr < m:
                idx[ncorr] = i
            ncorr += 1
        if v == 0.0 and g[i] < 0.0:
            # Overlap: out of contact but penetrating -> add pressure there.
            v = -tau * g[i]
            if nol < m:
                idx[m + nol] = i
            nol += 1
        pn[i] = v
        ssum += v
    delta = 0.0 if nol > 0 else 1.0
    if not ssum > 0.0:
        return 2, delta, np.inf, 0, since_refresh
    scale = P / (ssum * dx)
    since_refresh += 1
    refresh = 1
    if ncorr + nol <= sparse_max and since_refresh < refresh_every:
        refresh = 0
        for i in range(n):
            w[i] -= tau * r[i]
        for c in range(ncorr):  # clipped cells: from trial to 0
            j = idx[c]
            a = trial[j]
            o = c0 - j
            for i in range(n):
                w[i] -= a * kfull[o + i]
        for c in range(nol):  # overlap cells: from 0 (after clipping) to their pressure
            j = idx[m + c]
            a = pn[j]
            o = c0 - j
            for i in range(n):
                w[i] += a * kfull[o + i]
        for i in range(n):
            w[i] *= scale
    err = 0.0
    for i in range(n):
        v = pn[i] * scale
        pn[i] = v
        err += abs(v - p[i])
    return 0, delta, err * dx / P, refresh, since_refresh


@njit(cache=True, nogil=True)
def contact_regions(x, p, gap, tol, mech, geom):  # pragma: no cover - compiled
    """Mechanical (``p > 0``) and geometric (``gap <= tol``) regions of one solution.

    The same arithmetic as :func:`.solution._mechanical_regions` and
    :func:`.solution.regions_within_gap` (cell-edge intervals; ends of the geometric ones
    interpolated linearly at ``gap = tol``), written into ``mech`` and ``geom``
    (``(n // 2 + 1, 2)`` each); returns their numbers of rows. One compiled pass instead
    of ~20 numpy calls per sweep position (its share of a position's time:
    ``docs/mechanics.md``).
    """
    n = x.size
    dx = x[1] - x[0]
    km = 0
    kg = 0
    inm = False
    ing = False
    for i in range(n):
        pm = p[i] > 0.0
        if pm and not inm:
            mech[km, 0] = x[i] - dx / 2
        elif inm and not pm:
            mech[km, 1] = x[i - 1] + dx / 2
            km += 1
        inm = pm
        pg = gap[i] <= tol
        if pg and not ing:
            if i > 0:
                g0 = gap[i - 1]
                g1 = gap[i]
                geom[kg, 0] = x[i - 1] + (x[i] - x[i - 1]) * (g0 - tol) / (g0 - g1)
            else:
                geom[kg, 0] = x[0]
        elif ing and not pg:
            g0 = gap[i - 1]
            g1 = gap[i]
            geom[kg, 1] = x[i - 1] + (x[i] - x[i - 1]) * (tol - g0) / (g1 - g0)
            kg += 1
        ing = pg
    if inm:
        mech[km, 1] = x[n - 1] + dx / 2
        km += 1
    if ing:
        geom[kg, 1] = x[n - 1]
        kg += 1
    return km, kg
