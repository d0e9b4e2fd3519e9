"""Plane-strain frictionless normal contact of the finger on a rigid relief, by BEM.

The finger (:class:`~fingerfriction.mechanics.finger.FingerParams`) is pressed on the
rigid relief ``h(x)`` with a normal load per unit width ``P' = F_N / D``. Unknowns: the
pressure ``p(x) >= 0`` (N/mm^2) on a uniform grid of ``n`` cells moving with the finger,
and the height ``z`` of the finger's rigid body. With ``s(u)`` the undeformed outline and
``w(x) = (K p)(x)`` the elastic displacement of the finger surface into the finger, the
deformed lower surface of the finger and the gap are::

    y_f(x) = z + s(x - x_finger) + w(x),     g(x) = y_f(x) - h(x) >= 0,
    p g = 0,   sum_i p_i dx = P'.

This is solved with the constrained conjugate gradient of Polonsky & Keer (1999),
load-controlled; the convolution ``K p`` is a linear (non-periodic) convolution evaluated
with zero padding to ``2n`` and real FFTs against a precomputed kernel spectrum.

Speed (for sweeps, see ``benchmarks/contact.py``): the vector work of each CG iteration is
fused into two compiled (numba) passes (:mod:`._cgkernels`); a warm-started solve iterates
on a window of cells around the start's contact (smaller FFTs) and checks the result on
the full grid, continuing there if a cell outside the window penetrates the surface.

Influence coefficients (piecewise-constant pressure on cells of width ``dx``, displacement
at cell centres; Johnson 1985, Eq. 2.25b)
--------------------------------------------------------------------------------------------
* half-space (``layer_thickness=None``)::

      K(x) = -(2 / (pi E*)) int_{x-dx/2}^{x+dx/2} ln(|t| / l) dt

  The 2-D half-space displacement is defined only up to a constant; we take it zero at
  the reference distance ``l = finger.radius`` from the load (the finger's bone/centre
  is the rigid reference). The constant changes only the reported rigid ``approach``,
  never the pressure, the deformed outline ``y_f`` or the gap.
* tissue layer of thickness ``t`` bonded to a rigid bone: the exact plane-strain surface
  compliance of a layer on a rigid base (frictionless top, bonded bottom)::

      W(k) / P(k) = 2 C(|k| t) / (E* |k|),
      C(q) = (2 kappa sinh 2q - 4 q) / (2 kappa cosh 2q + 1 + kappa^2 + 4 q^2),
      kappa = 3 - 4 nu,

  which tends to the half-space for ``q -> inf`` and to the confined (oedometric) layer
  ``t (1+nu)(1-2nu) / (E (1-nu))`` for ``q -> 0`` (checked in the tests; for ``nu = 0.5``
  it is the incompressible thin-layer law ``t^3 k^2 / E``). The displacement then has an
  absolute reference (zero far away). Its influence coefficients are the analytic cell
  integral of ``(1/(pi E*)) ln(1 + t^2/x^2)`` (the transform of ``2(1 - e^{-|k| t})/(E*|k|)``)
  plus a smooth remainder whose spectrum decays like ``e^{-2|k|t}``, summed by a long FFT.

* stiff skin sheet (modulus ``E_s``, thickness ``h_s``, bending stiffness ``B = E_s h_s^3
  / 12``) on the half-space pulp: a plate on an elastic foundation (Biot 1937) whose
  bending term saturates into a half-space of the skin's modulus at wavelengths shorter
  than the sheet (thin-plate theory holds only for ``|k| h_s << 1``)::

      W(k) / P(k) = 1 / (E* |k| / 2 + s(k)),   s(k) = B k^4 (E_s |k| / 2) / (B k^4 + E_s |k| / 2)

  so ``W/P ~ 2 / (E* |k|)`` at long wavelengths (soft pulp: the same log far field and
  reference ``l`` as the half-space), ``1 / (B k^4)`` at intermediate ones (the skin
  resists bending into short concave features), and ``2 / ((E* + E_s) |k|)`` at the
  shortest. Coefficients: with ``c = 4 dx``, the analytic cell integrals of the half-space
  ``E*`` kernel minus ``(1/(pi E*)) ln(1 + c^2/x^2)`` plus ``(1/(pi (E* + E_s))) ln(1 +
  c^2/x^2)``, and the FFT sum of the remainder spectrum (finite at ``k = 0``, decaying like
  ``k^-4``) times the cell factor ``S(k) = 2 sin(k dx / 2) / k``.

References
----------
1. I. A. Polonsky, L. M. Keer, "A numerical method for solving rough contact problems
   based on the multi-level multi-summation and conjugate gradient techniques",
   Wear 231 (1999) 206-219.
2. K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985.
4. M. A. Biot, "Bending of an infinite beam on an elastic foundation", J. Appl. Mech.
   4 (1937) A1-A7.
3. H. M. Stanley, T. Kato, "An FFT-based method for rough surface contact",
   J. Tribol. 119 (1997) 481-485 (zero padding for non-periodic contact).
"""

