"""Stage micro-benchmarks on the wall's first step: one stage, several implementations.

Used to document what each optimisation bought (docs/benchmarks.md):

* contact search: compiled grid + screen against the numpy/shapely path;
* assembly of K: scatter kernel, its numpy fallback (bincount), and the
  reference COO assembly (``np.add.at`` per contact, sum of duplicates,
  BSR -> CSC) the engine used before;
* factorisation: SuperLU with its own ordering on the scalar matrix, SuperLU
  on the matrix pre-ordered by the block ordering, PARDISO numeric phase;
* solves: one direct solve, and PCG on the next step's K with the old
  factorisation against factorising it.

``python -m dda.bench.stages 30`` prints one Markdown table.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

import dda
import dda.contact.broad as broad
import dda.contact.narrow as narrow
import dda.solve.assembly as assembly
from dda.bench.scenes import wall_scene
from dda.contact.contact_set import ContactSet
from dda.contact.pipeline import refresh_contacts
from dda.contact.rows import contact_rows
from dda.effects.base import StepContext
from dda.model import build
from dda.solve.linsolve import (
    Factorisation,
    PardisoFactorisation,
    block_ordering,
    pardiso_available,
    pcg,
)
from dda.solve.policy import DEFAULT, current_policy
from dda.solve.step import _effect_terms, _stiffness

PCG_SETTINGS = (DEFAULT.pcg_tolerance, DEFAULT.max_pcg_iterations)  # the runs' PCG


def best_of(function: Callable[[], object], repeat: int = 3) -> float:
    """Smallest wall time of ``repeat`` calls, seconds."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def reference_assembly(diagonal, fixed, block_a, block_b, terms) -> sp.csc_matrix:
    """K as the engine built it before: np.add.at, duplicates summed by np.unique, BSR."""
    rows = assembly.free_rows(fixed)
    nfree = int((~fixed).sum())
    diagonal = diagonal.copy()
    pi, pj, blocks = [], [], []
    for row_i, row_j, k in terms:
        ki, kj = k[:, None] * row_i, k[:, None] * row_j
        np.add.at(diagonal, block_a, ki[:, :, None] * row_i[:, None, :])
        np.add.at(diagonal, block_b, kj[:, :, None] * row_j[:, None, :])
        pi.append(block_a)
        pj.append(block_b)
        blocks.append(ki[:, :, None] * row_j[:, None, :])
    pi, pj, blocks = np.concatenate(pi), np.concatenate(pj), np.concatenate(blocks)
    both = (rows[pi] >= 0) & (rows[pj] >= 0) & (pi != pj)
    ri, rj, blocks = rows[pi[both]], rows[pj[both]], blocks[both]
    lo, hi = np.minimum(ri, rj), np.maximum(ri, rj)
    blocks = np.where((ri <= rj)[:, None, None], blocks, blocks.transpose(0, 2, 1))
    unique, inverse = np.unique(lo * nfree + hi, return_inverse=True)
    summed = np.zeros((len(unique), 6, 6))
    np.add.at(summed, inverse, blocks)
    ulo, uhi = unique // nfree, unique % nfree
    brow = np.concatenate([np.arange(nfree), ulo, uhi])
    bcol = np.concatenate([np.arange(nfree), uhi, ulo])
    data = np.concatenate([diagonal[~fixed], summed, summed.transpose(0, 2, 1)])
    order = np.lexsort((bcol, brow))
    indptr = np.zeros(nfree + 1, dtype=np.int64)
    np.cumsum(np.bincount(brow, minlength=nfree), out=indptr[1:])
    k = sp.bsr_matrix((data[order], bcol[order], indptr), shape=(6 * nfree,) * 2, blocksize=(6, 6))
    return k.tocsc()


def _search_rows(model, blocks) -> list[tuple[str, float]]:
    settings = model.contact
    out = [
        (
            "contact search, compiled",
            best_of(lambda: refresh_contacts(blocks, ContactSet.empty(), settings)),
        )
    ]
    saved = broad._grid_kernel, narrow._detect_kernel, narrow._screen_kernel
    broad._grid_kernel, narrow._detect_kernel, narrow._screen_kernel = None, None, None
    try:
        out.append(
            (
                "contact search, numpy + shapely STRtree",
                best_of(lambda: refresh_contacts(blocks, ContactSet.empty(), settings)),
            )
        )
    finally:
        broad._grid_kernel, narrow._detect_kernel, narrow._screen_kernel = saved
    return out


