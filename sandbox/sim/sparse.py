"""The implicit solver's Newton matrix, assembled, and its sparse factorisation.

Conjugate gradients with a block-Jacobi preconditioner needs on the order of √κ matrix
products per Newton iteration, and κ ≈ (h·ω_max)² grows with the step h: at h = 1/60 s on a
stiff cantilever that is about as many products as explicit steps (docs/error-vs-runtime.md).
A direct factorisation does not care about κ. Here the matrix

    A = M (1/h² + γ/h) + H      (3n x 3n, symmetric positive definite)

is assembled in 3x3 blocks from the same per-element Hessians the CG product uses
(triangles 3x3 corners, hinges 4x4, seams 2x2, the mass on the diagonal), with the
vertices in reverse Cuthill-McKee order, and factorised one of two ways:

* a narrow band (N·bw² <= ``BANDED_FLOPS``, e.g. a strip): banded Cholesky (LAPACK pbtrf)
  for every system, each solve exact (one "iteration");
* a wide band (garments): SuperLU without pivoting (``scipy.sparse.linalg.splu``,
  minimum-degree ordering on A + Aᵀ). Later systems keep the factors as the preconditioner
  of CG on the new matrix while it converges within ``refactor_after`` iterations; then the
  matrix is factorised again and the solve is exact.

The block pattern (which vertex pairs share an element) is fixed by the mesh; seams sewn
live change it, which :meth:`BlockPattern.update` notices through ``model.seam_version``.
Pinned vertices keep an identity block and no coupling, so their Δx is 0.

SuperLU sizes (a grid sheet, 2-core CPU): factorising takes 6 ms at 1.4k unknowns, 150 ms
at 15k and 330 ms at 30k; a solve with the factors is 0.4, 6 and 12 ms.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp
import scipy.sparse.linalg as spl
import taichi as ti
from scipy.linalg.blas import dsbmv as sbmv
from scipy.sparse.csgraph import reverse_cuthill_mckee


class BlockPattern:
    """The 3x3-block sparsity of the Newton matrix: BSR ``indptr``/``indices`` and, for each
    element corner pair, the index of its block.

    Attributes (numpy, int32 unless said):
        tri_block (m, 9): block of corner pair (a, b) of triangle t at ``[t, 3a + b]``.
        hinge_block (h, 16): block of hinge vertex pair (a, b) at ``[h, 4a + b]``.
        seam_block (capacity, 4): blocks (a,a), (a,b), (b,a), (b,b) of each live seam.
        diag_block (n,): the diagonal block of each vertex.
        indptr (n+1,), indices (nb,): BSR structure; ``count`` = nb blocks in use.
    """

    def __init__(self, model):
        self.model = model
        self.n = model.particle_count
        self.version = -1
        self.update()

    def update(self) -> bool:
        """Recompute the pattern if the seams changed since the last call; True if it did."""
        m = self.model
        version = getattr(m, "seam_version", 0)
        if version == self.version:
            return False
        self.version = version
        n = self.n
        tris = np.asarray(m.tri_indices_np, np.int64).reshape(-1, 3)
        hinges = (np.zeros((0, 4), np.int64) if m.hinge_indices_np is None
                  else np.asarray(m.hinge_indices_np, np.int64).reshape(-1, 4))  # fmt: skip
        seams = (np.zeros((0, 2), np.int64) if m.seam_pairs_np is None
                 else np.asarray(m.seam_pairs_np, np.int64).reshape(-1, 2))  # fmt: skip
        parts = [
            (tris[:, :, None] * n + tris[:, None, :]).reshape(-1),
            (hinges[:, :, None] * n + hinges[:, None, :]).reshape(-1),
            (seams[:, :, None] * n + seams[:, None, :]).reshape(-1),
            np.arange(n, dtype=np.int64) * (n + 1),
        ]
        pairs = np.unique(np.concatenate(parts))
        # order the vertices by reverse Cuthill-McKee: a narrow band for the banded solver,
        # a good start for SuperLU's own ordering
        graph = sp.csr_matrix((np.ones(len(pairs)), (pairs // n, pairs % n)), shape=(n, n))
        self.order = reverse_cuthill_mckee(graph, symmetric_mode=True).astype(np.int64)
        self.position = np.empty(n, np.int64)
        self.position[self.order] = np.arange(n)
        pos = self.position
        keys_of = lambda k: pos[k // n] * n + pos[k % n]  # noqa: E731  (vertex -> band order)
        keys = np.unique(keys_of(pairs))
        rows = keys // n
        self.indices = (keys % n).astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=n))]).astype(
            np.int32
        )
        self.count = len(keys)
        block = lambda k: np.searchsorted(keys, keys_of(k)).astype(np.int32)  # noqa: E731
        self.tri_block = block(parts[0]).reshape(-1, 9)
        self.hinge_block = block(parts[1]).reshape(-1, 16)
        self.seam_block = block(parts[2]).reshape(-1, 4)
        self.diag_block = block(parts[3])
        # the banded (LAPACK) layout of the upper triangle: scalar (R, C), R <= C, sits at
        # ab[bw + R − C, C]; src/dst map the block values there
        r3 = (3 * rows[:, None, None] + np.arange(3)[None, :, None]).repeat(3, axis=2)
        c3 = (3 * (keys % n)[:, None, None] + np.arange(3)[None, None, :]).repeat(3, axis=1)
        upper = (r3 <= c3).ravel()
        self.bandwidth = int(np.max(c3 - r3)) if len(keys) else 0
        self.band_src = np.flatnonzero(upper)
        self.band_dst = ((self.bandwidth + r3 - c3) * (3 * n) + c3).ravel()[upper]
        return True

    def banded_cost(self) -> float:
        """Flops of a banded Cholesky of A in this order: N·(bw + 1)²."""
        return 3.0 * self.n * (self.bandwidth + 1) ** 2

    def permute(self, v: np.ndarray) -> np.ndarray:
        """(n, 3) per-vertex values -> the matrix's scalar order (3n,)."""
        return np.ascontiguousarray(v[self.order]).reshape(-1)

    def unpermute(self, v: np.ndarray) -> np.ndarray:
        """The matrix's scalar order (3n,) -> (n, 3) per vertex."""
        return v.reshape(-1, 3)[self.position]

    def banded(self, blocks: np.ndarray) -> np.ndarray:
        """A's upper band (bw + 1, 3n) in LAPACK's layout, from block values (nb, 3, 3)."""
        ab = np.zeros((self.bandwidth + 1, 3 * self.n))
        ab.ravel()[self.band_dst] = blocks[: self.count].reshape(-1)[self.band_src]
        return ab

    def max_blocks(self) -> int:
        """An upper bound on the block count whatever seams are sewn (for field sizes)."""
        m = self.model
        return self.count + 2 * int(getattr(m, "seam_capacity", 0) or 0)

    def matrix(self, blocks: np.ndarray) -> sp.csc_matrix:
        """The assembled A from the block values (nb, 3, 3), as CSC for SuperLU."""
        a = sp.bsr_matrix((blocks[: self.count], self.indices, self.indptr),
                          shape=(3 * self.n, 3 * self.n))  # fmt: skip
        return a.tocsc()


