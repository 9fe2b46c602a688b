"""A static contact solve by a primal–dual interior-point method: the equilibrium start's
limit solve in a number of iterations that does not follow the number of contacts that
change state.

The step's Newton (:mod:`dda.solve.newton`) assumes a piece of every contact's potential
(open or closed, stuck or sliding) and corrects the wrong ones iteration by iteration;
where a static solve moves thousands of contacts onto other pieces its line steps stay
short and its iterations grow with the model (docs/contact.md). Here the pieces are not
assumed: every contact's forces are unknowns beside D, and the method follows the
central path of the contact conditions to their solution.

The solution is what the step's Newton passes converge to: D and, for every contact,
its normal force N and shear force F with

    K₀ D − F₀ + Σ N ∇g + Σ F ∇s = 0                the blocks' equilibrium
    N = max(λn + p g, −T)                           the normal spring, tension at most T
    F = clamp(λt + ps s, −b(N), b(N))               the shear spring within the bound

b(N) the friction bound of the contact's own normal force (Coulomb, Barton–Bandis). As
complementarity, with N' = N + T, y = λn + p g + T and z = λt + ps s:

    N' = y + w,           N' ≥ 0,  w ≥ 0,   N' w = μ
    F = z − u + v,        u ≥ 0,   v ≥ 0
    σ₁ = b(N) − F ≥ 0,    σ₂ = b(N) + F ≥ 0, u σ₁ = μ,  v σ₂ = μ

(μ = 0: the conditions above; w is the normal spring's unused stretch, u and v the
slip either way). Each iteration is a Newton step on these equations at a μ that
shrinks towards 0 (Mehrotra's predictor–corrector: a predictor step at μ = 0 sets the
centring σ = (μ_aff / μ)³, the corrector carries the predictor's second-order terms;
then Gondzio's centrality correctors push the products that the step would take
outside [0.1, 10] σμ back in, while that lengthens the step: 6 fewer factorisations in
the 40 × 40 wall's start),
cut to keep every N', w, u, v, σ₁, σ₂ positive (``interior_step_to_boundary``). The contact
unknowns are eliminated contact by contact:

    ΔN' = kn Δg + c_N,     kn = p N' / (N' + w)
    ΔF = ks Δs + k_sn ΔN' + c_F,
    ks = ps / q,   k_sn = b'(N) (u / σ₁ − v / σ₂) / q,   q = 1 + u / σ₁ + v / σ₂

so that each iteration factorises K₀ + Σ kn ∇g ∇gᵀ + Σ ks ∇s ∇sᵀ + Σ k_sn kn ∇s ∇gᵀ,
unsymmetric where a contact slides (its shear force follows its normal force: friction
is not associated), by :class:`dda.solve.unsymmetric.UnsymmetricLU`. A stuck contact has
ks → ps, a sliding one ks → 0 and k_sn → ±b'(N), an open one kn → 0: the springs of its
piece, reached continuously.

The method starts from the solution with every contact closed and stuck (one linear
solve), its forces shifted into the interior by a typical contact force f. Where blocks
cannot stand that start lies far inside the solution's slacks: a block its contacts
cannot hold moves by its load over the regulariser, and w, u, v of its contacts grow
with it to ~1e8 f. The iterates then creep towards them, their steps cut to a few
hundredths by the bounds, for about 20 iterations. So the first step cut below
``interior_stall_step`` raises every w, u, v to at least ``interior_stall_shift`` f (a
"big M"; the products N'w, u σ₁, v σ₂ and μ with them), and the method goes on from
there: 31 factorisations for the tunnel's start, not 59. It stops when
μ and the residuals are small against the loads; the caller finishes with the step's
Newton from there, whose pieces are then the solution's (one iteration, measured on the
bench walls and the shipped cases: docs/contact.md).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy

from dda.contact.potential import ContactTerms
from dda.contact.strength import JointProperties
from dda.jit import compiled, floats
from dda.solve.interior_contacts import (
    LIFT,
    ROOM_BACK,
    ROOM_FORWARD,
    SHEAR,
    SLIP_BACK,
    SLIP_FORWARD,
    SPARE,
    UNKNOWNS,
    advance_kernel,
    centring_kernel,
    centring_push,
    contact_direction,
    contact_residuals,
    direction_kernel,
    free_terms,
    matrix_values_kernel,
    mean_product_kernel,
    moved_value,
    product_after,
    residuals_kernel,
    rhs_kernel,
    room,
    springs_kernel,
)
from dda.solve.interior_contacts import springs as interior_springs
from dda.solve.newton import BlockQuadratic, ContactGeometry
from dda.solve.policy import StepPolicy, current_policy
from dda.solve.unsymmetric import UnsymmetricLU

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class StaticContactProblem:
    """The data of one static solve: the blocks' quadratic ½ DᵀK₀D − F₀ᵀD (with the
    regulariser), the contacts' gaps, their springs and tension (``terms``: λn, p, T,
    λt, ps; its bounds are not used) and the friction bound b(N) of every contact."""

    quadratic: BlockQuadratic
    geometry: ContactGeometry
    terms: ContactTerms
    bound: Callable[[np.ndarray], np.ndarray]
    friction: bool
    joints: JointProperties | None = None  # the law's bond rule, for the caller


@dataclass
class InteriorSolution:
    """What :func:`solve_interior` found."""

    d: np.ndarray  # (n, 6)
    normal: np.ndarray  # (m,) N
    iterations: int  # factorisations, the first (all contacts closed and stuck) included
    converged: bool


def solve_interior(
    problem: StaticContactProblem,
    matrix: NewtonMatrix | None = None,
    policy: StepPolicy | None = None,
    after_iteration: Callable[[int], None] | None = None,
) -> InteriorSolution:
    """D, N of ``problem`` by the predictor–corrector interior-point method (module
    docstring; its settings: the policy's ``interior_*``); ``converged`` False when
    ``interior_iterations`` did not reach the end, the iterates stopped being finite or
    nothing is loaded. ``matrix``: a :class:`NewtonMatrix` that fits the problem
    (:meth:`NewtonMatrix.fits`), to re-use (its pattern, its analysis); else one is made
    and released. ``policy``: the settings (None: the environment's).
    ``after_iteration``: told the factorisations so far after each iteration (a long
    solve's progress; what it raises ends the solve, the matrix released if made here)."""
    policy = current_policy() if policy is None else policy
    own = matrix is None
    system = NewtonMatrix(problem) if own else matrix.load(problem)
    iterate = _Iterate(problem, system, policy)
    iterations, converged = 1, False
    try:
        if iterate.start():
            while iterations < policy.interior_iterations and iterate.finite():
                residuals = iterate.residuals()
                if iterate.converged(residuals):
                    converged = True
                    break
                iterate.step(residuals)
                iterations += 1
                if after_iteration is not None:
                    after_iteration(iterations)
    finally:
        if own:
            system.release()
    log.debug("interior point: %d factorisations, converged %s", iterations, converged)
    normal = iterate.normal() if converged else np.zeros(0)
    return InteriorSolution(iterate.d(), normal, iterations, converged)


class NewtonMatrix:
    """K₀ + Σ kn ∇g∇gᵀ + Σ ks ∇s∇sᵀ + Σ k_sn kn ∇s∇gᵀ over the free blocks' unknowns, on
    one sparsity pattern (every contact's two blocks coupled), and its LU. The pattern
    and the contacts' part are those of the contacts' blocks and gradients; K₀'s values
    are the problem's (:meth:`load`)."""

    def __init__(self, problem: StaticContactProblem) -> None:
        quadratic, geometry = problem.quadratic, problem.geometry
        rows = geometry.rows
        free = quadratic.free
        number = np.full(len(free), -1)  # each free block's number among the free ones
        number[free] = np.arange(int(free.sum()))
        column = np.where(number >= 0, 6 * number, -1)
        self.free, self.size = free.copy(), 6 * int(free.sum())
        a, b = geometry.block_a, geometry.block_b
        self.blocks = (np.array(a), np.array(b))
        dofs = _dofs(column, a, b)
        self.normal_rows = np.concatenate([rows.normal_i, rows.normal_j], axis=1)  # (m, 12)
        self.shear_rows = np.concatenate([rows.shear_i, rows.shear_j], axis=1)
        self.gn = _rows_matrix(self.normal_rows, dofs, self.size)
        self.gs = _rows_matrix(self.shear_rows, dofs, self.size)
        self.gn_t, self.gs_t = self.gn.T.tocsr(), self.gs.T.tocsr()  # Σ N ∇g, Σ F ∇s
        gn, gs = self.gn, self.gs  # the kernels' CSR rows of ∇g and ∇s
        self.gradient_rows = (gn.indptr, gn.indices, gn.data, gs.indptr, gs.indices, gs.data)
        self.gn_abs, self.gs_abs = abs(self.gn), abs(self.gs)  # the gaps' round-off
        couplings = quadratic.couplings
        self.contact_blocks = (number[a], number[b])
        self.bolt_blocks = None
        if couplings is not None:
            self.bolt_blocks = (number[couplings.block_i], number[couplings.block_j])
        paired = [self.contact_blocks] + ([] if couplings is None else [self.bolt_blocks])
        self.blocks_pattern = BlockPattern(int(free.sum()), paired)
        self.pattern = self.blocks_pattern.csr()
        self.where = self.blocks_pattern.places(*self.contact_blocks)
        blocks = np.arange(self.blocks_pattern.count)  # each free block with itself
        self.diagonal = self.blocks_pattern.places(blocks, blocks)[:, :6, :6].reshape(-1)
        self.bolt_where = (
            None if couplings is None else self.blocks_pattern.places(*self.bolt_blocks)
        )
        self._fill = None
        self.lu = UnsymmetricLU(self.pattern)
        self.load(problem)

    def fits(self, problem: StaticContactProblem) -> bool:
        """True when ``problem`` has this matrix's blocks, contacts and gradients."""
        geometry, rows = problem.geometry, problem.geometry.rows
        same = (
            np.array_equal(problem.quadratic.free, self.free)
            and np.array_equal(geometry.block_a, self.blocks[0])
            and np.array_equal(geometry.block_b, self.blocks[1])
        )
        normal = np.concatenate([rows.normal_i, rows.normal_j], axis=1) if same else None
        shear = np.concatenate([rows.shear_i, rows.shear_j], axis=1) if same else None
        coupled = (problem.quadratic.couplings is not None) == (self.bolt_blocks is not None)
        return (
            same and coupled
            and np.array_equal(normal, self.normal_rows)
            and np.array_equal(shear, self.shear_rows)
        )  # fmt: skip

    def load(self, problem: StaticContactProblem) -> NewtonMatrix:
        """K₀'s values (the blocks' and the couplings' springs) of ``problem``."""
        quadratic = problem.quadratic
        self.base = np.zeros(self.blocks_pattern.values)
        self.base[self.diagonal] = quadratic.stiffness[self.free].reshape(-1)
        couplings = quadratic.couplings
        if couplings is not None:
            rows_b = np.concatenate([couplings.row_i, couplings.row_j], axis=1)
            outer = couplings.stiffness[:, None, None] * rows_b[:, :, None] * rows_b[:, None, :]
            valid = self.bolt_where >= 0
            np.add.at(self.base, self.bolt_where[valid], outer[valid])
        return self

    def factor(self, kn: np.ndarray, ks: np.ndarray, k_sn: np.ndarray) -> None:
        """Factorise the matrix of the springs kn, ks and the coupling k_sn (per contact)."""
        if compiled(matrix_values_kernel):
            values = matrix_values_kernel(
                self.base, self.where, self.normal_rows, self.shear_rows, kn, ks, k_sn * kn
            )
        else:
            values = self.base + self.fill @ np.column_stack([kn, ks, k_sn * kn]).ravel()
        self.lu.factor(values)

    @property
    def fill(self) -> scipy.sparse.csr_matrix:
        """The (values × 3m) matrix W with W (kn, ks, k_sn kn of each contact in turn) =
        the contacts' part of the values (:func:`_fill_matrix`), made at its first use
        (numpy's path)."""
        if self._fill is None:
            values = self.blocks_pattern.values
            self._fill = _fill_matrix(self.normal_rows, self.shear_rows, self.where, values)
        return self._fill

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        return self.lu.solve(rhs)

    def release(self) -> None:
        self.lu.release()


class BlockPattern:
    """The CSR pattern of a matrix over the free blocks' unknowns (6 a block) whose 6 × 6
    blocks couple each free block with itself and with the blocks it is paired with, and
    the places of those couplings among its values, found block by block (a search in
    the blocks' pairs, not in the unknowns' 36 times as many).

    Block row I with deg(I) blocks, the first at place ptr(I) among the blocks' pairs
    sorted by (row, column): its unknowns' row 6I + r starts at 36 ptr(I) + 6 r deg(I),
    and the column 6J + s of its k-th block J is 6 k + s further on."""

    def __init__(self, count: int, pairs: list[tuple[np.ndarray, np.ndarray]]) -> None:
        """``count`` free blocks; ``pairs``: (first, second) free-block numbers of the
        paired blocks (−1: a fixed block, no coupling), each pair coupled both ways."""
        self.count = count
        keys = [np.arange(count) * (count + 1)]  # the diagonal blocks
        for first, second in pairs:
            both = (first >= 0) & (second >= 0)
            keys += [first[both] * count + second[both], second[both] * count + first[both]]
        keys = np.unique(np.concatenate(keys))
        self.keys = keys
        self.indptr = _indptr(keys // max(count, 1), count)
        self.values = 36 * len(keys)

    def csr(self) -> scipy.sparse.csr_matrix:
        """The unknowns' pattern (values 0), column indices sorted in each row."""
        count, size = self.count, 6 * self.count
        row = self.keys // max(count, 1)
        start = self.indptr[row]
        place = self._places(row, start, np.arange(len(self.keys)) - start)
        columns = 6 * (self.keys % max(count, 1))[:, None, None] + np.arange(6)
        indices = np.empty(self.values, dtype=np.int32)
        indices[place.reshape(-1)] = np.broadcast_to(columns, place.shape).reshape(-1)
        indptr = np.zeros(size + 1, dtype=np.int64)
        indptr[1:] = np.cumsum(np.repeat(6 * np.diff(self.indptr), 6))
        return scipy.sparse.csr_matrix((np.zeros(self.values), indices, indptr), shape=(size, size))

    def places(self, first: np.ndarray, second: np.ndarray) -> np.ndarray:
        """(k, 12, 12) the places among the values of the unknowns of blocks ``first`` (rows
        0-5, columns 0-5) and ``second`` (6-11) of each pair, −1 where a block is fixed
        (int32 where the values allow)."""
        index = np.int32 if self.values < np.iinfo(np.int32).max else np.int64
        out = np.full((len(first), 12, 12), -1, dtype=index)
        for rows, i in ((first, 0), (second, 6)):
            for columns, j in ((first, 0), (second, 6)):
                both = (rows >= 0) & (columns >= 0)
                row = rows[both]
                start = self.indptr[row]
                rank = np.searchsorted(self.keys, row * self.count + columns[both]) - start
                out[both, i : i + 6, j : j + 6] = self._places(row, start, rank)
        return out

    def _places(self, row: np.ndarray, start: np.ndarray, rank: np.ndarray) -> np.ndarray:
        """(k, 6, 6) the places of the 6 × 6 blocks at block row ``row`` (its first block
        at ``start`` among the blocks' pairs), the ``rank``-th of their row:
        36 start + 6 r deg(row) + 6 rank + s."""
        degree = (self.indptr[row + 1] - start)[:, None, None]
        r, s = np.arange(6)[None, :, None], np.arange(6)[None, None, :]
        return 36 * start[:, None, None] + 6 * r * degree + 6 * rank[:, None, None] + s


def _dofs(column: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(m, 12) the unknowns of blocks a and b (−1 for a fixed block's)."""
    offsets = np.arange(6)
    first = np.where(column[a][:, None] >= 0, column[a][:, None] + offsets, -1)
    second = np.where(column[b][:, None] >= 0, column[b][:, None] + offsets, -1)
    return np.concatenate([first, second], axis=1)


def _fill_matrix(normal, shear, where, values: int) -> scipy.sparse.csr_matrix:
    """The (pattern's values × 3m) matrix W with W (kn, ks, k_sn kn of each contact in
    turn: columns 3c, 3c + 1, 3c + 2) = the contacts' part of the values: ∇g∇gᵀ, ∇s∇sᵀ
    and ∇s∇gᵀ of each contact at its blocks' unknowns (``where``: their places among the
    values, −1 for a fixed block's). Its rows' entries, sorted by column, add a value's
    terms contact by contact, each contact's three in turn: the order of the kernel
    :func:`dda.solve.interior_contacts._matrix_values`."""
    m = len(where)
    valid = where >= 0
    contact = np.broadcast_to(np.arange(m)[:, None, None], valid.shape)[valid]
    parts = [
        (normal[:, :, None] * normal[:, None, :])[valid],
        (shear[:, :, None] * shear[:, None, :])[valid],
        (shear[:, :, None] * normal[:, None, :])[valid],
    ]
    return scipy.sparse.csr_matrix(
        (
            np.concatenate(parts),
            (np.tile(where[valid], 3), np.concatenate([3 * contact + k for k in range(3)])),
        ),
        shape=(values, 3 * m),
    )


def _indptr(rows: np.ndarray, size: int) -> np.ndarray:
    out = np.zeros(size + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=size), out=out[1:])
    return out


def _rows_matrix(rows: np.ndarray, dofs: np.ndarray, size: int) -> scipy.sparse.csr_matrix:
    """The (m, size) matrix whose row c holds ``rows[c]`` at the unknowns ``dofs[c]``."""
    m = len(rows)
    valid = dofs >= 0
    contact = np.broadcast_to(np.arange(m)[:, None], dofs.shape)
    return scipy.sparse.csr_matrix((rows[valid], (contact[valid], dofs[valid])), shape=(m, size))


class _Iterate:
    """The iterate: x (D's free unknowns), the gaps g, s and the contact unknowns stacked
    in ``state`` (7, m), the rows of :mod:`dda.solve.interior_contacts`: N' (N + T),
    w, F, u, v, σ₁, σ₂. Where the kernels are used (:func:`dda.jit.compiled`), an
    iteration's contact algebra is a few compiled calls (:meth:`step`), else numpy runs
    the same formulas on the arrays."""

    def __init__(
        self, problem: StaticContactProblem, system: NewtonMatrix, policy: StepPolicy
    ) -> None:
        self.problem, self.system, self.policy = problem, system, policy
        quadratic, terms = problem.quadratic, problem.terms
        self.forces = quadratic.forces[system.free].ravel()
        self.load = quadratic.load_norm
        self.live = terms.shear_penalty > 0.0
        if problem.friction:
            probe = np.full(len(self.live), 1e3 * max(self.load, 1.0))
            self.live &= problem.bound(probe) > 0.0  # a bound that grows with N
        else:
            self.live[:] = False
        self.x = np.zeros(system.size)
        self.g = problem.geometry.rows.penetration.copy()
        self.s = problem.geometry.rows.slip.copy()
        self.scale = 0.0  # f: a typical contact force, set by :meth:`start`
        self.stalled = False  # a step was cut below interior_stall_step (raise_slacks)
        self.state = np.zeros((UNKNOWNS, len(self.live)))
        self.fast = compiled(direction_kernel)
        if self.fast:  # the kernels' copy of λn, p, T, λt, ps (:func:`residuals_kernel`)
            rows = (terms.normal_base, terms.penalty, terms.tension, terms.shear_base,
                    terms.shear_penalty)  # fmt: skip
            self.terms = np.array(rows, dtype=np.float64)
            self.penalties = self.terms[1], self.terms[4]  # p, ps: its rows, not copies

    def d(self) -> np.ndarray:
        """D (n, 6) of the iterate (fixed blocks 0)."""
        out = np.zeros_like(self.problem.quadratic.forces)
        out[self.system.free] = self.x.reshape(-1, 6)
        return out

    def normal(self) -> np.ndarray:
        """N = N' − T."""
        return self.state[LIFT] - self.problem.terms.tension

    def finite(self) -> bool:
        """x and every contact unknown finite (an overflow ends the solve unconverged)."""
        return bool(np.all(np.isfinite(self.x)) and np.all(np.isfinite(self.state)))

    def gradient(self, normal: np.ndarray, shear: np.ndarray) -> np.ndarray:
        """K₀ D − F₀ + Σ N ∇g + Σ F ∇s over the free unknowns."""
        system = self.system
        kd = self.problem.quadratic.product(self.d())[system.free].ravel()
        return kd - self.forces + system.gn_t @ normal + system.gs_t @ shear

    def move(self, dx: np.ndarray) -> None:
        self.x = self.x + dx
        self.g = self.g + self.system.gn @ dx
        self.s = self.s + self.system.gs @ dx

    def start(self) -> bool:
        """The linear solve with every contact closed and stuck, its contact unknowns
        shifted into the interior by ``interior_start_shift`` f, f the larger of the loads'
        root mean square per free block and the mean normal force there. False when
        nothing is loaded (f = 0)."""
        t, live = self.problem.terms, self.live
        shear_springs = np.where(live, t.shear_penalty, 0.0)
        self.system.factor(t.penalty, shear_springs, np.zeros_like(t.penalty))
        normal = t.normal_trial(self.g)
        shear = np.where(live, t.shear_trial(self.s), 0.0)
        self.move(self.system.solve(-self.gradient(normal, shear)))
        y = t.normal_trial(self.g) + t.tension
        blocks = max(1, int(self.system.free.sum()))
        mean = float(np.mean(np.abs(y))) if len(y) else 0.0
        self.scale = f = max(self.load / np.sqrt(blocks), mean)
        if not f > 0.0:
            return False
        shift = self.policy.interior_start_shift * f
        state = self.state
        state[LIFT], state[SPARE] = np.maximum(y, 0.0) + shift, np.maximum(-y, 0.0) + shift
        bound = self.problem.bound(self.normal())
        z = t.shear_trial(self.s)
        state[SHEAR] = np.where(live, np.clip(z, -0.5 * bound, 0.5 * bound), 0.0)
        state[SLIP_FORWARD] = state[SLIP_BACK] = np.where(live, shift, 1.0)
        state[ROOM_FORWARD] = np.where(live, np.maximum(bound - state[SHEAR], shift), 1.0)
        state[ROOM_BACK] = np.where(live, np.maximum(bound + state[SHEAR], shift), 1.0)
        return True

    def residuals(self) -> _Residuals:
        """The equations' residuals at the iterate, and the bound's slope b'(N)
        (:func:`contact_residuals`)."""
        t, live, state = self.problem.terms, self.live, self.state
        normal = self.normal()
        bound = self.problem.bound(normal)
        step = self.policy.interior_slope_step * np.maximum(np.abs(normal), self.scale)
        after = self.problem.bound(normal + step)
        equilibrium = self.gradient(normal, state[SHEAR])
        if self.fast:
            contact = residuals_kernel(
                state, self.g, self.s, self.terms, floats(bound), floats(after), step, live
            )
            return _Residuals(equilibrium, contact)
        y = t.normal_trial(self.g) + t.tension
        z = t.shear_trial(self.s)
        lift, spare, shear, u, v, r1, r2 = state
        contact = np.array(
            contact_residuals(lift, spare, shear, u, v, r1, r2, y, z, bound, after, step, live)
        )
        return _Residuals(equilibrium, contact)

    def complementarity(self, step: _Direction | None = None, alpha: float = 0.0) -> float:
        """μ: the mean of N'w, u σ₁ and v σ₂ (after ``alpha`` × ``step`` when given)."""
        moved = step is not None
        change = step.change if moved else self.state  # (not read where not moved)
        if self.fast:
            return mean_product_kernel(self.state, change, float(alpha), moved, self.live)
        lift, spare, _, u, v, r1, r2 = moved_value(self.state, change, alpha, moved)
        live = self.live
        total = float(lift @ spare) + float(u[live] @ r1[live]) + float(v[live] @ r2[live])
        return total / max(1, len(lift) + 2 * int(live.sum()))

    def converged(self, residuals: _Residuals) -> bool:
        """μ within ``interior_complementarity_end`` f² and every residual within
        ``interior_residual_end`` of its force (at least f) plus ``interior_round_off`` of
        the large terms whose difference the force is (a sliding block's D, and with it
        its slip u and its shear spring's stretch z, grow as the regulariser falls: z − u
        keeps only their round-off)."""
        f, policy = self.scale, self.policy
        end, round_off = policy.interior_residual_end, policy.interior_round_off
        if self.complementarity() > policy.interior_complementarity_end * f * f:
            return False
        if np.linalg.norm(residuals.equilibrium) > end * max(self.load, f):
            return False
        t, system, x = self.problem.terms, self.system, np.abs(self.x)
        rows = self.problem.geometry.rows
        lift, spare, shear, u, v, r1, r2 = self.state
        # the large terms whose difference is a force: an open contact's y and w, a
        # sliding one's z and u (or v), all with the gaps' own round-off p |∇g||D|
        y = np.abs(t.normal_trial(self.g)) + spare
        y += t.penalty * (np.abs(rows.penetration) + system.gn_abs @ x)
        z = np.abs(t.shear_trial(self.s)) + u + v
        z += t.shear_penalty * (np.abs(rows.slip) + system.gs_abs @ x)
        forces = (lift, np.abs(shear), r1, r2)
        noises = (y, z, 0.0, 0.0)
        return all(
            bool(np.all(np.abs(r) <= end * np.maximum(force, f) + round_off * noise))
            for r, force, noise in zip(residuals.contact[:4], forces, noises, strict=True)
        )

    def step(self, residuals: _Residuals) -> None:
        """One predictor–corrector iteration (one factorisation, two solves)."""
        springs = self.springs(residuals.contact[4])
        self.system.factor(springs[0], springs[1], springs[2])
        mu, fraction = self.complementarity(), self.policy.interior_step_to_boundary
        predictor = self.direction(residuals, springs, 0.0, np.zeros((3, len(self.live))))
        reach = self.reach(predictor, 1.0)
        target = (self.complementarity(predictor, reach) / mu) ** 3 * mu
        second = self.second_order(predictor)
        corrector = self.direction(residuals, springs, target, second)
        alpha = self.reach(corrector, fraction)
        for _ in range(self.policy.interior_centrality_correctors):
            aim = min(1.0, 1.5 * alpha + 0.1)
            changes = self.centring(corrector, aim, target, second)
            better = self.direction(residuals, springs, target, changes)
            longer = self.reach(better, fraction)
            if longer < alpha + 0.1 * (aim - alpha):
                break
            corrector, alpha, second = better, longer, changes
        self.advance(corrector, alpha)
        if alpha < self.policy.interior_stall_step and not self.stalled:
            self.raise_slacks()

    def raise_slacks(self) -> None:
        """After the first stall (a step cut below ``interior_stall_step``): every w, and u
        and v of the contacts with friction, at least ``interior_stall_shift`` f (a big M,
        module docstring)."""
        self.stalled = True
        floor, state, live = self.policy.interior_stall_shift * self.scale, self.state, self.live
        state[SPARE] = np.maximum(state[SPARE], floor)
        for row in (SLIP_FORWARD, SLIP_BACK):
            state[row] = np.where(live, np.maximum(state[row], floor), state[row])

    def springs(self, slope: np.ndarray) -> np.ndarray:
        """(4, m): kn, ks, k_sn, q of every contact (:func:`interior_springs`)."""
        t, state = self.problem.terms, self.state
        if self.fast:
            return springs_kernel(state, slope, *self.penalties, self.live)
        return np.array(interior_springs(
            state[LIFT], state[SPARE], state[SLIP_FORWARD], state[SLIP_BACK],
            state[ROOM_FORWARD], state[ROOM_BACK], slope, t.penalty, t.shear_penalty, self.live,
        ))  # fmt: skip

    @staticmethod
    def second_order(step: _Direction) -> np.ndarray:
        """(3, m) ΔN'Δw, Δu Δσ₁, Δv Δσ₂ of ``step``: the products' terms beyond the linear
        ones (Mehrotra's corrector carries the predictor's)."""
        change = step.change
        return np.array([change[LIFT] * change[SPARE],
                         change[SLIP_FORWARD] * change[ROOM_FORWARD],
                         change[SLIP_BACK] * change[ROOM_BACK]])  # fmt: skip

    def centring(self, step: _Direction, aim: float, target: float, second) -> np.ndarray:
        """(3, m) ``second`` less Gondzio's push (:func:`centring_push`) of N'w, u σ₁,
        v σ₂ after ``aim`` × ``step`` (0 where not live) towards [0.1, 10] ``target``."""
        state, change, live = self.state, step.change, self.live
        if self.fast:
            return centring_kernel(state, change, float(aim), float(target), second, live)
        trial = [
            product_after(state[LIFT], change[LIFT], state[SPARE], change[SPARE], aim),
            np.where(live, product_after(state[SLIP_FORWARD], change[SLIP_FORWARD],
                                         state[ROOM_FORWARD], change[ROOM_FORWARD], aim), 0.0),
            np.where(live, product_after(state[SLIP_BACK], change[SLIP_BACK],
                                         state[ROOM_BACK], change[ROOM_BACK], aim), 0.0),
        ]  # fmt: skip
        return second - centring_push(np.array(trial), target)

    def direction(self, res: _Residuals, springs, target: float, second) -> _Direction:
        """The Newton direction of the equations with the products N'w, u σ₁, v σ₂ at
        ``target`` less ``second`` (their terms beyond the linear ones: the predictor's
        products, Mehrotra; less Gondzio's push towards the target) (module docstring;
        contact by contact :mod:`dda.solve.interior_contacts`, compiled where the kernels
        are used)."""
        t, live, system, state = self.problem.terms, self.live, self.system, self.state
        if self.fast:
            rows = system.gradient_rows
            rhs, n_free, f_free = rhs_kernel(
                res.equilibrium, rows, state, springs, res.contact, float(target), second, live
            )
            dx = system.solve(rhs)
            change, limit = direction_kernel(
                dx, rows, state, springs, res.contact, *self.penalties, n_free, f_free,
                float(target), second, live,
            )  # fmt: skip
            return _Direction(dx, change, float(limit))
        kn, ks, k_sn, q = springs
        lift, spare, _, u, v, r1, r2 = state
        res_n, res_s, res_1, res_2, slope = res.contact
        n_free, f_free = free_terms(lift, spare, u, v, r1, r2, q, res_n, res_s, res_1, res_2,
                                    target, *second, live)  # fmt: skip
        rhs = -res.equilibrium - system.gn_t @ n_free - system.gs_t @ (f_free + k_sn * n_free)
        dx = system.solve(rhs)
        dg, ds = system.gn @ dx, system.gs @ dx
        change = np.array(contact_direction(
            dg, ds, lift, spare, u, v, r1, r2, kn, ks, k_sn, slope, t.penalty, t.shear_penalty,
            n_free, f_free, res_n, res_s, res_1, res_2, target, second[1], second[2], live,
        ))  # fmt: skip
        rooms = [room(state[j], change[j]) for j in (LIFT, SPARE)]
        rooms += [room(state[j][live], change[j][live])
                  for j in range(SLIP_FORWARD, UNKNOWNS)]  # fmt: skip
        limit = min((float(np.min(r)) for r in rooms if len(r)), default=np.inf)
        return _Direction(dx, change, limit)

    def reach(self, step: _Direction, fraction: float) -> float:
        """The longest step ≤ 1 that keeps N', w, u, v, σ₁, σ₂ positive, times ``fraction``."""
        return min(1.0, fraction * step.limit)

    def advance(self, step: _Direction, alpha: float) -> None:
        """Move the iterate by ``alpha`` × ``step``."""
        if self.fast:
            advance_kernel(self.x, self.g, self.s, self.state, self.system.gradient_rows,
                           step.x, step.change, float(alpha))  # fmt: skip
            return
        self.move(alpha * step.x)
        self.state = self.state + alpha * step.change


@dataclass(frozen=True)
class _Residuals:
    equilibrium: np.ndarray  # K₀D − F₀ + Σ N∇g + Σ F∇s (free unknowns)
    contact: np.ndarray  # (5, m): y + w − N', z − u + v − F, b(N) − F − σ₁, b(N) + F − σ₂, b'(N)


@dataclass(frozen=True)
class _Direction:
    x: np.ndarray
    change: np.ndarray  # (7, m) of the contact unknowns, the rows of ``_Iterate.state``
    limit: float  # the largest step that keeps the contact unknowns positive
