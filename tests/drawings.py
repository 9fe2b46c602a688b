"""DXF drawings for the tests, made with ezdxf: the shipped example (cases/drawing_example.dxf
is this function's output) and the broken drawings a scene must refuse."""

from __future__ import annotations

import math
from pathlib import Path

# the example: a 53 degree rock slope on a fixed base, cut by bedding dipping 25 degrees out
# of its face, two steep cross joints and a kinked joint near the base; a tunnel (a circle)
# in the slope is excavated by a stage
SLOPE = [(0.0, 0.0), (40.0, 0.0), (40.0, 20.0), (24.0, 20.0), (12.0, 4.0), (0.0, 4.0)]
BASE = [(0.0, -4.0), (40.0, -4.0), (40.0, 0.0), (0.0, 0.0)]
RISE = math.tan(math.radians(25.0))
BEDDING = [((4.0, y), (46.0, y + 42.0 * RISE)) for y in (-3.0, 2.0, 7.0)]
CROSS = [((26.0, -1.0), (22.0, 22.0)), ((34.0, -1.0), (30.0, 22.0))]
KINKED = [(-1.0, 2.0), (14.0, 1.2), (41.0, 1.6)]
TUNNEL = ((31.0, 8.0), 2.5)


def example_drawing(path: Path, units: int = 6) -> Path:
    """Write the example drawing (``$INSUNITS`` = ``units``, 6: metres)."""
    import ezdxf

    document = ezdxf.new("R2010")
    document.header["$INSUNITS"] = units
    for name in ("BLOCKS", "FIXED", "JOINTS", "EXCAVATION"):
        document.layers.add(name)
    space = document.modelspace()
    space.add_lwpolyline(SLOPE, close=True, dxfattribs={"layer": "BLOCKS"})
    space.add_lwpolyline(BASE, close=True, dxfattribs={"layer": "FIXED"})
    for start, end in BEDDING + CROSS:
        space.add_line(start, end, dxfattribs={"layer": "JOINTS"})
    space.add_lwpolyline(KINKED, dxfattribs={"layer": "JOINTS"})
    centre, radius = TUNNEL
    space.add_circle(centre, radius, dxfattribs={"layer": "EXCAVATION"})
    document.saveas(path)
    return path


def drawing_with(path: Path, layer: str, points, closed: bool, units: int = 6) -> Path:
    """A drawing of one polyline on ``layer`` (for the refusals)."""
    import ezdxf

    document = ezdxf.new("R2010")
    document.header["$INSUNITS"] = units
    document.layers.add(layer)
    document.modelspace().add_lwpolyline(points, close=closed, dxfattribs={"layer": layer})
    document.saveas(path)
    return path
