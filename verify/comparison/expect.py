"""What a verification case expects: ``cases/verify/NAME.expect.toml``.

The scene file stays an ordinary scene (the loader refuses unknown keys);
its expectations live beside it::

    summary = "One block under self-weight on a fixed base"
    quick = true                # part of the quick suite (default test run)
    kind = "static"             # "static" | "dynamic" | "fracture"
    component = "syy"           # stress component shown in the picture
    frame = 0.0                 # degrees: components along a rotated frame
    catches = ["young_x0.97"]   # engine faults this case must catch (tests)
    [environment]               # optional: the engine's DDA_* settings for this case
    DDA_SYSTEMS = "sparse"      # (set while the case runs, restored after)
    [fem]
    size = 0.125                # element size (default: mesh.default_size)
    order = 2
    turn = -34.38               # optional: the FEM model is the scene turned by this
    about = [0.5, 2.0]          # (degrees) about this point (verify.fem.turn)
    [checks.stress]             # one table per checked quantity
    tolerance = 1e-4            # largest |error| allowed (see verify.comparison.compare)
    why = "..."                 # why this agreement is expected
    blocks = ["block"]          # optional: only these blocks (or interfaces touching
                                # them) or vertices ("block[2]")
    components = ["syy"]        # optional: only these components
    [offsets]                   # predicted DDA − FEM, "quantity.item.component"
    "centroid.block.uy" = 1.7658e-6
    [closed_form]               # exact block stresses or strains for both sides,
    "block.syy" = -26487.0      # "block.component"
    [dda_closed_form]           # exact block stresses or strains of the DDA alone
    [notes]                     # optional: why a reported quantity is not checked
    vertex = "..."

A ``motion`` case (:mod:`verify.references.motion`) has no FEM side: ``reference`` names
its closed form ("free", "slide", "rocking"; "drop", "overlap" of
:mod:`verify.references.impact`; "momentum": the conservation laws of many colliding blocks,
:mod:`verify.references.collisions`, run at the scene's time step only), ``time_steps`` the
factors of the scene's time step it is run at (e.g. [4, 2, 1]; 1 is the scene
as written and gives the compared rows) and ``order`` the order of accuracy in
Δt the rows ``order`` are compared with.

A quantity without a ``[checks.NAME]`` table is reported but not checked.
Every check states why; a tolerance above 1 % must say why it is that large
(the test suite enforces a non-empty ``why``).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

KNOWN_CHECKS = (
    "stress",
    "strain",
    "centroid",
    "vertex",
    "contact_force",
    "penetration",
    "contact_state",
    "closed_form",
    "history",
    "stress_history",
    "onset",
    "children",
    "crack",
    "motion",
    "area",
    "order",
    "al_updates",
    "energy",
    "impact_time",
    "contact_time",
    "impact_speed",
    "rebound",
    "momentum",
    "overlap",
    "ground",
    "dissipation",
)
KINDS = ("static", "dynamic", "fracture", "motion")
# the closed forms of verify.references.motion, verify.references.impact,
# verify.references.shaking and verify.references.bolt, and the conservation laws of
# verify.references.collisions
MOTION_REFERENCES = (
    "free",
    "slide",
    "rocking",
    "drop",
    "overlap",
    "newmark",
    "newmark_record",
    "bolt",
    "momentum",
    "kinked_table",
)


class ExpectationError(ValueError):
    """An expectation file that cannot be used; the message names the file and the key."""


# the keys of an expectation file, of its [fem] table and of each [checks.NAME] table
TOP_KEYS = (
    "summary", "quick", "kind", "component", "frame", "catches", "environment", "fem",
    "checks", "offsets", "closed_form", "dda_closed_form", "notes", "reference",
    "time_steps", "order",
)  # fmt: skip
FEM_KEYS = ("size", "order", "turn", "about")
# the components a block's [closed_form] row may give: its stress, its strain
STRESS = ("sxx", "syy", "sxy")
STRAIN = ("exx", "eyy", "gxy")
TENSOR_COMPONENTS = STRESS + STRAIN
CHECK_KEYS = ("tolerance", "why", "blocks", "components")


def _known_keys(path: Path, table: object, where: str, known: tuple[str, ...]) -> dict:
    """``table`` (a TOML table at ``where``, "" for the file) with only ``known`` keys."""
    if not isinstance(table, dict):
        raise ExpectationError(f"{path}: {where or 'the file'}: must be a table")
    prefix = f"{where}." if where else ""
    for key in table:
        if key not in known:
            listed = ", ".join(known)
            raise ExpectationError(f"{path}: {prefix}{key}: unknown key (known: {listed})")
    return table


@dataclass(frozen=True)
class Check:
    """A tolerance on one quantity and the reason for it."""

    quantity: str
    tolerance: float
    why: str
    blocks: tuple[str, ...] = ()  # only rows of these blocks (default: all)
    components: tuple[str, ...] = ()  # only these components (default: all)

    def applies_to(self, item: str, component: str = "") -> bool:
        """Whether a row (item "block", "block[k]" or "a|b", component) is checked.

        ``blocks`` may name blocks (all their rows and their interfaces' rows)
        or single vertices ("block[2]").
        """
        if self.components and component not in self.components:
            return False
        if not self.blocks or item in self.blocks:
            return True
        return any(name in self.blocks for name in item.split("[")[0].split("|"))


@dataclass(frozen=True)
class Expectation:
    """The expectations of one verification case."""

    summary: str
    quick: bool = False
    kind: str = "static"
    component: str = "syy"
    frame: float = 0.0
    catches: tuple[str, ...] = ()
    fem_size: float | None = None
    fem_order: int = 2
    # the FEM model is the scene turned by fem_turn degrees about fem_about: the state
    # the engine is to come to rest in after a large rotation (verify.fem.turn)
    fem_turn: float = 0.0
    fem_about: tuple[float, float] = (0.0, 0.0)
    checks: dict[str, Check] = field(default_factory=dict)
    offsets: dict[str, float] = field(default_factory=dict)
    closed_form: dict[str, float] = field(default_factory=dict)
    dda_closed_form: dict[str, float] = field(default_factory=dict)
    notes: dict[str, str] = field(default_factory=dict)  # why a quantity is not checked
    # kind "motion" (verify.references.motion): the closed form, the time-step factors, the order
    reference: str = ""
    time_steps: tuple[int, ...] = (1,)
    order: float | None = None
    environment: dict[str, str] = field(default_factory=dict)  # DDA_* variables of the run


def _environment(path: Path, table: dict) -> dict[str, str]:
    """The ``[environment]`` table: the engine's own ``DDA_*`` variables only."""
    for name in table:
        if not name.startswith("DDA_"):
            raise ExpectationError(f"{path}: environment.{name}: only DDA_* variables")
    return {name: str(value) for name, value in table.items()}


def _check(path: Path, name: str, table: object) -> Check:
    if name not in KNOWN_CHECKS:
        raise ExpectationError(f"{path}: checks.{name}: unknown quantity (known: {KNOWN_CHECKS})")
    table = _known_keys(path, table, f"checks.{name}", CHECK_KEYS)
    if not str(table.get("why", "")).strip():
        raise ExpectationError(f"{path}: checks.{name}: 'why' is required")
    if "tolerance" not in table:
        raise ExpectationError(f"{path}: checks.{name}: 'tolerance' is required")
    tolerance = table["tolerance"]
    if not _number(tolerance) or tolerance < 0:  # nan would fail, inf pass, any engine
        raise ExpectationError(
            f"{path}: checks.{name}.tolerance: must be a finite number >= 0, got {tolerance!r}"
        )
    return Check(
        name,
        float(tolerance),
        str(table["why"]).strip(),
        _names(path, table, f"checks.{name}", "blocks"),
        _names(path, table, f"checks.{name}", "components"),
    )


def _number(value: object) -> bool:
    """A finite TOML number (not a boolean)."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _names(path: Path, table: dict, where: str, key: str) -> tuple[str, ...]:
    """``table[key]``: a list of names (a string alone would be read letter by letter)."""
    value = table.get(key, [])
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise ExpectationError(f"{path}: {where}.{key}: must be a list of names, got {value!r}")
    return tuple(value)


def _fem(path: Path, raw: dict) -> dict:
    """The ``[fem]`` table: a mesh size > 0 and an element order 1 or 2 where given."""
    fem = _known_keys(path, raw.get("fem", {}), "fem", FEM_KEYS)
    size = fem.get("size")
    if size is not None and not (_number(size) and size > 0):
        raise ExpectationError(f"{path}: fem.size: must be a length > 0, got {size!r}")
    if fem.get("order", 2) not in (1, 2) or isinstance(fem.get("order"), bool):
        raise ExpectationError(f"{path}: fem.order: must be 1 or 2, got {fem['order']!r}")
    return fem


def _values(path: Path, raw: dict, key: str, components: tuple[str, ...] | None) -> dict:
    """The table ``key`` of numbers by row; with ``components``, rows "BLOCK.COMPONENT" of
    one of them (``[closed_form]``: a block's stress or strain)."""
    table = raw.get(key, {})
    if not isinstance(table, dict):
        raise ExpectationError(f"{path}: {key}: must be a table")
    for row, value in table.items():
        if not _number(value):
            raise ExpectationError(f"{path}: {key}.{row}: must be a number, got {value!r}")
        component = row.rsplit(".", 1)[-1] if "." in row else ""
        if components is not None and component not in components:
            raise ExpectationError(
                f"{path}: {key}.{row}: expected BLOCK.COMPONENT, the component one of "
                f"{', '.join(components)}"
            )
    return {row: float(value) for row, value in table.items()}


def _checks(path: Path, raw: dict) -> dict[str, Check]:
    """The ``[checks.NAME]`` tables: at least one (a case that checks nothing passes
    whatever the engine does)."""
    tables = raw.get("checks", {})
    if not isinstance(tables, dict):
        raise ExpectationError(f"{path}: checks: must be a table of [checks.NAME] tables")
    if not tables:
        raise ExpectationError(
            f"{path}: checks: the case checks nothing; give at least one [checks.NAME] table "
            f"(NAME one of {', '.join(KNOWN_CHECKS)})"
        )
    return {name: _check(path, name, table) for name, table in tables.items()}


def _check_motion(path: Path, raw: dict) -> None:
    """A motion case names a known closed form and time-step factors that include 1."""
    reference = raw.get("reference")
    if reference is None:
        raise ExpectationError(
            f"{path}: reference: required for kind = 'motion' (one of {MOTION_REFERENCES})"
        )
    if reference not in MOTION_REFERENCES:
        raise ExpectationError(
            f"{path}: reference: {reference!r} is not one of {MOTION_REFERENCES}"
        )
    factors = raw.get("time_steps", [1])
    if not all(isinstance(f, int) and f >= 1 for f in factors) or 1 not in factors:
        raise ExpectationError(
            f"{path}: time_steps: {factors!r}: positive whole factors of the scene's "
            "time step, 1 among them"
        )


def load_expectation(path: Path) -> Expectation:
    """Read and check an expectation file."""
    try:
        raw = tomllib.loads((Path(path) if isinstance(path, str) else path).read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ExpectationError(f"{path}: not valid TOML: {exc}") from exc
    _known_keys(path, raw, "", TOP_KEYS)
    kind = str(raw.get("kind", "static"))
    if kind not in KINDS:
        raise ExpectationError(f"{path}: kind: {kind!r} is not one of {KINDS}")
    fem = _fem(path, raw)
    if kind == "motion":
        _check_motion(path, raw)
    environment = _environment(path, raw.get("environment", {}))
    checks = _checks(path, raw)
    try:
        return _expectation(path, raw, kind, fem, checks, environment)
    except ExpectationError:
        raise
    except (TypeError, ValueError) as exc:  # a value of the wrong type
        raise ExpectationError(f"{path}: {exc}") from exc


def _expectation(
    path: Path, raw: dict, kind: str, fem: dict, checks: dict, environment
) -> Expectation:
    """The :class:`Expectation` of the checked file ``raw``."""
    return Expectation(
        summary=str(raw.get("summary", "")),
        quick=bool(raw.get("quick", False)),
        kind=kind,
        component=str(raw.get("component", "syy")),
        frame=float(raw.get("frame", 0.0)),
        catches=tuple(raw.get("catches", ())),
        fem_size=fem.get("size"),
        fem_order=int(fem.get("order", 2)),
        fem_turn=float(fem.get("turn", 0.0)),
        fem_about=tuple(float(x) for x in fem.get("about", (0.0, 0.0))),
        checks=checks,
        offsets=_values(path, raw, "offsets", None),
        closed_form=_values(path, raw, "closed_form", TENSOR_COMPONENTS),
        dda_closed_form=_values(path, raw, "dda_closed_form", TENSOR_COMPONENTS),
        notes={k: str(v).strip() for k, v in raw.get("notes", {}).items()},
        reference=str(raw.get("reference", "")),
        time_steps=tuple(int(f) for f in raw.get("time_steps", (1,))),
        order=None if raw.get("order") is None else float(raw["order"]),
        environment=environment,
    )