from __future__ import annotations

import logging
import math

import numpy as np
import scipy.fft as sfft
from scipy import fftpack

from ..surfaces import Surface
from . import _cgkernels as _cg
from .finger import FingerParams
from .hertz import hertz_half_width
from .kernels import halfspace_kernel, layer_kernel, skin_kernel
from .solution import ContactSolution

__all__ = [
    "GEOMETRIC_TOL",
    "ContactSolution",
    "ContactSolver",
    "solve_contact",
]

log = logging.getLogger(__name__)

try:  # pocketfft's packed real FFT without the public wrapper (see _Convolver)
    from scipy.fft._pocketfft.pypocketfft import r2r_fftpack as _r2r
except ImportError:  # pragma: no cover - private scipy API moved
    _r2r = None
_AXES = (0,)

_SPARSE = 24  # up to this many corrected cells, update K p column by column (cheaper than FFT)
_MARGIN = 32  # cells beyond a warm start's contact in the CG window (ContactSolver._pk)

#: The paper's contact criterion: contour points within 3 px (about 70 um) are in contact.
GEOMETRIC_TOL = 0.070


# ------------------------------------------------------------------------------ solver
def check_load(load) -> float:
    """``load`` as a float: a finite positive normal force in N (TypeError, ValueError otherwise)."""
    if isinstance(load, bool) or not isinstance(load, (int, float, np.integer, np.floating)):
        raise TypeError(f"load must be a normal force in N, got {load!r}")
    F = float(load)
    if not math.isfinite(F) or F <= 0:
        raise ValueError(f"load must be a finite positive normal force in N, got {load!r}")
    return F


class _Convolver:
    """Linear convolution with the kernel of a pressure on ``m`` consecutive cells.

    Zero padding to ``2m`` and pocketfft's packed real FFT. The kernel is even, so its
    spectrum is real: fftpack's packed format ([r0, r1, i1, r2, i2, ...]) then needs
    only an elementwise product with the spectrum repeated per (r, i) pair (measured
    faster than scipy.fft's complex rfft path at these sizes). Work arrays are kept
    between calls (the solver is not thread-safe).

    Calling it returns ``K f`` on the ``m`` cells for ``f = fin[:m]``, a view into a
    buffer overwritten by the next call.
    """

    def __init__(self, kj: np.ndarray, m: int):
        kk = np.zeros(2 * m)
        kk[: m + 1] = kj[: m + 1]
        kk[m + 1 :] = kj[1:m][::-1]
        spec = sfft.rfft(kk).real
        packed = np.empty(2 * m)
        packed[0] = spec[0]
        packed[1:-1:2] = spec[1:m]
        packed[2:-1:2] = spec[1:m]
        packed[-1] = spec[m]
        self.m = m
        self.kspec = packed
        self.fin = np.zeros(2 * m)  # FFT input: the upper half stays zero (padding)
        self.spec = np.empty(2 * m)
        self.fout = np.empty(2 * m)
        self.work = np.zeros((7, m))  # CG work rows, see _cgkernels

    def __call__(self) -> np.ndarray:
        if _r2r is None:
            f = fftpack.rfft(self.fin)
            f *= self.kspec
            self.fout[:] = fftpack.irfft(f, overwrite_x=True)
        else:
            # pocketfft without the public wrapper, whose argument handling cost ~4 us of
            # ~12 us per transform pair at n = 1024.
            _r2r(self.fin, _AXES, True, True, 0, self.spec, 1)
            self.spec *= self.kspec
            _r2r(self.spec, _AXES, False, False, 2, self.fout, 1)
        return self.fout[: self.m]


