"""DDA against FEM, block by block and interface by interface.

Quantities (each row one number from each side, and their difference):

``stress``
    DDA block stress (constant in a block) against the FEM area average.
``strain``
    DDA block strain, measured from the block's vertices (the stretch of the
    affine map that moved them), against the FEM area-averaged strain. For a
    homogeneous block the average strain is the compliance times the average
    stress, however the field varies: wherever the block averages of stress
    agree by statics, the strains must agree too, and they carry E and ν.
``centroid``
    DDA centroid displacement against the FEM area-mean displacement. The
    DDA's field is linear about the centroid, so its centroid value *is* its
    block mean.
``vertex``
    DDA vertex displacement (final minus initial vertices) against the FEM
    displacement of the node at that vertex.
``contact_force``
    Resultant force (x, y) on the interface's second block, DDA contacts
    against FEM springs.
``penetration``
    Sum of the DDA's penetrations over its contacts on the interface against
    the FEM's overlap integrated along the interface over its length: both
    N / (n_c p) under a resultant N. With the augmented Lagrangian the row is
    a bound instead: both sides against zero, scaled by the contact tolerance.
``contact_state``
    The fraction of an interface that is closed, and the fraction of its
    closed part that slips: DDA contacts over its contacts on the interface,
    FEM length over the interface length.
``closed_form``
    Block stresses or strains against an exact value: both sides
    (``[closed_form]``) or the DDA alone (``[dda_closed_form]``, where the
    DDA's constant-strain block has a closed form and the continuum has none).

Components are in the case's frame (``frame``, degrees from the x axis; 0 by
default): ``sxx`` is then the stress along the frame's first axis.

Every row's error is signed: ``(DDA − FEM − offset) / scale``, where
``offset`` is the predicted DDA − FEM difference (``[offsets]``, 0 where no
difference is predicted) and ``scale`` the largest FEM magnitude of that
quantity in the case (the largest block stress or strain component, the
largest displacement, the largest interface force or mean penetration).
A check passes when |error| is within its tolerance. A component that is
zero in both models then has error zero, and a small component is not blown
up by its own size.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from verify.comparison.dda_side import DdaSide
from verify.comparison.expect import STRAIN, STRESS, Expectation, ExpectationError
from verify.fem import fields
from verify.fem.statics import FemSolution, contact_tolerance_of

VECTOR = ("ux", "uy")
FORCE = ("fx", "fy")


@dataclass(frozen=True)
class Row:
    """One compared number."""

    quantity: str
    item: str  # block name, "block[vertex]" or "a|b"
    component: str
    dda: float
    fem: float
    scale: float
    exact: float = float("nan")  # closed-form value, when the row checks one
    offset: float = 0.0  # predicted DDA − FEM

    @property
    def signed_error(self) -> float:
        """(DDA − FEM − offset) / scale; against a closed form, the worse side's error."""
        if self.scale <= 0:
            return 0.0
        if np.isfinite(self.exact):
            sides = [v for v in (self.dda, self.fem) if np.isfinite(v)]
            worst = max(sides, key=lambda v: abs(v - self.exact), default=float("nan"))
            return (worst - self.exact) / self.scale
        return (self.dda - self.fem - self.offset) / self.scale

    @property
    def error(self) -> float:
        """|signed error| (NaN when a side is missing)."""
        return abs(self.signed_error)

    @property
    def key(self) -> str:
        """``quantity.item.component``, the key of ``[offsets]``."""
        return f"{self.quantity}.{self.item}.{self.component}"

    def with_offset(self, offsets: dict[str, float]) -> Row:
        """This row with its predicted offset from ``offsets`` (keyed :attr:`key`)."""
        return replace(self, offset=offsets.get(self.key, 0.0))

    def as_dict(self) -> dict:
        """The row as a plain dict, with its errors."""
        return {**asdict(self), "error": self.error, "signed_error": self.signed_error}


