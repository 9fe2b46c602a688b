"""The interior point's block pattern (dda/solve/interior_point.py, BlockPattern): its CSR
pattern and the places of each pair's 12 × 12 unknowns against a pattern built unknown by
unknown from the same pairs."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from dda.solve.interior_point import BlockPattern


def _pairs(count: int, pairs: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Random pairs of distinct blocks among ``count``, some with a fixed block (−1)."""
    rng = np.random.default_rng(seed)
    first = rng.integers(0, count, pairs)
    second = (first + rng.integers(1, count, pairs)) % count
    fixed = rng.random(pairs) < 0.2
    return first, np.where(fixed, -1, second)


def _unknown_by_unknown(count: int, first: np.ndarray, second: np.ndarray) -> sp.csr_matrix:
    """The pattern of every free block's 6 × 6 diagonal and both blocks of every pair,
    entry by entry (ones), in scipy's canonical order."""
    rows, columns = [], []
    for a, b in [(i, i) for i in range(count)] + list(zip(first, second, strict=True)):
        for i, j in ((a, a), (a, b), (b, a), (b, b)):
            if i < 0 or j < 0:
                continue
            r, c = np.meshgrid(6 * i + np.arange(6), 6 * j + np.arange(6), indexing="ij")
            rows.append(r.ravel())
            columns.append(c.ravel())
    size = 6 * count
    ones = np.ones(sum(len(r) for r in rows))
    matrix = sp.csr_matrix((ones, (np.concatenate(rows), np.concatenate(columns))), (size, size))
    matrix.sum_duplicates()
    return matrix


def test_the_block_pattern_is_the_pattern_of_the_unknowns():
    count = 40
    first, second = _pairs(count, 90, seed=3)
    pattern = BlockPattern(count, [(first, second)])
    got, expected = pattern.csr(), _unknown_by_unknown(count, first, second)
    np.testing.assert_array_equal(got.indptr, expected.indptr)
    np.testing.assert_array_equal(got.indices, expected.indices)
    assert pattern.values == expected.nnz


def test_each_pairs_places_hold_its_unknowns_row_and_column():
    """values[places[k, i, j]] is the entry (unknown i of the pair, unknown j of the pair):
    unknowns 0-5 of ``first``, 6-11 of ``second``; −1 exactly where a block is fixed."""
    count = 25
    first, second = _pairs(count, 60, seed=7)
    pattern = BlockPattern(count, [(first, second)])
    csr = pattern.csr()
    row_of = np.repeat(np.arange(csr.shape[0]), np.diff(csr.indptr))
    places = pattern.places(first, second)
    for k in range(len(first)):
        unknowns = np.concatenate([6 * b + np.arange(6) if b >= 0 else np.full(6, -1)
                                   for b in (first[k], second[k])])  # fmt: skip
        for i in range(12):
            for j in range(12):
                place = places[k, i, j]
                if unknowns[i] < 0 or unknowns[j] < 0:
                    assert place == -1
                else:
                    assert (row_of[place], csr.indices[place]) == (unknowns[i], unknowns[j])