BANDED_FLOPS = 3e7
"""Largest N·(bw + 1)² for which the banded Cholesky is used (about 10 ms here)."""


class FactorisedSolver:
    """Solve A Δx = b with a (possibly stale) factorisation of A, as described above.

    Args:
        refactor_after: CG iterations preconditioned by the old factors after which the
            matrix is factorised again (the next solves are then exact).
        rtol: relative residual |b − A Δx| <= rtol |b| that ends CG.
        banded_flops: largest N·(bw + 1)² factorised by banded Cholesky; wider bands go
            to SuperLU (:data:`BANDED_FLOPS`).
    """

    def __init__(self, refactor_after: int = 8, rtol: float = 1e-3,
                 banded_flops: float = BANDED_FLOPS):  # fmt: skip
        self.refactor_after = int(refactor_after)
        self.rtol = float(rtol)
        self.banded_flops = float(banded_flops)
        self.factors = None  # (kind, factors): ("band", c) or ("lu", SuperLU object)
        self.factorisations = 0

    def invalidate(self) -> None:
        self.factors = None

    def solve(self, pattern: BlockPattern, blocks: np.ndarray, b: np.ndarray):
        """(Δx, iterations) for A Δx = b, A from the block values (nb, 3, 3) and b in the
        pattern's order; 1 iteration when A was factorised for this solve.

        A narrow band (cost N·bw² <= ``banded_flops``, e.g. a strip) is factorised by banded
        Cholesky (LAPACK pbtrf; 2 ms for the 1.4k-unknown cantilever), a wide one by SuperLU.
        Either is kept and preconditions CG on the next systems while that converges within
        ``refactor_after`` iterations.
        """
        kind = "band" if pattern.banded_cost() <= self.banded_flops else "lu"
        if kind == "band":
            ab = pattern.banded(blocks)
            matvec = lambda v: sbmv(pattern.bandwidth, 1.0, ab, v)  # noqa: E731
        else:
            a = pattern.matrix(blocks)
            matvec = a.dot
        if self.factors is not None and self.factors[0] == kind == "lu":  # (band: cheap)
            x, k, ok = self._pcg(matvec, b)
            if ok:
                return x, k
        if kind == "band":
            try:
                self.factors = ("band", sl.cholesky_banded(ab, check_finite=False))
            except np.linalg.LinAlgError:  # not positive definite after all: LU
                kind, a = "lu", pattern.matrix(blocks)
        if kind == "lu":
            # A is symmetric positive definite: no pivoting needed, and pivoting for size
            # (SuperLU's default) wrecks the fill-reducing order when stiffnesses span
            # decades (0.57 s instead of 41 ms for a 2.6k-unknown garment with seams)
            self.factors = ("lu", spl.splu(a, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                           options={"SymmetricMode": True}))  # fmt: skip
        self.factorisations += 1
        return self._apply_inverse(b), 1

    def _apply_inverse(self, r: np.ndarray) -> np.ndarray:
        kind, f = self.factors
        if kind == "band":
            return sl.cho_solve_banded((f, False), r, check_finite=False)
        return f.solve(r)

    def _pcg(self, matvec, b):
        """CG on A x = b preconditioned by the stored factors; (x, iterations, converged)."""
        bb = float(b @ b)
        x = np.zeros_like(b)
        if bb == 0.0:
            return x, 0, True
        target = self.rtol * self.rtol * bb
        r = b.copy()
        z = self._apply_inverse(r)
        p = z.copy()
        rz = float(r @ z)
        for k in range(1, self.refactor_after + 1):
            ap = matvec(p)
            pap = float(p @ ap)
            if not pap > 0.0:
                return x, k, False
            alpha = rz / pap
            x += alpha * p
            r -= alpha * ap
            if float(r @ r) <= target:
                return x, k, True
            z = self._apply_inverse(r)
            rz_new = float(r @ z)
            p = z + (rz_new / rz) * p
            rz = rz_new
        return x, self.refactor_after, False


def index_field(array: np.ndarray):
    """A Taichi i32 field holding ``array`` (at least one row)."""
    rows = max(1, len(array))
    shape = (rows,) + tuple(array.shape[1:])
    f = ti.field(ti.i32, shape=shape)
    if len(array):
        f.from_numpy(np.ascontiguousarray(array, dtype=np.int32))
    return f
