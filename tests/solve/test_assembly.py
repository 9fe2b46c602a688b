"""Block-sparse assembly equals a dense reference; compiled and numpy paths agree."""

from __future__ import annotations

import numpy as np
import pytest

import dda.solve.assembly as assembly
from dda.solve.assembly import (
    BlockPattern,
    assemble,
    free_rows,
    reassemble,
    subtract_contact_forces,
)
from dda.solve.step import LinearCache


def random_case(seed: int, n: int = 9, m: int = 40):
    """Random blocks (some fixed), contacts (repeats, self pairs excluded) and terms."""
    rng = np.random.default_rng(seed)
    fixed = rng.random(n) < 0.25
    a = rng.integers(0, n, m)
    b = (a + rng.integers(1, n, m)) % n
    diagonal = rng.normal(size=(n, 6, 6))
    diagonal = diagonal + diagonal.transpose(0, 2, 1)  # effects give symmetric blocks
    terms = [(rng.normal(size=(m, 6)), rng.normal(size=(m, 6)), rng.random(m)) for _ in range(2)]
    terms[0][2][::5] = 0.0  # open contacts: zero stiffness, still in the pattern
    return fixed, a, b, diagonal, terms


def dense_reference(fixed, a, b, diagonal, terms) -> np.ndarray:
    """K by the definition, over all blocks, then the fixed rows/columns removed."""
    n = len(fixed)
    k = np.zeros((6 * n, 6 * n))
    for i in range(n):
        k[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] += diagonal[i]
    for row_i, row_j, stiff in terms:
        for c in range(len(a)):
            r = np.zeros(6 * n)
            r[6 * a[c] : 6 * a[c] + 6] += row_i[c]
            r[6 * b[c] : 6 * b[c] + 6] += row_j[c]
            k += stiff[c] * np.outer(r, r)
    keep = np.repeat(~fixed, 6)
    return k[np.ix_(keep, keep)]


def reversed_order(nfree: int, pairs: np.ndarray) -> np.ndarray:
    return np.arange(nfree)[::-1].copy()


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("ordering", [None, reversed_order])
def test_assembly_equals_dense_reference(seed, ordering):
    fixed, a, b, diagonal, terms = random_case(seed)
    pattern = BlockPattern(fixed, a, b, ordering)
    k = assemble(pattern, diagonal, fixed, terms).toarray()
    ref = dense_reference(fixed, a, b, diagonal, terms)
    # the pattern orders the blocks: compare in that order
    perm = np.argsort(pattern.position)
    idx = (6 * perm[:, None] + np.arange(6)).ravel()
    np.testing.assert_allclose(k, ref[np.ix_(idx, idx)], rtol=1e-12, atol=1e-12)


