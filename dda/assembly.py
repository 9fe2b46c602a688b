"""Global stiffness matrix from 6x6 blocks: block-sparse, straight to CSR/CSC.

Diagonal blocks come from the effects and contacts (n, 6, 6); off-diagonal
blocks from contacts between two free blocks, summed per block pair before
the matrix is built. Fixed blocks are removed from the unknowns.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def free_rows(fixed: np.ndarray) -> np.ndarray:
    """Row of each block among the unknowns (-1 for fixed blocks)."""
    rows = np.cumsum(~fixed) - 1
    return np.where(fixed, -1, rows)


def add_pair_terms(
    diagonal: np.ndarray,
    block_i: np.ndarray,
    block_j: np.ndarray,
    row_i: np.ndarray,
    row_j: np.ndarray,
    stiffness: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Add k·[r_i; r_j][r_i; r_j]ᵀ for each term; return off-diagonal blocks.

    Parameters
    ----------
    diagonal : (n, 6, 6) accumulated in place (ii and jj parts)
    block_i, block_j : (m,) rows of the two blocks of each term
    row_i, row_j : (m, 6) gradient rows with respect to D_i and D_j
    stiffness : (m,) spring constant of each term

    Returns
    -------
    (i, j, blocks) : the ij parts (m, 6, 6), to be placed at (i, j) and
    transposed at (j, i).
    """
    ki = stiffness[:, None] * row_i
    kj = stiffness[:, None] * row_j
    np.add.at(diagonal, block_i, ki[:, :, None] * row_i[:, None, :])
    np.add.at(diagonal, block_j, kj[:, :, None] * row_j[:, None, :])
    return block_i, block_j, ki[:, :, None] * row_j[:, None, :]


def assemble(
    diagonal: np.ndarray,
    pair_i: np.ndarray,
    pair_j: np.ndarray,
    pair_blocks: np.ndarray,
    fixed: np.ndarray,
) -> sp.csc_matrix:
    """Sparse K over the free blocks (6 unknowns each)."""
    rows = free_rows(fixed)
    nfree = int((~fixed).sum())
    both = (rows[pair_i] >= 0) & (rows[pair_j] >= 0) & (pair_i != pair_j)
    ri, rj, blocks = rows[pair_i[both]], rows[pair_j[both]], pair_blocks[both]
    # one block per unordered pair, summed
    lo, hi = np.minimum(ri, rj), np.maximum(ri, rj)
    blocks = np.where((ri <= rj)[:, None, None], blocks, blocks.transpose(0, 2, 1))
    key = lo.astype(np.int64) * max(nfree, 1) + hi
    unique, inverse = np.unique(key, return_inverse=True)
    summed = np.zeros((len(unique), 6, 6))
    np.add.at(summed, inverse, blocks)
    ulo, uhi = unique // max(nfree, 1), unique % max(nfree, 1)

    free = ~fixed
    block_rows = np.concatenate([np.arange(nfree), ulo, uhi])
    block_cols = np.concatenate([np.arange(nfree), uhi, ulo])
    data = np.concatenate([diagonal[free], summed, summed.transpose(0, 2, 1)])
    order = np.lexsort((block_cols, block_rows))
    indptr = np.zeros(nfree + 1, dtype=np.int64)
    np.cumsum(np.bincount(block_rows, minlength=nfree), out=indptr[1:])
    k = sp.bsr_matrix(
        (data[order], block_cols[order], indptr), shape=(6 * nfree, 6 * nfree), blocksize=(6, 6)
    )
    return k.tocsc()


def add_forces(forces: np.ndarray, block: np.ndarray, row: np.ndarray, coef: np.ndarray) -> None:
    """F_block -= coef·row for each term (in place)."""
    np.add.at(forces, block, -coef[:, None] * row)
