"""The realisations of a scene with random values: draw, put into the scene, reproduce.

Realisation k of an ensemble with root seed s draws from
``numpy.random.SeedSequence(s, spawn_key=(k,))`` (the k-th child of
``SeedSequence(s).spawn``): one uniform number u per ``[[ensemble.vary]]`` entry, in
order, mapped through the inverse of its (cut) distribution,

    x = F⁻¹( F(low) + u (F(high) − F(low)) ),

so each realisation is reproducible from (s, k) alone, whatever ran before it and on
whichever worker. The joint sets' own seeds (their ``dip_std``, ``spacing_std`` and
random ``stagger``) are drawn from ``SeedSequence(s, spawn_key=(k, 1))``.
"""

from __future__ import annotations

import copy
import math
import re
from collections.abc import Mapping
from typing import Any

import numpy as np
from scipy import stats

from dda.scene import Distribution, EnsembleSettings

_SET_KEY = re.compile(r"joint_sets\[(\d+)\]\.(\w+)$")


def frozen(dist: Distribution):
    """The scipy distribution of ``dist`` (von Mises: in degrees about 0)."""
    if dist.kind == "normal":
        return stats.norm(dist.mean, dist.std)
    if dist.kind == "lognormal":
        sigma2 = math.log1p((dist.std / dist.mean) ** 2)
        return stats.lognorm(s=math.sqrt(sigma2), scale=math.exp(math.log(dist.mean) - sigma2 / 2))
    if dist.kind == "uniform":
        return stats.uniform(dist.low, dist.high - dist.low)
    return stats.vonmises(dist.kappa)


def draw(dist: Distribution, u: float) -> float:
    """The value of ``dist`` at the uniform number ``u`` (inverse CDF, cut to low..high)."""
    law = frozen(dist)
    if dist.kind == "von_mises":
        low = math.radians(max(dist.low - dist.mean, -180.0))
        high = math.radians(min(dist.high - dist.mean, 180.0))
        p0, p1 = law.cdf(low), law.cdf(high)
        return dist.mean + math.degrees(float(law.ppf(p0 + u * (p1 - p0))))
    p0, p1 = law.cdf(dist.low), law.cdf(dist.high)
    value = float(law.ppf(p0 + u * (p1 - p0)))
    return min(max(value, dist.low), dist.high)  # the cut ends, against round-off


def drawn_values(ensemble: EnsembleSettings, index: int) -> dict[str, float]:
    """The values of realisation ``index`` (key -> value, in the order of ``vary``)."""
    rng = np.random.default_rng(np.random.SeedSequence(ensemble.seed, spawn_key=(index,)))
    u = rng.random(len(ensemble.vary))
    return {d.key: draw(d, float(x)) for d, x in zip(ensemble.vary, u, strict=True)}


def set_value(raw: dict, key: str, value: float) -> None:
    """Put ``value`` at the dotted ``key`` of a raw scene (checked by the scene reader)."""
    match = _SET_KEY.match(key)
    if match:
        raw["joint_sets"][int(match.group(1))][match.group(2)] = value
        return
    table, name, field = key.split(".")
    raw.setdefault(table, {}).setdefault(name, {})[field] = value


def get_value(raw: dict, key: str) -> float:
    """The value at the dotted ``key`` of a raw scene (as :func:`set_value` put it)."""
    match = _SET_KEY.match(key)
    if match:
        return raw["joint_sets"][int(match.group(1))][match.group(2)]
    table, name, field = key.split(".")
    return raw[table][name][field]


# a residual strength and the peak it may not exceed (dda.scene.joints)
_PEAKS = {
    "residual_friction_angle": "friction_angle",
    "residual_cohesion": "cohesion",
    "residual_tensile_strength": "tensile_strength",
}


def _residuals_within_peaks(raw: dict) -> None:
    """A residual strength drawn (or left) above its joint's drawn peak is taken equal to
    it: a joint loses strength as it slips, and the realisation stays a scene."""
    joints = raw.get("joints")
    if not isinstance(joints, dict):
        return
    for joint in joints.values():
        if not isinstance(joint, dict) or joint.get("model") == "barton-bandis":
            continue
        for residual, peak in _PEAKS.items():
            if residual in joint and joint[residual] > joint.get(peak, 0.0):
                joint[residual] = joint.get(peak, 0.0)


def realise(raw: Mapping[str, Any], ensemble: EnsembleSettings, index: int) -> tuple[dict, dict]:
    """(the raw scene of realisation ``index``, its values as the scene uses them: the
    drawn ones, a residual drawn above its peak taken equal to it)."""
    out = copy.deepcopy(dict(raw))
    values = drawn_values(ensemble, index)
    for key, value in values.items():
        set_value(out, key, value)
    _residuals_within_peaks(out)
    values = {key: get_value(out, key) for key in values}
    sets = out.get("joint_sets")
    if isinstance(sets, list) and sets:
        sequence = np.random.SeedSequence(ensemble.seed, spawn_key=(index, 1))
        seeds = sequence.generate_state(len(sets))
        for table, seed in zip(sets, seeds, strict=True):
            table["seed"] = int(seed)
    return out, values
