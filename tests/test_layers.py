"""The package keeps its plan: every import in dda/ goes down the layers of docs/design.md.

A unit is a folder of dda/ or one of the shared vocabulary's modules at its top; each
has a layer. An import from one unit into another must go to a lower layer (two units
of one layer are peers and import neither each other nor anything above). Imports
inside functions count too (they are found in the source, not by running it).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "dda"

# unit -> layer, lowest first (docs/design.md, "The package")
LAYERS = {
    "dda.errors": 0,
    "dda.geometry": 0,
    "dda.result": 0,
    "dda.jit": 0,
    "dda.cases": 0,
    "dda.kinematics": 1,
    "dda.blocks": 1,
    "dda.scene": 2,
    "dda.effects": 3,
    "dda.contact": 3,
    "dda.io": 3,
    "dda.fracture": 4,
    "dda.model": 5,
    "dda.solve": 6,
    "dda.run": 7,
    "dda": 8,  # the public API: load_scene, simulate, the result types
    "dda.bench": 9,  # the benchmark wall and its timing
    "dda.parallel": 9,  # tasks at once: in this process, or on a dask cluster
    "dda.tradeoff": 10,  # accuracy against time sweeps (the wall is one of its cases)
    "dda.stability": 10,  # factor of safety and probability of failure
    "dda.commands": 11,
    "dda.__main__": 12,
}


def unit_of(module: str) -> str:
    """The unit of a dotted module name: ``dda.solve.step`` -> ``dda.solve``."""
    parts = module.split(".")
    if len(parts) == 1:
        return "dda"
    return ".".join(parts[:2])


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path) -> list[tuple[int, str]]:
    """(line, imported module) of every ``import dda...`` / ``from dda... import``."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
            if node.module == "dda":  # from dda import cases: the module dda.cases
                names = [f"dda.{a.name}" for a in node.names if (PACKAGE / a.name).exists()]
                names = names or ["dda"]
            found += [(node.lineno, n) for n in names if n.split(".")[0] == "dda"]
        elif isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names if a.name.split(".")[0] == "dda"]
    return found


def sources() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def test_every_unit_has_a_layer():
    units = {unit_of(module_name(p)) for p in sources()}
    assert units <= set(LAYERS), f"units without a layer: {sorted(units - set(LAYERS))}"


def test_only_the_shared_vocabulary_stands_outside_a_folder():
    loose = {p.stem for p in PACKAGE.glob("*.py")}
    assert loose == {
        "__init__", "__main__", "errors", "geometry", "result", "kinematics", "blocks", "model",
    }  # fmt: skip


@pytest.mark.parametrize("path", sources(), ids=lambda p: str(p.relative_to(PACKAGE.parent)))
def test_imports_go_down_the_layers(path):
    here = unit_of(module_name(path))
    wrong = []
    for line, target in imports(path):
        there = unit_of(target)
        if there != here and LAYERS[there] >= LAYERS[here]:
            wrong.append(f"line {line}: {target} (layer {LAYERS[there]} >= {LAYERS[here]})")
    assert not wrong, f"{here} (layer {LAYERS[here]}) imports " + "; ".join(wrong)


def test_the_check_catches_an_upward_import(tmp_path):
    """The rule itself: a contact module that imports the time loop is refused."""
    source = tmp_path / "bad.py"
    source.write_text("from dda.run.simulation import run\n")
    ((line, target),) = imports(source)
    assert LAYERS[unit_of(target)] >= LAYERS["dda.contact"]