def _scale(values) -> float:
    values = np.abs(np.asarray(values, dtype=float))
    values = values[np.isfinite(values)]
    return float(values.max()) if values.size else 0.0


def rotation(degrees: float) -> np.ndarray:
    """Rows: the frame's axes in x, y (x' at ``degrees`` from x)."""
    a = np.radians(degrees)
    return np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])


def tensor_in_frame(values: np.ndarray, degrees: float, engineering: bool = False) -> np.ndarray:
    """(…, 3) xx, yy, xy components in the frame; ``engineering``: xy is 2 ε_xy."""
    values = np.asarray(values, dtype=float)
    shear = values[..., 2] / (2.0 if engineering else 1.0)
    tensor = np.stack(
        [np.stack([values[..., 0], shear], -1), np.stack([shear, values[..., 1]], -1)], -2
    )
    r = rotation(degrees)
    t = r @ tensor @ r.T
    factor = 2.0 if engineering else 1.0
    return np.stack([t[..., 0, 0], t[..., 1, 1], factor * t[..., 0, 1]], -1)


def vector_in_frame(values: np.ndarray, degrees: float) -> np.ndarray:
    """(…, 2) vectors in the frame."""
    return np.asarray(values, dtype=float) @ rotation(degrees).T


class RowMaker:
    """Builds the rows of one case, with its frame and predicted offsets."""

    def __init__(self, expectation: Expectation, names: list[str]) -> None:
        self.expectation = expectation
        self.names = names

    def rows(self, quantity, items, components, dda, fem, scale) -> list[Row]:
        """One row per item and component; ``dda``, ``fem``: (len(items), len(components))."""
        offsets = self.expectation.offsets
        out = []
        for item, d_row, f_row in zip(items, dda, fem, strict=True):
            for c, d, f in zip(components, d_row, f_row, strict=True):
                out.append(Row(quantity, item, c, float(d), float(f), scale).with_offset(offsets))
        return out


def block_rows(dda: DdaSide, fem: FemSolution, maker: RowMaker) -> list[Row]:
    """Stress, strain and centroid rows of every free block."""
    free = list(fem.block_mesh.blocks)
    names = [maker.names[i] for i in free]
    frame = maker.expectation.frame
    stress_f = tensor_in_frame(fields.block_average_stress(fem)[free], frame)
    strain_f = tensor_in_frame(fields.block_average_strain(fem)[free], frame, True)
    mean_f = vector_in_frame(fields.block_mean_displacement(fem)[free], frame)
    stress_d = tensor_in_frame(dda.stresses[free], frame)
    strain_d = tensor_in_frame(dda.strains[free], frame, True)
    mean_d = vector_in_frame(dda.centroid_displacement[free], frame)
    return (
        maker.rows("stress", names, STRESS, stress_d, stress_f, _scale(stress_f))
        + maker.rows("strain", names, STRAIN, strain_d, strain_f, _scale(strain_f))
        + maker.rows("centroid", names, VECTOR, mean_d, mean_f, displacement_scale(fem))
    )


def displacement_scale(fem: FemSolution) -> float:
    """Largest FEM displacement at a node (the case's displacement scale)."""
    return _scale(np.linalg.norm(fields.nodal_displacement(fem), axis=1))


def vertex_rows(dda: DdaSide, fem: FemSolution, maker: RowMaker) -> list[Row]:
    """Vertex displacements of every free block."""
    scene, frame, scale = fem.scene, maker.expectation.frame, displacement_scale(fem)
    rows = []
    for i in fem.block_mesh.blocks:
        at_nodes = fields.vertex_displacements(fem, i, scene.blocks[i].vertices)
        items = [f"{maker.names[i]}[{v}]" for v in range(len(at_nodes))]
        ddav = vector_in_frame(dda.vertex_displacement[i], frame)
        rows += maker.rows("vertex", items, VECTOR, ddav, vector_in_frame(at_nodes, frame), scale)
    return rows


