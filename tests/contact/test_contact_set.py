"""Contacts keep their state from one step to the next through their keys."""

from __future__ import annotations

import numpy as np

from dda.contact.contact_set import ContactSet, merge, rows_in
from dda.result import LOCKED, SLIDING
from tests.contact.test_rows import two_blocks


def test_rows_in_finds_each_key_or_minus_one():
    rng = np.random.default_rng(7)
    known = rng.permutation(np.arange(0, 3000, 3))  # unique, unsorted
    keys = rng.permutation(np.arange(0, 3000, 2))[:700]
    where = {key: row for row, key in enumerate(known.tolist())}
    expected = [where.get(key, -1) for key in keys.tolist()]
    np.testing.assert_array_equal(rows_in(keys, known), expected)
    assert (rows_in(keys, known) >= 0).sum() == sum(k % 3 == 0 for k in keys.tolist())
    np.testing.assert_array_equal(rows_in(keys, known[:0]), -np.ones(700))
    np.testing.assert_array_equal(rows_in(keys[:0], known), [])


def test_merge_carries_the_state_of_the_contacts_found_again():
    blocks = two_blocks(-0.01)
    vertex, edge = np.array([4, 5]), np.array([2, 2])
    first = merge(ContactSet.empty(), blocks, vertex, edge, np.zeros(2), 1.0, np.zeros(2), 1e-9)
    first.state[:] = SLIDING
    first.normal_force[:] = [3.0, 4.0]
    again = merge(first, blocks, vertex[::-1], edge, np.zeros(2), 1.0, np.zeros(2), 1e-9)
    np.testing.assert_array_equal(again.normal_force, [4.0, 3.0])  # by key, not by position
    assert np.all(again.state == SLIDING) and not again.fresh.any()
    only_new = merge(first, blocks, np.array([6]), edge[:1], np.zeros(1), 1.0, np.zeros(1), 1e-9)
    assert only_new.state[0] == LOCKED and only_new.fresh[0] and only_new.normal_force[0] == 0.0


def test_the_compiled_merge_equals_numpy_field_by_field(monkeypatch):
    """:func:`merge` with the last step's rows given runs its compiled twin when numba
    is in use: every field, and its dtype, as the numpy code makes them."""
    from dataclasses import fields

    from dda.contact import contact_set
    from dda.result import OPEN

    blocks = two_blocks(-0.01)
    rng = np.random.default_rng(3)
    previous = merge(
        ContactSet.empty(), blocks, np.array([4, 5, 6, 4]), np.array([0, 1, 2, 3]),
        np.zeros(4), 1.0, np.zeros(4), 1e-9,
    )  # fmt: skip
    for name in ("normal_multiplier", "shear_multiplier", "penalty", "reference",
                 "slide_direction", "normal_force", "shear_force", "penetration"):  # fmt: skip
        getattr(previous, name)[:] = rng.normal(size=4)
    previous.state[:] = [OPEN, SLIDING, LOCKED, OPEN]
    previous.intact[:] = [True, False, True, False]
    vertex, edge = np.array([5, 4, 6, 4, 6]), np.array([1, 0, 3, 3, 1])
    penetration = np.array([1e-3, -1e-3, -2e-9, 0.0, -1e-12])
    parameter = rng.uniform(size=5)
    rows = contact_set.rows_in(contact_set.contact_keys(blocks, vertex, edge), previous.key)
    assert (rows >= 0).sum() == 3 and (rows < 0).sum() == 2

    def merged():
        return merge(previous, blocks, vertex, edge, penetration, 7.0, parameter, 1e-9,
                     previous_rows=rows)  # fmt: skip

    compiled = merged()
    with monkeypatch.context() as patch:
        patch.setattr(contact_set, "merge_kernel", None)
        plain = merged()
    for f in fields(ContactSet):
        a, b = getattr(plain, f.name), getattr(compiled, f.name)
        assert a.dtype == b.dtype and np.array_equal(a, b), f.name
    assert list(plain.fresh) == [False, False, True, False, True]
