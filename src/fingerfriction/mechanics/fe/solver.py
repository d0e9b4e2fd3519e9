"""Large-deformation plane-strain contact of the layered finger on a rigid relief (FE).

The finger (:class:`~.params.FEFingerParams`) is meshed with 9-node quadrilaterals
(:mod:`.mesh`, scikit-fem's ``ElementQuad2``: quadratic displacements, which keep the
nearly incompressible tissue free of the locking of linear elements). Each tissue is a
compressible neo-Hookean solid in plane strain (``F_33 = 1``)::

    W(F) = mu/2 (F:F + 1 - 3) - mu ln J + lam/2 (ln J)^2,     J = det F,
    P = dW/dF = mu (F - F^-T) + lam ln J F^-T

(Bonet & Wood 2008, Eq. 6.28; ``mu``, ``lam`` the small-strain Lame constants, so at small
strains it is linear elasticity with the same ``E`` and ``nu``). The bone is rigid: its
nodes move with the finger as one body, horizontally to the prescribed finger position
``x_c`` and vertically by the unknown height ``z``, which the normal load fixes.

Contact with the rigid relief ``h(x)`` is a penalty on the vertical gap of the outline's
nodes, ``d_i = y_i - h(x_i)``, with the nodal (Lobatto) weights ``w_i`` of the quadratic
edges (1/6, 2/3, 1/6 of an edge's length)::

    Pi(u, z) = int W dV + sum_i (k/2) w_i min(d_i, 0)^2 + P' z

whose stationary point balances the contact forces with the load per unit width
``P' = F_N / D``. Frictionless: a node in contact is pushed along ``(-h'(x), 1)``, the
relief's normal. Newton's method on ``(u, z)`` with the consistent tangent (including the
relief's curvature ``h''`` where it stiffens the contact; where it would soften it, on a
convex crest, the term is left out so that the tangent stays positive definite) and a
backtracking line search on ``Pi`` (which also rejects steps that invert an element); a
cold start ramps the load, a sweep starts each position from the previous one, and a move
from the previous one that fails is solved again from a cold start.

Assembly: scikit-fem provides the mesh, the quadratic element, the quadrature and the
degree-of-freedom maps; the element residuals and tangents of the neo-Hookean law are
evaluated by vectorised numpy over all elements at once and summed into a fixed sparse
pattern (faster than scikit-fem's generic form assembly for this law, ``docs/mechanics-fe.md``;
``tests/mechanics/test_fe.py`` checks the two agree).

References
----------
1. J. Bonet, R. D. Wood, *Nonlinear Continuum Mechanics for Finite Element Analysis*,
   2nd ed., Cambridge University Press, 2008.
2. P. Wriggers, *Computational Contact Mechanics*, 2nd ed., Springer, 2006 (penalty
   node-to-surface contact, Ch. 5).
3. T. Gustafsson, G. D. McBain, "scikit-fem: A Python package for finite element
   assembly", J. Open Source Softw. 5 (2020) 2369.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ...surfaces import Surface
from .mesh import FingerMesh, build_mesh
from .params import FEFingerParams, FEMeshParams
from .solution import FESolution, FEState

__all__ = ["FEContactSolver", "FESolution"]

log = logging.getLogger(__name__)


def _surface_funcs(surface):
    """``(h, h', h'')`` callables of a Surface (finite differences where it has no d2hdx2)."""
    if isinstance(surface, Surface):
        h, dh = surface.h, surface.dhdx
        d2 = getattr(surface, "d2hdx2", None)
        if d2 is None:
            def d2(x, _dh=dh, e=1e-4):
                return (np.asarray(_dh(np.asarray(x) + e)) - np.asarray(_dh(np.asarray(x) - e))) / (2 * e)
        return h, dh, d2
    if callable(surface):
        def dh(x, e=1e-5):
            return (np.asarray(surface(np.asarray(x) + e)) - np.asarray(surface(np.asarray(x) - e))) / (2 * e)

        def d2(x, e=1e-4):
            x = np.asarray(x)
            h0, hp, hm = (np.asarray(surface(v)) for v in (x, x + e, x - e))
            return (hp - 2 * h0 + hm) / (e * e)
        return surface, dh, d2
    raise TypeError(f"surface must be a Surface or a callable h(x), got {type(surface).__name__}")


class FEContactSolver:
    """Contact solver for one finger and mesh (build once, solve many positions).

    Parameters
    ----------
    finger : FEFingerParams
    mesh : FEMeshParams, optional
        Resolution (default :class:`FEMeshParams`).

    Examples
    --------
    >>> from fingerfriction import get_surface
    >>> from fingerfriction.mechanics.fe import FEContactSolver, LITERATURE_FINGER, FEMeshParams
    >>> s = FEContactSolver(LITERATURE_FINGER, FEMeshParams(surface_cell=0.4))
    >>> sol = s.solve(get_surface("bump-4mm"), -3.0, load=0.3)
    >>> sol.success
    True
    """

    def __init__(self, finger: FEFingerParams, mesh: FEMeshParams | None = None):
        import skfem  # only when a solver is built: the package imports without it

        if not isinstance(finger, FEFingerParams):
            raise TypeError(f"finger must be an FEFingerParams, got {type(finger).__name__}")
        self.finger = finger
        self.mesh_params = mesh or FEMeshParams()
        fm: FingerMesh = build_mesh(finger, self.mesh_params)
        self.fmesh = fm
        m = skfem.MeshQuad(fm.p, fm.t)
        sb = skfem.Basis(m, skfem.ElementQuad2(), intorder=4)
        self.skmesh, self.sbasis = m, sb
        self.n_dof = 2 * sb.N
        sd = sb.element_dofs  # (9, nel) scalar dofs
        self._sd = sd
        self._dphi = np.stack([sb.basis[a][0].grad for a in range(sd.shape[0])])  # (9, 2, nel, nq)
        self._dx = np.asarray(sb.dx)  # (nel, nq)
        E = np.array([finger.tissue_modulus, finger.skin_modulus, finger.nail_modulus])[fm.material]
        nu = finger.poisson
        self._mu = (E / (2 * (1 + nu)))[:, None] * np.ones_like(self._dx)
        self._lam = (E * nu / ((1 + nu) * (1 - 2 * nu)))[:, None] * np.ones_like(self._dx)
        self._build_pattern()
        self._boundary()
        self._finish_pattern()
        self.stats = {"lu": 0, "cg": 0}
        # reusing the last LU factors as a CG preconditioner measured no faster (0.39 s a
        # position either way on Step Up 2 mm): off, a fresh factorisation per iteration
        self.reuse_factors = False
        self.cg_maxiter = 15
        self.max_step = 0.05  # mm: largest nodal move of one Newton step
        self.max_split = 3  # a failed move is split in two at most this deep
        # the displacement-controlled predictor runs when the move pushes the outline more
        # than this far (mm) into the relief (measured: it halves the failures where a
        # feature enters the contact, and costs ~1 iteration a position elsewhere)
        self.pin_above = 0.005
        # Newton's contact tangent leaves out the relief's curvature term where it is a
        # negative stiffness (a node pressed onto a convex crest, h'' < 0): with it the
        # tangent is indefinite there, the Newton direction stops being a descent direction
        # and the line search stalls. The residual, hence the equilibrium, is unchanged.
        # Measured (Bump 2 mm, finger seed 6414's subject 1, coarse mesh, 120 positions every
        # 0.1 mm, frictionless): 17 unconverged in 44 s CPU with the exact tangent, 0 in 7.5 s
        # with this scheme and solve()'s cold restarts. Near the solution (residual below
        # exact_below, where plain Newton steps are taken) the exact tangent is used, for
        # quadratic convergence (the modified one stalled at 1.8e-6 > tol on a cold start
        # there). True: always exact.
        self.exact_tangent = False
        self.exact_below = 1e-3
        self.z_ref = 0.0

    # ------------------------------------------------------------------ set-up
    def _build_pattern(self) -> None:
        sd = self._sd
        nl, nel = sd.shape
        g = (2 * sd[:, None, :] + np.arange(2)[None, :, None]).reshape(2 * nl, nel)  # (18, nel), a-major
        self._gdof = g
        rows = np.broadcast_to(g[:, None, :], (2 * nl, 2 * nl, nel)).transpose(2, 0, 1).ravel()
        cols = np.broadcast_to(g[None, :, :], (2 * nl, 2 * nl, nel)).transpose(2, 0, 1).ravel()
        self._el_rows, self._el_cols = rows, cols

    def _finish_pattern(self) -> None:
        """The sparse pattern of the tangent (elements + contact couplings with ``z``),
        restricted to the unknowns once, so that each iteration only fills values."""
        N = self.n_dof + 1
        cs = self._cs
        zc = np.full(cs.size, self.n_dof)
        cr = np.concatenate([2 * cs, 2 * cs + 1, zc, zc, [self.n_dof]])
        cc = np.concatenate([zc, zc, 2 * cs, 2 * cs + 1, [self.n_dof]])
        key = np.concatenate([self._el_rows.astype(np.int64) * N + self._el_cols,
                              cr.astype(np.int64) * N + cc])
        uk, inv = np.unique(key, return_inverse=True)
        self._keys = uk
        self._zz = int(np.searchsorted(uk, np.int64(self.n_dof) * N + self.n_dof))
        self._inv = inv[: self._el_rows.size]
        self._nnz = uk.size
        pr, pc = uk // N, uk % N
        newidx = np.full(N, -1)
        newidx[self._free] = np.arange(self._free.size)
        keep = (newidx[pr] >= 0) & (newidx[pc] >= 0)
        self._sel = np.flatnonzero(keep)
        A = sp.csc_matrix((np.arange(1, self._sel.size + 1, dtype=float),
                           (newidx[pr[keep]], newidx[pc[keep]])), shape=(self._free.size,) * 2)
        A.sort_indices()
        self._red_order = self._sel[A.data.astype(np.int64) - 1]  # CSC data order -> full data index
        self._red = A
        self._lu = None

    def _reduced(self, data: np.ndarray) -> sp.csc_matrix:
        A = self._red.copy()
        A.data = data[self._red_order]
        return A

    def _boundary(self) -> None:
        fm, m = self.fmesh, self.skmesh
        n_th = fm.outer.size
        fac = m.facets  # (2, nf) sorted node pairs
        lookup = {(int(a), int(b)): k for k, (a, b) in enumerate(fac.T)}
        nn = m.p.shape[1]
        pts = []
        # outline points in CCW order: node i, then the mid-edge dof of (i, i+1)
        for i in range(n_th):
            a, b = int(fm.outer[i]), int(fm.outer[(i + 1) % n_th])
            f = lookup[(min(a, b), max(a, b))]
            pts += [a, nn + f]
        pts = np.array(pts)
        # scalar dof of a mid-edge point: skfem numbers facet dofs after the nodes
        X = self.sbasis.doflocs[:, pts]
        corners = X[:, ::2]
        L = np.linalg.norm(np.roll(corners, -1, axis=1) - corners, axis=0)  # edge i: corner i -> i+1
        w = np.zeros(pts.size)
        w[1::2] = 2.0 * L / 3.0
        w[::2] = (L + np.roll(L, 1)) / 6.0
        lower = X[1] < self.finger.semi_height - 1e-9
        # lower half, ordered left to right (CCW from the bottom: right half first)
        idx = np.flatnonzero(lower)
        order = np.argsort(X[0, idx])
        idx = idx[order]
        self._cs = pts[idx]  # scalar dofs of the contact points
        self._cX = X[:, idx]
        self._cw = w[idx]
        # reference arc length along the (sorted) contact points, for the local stretch
        self._cs_ref = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(self._cX, axis=1), axis=0))])
        bone_nodes = fm.bone
        bone_f = [lookup[(min(int(a), int(b)), max(int(a), int(b)))]
                  for a, b in zip(bone_nodes, np.roll(bone_nodes, -1), strict=True)]
        bone_s = np.concatenate([bone_nodes, nn + np.array(bone_f)])
        fixed = np.concatenate([2 * bone_s, 2 * bone_s + 1])
        free = np.setdiff1d(np.arange(self.n_dof), fixed)
        self._free = np.concatenate([free, [self.n_dof]])  # z is the last unknown

    # ------------------------------------------------------------------ element kernels
    def _kinematics(self, u: np.ndarray):
        ue = u[self._gdof].reshape(self._sd.shape[0], 2, -1)  # (9, 2, nel)
        G = np.einsum("aie,ajeq->ijeq", ue, self._dphi)
        F = G + np.eye(2)[:, :, None, None]
        J = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
        return F, J

    def energy(self, u: np.ndarray) -> float:
        """Strain energy per unit width (N mm / mm), ``inf`` if an element is inverted."""
        F, J = self._kinematics(u)
        if np.any(J <= 0):
            return math.inf
        lnJ = np.log(J)
        mu, lam = self._mu, self._lam
        W = 0.5 * mu * (np.einsum("ijeq,ijeq->eq", F, F) - 2.0) - mu * lnJ + 0.5 * lam * lnJ**2
        return float(np.sum(W * self._dx))

    def _internal(self, u: np.ndarray, tangent: bool = True):
        """Internal force (n_dof,) and the tangent data (CSR values on the pattern)."""
        F, J = self._kinematics(u)
        if np.any(J <= 0):
            raise FloatingPointError("inverted element")
        lnJ = np.log(J)
        inv = 1.0 / J
        FiT = np.empty_like(F)  # F^-T
        FiT[0, 0] = F[1, 1] * inv
        FiT[1, 1] = F[0, 0] * inv
        FiT[0, 1] = -F[1, 0] * inv
        FiT[1, 0] = -F[0, 1] * inv
        mu, lam, dx = self._mu, self._lam, self._dx
        P = mu * (F - FiT) + lam * lnJ * FiT
        re = np.einsum("ijeq,ajeq,eq->aie", P, self._dphi, dx)  # (9, 2, nel)
        fint = np.bincount(self._gdof.ravel(), weights=re.reshape(-1, re.shape[-1]).ravel(),
                           minlength=self.n_dof + 1)
        if not tangent:
            return fint, None
        nl, nel, nq = self._dphi.shape[0], dx.shape[0], dx.shape[1]
        g = np.einsum("ijeq,ajeq->eaiq", FiT, self._dphi).reshape(nel, 2 * nl, nq)  # F^-T grad phi_a
        c1 = (mu - lam * lnJ) * dx
        lw = lam * dx
        Ke = np.matmul(g, (g * lw[:, None, :]).transpose(0, 2, 1))  # lam g_a[i] g_b[k]
        T2 = np.matmul(g, (g * c1[:, None, :]).transpose(0, 2, 1)).reshape(nel, nl, 2, nl, 2)
        Ke = Ke.reshape(nel, nl, 2, nl, 2) + T2.transpose(0, 1, 4, 3, 2)  # c1 g_a[k] g_b[i]
        dp = self._dphi.transpose(2, 0, 1, 3).reshape(nel, nl, 2 * nq)
        M = np.matmul(dp, (dp * np.tile(mu * dx, (1, 2))[:, None, :]).transpose(0, 2, 1))
        Ke[:, :, 0, :, 0] += M
        Ke[:, :, 1, :, 1] += M
        vals = np.bincount(self._inv, weights=Ke.ravel(), minlength=self._nnz)
        return fint, vals

    # ------------------------------------------------------------------ contact
    def _contact(self, u, z, x_c, hf, tangent=True):
        """Penalty contact: energy, force (n_dof + 1,) and tangent triplets."""
        h, dh, d2 = hf
        k = self.mesh_params.penalty
        cs = self._cs
        x = self._cX[0] + u[2 * cs] + x_c
        y = self._cX[1] + u[2 * cs + 1] + z
        d = y - np.asarray(h(x), float)
        act = d < 0
        e = float(0.5 * k * np.sum(self._cw[act] * d[act] ** 2))
        f = np.zeros(self.n_dof + 1)
        if not act.any():
            return e, f, None, d
        ia = np.flatnonzero(act)
        s = np.asarray(dh(x[ia]), float)
        kw = k * self._cw[ia]
        kd = kw * d[ia]
        dofx, dofy = 2 * cs[ia], 2 * cs[ia] + 1
        np.add.at(f, dofx, -kd * s)
        np.add.at(f, dofy, kd)
        f[self.n_dof] += kd.sum()
        if not tangent:
            return e, f, None, d
        c = np.asarray(d2(x[ia]), float)
        zi = np.full(ia.size, self.n_dof)
        a = [(dofx, -s), (dofy, np.ones_like(s)), (zi, np.ones_like(s))]
        rows, cols, vals = [], [], []
        for ri, av in a:
            for ci, bv in a:
                rows.append(ri)
                cols.append(ci)
                vals.append(kw * av * bv)
        rows.append(dofx)
        cols.append(dofx)
        vals.append(-kd * c)
        key = np.concatenate(rows).astype(np.int64) * (self.n_dof + 1) + np.concatenate(cols)
        # the last ia.size entries are the curvature terms -kd c (see __init__ and _newton)
        return e, f, (np.searchsorted(self._keys, key), np.concatenate(vals), ia.size), d

    # ------------------------------------------------------------------ solve
    def initial_height(self, surface, x_c: float) -> float:
        """``z`` at which the undeformed outline first touches the relief (mm)."""
        h, _, _ = _surface_funcs(surface)
        return float(np.max(np.asarray(h(self._cX[0] + x_c), float) - self._cX[1]))

    def _linear_solve(self, A: sp.csc_matrix, b: np.ndarray) -> np.ndarray:
        """Solve ``A x = b``: conjugate gradients preconditioned by the last LU factors
        (a sweep's tangents change little between neighbouring positions), refactorising
        when they no longer help."""
        if self._lu is not None and self.reuse_factors:
            lu = self._lu
            M = spla.LinearOperator(A.shape, matvec=lu.solve, dtype=float)
            info_it = [0]

            def cb(_):
                info_it[0] += 1
            x, info = spla.cg(A, b, rtol=1e-10, atol=0.0, maxiter=self.cg_maxiter, M=M, callback=cb)
            if info == 0 and np.all(np.isfinite(x)):
                self.stats["cg"] += info_it[0]
                return x
        self._lu = spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                             options=dict(SymmetricMode=True))
        self.stats["lu"] += 1
        return self._lu.solve(b)

    def _newton(self, u, z, x_c, P, hf, tol, max_iter, pin=None, f_ext=None):
        """Newton iterations for the load ``P`` (N/mm); ``pin = z0`` holds the finger's
        height at ``z0`` with a stiff spring instead (a displacement-controlled predictor)."""
        N = self.n_dof
        kz = 1e4 * self.mesh_params.penalty
        free = self._free
        it = 0
        res = math.inf
        msg = ""
        for it in range(1, max_iter + 1):
            fint, vals = self._internal(u)
            ec, fc, trip, _ = self._contact(u, z, x_c, hf)
            r = fint + fc
            r[N] += P
            if f_ext is not None:
                r[:N] -= f_ext
            if pin is not None:
                r[N] += kz * (z - pin)
                vals[self._zz] += kz
            rf = r[free]
            res = float(np.max(np.abs(rf))) / P
            log.debug("newton %d: residual %.3e", it, res)
            if res < tol and it > 1:
                return u, z, it, res, True, f"converged in {it} Newton iterations"
            if trip is None:
                # no contact: lower the finger rigidly until the outline touches
                z = z - self._gap_min(u, z, x_c, hf) - 1e-3
                continue
            cv = trip[1]
            if not self.exact_tangent and res >= self.exact_below:  # see __init__
                cv = cv.copy()
                cv[cv.size - trip[2]:] = np.maximum(cv[cv.size - trip[2]:], 0.0)
            np.add.at(vals, trip[0], cv)
            try:
                du = -self._linear_solve(self._reduced(vals), rf)
            except RuntimeError as exc:  # singular
                return u, z, it, res, False, f"linear solve failed: {exc}"
            if not np.all(np.isfinite(du)):
                return u, z, it, res, False, "linear solve gave non-finite values"
            step = float(np.max(np.abs(du)))
            log.debug("          step %.3e (z %.3e)", step, du[-1])
            if res < tol and step < 1e-5:
                return u, z, it, res, True, f"converged in {it} Newton iterations"
            U = np.zeros(N + 1)
            alpha = min(1.0, self.max_step / step)  # damp large steps (active-set jumps)
            if res < 1e-3 and alpha == 1.0:
                # near the solution: plain Newton steps (an energy test is below round-off)
                U[free] = du
                un, zn = u + U[:N], z + U[N]
                if math.isfinite(self.energy(un)):
                    u, z = un, zn
                    continue
            # backtracking line search on the total potential
            pi0 = self.energy(u) + ec + P * z + (0.5 * kz * (z - pin) ** 2 if pin is not None else 0.0)
            if f_ext is not None:
                pi0 -= float(f_ext @ u)
            slope = float(rf @ du)
            log.debug("          line search: slope %.3e", slope)
            ok = False
            for _ in range(30):
                U[:] = 0.0
                U[free] = alpha * du
                un = u + U[:N]
                zn = z + U[N]
                we = self.energy(un)
                if math.isfinite(we):
                    pi1 = we + self._contact(un, zn, x_c, hf, tangent=False)[0] + P * zn
                    if pin is not None:
                        pi1 += 0.5 * kz * (zn - pin) ** 2
                    if f_ext is not None:
                        pi1 -= float(f_ext @ un)
                    if pi1 <= pi0 + 1e-4 * alpha * slope + 1e-13 * abs(pi0):
                        ok = True
                        break
                alpha *= 0.5
            if not ok:
                msg = "line search failed"
                if not math.isfinite(self.energy(un)):
                    return u, z, it, res, False, msg
            u, z = un, zn
        return u, z, it, res, False, f"did not converge in {max_iter} Newton iterations (residual {res:.2e})"

    def _friction_force(self, u, z, x_c, hf, mu):
        """Nodal sliding-friction force (n_dof,) on the finger: ``-mu F_i (1, h')``."""
        cs = self._cs
        x = self._cX[0] + u[2 * cs] + x_c
        y = self._cX[1] + u[2 * cs + 1] + z
        Fn = self.mesh_params.penalty * self._cw * np.maximum(np.asarray(hf[0](x), float) - y, 0.0)
        f = np.zeros(self.n_dof)
        f[2 * cs] = -mu * Fn
        f[2 * cs + 1] = -mu * Fn * np.asarray(hf[1](x), float)
        return f

    def _gap_min(self, u, z, x_c, hf):
        h = hf[0]
        cs = self._cs
        x = self._cX[0] + u[2 * cs] + x_c
        y = self._cX[1] + u[2 * cs + 1] + z
        return float(np.min(y - np.asarray(h(x), float)))

    def solve(self, surface, x_finger: float, *, load: float = 0.3, warm: FEState | None = None,
              tol: float = 1e-6, max_iter: int = 30, ramp: int = 4, friction: float = 0.0,
              ) -> tuple[FESolution, FEState]:
        """Contact of the finger centred at ``x_finger`` (mm) under ``load`` (N).

        Parameters
        ----------
        surface : Surface or callable
            The relief ``h(x)`` (mm).
        x_finger : float
            Finger centre in mm, surface coordinates.
        load : float
            Normal force ``F_N`` in N (the load per unit width is ``F_N / D``).
        warm : FEState, optional
            The state of a previous solve (a neighbouring position or load) to start from.
        tol : float
            Convergence: largest out-of-balance nodal force below ``tol * P'``.
        max_iter : int
            Newton iterations per load step.
        ramp : int
            Load steps of a cold start (no ``warm``).
        friction : float
            Coefficient ``mu`` of a sliding Coulomb traction on the contact, opposing a
            finger that moves towards ``+x`` (default 0: frictionless). It is applied as a
            nodal force ``-mu F_i (1, h'(x_i))`` from the normal contact forces ``F_i`` of
            the previous iterate, to a fixed point (max change below 1e-6 of the load).

        Returns
        -------
        (FESolution, FEState)
        """
        F = float(load)
        if not math.isfinite(F) or F <= 0:
            raise ValueError(f"load must be a finite positive normal force in N, got {load!r}")
        x_c = float(x_finger)
        if not math.isfinite(x_c):
            raise ValueError(f"x_finger must be a finite position in mm, got {x_finger!r}")
        if not (math.isfinite(friction) and friction >= 0):
            raise ValueError(f"friction must be a coefficient >= 0, got {friction!r}")
        hf = _surface_funcs(surface)
        P = F / self.finger.width
        total_it = 0
        cold = warm is None
        if warm is not None:
            f_ext = None
            if friction and warm.x_c is not None:
                # the previous position's traction: the move starts sheared, as the finger is
                f_ext = self._friction_force(warm.u, warm.z, warm.x_c, hf, float(friction))
            u, z, total_it, res, ok, msg = self._warm(warm, x_c, P, hf, tol, max_iter, depth=0, f_ext=f_ext)
            if not ok and f_ext is not None:  # the move without traction, then the fixed point
                u, z, it, res, ok, msg = self._warm(warm, x_c, P, hf, tol, max_iter, depth=0)
                total_it += it
            # a failed move from the neighbour: a cold start here instead. Measured (Bump 2 mm,
            # seed 6414's subject 1, mu 0.55, 120 positions): 15 unconverged without it, 0 with
            # it (2 cold starts: a failure no longer leaves the next moves a longer way to go)
            cold = not ok
            if cold:
                log.debug("x = %.4g mm: the move from %.4g mm failed (%s); a cold start", x_c, warm.x_c, msg)
        if cold:
            u = np.zeros(self.n_dof)
            z = self.initial_height(surface, x_c) - 1e-3
            ok, msg, res = True, "", 0.0
            for Pk in P * np.arange(1, ramp + 1) / ramp:
                u, z, it, res, ok, msg = self._newton(u, z, x_c, float(Pk), hf, tol, max_iter)
                total_it += it
                if not ok:
                    break
        # a cold start ramps the traction too (a full one at once can stall Newton on a slope)
        levels = friction * np.arange(1, ramp + 1) / ramp if cold else (friction,)
        # each step is in equilibrium with the traction of the previous one; when a step's
        # Newton fails (the active set cycles under the dead traction), the last converged
        # state is kept: in equilibrium with a traction one fixed-point step old
        for mu in levels if friction else ():
            for _ in range(30):
                if not ok:
                    break
                f_ext = self._friction_force(u, z, x_c, hf, float(mu))
                u0, z0, res0 = u, z, res
                u, z, it, res, ok1, msg1 = self._newton(u, z, x_c, P, hf, tol, max_iter, f_ext=f_ext)
                total_it += it
                if not ok1:
                    log.debug("friction fixed point at x = %.4g mm: %s; keeping the last state", x_c, msg1)
                    u, z, res = u0, z0, res0
                    msg += "; friction fixed point stopped early (a traction step did not converge)"
                    break
                msg = msg1
                change = np.max(np.abs(self._friction_force(u, z, x_c, hf, float(mu)) - f_ext))
                if change < 1e-6 * P and np.max(np.abs(u - u0)) < 1e-6:
                    break
        sol = self._solution(u, z, x_c, F, P, hf, total_it, res, ok, msg)
        return sol, FEState(u=u, z=z, x_c=x_c, P=P)

    def _warm(self, warm: FEState, x_c, P, hf, tol, max_iter, depth, f_ext=None):
        """From a neighbouring state: first at the start's height (the outline adapts to
        the moved relief) when the move pushes it into the relief, then at the load; on
        failure, the move is split in two. ``f_ext``: nodal forces held fixed (the
        neighbour's friction traction)."""
        u, z = warm.u.copy(), float(warm.z)
        it1, ok, res, msg = 0, True, math.inf, ""
        if -self._gap_min(u, z, x_c, hf) > self.pin_above:
            u, z, it1, res, ok, msg = self._newton(u, z, x_c, P, hf, max(tol, 1e-2), max_iter, pin=z,
                                                   f_ext=f_ext)
        it2 = 0
        if ok:
            u, z, it2, res, ok, msg = self._newton(u, z, x_c, P, hf, tol, max_iter, f_ext=f_ext)
        if ok or depth >= self.max_split or warm.x_c is None or warm.P is None:
            return u, z, it1 + it2, res, ok, msg
        log.debug("split the move %.4g -> %.4g mm", warm.x_c, x_c)
        xm, Pm = 0.5 * (warm.x_c + x_c), 0.5 * (warm.P + P)
        um, zm, ita, res, ok, msg = self._warm(warm, xm, Pm, hf, tol, max_iter, depth + 1, f_ext)
        if not ok:
            return um, zm, it1 + it2 + ita, res, ok, msg
        mid = FEState(u=um, z=zm, x_c=xm, P=Pm)
        u, z, itb, res, ok, msg = self._warm(mid, x_c, P, hf, tol, max_iter, depth + 1, f_ext)
        return u, z, it1 + it2 + ita + itb, res, ok, msg

    def _solution(self, u, z, x_c, F, P, hf, it, res, ok, msg) -> FESolution:
        cs = self._cs
        x = self._cX[0] + u[2 * cs] + x_c
        y = self._cX[1] + u[2 * cs + 1] + z
        d = y - np.asarray(hf[0](x), float)
        # pressure per unit horizontal length of the deformed outline: the penalty
        # pressure k (-d) per unit reference length over the local horizontal stretch
        stretch = np.gradient(x, self._cs_ref)
        pen = self.mesh_params.penalty * np.maximum(-d, 0.0)
        press = pen / np.maximum(np.abs(stretch), 1e-6)
        order = np.argsort(x)
        if np.any(np.diff(x[order]) <= 0):
            ok = False
            msg = "the deformed outline folds over itself (not a graph y(x))"
        return FESolution(x_finger=x_c, load=F, z=float(z), outline_x=x[order], outline_y=y[order],
                          outline_pressure=press[order], iterations=it,
                          residual=res, success=bool(ok), message=msg)