def _all_stuck(contacts: ContactSet, law) -> tuple[np.ndarray, ...]:
    """(kn, ks, normal offsets, shear offsets) with every contact closed and stuck."""
    none = np.zeros(len(contacts))
    return contacts.penalty, law.shear_ratio * contacts.penalty, none, none


def stage_rows(columns: int) -> list[tuple[str, float]]:
    """(what, milliseconds) for every stage and implementation on a columns x columns wall."""
    model = build(dda.load_scene(wall_scene(columns, steps=2)))
    blocks = model.blocks.copy()
    rows_out = _search_rows(model, blocks)
    contacts = refresh_contacts(blocks, ContactSet.empty(), model.contact)
    ctx = StepContext(dt=1e-3, time=1e-3, step=1, static=False)
    base_k, base_f = _effect_terms(model, blocks, ctx)
    crows = contact_rows(blocks, contacts)
    law = model.contact.law
    coefficients = _all_stuck(contacts, law)
    pattern = assembly.BlockPattern(
        blocks.fixed, contacts.block_a, contacts.block_b, block_ordering
    )
    rows_out.append(
        (
            "pattern (ordering, CSR structure, slots), once per graph",
            best_of(
                lambda: assembly.BlockPattern(
                    blocks.fixed, contacts.block_a, contacts.block_b, block_ordering
                )
            ),
        )
    )
    rows_out.append(
        (
            "assemble K, scatter kernel",
            best_of(lambda: _stiffness(pattern, blocks, base_k, coefficients, crows, law)),
        )
    )
    saved = assembly._scatter_kernel
    assembly._scatter_kernel = None
    try:
        rows_out.append(
            (
                "assemble K, numpy bincount fallback",
                best_of(lambda: _stiffness(pattern, blocks, base_k, coefficients, crows, law)),
            )
        )
    finally:
        assembly._scatter_kernel = saved
    p, ps, _, _ = coefficients
    terms = [(crows.normal_i, crows.normal_j, p), (crows.shear_i, crows.shear_j, ps)]
    rows_out.append(
        (
            "assemble K, reference COO (before)",
            best_of(
                lambda: reference_assembly(
                    base_k, blocks.fixed, contacts.block_a, contacts.block_b, terms
                ),
                1,
            ),
        )
    )
    k, _ = _stiffness(pattern, blocks, base_k, coefficients, crows, law)
    natural = reference_assembly(base_k, blocks.fixed, contacts.block_a, contacts.block_b, terms)
    rhs = np.random.default_rng(0).normal(size=k.shape[0])
    rows_out.append(
        (
            "factorise, SuperLU MMD on the scalar matrix (before)",
            best_of(lambda: Factorisation(natural), 1),
        )
    )
    rows_out.append(
        (
            "factorise, SuperLU, block MMD order (pattern)",
            best_of(lambda: Factorisation(k, "NATURAL"), 1),
        )
    )
    superlu = Factorisation(k, "NATURAL")
    rows_out.append(("solve, SuperLU", best_of(lambda: superlu.solve(rhs))))
    nearby = sp.csc_matrix(
        (k.data * (1.0 + 1e-6 * np.cos(np.arange(k.nnz))), k.indices, k.indptr), shape=k.shape
    )
    nearby = sp.csc_matrix(0.5 * (nearby + nearby.T))
    rows_out.append(
        (
            "PCG on a perturbed K with the old SuperLU factor",
            best_of(lambda: pcg(nearby, rhs, superlu.solve, *PCG_SETTINGS)),
        )
    )
    if pardiso_available():
        threads = current_policy().solver_threads()
        pardiso = PardisoFactorisation(k)
        rows_out.append(
            (
                "factorise, PARDISO numeric phase (analysis kept)",
                best_of(lambda: pardiso.factor(k, threads)),
            )
        )
        pardiso.factor(k, threads)
        rows_out.append(("solve, PARDISO", best_of(lambda: pardiso.solve(rhs))))
    return rows_out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m dda.bench.stages")
    parser.add_argument("sizes", type=int, nargs="+")
    args = parser.parse_args(argv)
    dda.simulate(dda.load_scene(wall_scene(2, steps=2)))  # compile kernels first
    tables = {n: stage_rows(n) for n in args.sizes}
    names = [name for name, _ in tables[args.sizes[0]]]
    sys.stdout.write(
        "| stage (wall's first step) | " + " | ".join(f"{n}x{n} ms" for n in args.sizes) + " |\n"
    )
    sys.stdout.write("|---|" + "---|" * len(args.sizes) + "\n")
    for i, name in enumerate(names):
        cells = " | ".join(f"{1000 * tables[n][i][1]:.2f}" for n in args.sizes)
        sys.stdout.write(f"| {name} | {cells} |\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
