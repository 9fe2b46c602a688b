"""Overlap found at a new contact is removed by position, not by velocity.

A contact found for the first time already overlapping (a pairing that detection
could not make earlier: among fresh fracture fragments, where a corner slips between
pieces that part at a node, or a scene drawn overlapping) would push the blocks apart
with its penalty spring, and the spring's energy ½ p g₀² would become kinetic energy
the blocks never had (a fragment's corner found 0.36 mm deep: 1.4 kJ in one step).
Like the position correction of game-physics contact solvers, the step is solved with
such a contact starting at touch (its start penetration g₀ taken out of its gap), and
what overlap the step leaves is removed by a displacement left out of the velocity.

The push moves the blocks, it does not set them moving, so a rigid motion costs no
energy, and a strain costs its elastic energy, which the block's spring-back would turn
into motion. The push is therefore the displacement of least strain energy, among
those the least rigid motion,

    min ½ Dᵀ W D   subject to   G D ≤ b,
    W_i = K_i + ε (E_i / m_i) M_i^rigid,

K_i the block's springs of the step without its inertia (elasticity, material damping,
fixed points), M_i^rigid the translation and rotation rows of its mass matrix, ε =
``RIGID_WEIGHT``: a rigid push of the overlap e costs about ε E e², a strain that takes
it up E e². G holds every contact's normal row (penetration d = d0 + G D, fixed blocks
not moving) and b its room: at a contact found overlapping by e with penetration g from
touch after the step, b = −(e + g) (the push leaves it touching; nothing where the step
has parted it); at every other contact b = max(−g, 0) (a closed contact goes no deeper,
an open one may close its gap): a push drives no block into a third one, and the blocks
behind a contact it closes are pushed along.

This is a least-distance problem in x = Lᵀ D (W = L Lᵀ block by block): min ‖x‖ with
Ĝ x ≤ b, solved as Lawson and Hanson's non-negative least squares on [−Ĝᵀ; −bᵀ]
(scipy.optimize.nnls), over the contacts it has to respect, found by rounds: those that
must move and those within reach of them, then every contact the last push drove beyond
its room by more than ``SLACK`` of the overlap. In a packed mass (more than ``PACKED``
contacts within reach: a rock mass in its in-situ field, every contact closed) a rigid
push would shove the whole mass; there the push is the least ½ Dᵀ K₀ D, K₀ the step's
block stiffness with its inertia 2M/Δt², which keeps it local (a few blocks strained).

An overlap found late is one the blocks sank into with no contact, turning potential
energy into motion; the push lifts them back out, and the energy it stores (potential,
elastic) would be energy made, as their motion stays. The pushed blocks pay for it
(:func:`pay_for_the_push`): their kinetic energy falls by what the push stores less the
loads' work over it, as far as they have it.
"""

from __future__ import annotations

import logging

import numpy as np

from dda.contact.contact_set import ContactSet
from dda.contact.rows import ContactRows, gaps_after
from dda.result import OPEN

log = logging.getLogger(__name__)

# the rigid motion's weight in the push's metric, over each block's E / m: a rigid push
# is this many times cheaper than a strain of the same size
RIGID_WEIGHT = 1e-6
# of the deepest overlap: a contact driven beyond its room by less is not held (its
# spring gives back at most 1e-4 of the ½ p e² the push takes out; a push in a packed
# mass reaches every block of it by ever smaller moves, and a smaller slack holds them
# all: cases/tunnel_deep.toml's pushes 0.06 s each at 1e-2, 0.5-1 s at 1e-4)
SLACK = 1e-2
# rounds that add the contacts the last push drove beyond their room
ROUNDS = 20
# a round holds every contact of a block the last push moved that it brought within this
# many overlaps of its room, not only those it drove beyond (fewer rounds)
LOOK_AHEAD = 1.0
# contacts within reach beyond which a mass is packed: its rigid push would move the whole
# of it (cases/tunnel_deep.toml: 1,400 contacts, 0.5-1 s a push), and the push is local
PACKED = 300
# the unknowns a push moves: first the rigid motion alone, then with the strain
RIGID, ALL = 3, 6


def found_overlap(contacts: ContactSet, touch: float) -> np.ndarray:
    """(m,) the penetration each contact found this step (``fresh``) touching was found
    with (``contacts.penetration``, at detection: not the ground's prescribed motion of
    the step), where deeper than ``touch`` (the contacts' touch tolerance) and carrying
    no force yet (a contact preloaded by an in-situ field keeps its overlap); 0
    elsewhere."""
    found = contacts.fresh & (contacts.state != OPEN) & (contacts.penetration > touch)
    found &= contacts.normal_multiplier == 0.0
    return np.where(found, contacts.penetration, 0.0)


