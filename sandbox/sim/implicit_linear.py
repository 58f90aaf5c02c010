"""The implicit step's linear solves: (M (1/h² + γ/h) + H) Δx = −∇E.

Matrix-free conjugate gradients with a 3x3 block-Jacobi preconditioner to a relative
residual ``cg_tol`` (one iteration per kernel launch, or the whole loop in one serial
launch for small meshes), or, with ``linear_solver="direct"``, the matrix assembled and
factorised by sparse LU (:mod:`sandbox.sim.sparse`).

A mixin of :class:`sandbox.sim.implicit.ImplicitEulerSolver` (its fields and settings).
"""

import numpy as np
import taichi as ti

from sandbox.sim.implicit_config import REAL


class LinearSolve:
    """CG (matrix-free) and the direct solve of one Newton system."""

    def _solve(self) -> int:
        """CG on (M c + H) Δx = −∇E; returns the iterations used."""
        if self.pattern is not None:
            return self._solve_direct()
        self._cg_init()
        rr0 = float(self.rr[None])
        if rr0 <= 0.0:
            return 0
        target = self.config.cg_tol * self.config.cg_tol * rr0
        if self.fused:
            return int(self._cg_loop(self.config.max_cg, target))
        for k in range(1, self.config.max_cg + 1):
            self._cg_iter()
            if float(self.rr[None]) <= target or self.negative[None]:
                return k
        return self.config.max_cg

    def _init_direct(self) -> None:
        """Fields for the assembled matrix (``linear_solver="direct"``)."""
        from sandbox.sim import sparse

        m = self.model
        self.pattern = sparse.BlockPattern(m)
        self.factor = sparse.FactorisedSolver(banded_flops=self.config.banded_flops)
        # numpy arrays the assembly kernel writes into directly (no copies, no extra launch)
        self.blocks = np.zeros((self.pattern.max_blocks(), 3, 3))
        self.grad_np = np.zeros((max(1, m.particle_count), 3))
        self.dx_np = np.zeros((max(1, m.particle_count), 3))
        self.tri_block = sparse.index_field(self.pattern.tri_block)
        self.hinge_block = sparse.index_field(self.pattern.hinge_block)
        self.diag_block = sparse.index_field(self.pattern.diag_block)
        self.seam_block = None
        if m.has_seams:
            self.seam_block = ti.field(ti.i32, shape=(m.seam_capacity, 4))
        self._load_block_indices()

    def _load_block_indices(self) -> None:
        """Load the pattern's block indices after a change (the vertex order changes too)."""
        p = self.pattern
        for field, index in ((self.tri_block, p.tri_block), (self.hinge_block, p.hinge_block),
                             (self.diag_block, p.diag_block)):  # fmt: skip
            if len(index):
                field.from_numpy(np.ascontiguousarray(index, dtype=np.int32))
        if self.seam_block is None:
            return
        pad = np.zeros((self.model.seam_capacity, 4), np.int32)
        pad[: len(p.seam_block)] = p.seam_block
        self.seam_block.from_numpy(pad)

    def _assemble_into_numpy(self) -> None:
        """blocks := A's 3x3 blocks and grad_np := ∇E at the current iterate (numpy)."""
        self.blocks.fill(0.0)
        self._assemble(self.blocks, self.grad_np)

    def _dx_source(self):
        return self.dx_np if self.dx_np is not None else self._no_dx

    def _solve_direct(self) -> int:
        """Assemble A = M c + H, solve A Δx = −∇E with the (re)used factors."""
        n = self.model.particle_count
        if self.pattern.update():  # seams sewn or cut since the last solve
            self._load_block_indices()
            self.factor.invalidate()
        self._assemble_into_numpy()
        b = self.pattern.permute(-self.grad_np[:n])
        dx, iterations = self.factor.solve(self.pattern, self.blocks, b)
        self.dx_np[:n] = self.pattern.unpermute(dx)  # _post_solve loads it into self.dx
        return iterations

    @ti.kernel
    def _cg_init(self):
        self.rz[None] = 0.0
        self.rr[None] = 0.0
        self.negative[None] = 0
        self.cg_k[None] = 0
        for i in range(self.model.particle_count):
            self.dx[i] = ti.Vector.zero(REAL, 3)
            r = -self.grad[i]
            z = self.pinv[i] @ r
            self.r[i] = r
            self.z[i] = z
            self.p[i] = z
            self.rz[None] += ti.cast(r.dot(z), ti.f64)
            self.rr[None] += ti.cast(r.dot(r), ti.f64)

    @ti.kernel
    def _apply_kernel(self):
        self._apply(self.p, self.ap, self.pap)

    @ti.kernel
    def _cg_iter(self):
        """One preconditioned CG iteration; its loops run in parallel."""
        self._cg_body()

    @ti.kernel
    def _cg_loop(self, max_cg: ti.i32, target: ti.f64) -> ti.i32:
        """CG iterations until |r|² <= target, all in one launch (serial loops)."""
        k = 0
        while k < max_cg and self.rr[None] > target and self.negative[None] == 0:
            self._cg_body()
            k += 1
        return k

    @ti.func
    def _cg_body(self):
        """One preconditioned CG iteration (Hestenes-Stiefel form), truncated at negative
        curvature (p·Ap <= 0, possible with the compression term): then it stops and keeps
        Δx, or takes the preconditioned steepest descent direction if that was the first
        iteration (Nocedal and Wright, Newton-CG). Either is a descent direction."""
        self._apply(self.p, self.ap, self.pap)
        if self.pap[None] <= 0.0:
            self.negative[None] = 1
        self.alpha[None] = ti.cast(self.rz[None] / ti.max(self.pap[None], 1e-300), REAL)
        self.rz_new[None] = 0.0
        if self.negative[None] == 0:
            self.rr[None] = 0.0
        for i in range(self.model.particle_count):
            if self.negative[None] == 0:
                a = self.alpha[None]
                self.dx[i] += a * self.p[i]
                r = self.r[i] - a * self.ap[i]
                z = self.pinv[i] @ r
                self.r[i] = r
                self.z[i] = z
                self.rz_new[None] += ti.cast(r.dot(z), ti.f64)
                self.rr[None] += ti.cast(r.dot(r), ti.f64)
            elif self.cg_k[None] == 0:
                self.dx[i] = self.p[i]
        if self.negative[None] == 0:
            self.beta[None] = ti.cast(self.rz_new[None] / ti.max(self.rz[None], 1e-300), REAL)
            self.rz[None] = self.rz_new[None]
            self.cg_k[None] += 1
        for i in range(self.model.particle_count):
            if self.negative[None] == 0:
                self.p[i] = self.z[i] + self.beta[None] * self.p[i]
