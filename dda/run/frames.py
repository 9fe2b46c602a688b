"""Snapshots of the block system for the Result."""

from __future__ import annotations

import dataclasses

import numpy as np

from dda.blocks import BlockSet
from dda.contact.contact_set import ContactSet
from dda.contact.rows import contact_rows
from dda.geometry import unpack_polygons
from dda.result import Contacts, Frame


def frame_contacts(blocks: BlockSet, contacts: ContactSet) -> Contacts:
    """Public view of the contact set (rows refer to the frame's blocks)."""
    if not len(contacts):
        return Contacts.empty()
    rows = contact_rows(blocks, contacts)
    return Contacts(
        block_a=contacts.block_a.copy(),
        block_b=contacts.block_b.copy(),
        points=rows.points.copy(),
        normals=rows.normals.copy(),
        normal_force=contacts.normal_force.copy(),
        shear_force=contacts.shear_force.copy(),
        penetration=contacts.penetration.copy(),
        state=contacts.state.copy(),
    )


def make_frame(
    blocks: BlockSet,
    contacts: ContactSet,
    time: float,
    step: int,
    measured: dict[str, np.ndarray] | None = None,
    bolts: np.ndarray | None = None,
    poisson: np.ndarray | None = None,
    bolt_tensions: np.ndarray | None = None,
    bolt_ids: np.ndarray | None = None,
) -> Frame:
    """Copy the current state into an immutable Frame (``measured``: the
    ``[[measure]]`` rows since the previous frame; ``bolts``: the bolts' end points,
    ``bolt_tensions`` their tensions, ``bolt_ids`` their indices among the scene's bolts;
    ``poisson``: each block's Poisson's ratio in a plane-strain scene, whose frames carry
    szz = ν (sxx + syy), None in plane stress)."""
    out_of_plane = None
    if poisson is not None:
        out_of_plane = poisson * (blocks.stress[:, 0] + blocks.stress[:, 1])
    return Frame(
        time=float(time),
        step=int(step),
        names=tuple(blocks.names),
        ids=blocks.ids.copy(),
        centroids=blocks.centroid.copy(),
        rotations=blocks.rotation.copy(),
        velocities=blocks.velocity[:, :3].copy(),
        stresses=blocks.stress.copy(),
        displacements=blocks.displacement.copy(),
        vertices=unpack_polygons(blocks.vertices, blocks.offsets),
        areas=blocks.area.copy(),
        fixed=blocks.fixed.copy(),
        contacts=frame_contacts(blocks, contacts),
        measured=measured,
        bolts=bolts,
        bolt_tensions=bolt_tensions,
        bolt_ids=bolt_ids,
        out_of_plane=out_of_plane,
    )


def shifted(frame: Frame, origin: tuple[float, float]) -> Frame:
    """``frame`` with its positions (centroids, vertices, contact points, bolt ends) moved
    by ``origin``: from the run's local frame back to the scene's (dda.scene.local_frame).
    Displacements, velocities, stresses and forces do not change."""
    if origin == (0.0, 0.0):
        return frame
    o = np.asarray(origin, float)
    contacts = dataclasses.replace(frame.contacts, points=frame.contacts.points + o)
    return dataclasses.replace(
        frame,
        centroids=frame.centroids + o,
        vertices=[v + o for v in frame.vertices],
        contacts=contacts,
        bolts=None if frame.bolts is None else frame.bolts + o,
    )