def push_metric(springs: np.ndarray, masses: np.ndarray, young_over_mass: np.ndarray) -> np.ndarray:
    """(n, 6, 6) W_i = K_i + ε (E_i / m_i) M_i^rigid: the blocks' ``springs`` without
    inertia, and ``RIGID_WEIGHT`` of their ``masses``' translation and rotation rows."""
    metric = springs.copy()
    metric[:, :3, :3] += RIGID_WEIGHT * young_over_mass[:, None, None] * masses[:, :3, :3]
    return metric


def push_out_displacement(
    metric: np.ndarray,
    fixed: np.ndarray,
    contacts: ContactSet,
    rows: ContactRows,
    overlap: np.ndarray,
    after: np.ndarray,
    step_stiffness: np.ndarray | None = None,
) -> np.ndarray:
    """(n, 6) the push D (module docstring) for the contacts with ``overlap`` e > 0
    (zeros where none is left), ``metric`` W (n, 6, 6), D = 0 on ``fixed`` blocks,
    ``after`` every contact's penetration after the step's D (the overlapping ones' from
    touch). In a packed mass (more than ``PACKED`` contacts within reach) the push is
    the least ½ Dᵀ K₀ D with ``step_stiffness`` K₀ (inertia and elasticity: a local
    push) where it is given."""
    n = len(fixed)
    room = np.where(overlap > 0.0, -(after + overlap), np.maximum(-after, 0.0))
    must = room < 0.0
    if not must.any():
        return np.zeros((n, 6))
    free = ~fixed
    slack = SLACK * float(overlap.max())
    reach = float(-room.min())  # the deepest overlap
    packed = _within_reach(contacts, free, room, reach)
    modes = [(metric, RIGID, packed), (metric, ALL, packed)]
    if step_stiffness is not None and packed.sum() > PACKED:
        modes = [(step_stiffness, ALL, must)]
    for weights, dofs, held in modes:
        whiten = _whitening(weights, free, dofs)
        push = _push_in_rounds(whiten, dofs, free, contacts, rows, room, reach, slack, held)
        if push is not None:
            return push
    log.debug("push-out: no displacement meets the contacts' room")
    return np.zeros((n, 6))


def _whitening(metric: np.ndarray, free: np.ndarray, dofs: int) -> np.ndarray:
    """(n, 6, 6) L⁻ᵀ of the free blocks' metric on their first ``dofs`` unknowns (W = L Lᵀ
    there, D = L⁻ᵀ x), zero on the others: the push moves only those."""
    whiten = np.zeros((len(free), 6, 6))
    factor = np.linalg.cholesky(metric[free][:, :dofs, :dofs])
    whiten[np.ix_(free, range(dofs), range(dofs))] = np.linalg.inv(factor).transpose(0, 2, 1)
    return whiten


def _push_in_rounds(
    whiten, dofs, free, contacts, rows, room, reach, slack, held
) -> np.ndarray | None:
    """The least-distance push (:func:`_least_distance_push`) over the contacts ``held``
    (those that must move, and those within reach of them: :func:`_within_reach`), then,
    round by round, every contact the last push drove beyond its room; None where none
    meets their room; ``reach`` the deepest overlap."""
    held = held.copy()
    for _ in range(ROUNDS):
        chosen = np.flatnonzero(held)
        push = _least_distance_push(whiten, dofs, free, contacts, rows, chosen, room)
        if push is None:
            return None
        motion = _normal_motion(contacts, rows, push)
        beyond = motion - room > slack
        if not beyond.any():
            return push
        if not (beyond & ~held).any():
            return None  # the contacts it holds are beyond their room: none meets it
        moved = push.any(axis=1)
        near = (motion - room > -LOOK_AHEAD * reach) & (
            moved[contacts.block_a] | moved[contacts.block_b]
        )
        held |= beyond | near
    log.debug("push-out: %d contacts held after %d rounds", held.sum(), ROUNDS)
    return push


