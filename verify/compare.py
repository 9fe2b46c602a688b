"""DDA against FEM, block by block and interface by interface.

Quantities (each row one number from each side, and their difference):

``stress``
    DDA block stress (constant in a block) against the FEM area average.
``centroid``
    DDA centroid displacement against the FEM area-mean displacement. The
    DDA's field is linear about the centroid, so its centroid value *is* its
    block mean. (The FEM value at the centroid point is reported as
    ``centroid_point``, not checked.)
``vertex``
    DDA vertex displacement (final minus initial vertices) against the FEM
    displacement of the node at that vertex.
``contact_force``
    Sum of the DDA's normal forces between two blocks against the FEM's
    normal spring resultant on that interface.
``penetration``
    Mean DDA penetration of the closed contacts against the FEM's
    length-weighted mean penetration of the closed part of the interface.
``closed_form``
    Both block stresses against an exact value, where the case gives one.
``closed_fraction`` (reported, not checked)
    DDA: closed contacts over all contacts of the pair; FEM: closed length
    over the interface length.

Errors are absolute differences divided by a scale per quantity and case:
the largest FEM magnitude of that quantity in the case (the largest stress
component of any block, the largest displacement, the largest interface
force or penetration; for penetration with the augmented Lagrangian, at
least the contact tolerance). A component that is zero in both models then has
error zero, and a small component is not blown up by its own size.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from dda.geometry import polygon_moments
from verify import fields
from verify.dda_side import DdaSide
from verify.fem import FemSolution, contact_tolerance_of

CHECKED = ("stress", "centroid", "vertex", "contact_force", "penetration")


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

    @property
    def error(self) -> float:
        """|fem - dda| / scale; with a closed form, the worse of the two against it."""
        if not np.isfinite(self.dda) or not np.isfinite(self.fem):
            return float("nan")
        if self.scale <= 0:
            return 0.0
        if np.isfinite(self.exact):
            return max(abs(self.dda - self.exact), abs(self.fem - self.exact)) / self.scale
        return abs(self.fem - self.dda) / self.scale

    def as_dict(self) -> dict:
        """The row as a plain dict, with its error."""
        return {**asdict(self), "error": self.error}


def _scale(values) -> float:
    values = np.abs(np.asarray(values, dtype=float))
    values = values[np.isfinite(values)]
    return float(values.max()) if values.size else 0.0


def stress_rows(dda: DdaSide, fem: FemSolution) -> list[Row]:
    """DDA block stress against the FEM block average, every free block and component."""
    names = [b.name for b in fem.scene.blocks]
    average = fields.block_average_stress(fem)
    free = list(fem.block_mesh.blocks)
    scale = _scale(average[free])
    return [
        Row("stress", names[i], c, float(dda.stresses[i, k]), float(average[i, k]), scale)
        for i in free
        for k, c in enumerate(fields.COMPONENTS)
    ]


def displacement_rows(dda: DdaSide, fem: FemSolution) -> list[Row]:
    """Centroid (block mean), vertex and centroid-point displacement rows."""
    scene, free = fem.scene, list(fem.block_mesh.blocks)
    names = [b.name for b in scene.blocks]
    mean = fields.block_mean_displacement(fem)
    vertex_fem = {i: fields.vertex_displacements(fem, i, scene.blocks[i].vertices) for i in free}
    scale = _scale(np.concatenate([mean[free].ravel()] + [v.ravel() for v in vertex_fem.values()]))
    rows = []
    for i in free:
        centroid = block_centroid(np.asarray(scene.blocks[i].vertices))
        point = fields.displacement_at_point(fem, i, centroid)
        for k, c in enumerate(("ux", "uy")):
            ddav = float(dda.centroid_displacement[i, k])
            rows.append(Row("centroid", names[i], c, ddav, float(mean[i, k]), scale))
            rows.append(Row("centroid_point", names[i], c, ddav, float(point[k]), scale))
        for v, (du, fu) in enumerate(zip(dda.vertex_displacement[i], vertex_fem[i], strict=True)):
            for k, c in enumerate(("ux", "uy")):
                rows.append(Row("vertex", f"{names[i]}[{v}]", c, float(du[k]), float(fu[k]), scale))
    return rows


def block_centroid(vertices: np.ndarray) -> np.ndarray:
    """Area centroid of one polygon."""
    return polygon_moments(vertices, np.array([0, len(vertices)]))["centroid"][0]


def contact_rows(dda: DdaSide, fem: FemSolution) -> list[Row]:
    """Normal force, mean penetration and closed fraction of every FEM interface."""
    names = [b.name for b in fem.scene.blocks]
    forces = fields.interface_forces(fem)
    force_scale = _scale([f["normal_force"] for f in forces])
    # with the augmented Lagrangian both penetrations are within the tolerance
    pen_scale = max(
        _scale([f["penetration"] for f in forces]), contact_tolerance_of(fem.scene) or 0
    )
    rows = []
    for f in forces:
        a, b = f["blocks"]
        item = f"{names[a]}|{names[b]}"
        side = dda.interfaces.get((a, b))
        n_dda = side.normal_force if side else 0.0
        p_dda = side.penetration if side else 0.0
        closed = side.count / side.total if side else 0.0
        rows.append(Row("contact_force", item, "N", n_dda, f["normal_force"], force_scale))
        rows.append(Row("penetration", item, "d", p_dda, f["penetration"], pen_scale))
        rows.append(Row("closed_fraction", item, "-", closed, f["closed_fraction"], 1.0))
    return rows


def closed_form_rows(dda: DdaSide, fem: FemSolution, exact: dict[str, float]) -> list[Row]:
    """Rows of block stresses with a closed form, keyed ``"block.component"``."""
    names = [b.name for b in fem.scene.blocks]
    average = fields.block_average_stress(fem)
    scale = _scale(average[list(fem.block_mesh.blocks)])
    rows = []
    for key, value in exact.items():
        name, component = key.rsplit(".", 1)
        i, k = names.index(name), fields.COMPONENTS.index(component)
        rows.append(
            Row(
                "closed_form",
                name,
                component,
                float(dda.stresses[i, k]),
                float(average[i, k]),
                scale,
                exact=value,
            )
        )
    return rows


def compare(dda: DdaSide, fem: FemSolution, exact: dict[str, float] | None = None) -> list[Row]:
    """Every comparison row of one case (see the module notes)."""
    rows = stress_rows(dda, fem) + displacement_rows(dda, fem) + contact_rows(dda, fem)
    return rows + closed_form_rows(dda, fem, exact or {})


def max_errors(rows: list[Row]) -> dict[str, float]:
    """Largest error per quantity."""
    out: dict[str, float] = {}
    for row in rows:
        error = row.error
        if np.isfinite(error):
            out[row.quantity] = max(out.get(row.quantity, 0.0), error)
    return out
