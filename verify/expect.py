"""What a verification case expects: ``cases/verify/NAME.expect.toml``.

The scene file stays an ordinary scene (the loader refuses unknown keys);
its expectations live beside it::

    summary = "One block under self-weight on a fixed base"
    quick = true                # part of the quick suite (default test run)
    component = "syy"           # stress component shown in the picture
    [fem]
    size = 0.125                # element size (default: mesh.default_size)
    order = 2
    [checks.stress]             # one table per checked quantity
    tolerance = 1e-4            # largest error allowed (see verify.compare)
    why = "..."                 # why this agreement is expected
    blocks = ["block"]          # optional: only these blocks (or interfaces touching them)
    [closed_form]               # optional exact values, "block.component"
    "block.syy" = -13243.5
    [notes]                     # optional: why a reported quantity is not checked
    vertex = "..."

A quantity without a ``[checks.NAME]`` table is reported but not checked.
Every check states why; a tolerance above 1 % must say why it is that large
(the test suite enforces a non-empty ``why``).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from verify.compare import CHECKED

KNOWN_CHECKS = (*CHECKED, "closed_form")


@dataclass(frozen=True)
class Check:
    """A tolerance on one quantity and the reason for it."""

    quantity: str
    tolerance: float
    why: str
    blocks: tuple[str, ...] = ()  # only rows of these blocks (default: all)

    def applies_to(self, item: str) -> bool:
        """Whether a row's item ("block", "block[k]" or "a|b") is checked."""
        if not self.blocks:
            return True
        return any(name in self.blocks for name in item.split("[")[0].split("|"))


@dataclass(frozen=True)
class Expectation:
    """The expectations of one verification case."""

    summary: str
    quick: bool = False
    component: str = "syy"
    fem_size: float | None = None
    fem_order: int = 2
    checks: dict[str, Check] = field(default_factory=dict)
    closed_form: dict[str, float] = field(default_factory=dict)
    notes: dict[str, str] = field(default_factory=dict)  # why a quantity is not checked


def load_expectation(path: Path) -> Expectation:
    """Read and check an expectation file."""
    path = Path(path) if isinstance(path, str) else path
    raw = tomllib.loads(path.read_text(encoding="utf-8"))
    checks = {}
    for name, table in raw.get("checks", {}).items():
        if name not in KNOWN_CHECKS:
            raise ValueError(f"{path}: checks.{name}: unknown quantity (known: {KNOWN_CHECKS})")
        if not str(table.get("why", "")).strip():
            raise ValueError(f"{path}: checks.{name}: 'why' is required")
        checks[name] = Check(
            name,
            float(table["tolerance"]),
            str(table["why"]).strip(),
            tuple(table.get("blocks", ())),
        )
    fem = raw.get("fem", {})
    return Expectation(
        summary=str(raw.get("summary", "")),
        quick=bool(raw.get("quick", False)),
        component=str(raw.get("component", "syy")),
        fem_size=fem.get("size"),
        fem_order=int(fem.get("order", 2)),
        checks=checks,
        closed_form={k: float(v) for k, v in raw.get("closed_form", {}).items()},
        notes={k: str(v).strip() for k, v in raw.get("notes", {}).items()},
    )
