"""Contacts keep their state from one step to the next through their keys."""

from __future__ import annotations

import numpy as np

from dda.contact.contact_set import ContactSet, merge, rows_in
from dda.result import LOCKED, SLIDING
from tests.test_contact_rows import two_blocks


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