def test_numpy_path_equals_compiled_path(monkeypatch):
    fixed, a, b, diagonal, terms = random_case(7, n=30, m=200)
    pattern = BlockPattern(fixed, a, b)
    first = assemble(pattern, diagonal, fixed, terms).toarray()
    monkeypatch.setattr(assembly, "_scatter_kernel", None)
    second = assemble(pattern, diagonal, fixed, terms).toarray()
    np.testing.assert_allclose(first, second, rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("compiled", [True, False])
def test_reassembly_of_the_changed_springs_equals_a_new_assembly(monkeypatch, compiled):
    """Springs that open (k -> 0), close (0 -> k) or change: adding k_new - k_old
    of those contacts to K gives the K of the new springs."""
    if not compiled:
        monkeypatch.setattr(assembly, "_scatter_kernel", None)
    fixed, a, b, diagonal, terms = random_case(3, n=12, m=60)
    pattern = BlockPattern(fixed, a, b)
    before = assemble(pattern, diagonal, fixed, terms)
    old_data = before.data.copy()
    springs = np.stack([t[2] for t in terms])
    new = springs.copy()
    new[0, 1::7] = 0.0  # open
    new[:, ::5] = 2.5  # close (the zeros at ::5) or stiffen
    changed = np.flatnonzero((new != springs).any(axis=0))
    assert 10 < len(changed) < 60
    change = [
        (t[0][changed], t[1][changed], (new - springs)[q, changed]) for q, t in enumerate(terms)
    ]
    after = reassemble(pattern, before, change, changed)
    expected = assemble(
        pattern, diagonal, fixed, [(t[0], t[1], new[q]) for q, t in enumerate(terms)]
    )
    np.testing.assert_allclose(after.toarray(), expected.toarray(), rtol=1e-13, atol=1e-12)
    np.testing.assert_array_equal(before.data, old_data)  # K itself is left as it was


def test_solution_maps_back_to_blocks():
    fixed = np.array([True, False, False, True, False])
    pattern = BlockPattern(fixed, np.array([1, 2]), np.array([4, 1]), reversed_order)
    per_block = np.arange(30, dtype=float).reshape(5, 6)
    ordered = pattern.to_matrix_order(per_block).ravel()
    back = pattern.from_matrix_order(ordered)
    np.testing.assert_array_equal(back[~fixed], per_block[~fixed])
    assert not back[fixed].any()


def test_patterns_of_the_same_graph_have_the_same_key():
    fixed = np.array([False, False, True])
    one = BlockPattern(fixed, np.array([0, 1]), np.array([1, 2]))
    two = BlockPattern(fixed.copy(), np.array([0, 1]), np.array([1, 2]))
    same_graph = BlockPattern(fixed, np.array([1, 0, 2]), np.array([0, 1, 1]))
    other_graph = BlockPattern(fixed, np.array([0]), np.array([2]))
    assert one.key == two.key == same_graph.key != other_graph.key
    assert one.contacts_key != same_graph.contacts_key


@pytest.mark.parametrize("compiled", [True, False])
def test_contact_forces_go_to_both_blocks(monkeypatch, compiled):
    if not compiled:
        monkeypatch.setattr(assembly, "_subtract_pairs_kernel", None)
    rng = np.random.default_rng(6)
    m, n = 300, 40
    block_a, block_b = rng.integers(0, n, m), rng.integers(0, n, m)
    gradients = tuple(rng.normal(size=(m, 6)) for _ in range(4))
    normal, shear = rng.normal(size=m), rng.normal(size=m)
    forces = np.ones((n, 6))
    subtract_contact_forces(forces, block_a, block_b, gradients, normal, shear)
    e, g, es, gs = gradients
    expected = np.ones((n, 6))
    for c in range(m):  # F_a -= N E + F Es, F_b -= N G + F Gs
        expected[block_a[c]] -= normal[c] * e[c] + shear[c] * es[c]
        expected[block_b[c]] -= normal[c] * g[c] + shear[c] * gs[c]
    np.testing.assert_allclose(forces, expected, rtol=1e-12, atol=1e-12)


def test_free_rows_skip_fixed_blocks():
    np.testing.assert_array_equal(free_rows(np.array([False, True, False])), [0, -1, 1])


def test_spare_pairs_stay_zero_and_cover_returning_contacts():
    fixed, a, b, diagonal, terms = random_case(11)
    keep = np.arange(len(a)) % 3 != 0  # a third of the contacts gone this step
    spare = BlockPattern(fixed, a, b).pairs
    pattern = BlockPattern(fixed, a[keep], b[keep], reversed_order, extra_pairs=spare)
    assert pattern.covers(fixed, a, b) and len(pattern.pairs) == len(spare)
    kept_terms = [(ri[keep], rj[keep], k[keep]) for ri, rj, k in terms]
    k = assemble(pattern, diagonal, fixed, kept_terms).toarray()
    ref = dense_reference(fixed, a[keep], b[keep], diagonal, kept_terms)
    perm = np.argsort(pattern.position)
    idx = (6 * perm[:, None] + np.arange(6)).ravel()
    np.testing.assert_allclose(k, ref[np.ix_(idx, idx)], rtol=1e-12, atol=1e-12)
    back = pattern.with_contacts(a, b)  # the contacts come back: same structure, same key
    assert back.key == pattern.key
    full = assemble(back, diagonal, fixed, terms).toarray()
    np.testing.assert_allclose(
        full,
        dense_reference(fixed, a, b, diagonal, terms)[np.ix_(idx, idx)],
        rtol=1e-12,
        atol=1e-12,
    )


def test_open_contacts_need_no_block():
    fixed, a, b, diagonal, terms = random_case(12)
    active = np.arange(len(a)) % 2 == 0
    terms = [(ri, rj, np.where(active, k, 0.0)) for ri, rj, k in terms]  # open: no spring
    pattern = BlockPattern(fixed, a, b, reversed_order, active=active)
    assert pattern.covers(fixed, a, b, active) and pattern.lands(active)
    full = BlockPattern(fixed, a, b, reversed_order)
    assert len(pattern.pairs) < len(full.pairs)  # the open contacts' pairs have no block
    assert not pattern.lands()  # so those contacts may not close without a new pattern
    assert np.all(pattern.slot_ij[~pattern.landed] == -1)
    k = assemble(pattern, diagonal, fixed, terms).toarray()
    perm = np.argsort(pattern.position)
    idx = (6 * perm[:, None] + np.arange(6)).ravel()
    ref = dense_reference(fixed, a, b, diagonal, terms)
    np.testing.assert_allclose(k, ref[np.ix_(idx, idx)], rtol=1e-12, atol=1e-12)


def test_the_cache_keeps_the_pattern_while_closing_contacts_land_in_it():
    """Within a step the contact list stays; only which contacts are closed changes."""
    fixed, a, b, _, _ = random_case(13)
    first = np.arange(len(a)) % 2 == 0
    cache = LinearCache(solver=None)
    pattern = cache.pattern_for(fixed, a, b, active=first)
    assert cache.pattern_for(fixed, a, b, active=first) is pattern
    landing = first | pattern.landed  # contacts whose blocks already have a block of K
    assert cache.pattern_for(fixed, a, b, active=landing) is pattern
    everything = np.ones(len(a), bool)
    assert not pattern.lands(everything)
    bigger = cache.pattern_for(fixed, a, b, active=everything)
    assert bigger is not pattern and bigger.lands(everything)


@pytest.mark.parametrize("compiled", [True, False])
def test_slots_are_found_and_missing_blocks_are_not_covered(monkeypatch, compiled):
    """Every block of K is found at its slot, any other block is -1 (both lookups), and a
    contact between blocks that K does not join is not covered."""
    if not compiled:
        monkeypatch.setattr(assembly, "_find_slots_kernel", None)
    fixed, a, b, _, _ = random_case(14)
    keep = np.arange(len(a)) % 4 != 0
    pattern = BlockPattern(fixed, a[keep], b[keep], reversed_order)
    n = pattern.nfree
    brow, bcol = np.divmod(np.arange(n * n), n)
    slots = pattern._slot_of(brow, bcol)
    present = np.zeros(n * n, bool)
    present[pattern.block_rows * n + pattern.block_cols] = True
    np.testing.assert_array_equal(slots >= 0, present)
    np.testing.assert_array_equal(slots[present], np.arange(pattern.block_count))
    assert pattern.covers(fixed, a[keep], b[keep])
    ra, rb = pattern.block_of_row[a], pattern.block_of_row[b]
    joined = (ra < 0) | (rb < 0) | present[np.maximum(ra, 0) * n + np.maximum(rb, 0)]
    assert not joined.all()  # some dropped contact joins blocks K does not join
    assert not pattern.covers(fixed, a, b)
    assert pattern.covers(fixed, a, b, active=joined)


def test_a_contact_on_the_first_block_row_counts_in_covers_and_lands():
    """A contact between blocks K does not join is neither covered nor landed, also
    when one of its blocks is the first block row of K (row 0)."""
    fixed = np.zeros(3, bool)
    a, b = np.array([1, 2, 0]), np.array([2, 0, 1])
    pattern = BlockPattern(fixed, a, b, active=np.array([True, False, False]))
    assert pattern.block_of_row.tolist() == [0, 1, 2]  # K joins blocks 1 and 2 only
    assert pattern.landed.tolist() == [True, False, False]
    assert pattern.covers(fixed, a[:1], b[:1])
    assert not pattern.covers(fixed, a[1:2], b[1:2])
    assert not pattern.covers(fixed, a[2:], b[2:])


def test_unique_pairs_are_the_distinct_rows_sorted():
    pairs = np.random.default_rng(15).integers(0, 40, size=(500, 2))
    np.testing.assert_array_equal(assembly._unique_pairs(pairs, 40), np.unique(pairs, axis=0))


def test_stacked_takes_consecutive_halves_without_a_copy():
    """The contact rows keep normal and shear gradients as halves of one array: the
    assembly passes that array on; other parts are stacked as np.stack would."""
    from dda.contact.rows import _empty_rows

    rows = _empty_rows(5)
    rows.normal_i[:] = 1.0
    rows.shear_i[:] = 2.0
    both = assembly.stacked([rows.normal_i, rows.shear_i])
    assert np.shares_memory(both, rows.normal_i) and both.shape == (2, 5, 6)
    np.testing.assert_array_equal(both, np.stack([rows.normal_i, rows.shear_i]))
    swapped = assembly.stacked([rows.shear_i, rows.normal_i])
    assert not np.shares_memory(swapped, rows.normal_i)
    np.testing.assert_array_equal(swapped, np.stack([rows.shear_i, rows.normal_i]))
    single = assembly.stacked([rows.normal_i])
    assert single.shape == (1, 5, 6) and not np.shares_memory(single, rows.normal_i)
    apart = [np.ones((5, 6)), np.zeros((5, 6))]
    np.testing.assert_array_equal(assembly.stacked(apart), np.stack(apart))


@pytest.mark.parametrize("seed", range(6))
def test_block_order_conversions_equal_the_masked_ones(seed):
    """The gathers by the kept inverse numbering give what boolean masks give, to the bit:
    none or some blocks fixed, natural or reversed order, (n, 6) and (n, 6, 6) values."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 12))
    fixed = rng.random(n) < (0.0 if seed % 3 == 0 else 0.4)
    fixed[int(rng.integers(n))] = False  # at least one free block
    a, b = rng.integers(0, n, 8), rng.integers(0, n, 8)
    keep = a != b
    pattern = BlockPattern(fixed, a[keep], b[keep], reversed_order if seed % 2 else None)
    rows = pattern.block_of_row
    for shape in ((n, 6), (n, 6, 6)):
        values = rng.standard_normal(shape)
        masked = np.empty((pattern.nfree, *shape[1:]))
        masked[rows[~fixed]] = values[~fixed]
        ordered = pattern.to_matrix_order(values)
        assert ordered.tobytes() == masked.tobytes()
    solution = rng.standard_normal(6 * pattern.nfree)
    masked = np.zeros((n, 6))
    masked[rows >= 0] = solution.reshape(-1, 6)[rows[rows >= 0]]
    assert pattern.from_matrix_order(solution).tobytes() == masked.tobytes()
