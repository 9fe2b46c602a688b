"""The FEM side of a rock mass standing in its in-situ stress, and of an opening made by a stage.

From the scene alone (``[in_situ]``, ``[[boundary_stresses]]``, ``[[stages]]``), as
docs/scene.md defines them, never from the engine:

- the field σ0(y) = ``stress`` + ``gradient`` · y is the initial stress of every element:
  its load is −∫ σ0 : ε(v) dA and the element stresses are σ0 + C ε(u);
- every contact point of a joint carries the field's traction from the start, as its
  multipliers: with n the master's outward normal (towards the slave) and t its tangent,
  λn = (n·σ0·n) w and λt = (t·σ0·n) w (w the point's tributary length), the forces
  that balance σ0 across the joint (:mod:`verify.fem.contact_law`'s signs);
- a boundary stress loads the boundary facets of the meshed blocks that no other
  block covered when it was applied (the stages' removed blocks counted until their
  stage), midpoint in its box, with ∫ (σ·n)·v ds;
- the blocks a stage removes are not meshed: the FEM solves the state after the last
  stage, statically (:func:`excavated`).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import shapely
from skfem import FacetBasis, LinearForm
from skfem.helpers import ddot, dot, sym_grad

from dda.scene import Scene
from verify.fem.contact import ContactPoints
from verify.fem.geometry import geometric_tolerance
from verify.fem.mesh import BlockMesh


def excavated(scene: Scene) -> Scene:
    """``scene`` after its stages: without the blocks they remove (the scene the FEM solves
    and the DDA's last frame is compared in; its boundary stresses keep the times they are
    in force, judged against :func:`present_at` of the scene as written)."""
    gone = {name for stage in scene.stages for name in stage.remove}
    if not gone:
        return scene
    kept = tuple(b for b in scene.blocks if b.name not in gone)
    return dataclasses.replace(scene, blocks=kept)


def present_at(scene: Scene, time: float) -> list[np.ndarray]:
    """The polygons of the scene's blocks there at ``time`` (a stage at that time has
    removed its blocks)."""
    gone = {name for stage in scene.stages if stage.time <= time for name in stage.remove}
    return [np.asarray(b.vertices, float) for b in scene.blocks if b.name not in gone]


def field_at(field, y: np.ndarray) -> np.ndarray:
    """(3, ...) sxx, syy, sxy of a scene stress field at heights ``y``."""
    stress = np.asarray(field.stress, float).reshape(3, *([1] * np.ndim(y)))
    gradient = np.asarray(field.gradient, float).reshape(3, *([1] * np.ndim(y)))
    return stress + gradient * np.asarray(y, float)[None]


def _tensor(s: np.ndarray) -> np.ndarray:
    """(2, 2, ...) from (3, ...) sxx, syy, sxy."""
    return np.array([[s[0], s[2]], [s[2], s[1]]])


@LinearForm
def _initial_stress_form(v, w):
    return -ddot(w["sigma"], sym_grad(v))


@LinearForm
def _traction_form(v, w):
    sigma = w["sigma"]
    traction = np.einsum("ij...,j...->i...", sigma, w.n)
    return dot(traction, v)


def initial_stress_load(scene: Scene, basis) -> np.ndarray:
    """−∫ σ0 : ε(v) dA over the meshed blocks (zero without ``[in_situ]``)."""
    if scene.in_situ is None:
        return np.zeros(basis.N)
    sigma = _tensor(field_at(scene.in_situ, np.asarray(basis.global_coordinates()[1])))
    return _initial_stress_form.assemble(basis, sigma=sigma)


def initial_stress_at(scene: Scene, y: np.ndarray) -> np.ndarray:
    """(3, ...) σ0 at heights ``y`` (zeros without ``[in_situ]``)."""
    if scene.in_situ is None:
        return np.zeros((3, *np.shape(y)))
    return field_at(scene.in_situ, y)


def contact_preload(scene: Scene, contact: ContactPoints) -> tuple[np.ndarray, np.ndarray]:
    """(λn, λt) of every contact point carrying the in-situ field (zeros without it)."""
    if scene.in_situ is None or not len(contact):
        return np.zeros(len(contact)), np.zeros(len(contact))
    s = field_at(scene.in_situ, contact.points[:, 1])
    n = contact.normal
    t = np.column_stack([-n[:, 1], n[:, 0]])
    sigma_n = np.stack([s[0] * n[:, 0] + s[2] * n[:, 1], s[2] * n[:, 0] + s[1] * n[:, 1]], 1)
    normal = np.einsum("mi,mi->m", n, sigma_n) * contact.weight
    shear = np.einsum("mi,mi->m", t, sigma_n) * contact.weight
    return normal, shear


def boundary_stress_load(written: Scene, bm: BlockMesh, element) -> np.ndarray:
    """∫ (σ·n)·v ds over the loaded boundary facets of every ``[[boundary_stresses]]``
    entry of the scene as ``written`` in force after its stages (empty without them)."""
    total = np.zeros(0)
    for stress in written.boundary_stresses:
        if stress.off != np.inf:
            continue
        facets = _loaded_facets(written, bm, stress)
        if not len(facets):
            continue
        basis = FacetBasis(bm.mesh, element, facets=facets)
        sigma = _tensor(field_at(stress.field, np.asarray(basis.global_coordinates()[1])))
        load = _traction_form.assemble(basis, sigma=sigma)
        total = load if not len(total) else total + load
    return total


def _loaded_facets(written: Scene, bm: BlockMesh, stress) -> np.ndarray:
    """Boundary facets with their midpoint in the box that no other block present when
    the boundary stress was applied covers."""
    mesh = bm.mesh
    facets = mesh.boundary_facets()
    mid = mesh.p[:, mesh.facets[:, facets]].mean(axis=1).T
    owner = bm.element_block[mesh.f2t[0, facets]]
    x0, y0, x1, y1 = stress.box
    inside = (mid[:, 0] >= x0) & (mid[:, 0] <= x1) & (mid[:, 1] >= y0) & (mid[:, 1] <= y1)
    own = np.array([shapely.Polygon(p) for p in bm.polygons], dtype=object)[owner]
    tol = 10 * geometric_tolerance(written)
    points = shapely.points(mid)
    covered = np.zeros(len(facets), bool)
    for vertices in present_at(written, stress.on):
        other = shapely.Polygon(vertices)
        near = shapely.dwithin(other, points, tol) & ~shapely.equals(own, other)
        covered |= near
    return facets[inside & ~covered]