class ContactSolver:
    """A contact solver for one finger on one grid (kernel spectrum precomputed).

    Build it once and call :meth:`solve` for many positions/loads (what :func:`sweep`
    does); :func:`solve_contact` is the one-shot convenience wrapper.

    Parameters
    ----------
    finger : FingerParams
        The finger.
    n : int, optional
        Number of grid cells (default 2048), ``>= 64``.
    half_width : float, optional
        Half-width of the grid in mm around the finger centre; default
        ``finger.default_half_width()``: where the outline has risen 2.5 mm, at most
        ``0.98 * finger.half_extent`` (the circle's outline is defined for ``|u| < R``).

    Notes
    -----
    Grid cell ``i`` is centred at ``x_finger + u_i`` with ``u_i = -half_width + (i + 1/2)
    dx`` and ``dx = 2 half_width / n``.
    """

    def __init__(self, finger: FingerParams, *, n: int = 2048, half_width: float | None = None):
        if not isinstance(finger, FingerParams):
            raise TypeError(f"finger must be a FingerParams, got {type(finger).__name__}")
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 64:
            raise ValueError(f"n (number of grid cells) must be an integer >= 64, got {n!r}")
        n = int(n)
        hw = finger.default_half_width() if half_width is None else float(half_width)
        if not math.isfinite(hw) or hw <= 0:
            raise ValueError(f"half_width must be a positive length in mm, got {half_width!r}")
        if hw > finger.half_extent:
            raise ValueError(
                f"half_width ({hw:g} mm) exceeds the finger outline's half extent "
                f"({finger.half_extent:g} mm)"
            )
        self.finger = finger
        self.n = n
        self.half_width = hw
        self.dx = 2.0 * hw / n
        self.u = -hw + (np.arange(n) + 0.5) * self.dx
        self.outline = finger.outline(self.u)
        j = np.arange(n + 1) * self.dx
        if finger.has_skin:
            kj = skin_kernel(
                j, self.dx, finger.modulus, float(finger.skin_modulus), float(finger.skin_thickness),
                finger.radius,
            )
        elif finger.layer_thickness is None:
            kj = halfspace_kernel(j, self.dx, finger.modulus, finger.radius)
        else:
            kj = layer_kernel(j, self.dx, finger.modulus, finger.layer_thickness, finger.poisson)
        self._kj = kj
        self._full = _Convolver(kj, n)
        self._windows: dict[int, _Convolver] = {}
        # Symmetric kernel K(|i - j|) as one array: column j is kfull[n-1-j : 2n-1-j].
        self._kfull = np.concatenate([kj[1:n][::-1], kj[:n]])
        self._idx = np.empty(2 * _SPARSE, dtype=np.int64)
        self._rbuf = (np.empty((n // 2 + 1, 2)), np.empty((n // 2 + 1, 2)))  # region rows
        self.kernel0 = float(kj[0])

    # ------------------------------------------------------------------ helpers
    def displacement(self, p: np.ndarray) -> np.ndarray:
        """Elastic displacement ``w = K p`` (mm, into the finger) of the pressure ``p`` (n,)."""
        self._full.fin[: self.n] = p
        return self._full().copy()

    def grid(self, x_finger: float) -> np.ndarray:
        """Cell centres in mm (surface coordinates) for a finger at ``x_finger``."""
        return x_finger + self.u

    def check_resolution(self, load: float) -> None:
        """Raise ``ValueError`` if the grid is too coarse for the flat-ground contact."""
        P = self.finger.load_per_width(load)
        R = self.finger.tip_radius
        a = hertz_half_width(P, R if math.isfinite(R) else self.finger.radius, self.finger.modulus)
        if a < 8.0 * self.dx:
            raise ValueError(
                f"grid too coarse for the contact: the Hertz half-width at {load:g} N is "
                f"{a:.4g} mm but the cell size is {self.dx:.4g} mm (need >= 8 cells per "
                f"half-width); increase n (now {self.n}) or decrease half_width"
            )
        # A contact wider than the grid is reported after the solve (success=False):
        # the Hertz estimate is too crude for non-circular outlines to decide it here.

    # ------------------------------------------------------------------ solve
    def solve(
        self,
        surface,
        x_finger: float,
        *,
        load: float = 0.3,
        x0=None,
        tol: float = 1e-8,
        max_iter: int = 1000,
        gap_tol: float = GEOMETRIC_TOL,
        check: bool = True,
    ) -> ContactSolution:
        """Solve the contact for the finger centred at ``x_finger``.

        Parameters
        ----------
        surface : Surface or callable
            The relief: a :class:`~fingerfriction.surfaces.Surface` or a function
            ``h(x)`` (mm -> mm).
        x_finger : float
            Finger centre in mm (surface coordinates).
        load : float, optional
            Normal force ``F_N`` in N (default 0.3 N, the paper's prescribed force).
        x0 : ContactSolution or (n,) ndarray, optional
            Warm start: a previous solution (its pressure is used on the same finger-frame
            cells) or an initial pressure (n,) in MPa.
        tol : float, optional
            Convergence tolerance on ``dx sum |p - p_old| / P'`` (default 1e-8).
        max_iter : int, optional
            Maximum conjugate-gradient iterations (default 1000).
        gap_tol : float, optional
            Gap (mm) below which a point is in geometric contact (default 0.070 mm).
        check : bool, optional
            Check the grid resolution against the Hertz half-width (default True).

        Returns
        -------
        ContactSolution
            ``success=False`` with a message when the iteration did not converge.
        """
        F = check_load(load)
        x_finger = float(x_finger)
        if not math.isfinite(x_finger):
            raise ValueError(f"x_finger must be a finite position in mm, got {x_finger!r}")
        if not (math.isfinite(gap_tol) and gap_tol >= 0):
            raise ValueError(f"gap_tol must be a length >= 0 in mm, got {gap_tol!r}")
        if check:
            self.check_resolution(F)
        x = self.grid(x_finger)
        hfun = surface.h if isinstance(surface, Surface) else surface
        if not callable(hfun):
            raise TypeError(f"surface must be a Surface or a callable h(x), got {type(surface).__name__}")
        h = np.asarray(hfun(x), dtype=float)
        if h.shape != x.shape:
            raise ValueError(f"surface h(x) returned shape {h.shape}, expected {x.shape}")
        if not np.all(np.isfinite(h)):
            i = int(np.flatnonzero(~np.isfinite(h))[0])
            raise ValueError(f"surface height is not finite at x = {x[i]:.6g} mm (h = {h[i]!r})")
        P = F / self.finger.width
        p0 = None
        if x0 is not None:
            p0 = np.asarray(x0.pressure if isinstance(x0, ContactSolution) else x0, dtype=float)
            if p0.shape != (self.n,) or not np.all(np.isfinite(p0)) or p0.sum() <= 0:
                log.warning("warm start ignored: expected a finite non-negative (n,) pressure with load")
                p0 = None
        p, w, z, it, err, conv = self._pk(h - self.outline, P, p0, tol, max_iter)
        return self._finish(x, h, p, w, z, it, err, conv, F, P, gap_tol, x_finger, max_iter)

    def _pk(self, hs: np.ndarray, P: float, p0, tol: float, max_iter: int):
        """Polonsky-Keer constrained CG, load controlled. ``hs = h - s`` (mm).

        Returns ``(p, w, z, iterations, residual, converged)``.

        With a warm start the CG runs on a window of cells around the start's contact
        (``_MARGIN`` cells beyond it on each side, rounded up to a fast FFT length): the
        pressure is zero outside it, so the convolutions of the iteration shrink to the
        window. The result is then checked on the full grid: if any cell outside the
        window penetrates the surface, the window solution is not the full problem's
        and the CG continues from it on the full grid. When there is no penetration
        outside, the window solution satisfies all the full problem's conditions
        (``p >= 0``, ``g >= 0``, ``p g = 0``, load), so it is that (unique) solution.
        """
        n, dx = self.n, self.dx
        hs = np.ascontiguousarray(hs, dtype=float)
        if p0 is None:
            # Start from a patch around the highest points of h - s.
            top = hs.max()
            mask = hs >= top - 0.5 * (top - np.median(hs)) - 1e-12
            p = np.where(mask, 1.0, 0.0)
        else:
            p = np.clip(p0, 0.0, None)
        p *= P / (p.sum() * dx)
        it_used = 0
        if p0 is not None:
            nz = np.flatnonzero(p > 0)
            # A 5-smooth window length: cheap FFTs without doubling to a power of two
            # (two contacts far apart, e.g. a bump meeting the finger's rising edge,
            # span more than half the grid: measured 1.7x fewer FFT flops there).
            m = sfft.next_fast_len(int(nz[-1] - nz[0] + 1 + 2 * _MARGIN), real=True)
            if m < n:
                i0 = min(max((nz[0] + nz[-1] + 1 - m) // 2, 0), n - m)
                conv = self._windows.get(m)
                if conv is None:
                    conv = self._windows[m] = _Convolver(self._kj, m)
                pw, _, it_used, err = self._cg(
                    conv, hs[i0 : i0 + m], P, p[i0 : i0 + m], tol, max_iter, final_w=False
                )
                p = np.zeros(n)
                p[i0 : i0 + m] = pw
                w = self.displacement(p)
                g = w - hs
                S = p > 0
                z = -float(g[S].mean())
                g += z
                if err >= tol:
                    log.debug("window [%d, %d) did not converge: continuing on the full grid", i0, i0 + m)
                elif g[:i0].min(initial=0.0) >= 0.0 and g[i0 + m :].min(initial=0.0) >= 0.0:
                    return p, w, z, it_used, err, True
                else:
                    log.debug("window [%d, %d) penetrated outside: continuing on the full grid", i0, i0 + m)
        p, w, it, err = self._cg(self._full, hs, P, p, tol, max(max_iter - it_used, 1))
        g = w - hs
        S = p > 0
        z = -float(g[S].mean()) if S.any() else -float(g.min())
        return p, w, z, it + it_used, err, err < tol

    def _cg(
        self, conv: _Convolver, hs: np.ndarray, P: float, p: np.ndarray, tol: float, max_iter: int,
        final_w: bool = True,
    ):
        """The CG iterations on the ``m`` cells of ``conv`` from the pressure ``p`` (m,).

        Returns ``(p, w, iterations, residual)``; ``w`` is None unless ``final_w``.
        The displacement ``w = K p`` is updated
        incrementally: ``p`` changes by ``-tau t`` (whose image ``K t`` the CG step
        computes anyway) plus a few clipped/overlap cells, added column by column when
        there are at most ``_SPARSE`` of them, else ``K p`` is recomputed by FFT. This
        halves the FFTs per iteration (the speed-up: ``docs/mechanics.md``). The
        vector work of each iteration runs in two compiled passes (:mod:`._cgkernels`).
        """
        m, dx = conv.m, self.dx
        work, fin = conv.work, conv.fin
        ip, inew = 4, 5
        work[ip] = p
        work[_cg.T] = 0.0
        fin[:m] = p
        work[_cg.W] = conv()
        kfull, idx = self._kfull, self._idx
        sparse_max = min(_SPARSE, idx.size // 2)
        delta = 0.0
        G_old = 1.0
        err = math.inf
        it = 0
        since_refresh = 0
        direction, step = _cg.cg_direction, _cg.cg_step
        while it < max_iter:
            it += 1
            nS, G = direction(work, hs, ip, fin, delta, G_old)
            if G == 0.0:
                err = 0.0
                break
            G_old = G
            r = conv()
            status, new_delta, e, refresh, since_refresh = step(
                work, ip, inew, r, kfull, idx, nS, P, dx, since_refresh, sparse_max, 50
            )
            if status == 1 and delta != 0.0:
                # Lost conjugacy (round-off on ill-conditioned kernels): restart from the
                # steepest-descent direction rather than stopping.
                work[_cg.T] = work[_cg.GS]
                fin[:m] = work[_cg.GS]
                r = conv()
                status, new_delta, e, refresh, since_refresh = step(
                    work, ip, inew, r, kfull, idx, nS, P, dx, since_refresh, sparse_max, 50
                )
            if status != 0:
                break
            delta = new_delta
            err = e
            if refresh:
                fin[:m] = work[inew]
                work[_cg.W] = conv()
                since_refresh = 0
            ip, inew = inew, ip
            if err < tol:
                break
        p = work[ip].copy()
        if not final_w:
            return p, None, it, err
        # The incrementally updated w drifts by round-off only; recompute it once.
        fin[:m] = p
        return p, conv().copy(), it, err

    def _finish(self, x, h, p, w, z, it, err, conv, F, P, gap_tol, x_finger, max_iter) -> ContactSolution:
        yf = z + self.outline + w
        gap = yf - h
        gap_c = np.where(p > 0, 0.0, gap)
        pen = float(max(0.0, -gap_c.min()))
        load_error = abs(p.sum() * self.dx - P) / P
        approach = float(np.max(h - self.outline)) - z
        # Compiled equivalent of _mechanical_regions and regions_within_gap (tested equal).
        rm, rg = self._rbuf
        km, kg = _cg.contact_regions(x, p, np.maximum(gap_c, 0.0), float(gap_tol), rm, rg)
        mech, geom = rm[:km].copy(), rg[:kg].copy()
        success = bool(conv)
        if conv:
            msg = f"converged in {it} iterations (residual {err:.2e})"
        else:
            msg = (
                f"did not converge: residual {err:.2e} after {it} iterations (max_iter={max_iter}); "
                "the pressure may be wrong"
            )
        if success and (p[0] > 0 or p[-1] > 0):
            success = False
            msg = (
                "contact reaches the edge of the grid: widen half_width or reduce the load "
                f"(grid half-width {self.half_width:g} mm)"
            )
        scale = max(abs(h).max(), self.outline.max(), 1e-9)
        if success and pen > 1e-6 * scale + 1e-9:
            log.debug("penetration %.3g mm after convergence", pen)
        return ContactSolution(
            x=x, pressure=p, gap=gap_c, finger_y=yf, surface_h=h, x_finger=x_finger, load=F,
            load_per_width=P, z=z, approach=approach, mechanical_regions=mech,
            geometric_regions=geom, gap_tol=float(gap_tol), iterations=it, residual=err,
            max_penetration=pen, load_error=float(load_error), success=success, message=msg,
            finger=self.finger,
        )


def solve_contact(
    surface,
    finger: FingerParams,
    x_finger: float,
    *,
    load: float = 0.3,
    n: int = 2048,
    half_width: float | None = None,
    x0=None,
    tol: float = 1e-8,
    max_iter: int = 1000,
    gap_tol: float = GEOMETRIC_TOL,
) -> ContactSolution:
    """Contact of ``finger`` centred at ``x_finger`` on ``surface`` under ``load``.

    One-shot wrapper of :class:`ContactSolver` (build the solver yourself to solve many
    positions without recomputing the kernel). Parameters as in
    :meth:`ContactSolver.solve` and :class:`ContactSolver`.

    Examples
    --------
    >>> from fingerfriction import get_surface
    >>> from fingerfriction.mechanics import SUBJECTS, solve_contact
    >>> sol = solve_contact(get_surface("bump-4mm"), SUBJECTS[1], x_finger=-3.0)
    >>> sol.success, sol.mechanical_regions.shape[1]
    (True, 2)
    """
    solver = ContactSolver(finger, n=n, half_width=half_width)
    return solver.solve(
        surface, x_finger, load=load, x0=x0, tol=tol, max_iter=max_iter, gap_tol=gap_tol
    )