def _within_reach(contacts: ContactSet, free: np.ndarray, room: np.ndarray, reach: float):
    """(m,) the contacts that must move (room < 0) and every contact with less room than
    ``reach`` of the free blocks joined to theirs by such contacts: a rigid push of one
    block of a packed mass moves the blocks it is packed with (fewer rounds)."""
    import scipy.sparse.csgraph  # here: a run without a push does not load scipy.sparse

    near = room < reach
    a, b = contacts.block_a[near], contacts.block_b[near]
    link = free[a] & free[b]
    n = len(free)
    graph = scipy.sparse.coo_matrix((np.ones(link.sum()), (a[link], b[link])), shape=(n, n))
    label = scipy.sparse.csgraph.connected_components(graph, directed=False)[1]
    must = room < 0.0
    seeds = np.concatenate([contacts.block_a[must], contacts.block_b[must]])
    inside = np.isin(label, label[seeds[free[seeds]]]) & free
    return must | (near & (inside[contacts.block_a] | inside[contacts.block_b]))


def _least_distance_push(
    whiten: np.ndarray,
    dofs: int,
    free: np.ndarray,
    contacts: ContactSet,
    rows: ContactRows,
    chosen: np.ndarray,
    room: np.ndarray,
) -> np.ndarray | None:
    """(n, 6) D = L⁻ᵀ x, x the least ‖x‖ with Ĝ x ≤ b at the ``chosen`` contacts (Ĝ their
    rows in x): by NNLS, min ‖E u − f‖, u ≥ 0, E = [−Ĝᵀ; −bᵀ], f = (0, …, 0, 1), then
    x = −r / r_last with r = E u − f (Lawson and Hanson, ch. 23); None where r_last ≥ 0
    (no x meets them)."""
    import scipy.optimize  # here: a run without a push does not load it

    n = len(free)
    ends = np.concatenate([contacts.block_a[chosen], contacts.block_b[chosen]])
    gradient = np.concatenate([rows.normal_i[chosen], rows.normal_j[chosen]])
    which = np.tile(np.arange(len(chosen)), 2)
    moving = free[ends]
    ends, gradient, which = ends[moving], gradient[moving], which[moving]
    blocks, column = np.unique(ends, return_inverse=True)
    rows_x = np.einsum("ej,eji->ei", gradient, whiten[ends])[:, :dofs]  # g L⁻ᵀ
    g_hat = np.zeros((len(chosen), dofs * len(blocks)))
    np.add.at(g_hat, (which[:, None], dofs * column[:, None] + np.arange(dofs)), rows_x)
    # each row over its norm, b over the largest of those distances: x in units of the
    # farthest constraint, whatever the metric's scale (K₀'s 2M/Δt² at a small Δt)
    norms = np.linalg.norm(g_hat, axis=1)
    bound = room[chosen]
    if np.any((norms == 0.0) & (bound < 0.0)):
        return None  # a contact the unknowns cannot move
    keep = norms > 0.0
    g_hat, bound = g_hat[keep] / norms[keep, None], bound[keep] / norms[keep]
    scale = float(np.abs(bound).max())
    system = np.vstack([-g_hat.T, -bound[None, :] / scale])
    target = np.zeros(len(system))
    target[-1] = 1.0
    try:
        weights = scipy.optimize.nnls(system, target, maxiter=50 * system.shape[1])[0]
    except RuntimeError:  # its iterations ran out
        return None
    residual = system @ weights - target
    if residual[-1] >= -1e-12:
        return None
    x = (-scale * residual[:-1] / residual[-1]).reshape(-1, dofs)
    push = np.zeros((n, 6))
    push[blocks] = np.einsum("bij,bj->bi", whiten[blocks][:, :, :dofs], x)
    return push


def _normal_motion(contacts: ContactSet, rows: ContactRows, d: np.ndarray) -> np.ndarray:
    """(m,) G D: each contact's change of penetration under D (n, 6)
    (:func:`dda.contact.rows.gaps_after` less the penetration it starts from)."""
    return gaps_after(rows, contacts.block_a, contacts.block_b, d)[0] - rows.penetration


def pay_for_the_push(
    velocity: np.ndarray, pushed: np.ndarray, masses: np.ndarray, cost: float
) -> None:
    """Scale the velocities (n, 6, in place) of the blocks that ``pushed`` (n, 6) moved so
    that their kinetic energy ½ Σ vᵢᵀ Mᵢ vᵢ (``masses`` (n, 6, 6)) falls by ``cost`` (the
    energy the push stored less the loads' work over it), to 0 at most; nothing where
    the cost is not positive (a push that lowers the blocks gives the loads' work)."""
    moved = np.flatnonzero(np.any(pushed != 0.0, axis=1))
    if cost <= 0.0 or not len(moved):
        return
    v = velocity[moved]
    kinetic = 0.5 * float(np.einsum("ni,nij,nj->", v, masses[moved], v))
    if kinetic > 0.0:
        velocity[moved] = v * np.sqrt(max(0.0, 1.0 - cost / kinetic))
