"""Polygon integrals and checks on packed polygons (docs/theory.md §2).

Polygons are stored packed: ``vertices`` (NV, 2) with ``offsets`` (n+1,) so
that block i owns rows ``offsets[i]:offsets[i+1]``. All functions are
vectorised over every polygon at once.
"""

from __future__ import annotations

import numpy as np


def next_vertex_index(offsets: np.ndarray) -> np.ndarray:
    """Index of the next vertex (cyclic within each polygon) for every vertex."""
    counts = np.diff(offsets)
    nxt = np.arange(offsets[-1]) + 1
    last = offsets[1:] - 1
    nxt[last] = offsets[:-1]
    nxt[last[counts == 0]] = last[counts == 0]
    return nxt


def block_sizes(vertices: np.ndarray, offsets: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """(n,) each polygon's size 4 A / P (area over perimeter): a square's side, a circle's
    diameter, twice a sliver's thickness (√A would be √(length × thickness))."""
    edges = vertices[next_vertex_index(offsets)] - vertices
    lengths = np.hypot(edges[:, 0], edges[:, 1])
    perimeter = np.bincount(owner_of_vertex(offsets), weights=lengths, minlength=len(areas))
    return 4.0 * np.asarray(areas) / np.maximum(perimeter, 1e-300)


def previous_vertex_index(offsets: np.ndarray) -> np.ndarray:
    """Index of the previous vertex (cyclic within each polygon)."""
    prv = np.arange(offsets[-1]) - 1
    prv[offsets[:-1]] = offsets[1:] - 1
    return prv


def expand_counts(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For counts c_k: (k repeated c_k times, 0..c_k-1 for each k), the segment and the
    position within it of every item of segments packed one after the other."""
    segment = np.repeat(np.arange(len(counts)), counts)
    starts = np.cumsum(counts) - counts
    return segment, np.arange(counts.sum()) - starts[segment]


def owner_of_vertex(offsets: np.ndarray) -> np.ndarray:
    """Polygon index of every packed vertex."""
    return np.repeat(np.arange(len(offsets) - 1), np.diff(offsets))


def polygon_moments(vertices: np.ndarray, offsets: np.ndarray) -> dict[str, np.ndarray]:
    """Area integrals of every polygon by Green's theorem.

    Returns S = ∫dA, the centroid (x0, y0) = (∫x dA, ∫y dA)/S and the second
    moments about the centroid Ixx = ∫(x-x0)² dA, Iyy = ∫(y-y0)² dA,
    Ixy = ∫(x-x0)(y-y0) dA. Edge terms use the exact polygon formulas
    (per edge with c = x_k y_{k+1} - x_{k+1} y_k):
    S = Σc/2, Sx = Σ(x_k+x_{k+1})c/6, Sxx = Σ(x_k²+x_k x_{k+1}+x_{k+1}²)c/12,
    Sxy = Σ(x_k y_{k+1} + 2x_k y_k + 2x_{k+1} y_{k+1} + x_{k+1} y_k)c/24.
    Counter-clockwise polygons have S > 0; concave polygons are fine.
    """
    n = len(offsets) - 1
    owner = owner_of_vertex(offsets)
    nxt = next_vertex_index(offsets)
    # shift to a per-polygon reference point for round-off safety
    ref = vertices[offsets[:-1]]
    p = vertices - ref[owner]
    q = p[nxt]
    terms = edge_moment_terms(p[:, 0], p[:, 1], q[:, 0], q[:, 1])
    sums = [np.bincount(owner, weights=term, minlength=n) for term in terms]
    s, sx, sy, sxx, syy, sxy = polygon_integrals(*sums)
    with np.errstate(divide="ignore", invalid="ignore"):
        cx, cy = sx / s, sy / s
    ixx, iyy, ixy = central_moments(s, cx, cy, sxx, syy, sxy)
    return {
        "area": s,
        "centroid": np.column_stack([cx, cy]) + ref,
        "ixx": ixx,
        "iyy": iyy,
        "ixy": ixy,
    }


# edge_moment_terms, polygon_integrals and central_moments are formulas (arithmetic only,
# arrays or numbers): dda.blocks registers them with dda.jit.formula for its moments
# kernel (this module, below dda.jit's layer, cannot)
def edge_moment_terms(x0, y0, x1, y1):
    """The edge (x0, y0) → (x1, y1)'s terms of Green's theorem (:func:`polygon_moments`),
    c, (x0+x1) c, (y0+y1) c, (x0²+x0 x1+x1²) c, (y0²+y0 y1+y1²) c and
    (x0 y1+2 x0 y0+2 x1 y1+x1 y0) c, with c = x0 y1 − x1 y0. Arithmetic only: arrays
    here, one edge's numbers in the compiled twin (:mod:`dda.blocks`)."""
    c = x0 * y1 - x1 * y0
    return (
        c,
        (x0 + x1) * c,
        (y0 + y1) * c,
        (x0 * x0 + x0 * x1 + x1 * x1) * c,
        (y0 * y0 + y0 * y1 + y1 * y1) * c,
        (x0 * y1 + 2 * x0 * y0 + 2 * x1 * y1 + x1 * y0) * c,
    )


def polygon_integrals(sum_c, sum_x, sum_y, sum_xx, sum_yy, sum_xy):
    """S, Sx, Sy, Sxx, Syy, Sxy from the sums of :func:`edge_moment_terms` over a
    polygon's edges (divided by 2, 6, 6, 12, 12, 24)."""
    return sum_c / 2.0, sum_x / 6.0, sum_y / 6.0, sum_xx / 12.0, sum_yy / 12.0, sum_xy / 24.0


def central_moments(s, cx, cy, sxx, syy, sxy):
    """Ixx, Iyy, Ixy about the centroid (cx, cy): Sxx − S cx², Syy − S cy², Sxy − S cx cy."""
    return sxx - s * cx * cx, syy - s * cy * cy, sxy - s * cx * cy


def pack_polygons(polygons: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Pack a list of (k_i, 2) arrays into ``(vertices, offsets)``."""
    counts = np.array([len(p) for p in polygons], dtype=np.int64)
    offsets = np.zeros(len(polygons) + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    if len(polygons) == 0:
        return np.zeros((0, 2)), offsets
    return np.concatenate([np.asarray(p, dtype=float) for p in polygons]), offsets


def unpack_polygons(vertices: np.ndarray, offsets: np.ndarray) -> list[np.ndarray]:
    """Split packed vertices back into one array per polygon (copies)."""
    return [vertices[a:b].copy() for a, b in zip(offsets[:-1], offsets[1:], strict=True)]


def reflex_vertices(vertices: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """True where the interior angle of a counter-clockwise polygon exceeds 180°."""
    prv = vertices[previous_vertex_index(offsets)]
    nxt = vertices[next_vertex_index(offsets)]
    a = vertices - prv
    b = nxt - vertices
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] < 0.0


def power_of_two_centre(low: np.ndarray, high: np.ndarray, size: float) -> np.ndarray:
    """The centre of the box [low, high] rounded to a multiple of 2^⌈log₂ size⌉.

    Points in the box and that origin are then multiples of one power of two, so
    ``xy - origin`` (and adding it back) is exact in floating point: work done in those
    small local coordinates gives the input's digits back bit for bit. (0, 0) for a
    size that is not positive and finite.
    """
    if not np.isfinite(size) or size <= 0.0:
        return np.zeros(2)
    step = 2.0 ** np.ceil(np.log2(size))
    return np.round(0.5 * (low + high) / step) * step