def contact_rows(dda: DdaSide, fem: FemSolution, maker: RowMaker) -> list[Row]:
    """Resultant force and mean penetration of every FEM interface."""
    forces = fields.interface_forces(fem)
    frame = maker.expectation.frame
    if not forces:
        return []
    items, f_dda, f_fem, p_dda, p_fem, s_dda, s_fem = [], [], [], [], [], [], []
    for f in forces:
        a, b = f["blocks"]
        items.append(f"{maker.names[a]}|{maker.names[b]}")
        side = dda.interfaces.get((a, b))
        f_dda.append(side.force if side else np.zeros(2))
        f_fem.append(f["force"])
        p_dda.append([side.penetration if side else 0.0])
        p_fem.append([f["penetration"]])
        states = [side.closed / side.total, side.sliding / max(side.closed, 1)] if side else [0, 0]
        s_dda.append(states)
        s_fem.append([f["closed_fraction"], f["slip_fraction"]])
    f_fem = vector_in_frame(np.array(f_fem), frame)
    rows = maker.rows(
        "contact_force", items, FORCE, vector_in_frame(np.array(f_dda), frame), f_fem, _scale(f_fem)
    )
    rows += maker.rows("contact_state", items, ("closed", "slip"), s_dda, s_fem, 1.0)
    tolerance = contact_tolerance_of(fem.scene)
    if tolerance is None:
        return rows + maker.rows("penetration", items, ("d",), p_dda, p_fem, _scale(p_fem))
    return rows + [  # augmented Lagrangian: both within the tolerance
        Row("penetration", item, "d", d[0], f[0], tolerance, exact=0.0)
        for item, d, f in zip(items, p_dda, p_fem, strict=True)
    ]


def closed_form_rows(dda: DdaSide, fem: FemSolution, maker: RowMaker) -> list[Row]:
    """Block stresses or strains against ``[closed_form]`` and ``[dda_closed_form]``."""
    free = list(fem.block_mesh.blocks)
    frame = maker.expectation.frame
    sides = {
        STRESS: (
            tensor_in_frame(dda.stresses, frame),
            tensor_in_frame(fields.block_average_stress(fem), frame),
        ),
        STRAIN: (
            tensor_in_frame(dda.strains, frame, True),
            tensor_in_frame(fields.block_average_strain(fem), frame, True),
        ),
    }
    rows = []
    tables = ((maker.expectation.closed_form, True), (maker.expectation.dda_closed_form, False))
    for (table, both), where in zip(tables, ("closed_form", "dda_closed_form"), strict=True):
        for key, value in table.items():
            name, component = key.rsplit(".", 1)
            if name not in maker.names:
                raise ExpectationError(f"{where}.{key}: the scene has no block {name!r}")
            names = STRESS if component in STRESS else STRAIN
            on_dda, on_fem = sides[names]
            i, k = maker.names.index(name), names.index(component)
            fem_value = float(on_fem[i, k]) if both else float("nan")
            scale = _scale(on_fem[free])
            rows.append(
                Row("closed_form", name, component, float(on_dda[i, k]), fem_value, scale, value)
            )
    return rows


def compare(dda: DdaSide, fem: FemSolution, expectation: Expectation) -> list[Row]:
    """Every comparison row of one case (see the module notes)."""
    maker = RowMaker(expectation, [b.name for b in fem.scene.blocks])
    rows = block_rows(dda, fem, maker) + vertex_rows(dda, fem, maker)
    return rows + contact_rows(dda, fem, maker) + closed_form_rows(dda, fem, maker)


def max_errors(rows: list[Row]) -> dict[str, float]:
    """Largest error per quantity. A row without a number on a side (NaN) is left out; a
    row whose error is infinite (a fracture onset on one side only) counts, and fails."""
    out: dict[str, float] = {}
    for row in rows:
        error = row.error
        if not np.isnan(error):
            out[row.quantity] = max(out.get(row.quantity, 0.0), error)
    return out
