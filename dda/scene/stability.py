"""Scene sections for stability: ``[fos]`` (strength reduction) and ``[ensemble]``.

``[fos]`` sets the search and the failure criterion of ``dda fos`` (docs/stability.md);
``[ensemble]`` names the scene values drawn at random for ``dda ensemble``, each by a
dotted key of the scene as written (``joints.default.friction_angle``,
``joint_sets[0].spacing``) and a distribution. Both are checked like every section:
an unknown key or a bad value is one :class:`dda.errors.SceneError` naming the key.

A distribution must stay inside what its key may take: a bounded one (uniform) with
both ends inside, an unbounded one (normal, lognormal, von Mises) with its mean inside
and is then cut to that range (``min`` and ``max`` cut it further).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from dda.scene.checks import (
    ANGLE,
    ANY,
    NON_NEGATIVE,
    POSITIVE,
    Checker,
    Interval,
    Spec,
    checked_fields,
    join_key,
    real,
    table_list,
)
from dda.scene.joints import JRC, RESTITUTION, other_model

STABILITY_KEYS = ("fos", "ensemble")
# a trial fails when its watched blocks move faster, over the last `window` of the trial,
# than this fraction of gravity would have accelerated them from rest in the whole trial
DEFAULT_ACCELERATION = 1e-4
UNIT_FRACTION = Interval(0.0, 1.0, high_closed=True)


@dataclass(frozen=True)
class FosSettings:
    """``[fos]``: the bracket and tolerance of the search, and the failure criterion."""

    lower: float = 0.25  # smallest reduction factor tried
    upper: float = 4.0  # largest
    tolerance: float = 0.01  # the search stops when the bracket is this narrow
    duration: float | None = None  # simulated time of a trial (default: the scene's run)
    velocity: float | None = None  # speed limit (default: acceleration x |g| x duration)
    acceleration: float = DEFAULT_ACCELERATION  # of |g|: sets the default speed limit
    window: float = 0.2  # the end of the trial judged, as a fraction of its duration
    blocks: tuple[str, ...] = ()  # the watched blocks (default: every free block)
    intact: bool = False  # reduce the breakable materials' strengths too


@dataclass(frozen=True)
class Distribution:
    """``[[ensemble.vary]]``: one scene value drawn per realisation.

    ``normal`` (mean, std), ``lognormal`` (mean, std of the value itself), ``uniform``
    (low, high), ``von_mises`` (mean, kappa; degrees about the mean, orientation keys
    only); ``low``/``high`` of the unbounded ones are where they are cut.
    """

    key: str  # dotted key of the raw scene, e.g. "joints.default.friction_angle"
    kind: str
    mean: float = 0.0
    std: float = 0.0
    kappa: float = 0.0
    low: float = -math.inf
    high: float = math.inf


@dataclass(frozen=True)
class EnsembleSettings:
    """``[ensemble]``: the root seed, the number of realisations, the drawn values."""

    vary: tuple[Distribution, ...]
    seed: int = 0
    realisations: int = 100


# what each variable key may take, and whether it is an orientation (von Mises allowed)
_JOINT_VALUES = {
    "friction_angle": ANGLE,
    "cohesion": NON_NEGATIVE,
    "tensile_strength": NON_NEGATIVE,
    "residual_friction_angle": ANGLE,
    "residual_cohesion": NON_NEGATIVE,
    "residual_tensile_strength": NON_NEGATIVE,
    "jrc": JRC,
    "jcs": POSITIVE,
    "restitution": RESTITUTION,
}
_JOINT_SET_VALUES = {
    "dip": ANY,
    "spacing": POSITIVE,
    "offset": ANY,
    "trace_length": POSITIVE,
    "bridge_length": NON_NEGATIVE,
}
_ORIENTATIONS = ("dip",)
_KINDS = {
    "normal": ("mean", "std"),
    "lognormal": ("mean", "std"),
    "uniform": ("low", "high"),
    "von_mises": ("mean", "kappa"),
}
# a normal law whose std exceeds this many times its cut range is flat over it: the cut
# inverse F⁻¹(F(low) + u (F(high) − F(low))) then draws its mean alone (round-off)
FLAT_NORMAL = 1e6
_VARY_KEYS = ("key", "distribution", "mean", "std", "kappa", "low", "high")
_SET_KEY = re.compile(r"joint_sets\[(\d+)\]\.(\w+)$")

# the decimals a factor of safety search rounds its trial factors to, so that a rerun asks
# for the very same ones (dda.stability.search)
DIGITS = 9
# the narrowest bracket a search is asked for, well above that rounding (a tolerance of
# 1e-10 asked for factors it already had, for ever)
MIN_FOS_TOLERANCE = 1e-6
_FOS: dict[str, Spec] = {
    "lower": real(POSITIVE),
    "upper": real(POSITIVE),
    "tolerance": real(POSITIVE),
    "duration": real(POSITIVE),
    "velocity": real(POSITIVE),
    "acceleration": real(POSITIVE),
    "window": real(UNIT_FRACTION),
    "blocks": Checker.listed,
    "intact": Checker.boolean,
}


def parse_stability(
    chk: Checker,
    raw: Mapping[str, Any],
    written: Mapping[str, Any],
    blocks: Sequence[Any],
    groups: Mapping[str, tuple[str, ...]],
) -> dict[str, Any]:
    """The Scene fields ``fos`` and ``ensemble``.

    ``raw`` is the scene with its blocks explicit, ``written`` the scene as written
    (before a rock mass is cut: the keys ``[ensemble]`` draws refer to it).
    """
    out: dict[str, Any] = {}
    if "fos" in raw:
        out["fos"] = _fos(chk, raw["fos"], blocks, groups)
    if "ensemble" in raw:
        out["ensemble"] = _ensemble(chk, raw["ensemble"], written)
    return out


def _fos(
    chk: Checker,
    value: object,
    blocks: Sequence[Any],
    groups: Mapping[str, tuple[str, ...]],
) -> FosSettings:
    values = checked_fields(chk, value, "fos", _FOS)
    settings = FosSettings(**{**values, "blocks": ()})
    if settings.lower >= settings.upper:
        chk.fail("fos.upper", f"must exceed fos.lower ({settings.lower:g}), got {settings.upper:g}")
    if settings.tolerance < MIN_FOS_TOLERANCE:
        chk.fail(
            "fos.tolerance",
            f"must be at least {MIN_FOS_TOLERANCE:g} (the search keeps its trial factors to "
            f"{DIGITS} decimals), got {settings.tolerance:g}",
        )
    if settings.tolerance >= settings.upper - settings.lower:
        chk.fail(
            "fos.tolerance",
            f"must be below upper - lower ({settings.upper - settings.lower:g}), "
            f"got {settings.tolerance:g}",
        )
    watched = _watched(chk, values.get("blocks", ()), blocks, groups)
    return FosSettings(**{**values, "blocks": watched})


def _watched(
    chk: Checker, items: Sequence[Any], blocks: Sequence[Any], groups: Mapping[str, tuple[str, ...]]
) -> tuple[str, ...]:
    """Block names from block or group names; at least one of them free."""
    if not len(items):
        return ()
    fixed = {b.name: b.fixed for b in blocks}
    names: list[str] = []
    for k, item in enumerate(items):
        name = chk.known(item, f"fos.blocks[{k}]", {**fixed, **groups}, "block or group")
        names += [m for m in (groups[name] if name not in fixed else (name,)) if m not in names]
    if all(fixed[n] for n in names):
        chk.fail("fos.blocks", "every watched block is fixed: a trial could never fail")
    return tuple(names)


def _ensemble(chk: Checker, value: object, written: Mapping[str, Any]) -> EnsembleSettings:
    table = chk.table(value, "ensemble", ("seed", "realisations", "vary"))
    seed = chk.integer(table.get("seed", 0), "ensemble.seed", 0)
    count = chk.count(table.get("realisations", 100), "ensemble.realisations")
    items = table_list(chk, table, "vary")
    vary = tuple(_distribution(chk, v, f"ensemble.vary[{k}]", written) for k, v in enumerate(items))
    keys = [d.key for d in vary]
    for k, key in enumerate(keys):
        if key in keys[:k]:
            chk.fail(f"ensemble.vary[{k}].key", f"{key!r} is drawn twice")
    return EnsembleSettings(vary=vary, seed=seed, realisations=count)


def _distribution(
    chk: Checker, value: object, key: str, written: Mapping[str, Any]
) -> Distribution:
    table = chk.table(value, key, _VARY_KEYS)
    for name in ("key", "distribution"):
        if name not in table:
            chk.fail(join_key(key, name), "is required")
    target = chk.text(table["key"], join_key(key, "key"))
    allowed, orientation = _target(chk, target, join_key(key, "key"), written)
    kind = chk.choice(table["distribution"], join_key(key, "distribution"), tuple(_KINDS))
    needed = _KINDS[kind]
    given = {n: chk.real(table[n], join_key(key, n)) for n in _VARY_KEYS[2:] if n in table}
    for name in needed:
        if name not in given:
            chk.fail(join_key(key, name), f"is required by a {kind} distribution")
    for name in ("std", "kappa"):
        if name in needed and given[name] <= 0.0:
            chk.fail(join_key(key, name), f"must be > 0, got {given[name]:g}")
    extra = sorted(set(given) - set(needed) - ({"low", "high"} if kind != "uniform" else set()))
    if extra:
        chk.fail(join_key(key, extra[0]), f"is not a parameter of a {kind} distribution")
    if kind == "von_mises" and not orientation:
        chk.fail(join_key(key, "distribution"), f"von_mises is for orientations, not {target!r}")
    if kind == "lognormal" and allowed.low < 0.0:
        chk.fail(join_key(key, "distribution"), f"lognormal values are positive; {target!r} "
                 f"may be negative: use normal")  # fmt: skip
    low, high = given.get("low", -math.inf), given.get("high", math.inf)
    if low >= high:
        chk.fail(join_key(key, "high"), f"must exceed low ({low:g}), got {high:g}")
    for name, bound in (("low", low), ("high", high)):
        if name in given and not _inside(allowed, bound, bounded=kind == "uniform"):
            chk.fail(join_key(key, name), f"{target} must be {allowed.describe()}, got {bound:g}")
    if kind != "uniform":
        mean = given["mean"]
        if kind == "lognormal" and mean <= 0.0:
            chk.fail(join_key(key, "mean"), f"a lognormal distribution's mean must be > 0, "
                     f"got {mean:g}")  # fmt: skip
        if not (allowed.holds(mean) and low < mean < high):
            between = " and between low and high" if given.keys() & {"low", "high"} else ""
            chk.fail(join_key(key, "mean"), f"{target} must be {allowed.describe()}"
                     f"{between}, got {mean:g}")  # fmt: skip
        low, high = max(low, allowed.low), min(high, allowed.high)
        if kind == "normal" and given["std"] > FLAT_NORMAL * (high - low):
            chk.fail(join_key(key, "std"), f"{given['std']:g} is over {FLAT_NORMAL:g} times the "
                     f"range {low:g} to {high:g}: the normal is flat there and its cut inverse "
                     "draws the mean alone; draw it uniform")  # fmt: skip
    return Distribution(key=target, kind=kind, **{**given, "low": low, "high": high})


def _inside(allowed: Interval, bound: float, bounded: bool) -> bool:
    """A cut (or, for a uniform law, an end) within the values a key may take; an open
    end of the range is allowed as a cut of an unbounded law."""
    if bounded:
        return allowed.holds(bound)
    return allowed.low <= bound <= allowed.high


def _target(
    chk: Checker, target: str, key: str, written: Mapping[str, Any]
) -> tuple[Interval, bool]:
    """What the scene value at ``target`` may take, and whether it is an orientation."""
    parts = target.split(".")
    if len(parts) == 3 and parts[0] == "joints":
        joints = written.get("joints", {})
        if parts[1] != "default" and not (isinstance(joints, Mapping) and parts[1] in joints):
            chk.fail(key, f"no joint {parts[1]!r} in [joints]")
        table = joints.get(parts[1], {}) if isinstance(joints, Mapping) else {}
        model = table.get("model", "coulomb") if isinstance(table, Mapping) else "coulomb"
        owner = other_model(parts[2], model)
        if owner is not None:
            chk.fail(key, f"{parts[2]} is a key of model = {owner!r}; joints.{parts[1]} is "
                     f"{model!r}")  # fmt: skip
        if parts[2] in _JOINT_VALUES:
            return _JOINT_VALUES[parts[2]], False
    match = _SET_KEY.match(target)
    if match:
        index, name = int(match.group(1)), match.group(2)
        sets = written.get("joint_sets", [])
        if not isinstance(sets, list) or index >= len(sets):
            chk.fail(key, f"no joint set {index} (the scene has {len(sets)} [[joint_sets]])")
        if name in _JOINT_SET_VALUES:
            if name == "bridge_length" and "trace_length" not in sets[index]:
                chk.fail(key, f"joint_sets[{index}] has no trace_length: bridges need one")
            return _JOINT_SET_VALUES[name], name in _ORIENTATIONS
    chk.fail(
        key,
        f"cannot draw {target!r}: expected joints.NAME.{'|'.join(_JOINT_VALUES)} or "
        "joint_sets[i].dip|spacing|offset|trace_length|bridge_length",
    )


__all__ = [
    "DEFAULT_ACCELERATION",
    "STABILITY_KEYS",
    "Distribution",
    "EnsembleSettings",
    "FosSettings",
    "parse_stability",
]
