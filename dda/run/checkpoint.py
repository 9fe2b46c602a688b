"""Checkpoints: the complete state of a run in one file, to continue it later.

A checkpoint is one ``.npz`` file (numpy's zip of arrays; read without
pickle, so opening one runs no code), written atomically:

- ``run/<attribute>``: every attribute of the run's state (``dda.run.simulation``)
  but the model: the blocks (every field of :class:`dda.blocks.BlockSet`), the
  contact set (every field of :class:`dda.contact.contact_set.ContactSet`:
  states, multipliers, penalties, shear references, ...), step, time, Δt, the
  run counters, the energy account, the broad-phase list, the stage timings,
  the fracture events and the per-step history;
- ``effects/<k>/...`` and ``fracture/...``: the attributes of the model's
  effects, which hold state of their own (load and fixed points moving with
  their blocks, the ids the next fragments get);
- ``meta.json``: the scalars above, the format version, the step, the time,
  the wall time so far and a fingerprint of the scene.

The state is found by walking attributes (dataclass fields, ``vars``), not
by a list of names: a field added to a dataclass is saved and restored
without a change here. Restoring walks the freshly built run of the same
scene the same way and refuses a checkpoint whose entries differ from what
the run holds (written by another version of dda). The engine has no random
numbers, so there is no generator state to keep.

- ``solver/...``: the run's linear cache (:class:`dda.solve.step.LinearCache`: the block
  pattern, the springs of the factorised K, the band numbering), the matrix its solver
  had factorised, which a resumed run factorises again, and what the solver learned
  (:meth:`dda.solve.linsolve.ReusingSolver.learned`).

Not in a checkpoint: the model (rebuilt from the scene, which must match the
fingerprint) and the step's policy (:class:`dda.solve.policy.StepPolicy`), read from
the resumed run's environment.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib
import json
import logging
import os
import time
import types
import zipfile
from array import array
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dda.io.atomic import atomic_path
from dda.io.tables import to_jsonable
from dda.result import BoltEvent, FractureEvent

log = logging.getLogger(__name__)

# the layout of a checkpoint; raised when the run's state gains an entry that an older
# checkpoint cannot have (2: the blocks' last acceleration, for [analysis] newmark_gamma;
# 3: the contact search's reach, dda.contact.reach; 4: the count of Newton iterations;
# 5: the blocks' mass areas, the material damping, the equilibrium start's preloads;
# 6: the solver's state by the names of ReusingSolver.learned; 7: a block pattern's
# inverse numbering, dda.solve.assembly.BlockPattern; 9: a static run's largest vertex
# move of the step before the last; 10: the water's drawn table and the ground that
# carries it; 12: the boundary stresses' anchors, from which their rigid turn is found)
FORMAT = 12
META = "meta.json"
DEFAULT_SECONDS = 600.0  # wall seconds between checkpoints when no step count is given
NOT_SAVED = ("model", "linear")  # run attributes rebuilt from the scene, or saved apart
CACHE_NOT_SAVED = ("solver", "policy")  # the linear cache's: saved apart, or the environment's
RUN_CONTROL = ("save_every", "checkpoint_every", "max_steps")  # not part of the fingerprint
NAMED_TUPLES = {"FractureEvent": FractureEvent, "BoltEvent": BoltEvent}  # result types in lists
_SCALARS = (np.generic, bool, int, float, str, type(None))
_CODE = (type, types.FunctionType, types.MethodType, types.BuiltinFunctionType, types.ModuleType,
         functools.partial)  # fmt: skip


class CheckpointError(ValueError):
    """A checkpoint that cannot be used: ``str(exc)`` is ``"<file>: <reason>"``."""

    def __init__(self, path: str | os.PathLike[str], reason: str) -> None:
        self.path = Path(path)
        self.reason = reason
        super().__init__(f"{path}: {reason}")


@dataclass
class Checkpoint:
    """A run's state: arrays by path and the JSON-able rest (``meta``)."""

    arrays: dict[str, np.ndarray]
    meta: dict[str, Any]
    source: str = "<memory>"

    @property
    def step(self) -> int:
        """Steps done when the checkpoint was taken."""
        return int(self.meta["step"])

    @property
    def time(self) -> float:
        """Simulated time then."""
        return float(self.meta["time"])

    @property
    def wall_seconds(self) -> float:
        """Wall time the run had taken until then (all its sessions)."""
        return float(self.meta.get("wall_seconds", 0.0))


@dataclass
class CheckpointPlan:
    """Where and when the engine writes checkpoints.

    A checkpoint is due after every ``every_steps``-th step and whenever
    ``every_seconds`` of wall time have passed since the last one (either
    may be ``None``: not by that measure), and when a run is stopped on request;
    with ``at_start`` also one of the first state, so that a run stopped in any
    way before the next one can be resumed (from its start).
    Checkpoints read the run's state and never change it: a run writes the
    same results with or without them, whenever they come.
    """

    path: Path
    every_steps: int | None = None
    every_seconds: float | None = DEFAULT_SECONDS
    at_start: bool = False  # also one of the first state (step 0, after the start)
    written: int = 0
    _last: float = field(default_factory=time.monotonic, repr=False)

    def __post_init__(self) -> None:
        """Refuse a step count that is not a positive whole number, or seconds that are
        not positive (-1 wrote a checkpoint after every step)."""
        steps, seconds = self.every_steps, self.every_seconds
        whole = isinstance(steps, int) and not isinstance(steps, bool)
        if steps is not None and not (whole and steps >= 1):
            raise ValueError(f"every_steps: expected a positive integer or None, got {steps!r}")
        if seconds is not None and not (isinstance(seconds, int | float) and seconds > 0):
            raise ValueError(f"every_seconds: expected a positive number or None, got {seconds!r}")

    def due(self, step: int) -> bool:
        """True when a checkpoint should be written after ``step``."""
        if self.every_steps and step % self.every_steps == 0:
            return True
        return self.every_seconds is not None and time.monotonic() - self._last >= (
            self.every_seconds
        )

    def write(self, run: Any, wall_seconds: float) -> Path:
        """Write the checkpoint of ``run`` (see :func:`capture`)."""
        path = write_checkpoint(self.path, capture(run, wall_seconds))
        self.written += 1
        self._last = time.monotonic()
        log.info("checkpoint at step %d: %s", run.step, path)
        return path


# --------------------------------------------------------------------------- scene


def scene_fingerprint(scene: Any) -> dict[str, str]:
    """A hash per section of the scene (``source`` and the run-control keys left out).

    Run-control keys (``RUN_CONTROL``: how often frames and checkpoints are
    written, the step limit) may change between the sessions of one run;
    everything else must stay.
    """
    parts = {}
    for f in dataclasses.fields(scene):
        if f.name == "source":
            continue
        value = to_jsonable(getattr(scene, f.name))
        if f.name == "analysis":
            value = {k: v for k, v in value.items() if k not in RUN_CONTROL}
        text = json.dumps(value, sort_keys=True)
        parts[f.name] = hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
    return parts


def differing_sections(stored: dict[str, str], scene: Any) -> list[str]:
    """The sections of ``scene`` (as a run holds it: in its local frame, its preset
    applied) whose hashes differ from the fingerprint ``stored`` (:func:`scene_fingerprint`
    of a run's scene, in its checkpoint or its summary)."""
    from dda.scene.local_frame import local_origin, translated
    from dda.scene.presets import apply_preset

    current = scene_fingerprint(apply_preset(translated(scene, local_origin(scene))))
    return sorted(k for k in set(stored) | set(current) if stored.get(k) != current.get(k))


def check_scene(checkpoint: Checkpoint, scene: Any) -> None:
    """Refuse a checkpoint written for another scene, naming the sections that differ.

    Raises
    ------
    CheckpointError
    """
    differ = differing_sections(checkpoint.meta.get("scene", {}), scene)
    if differ:
        raise CheckpointError(
            checkpoint.source,
            f"written for another scene ({', '.join(differ)} differ from {scene.source})",
        )


# --------------------------------------------------------------------------- files


def write_checkpoint(path: str | os.PathLike[str], checkpoint: Checkpoint) -> Path:
    """Write ``checkpoint`` to ``path`` atomically (uncompressed ``.npz``)."""
    path = Path(path)
    meta = np.frombuffer(json.dumps(checkpoint.meta).encode("utf-8"), dtype=np.uint8)
    with atomic_path(path) as tmp:
        with open(tmp, "xb") as stream:
            np.savez(stream, **checkpoint.arrays, **{META: meta})
    return path


def read_checkpoint(path: str | os.PathLike[str]) -> Checkpoint:
    """Read a checkpoint written by :func:`write_checkpoint`.

    Raises
    ------
    CheckpointError
        No such file, not a checkpoint, or one of another format.
    """
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(path, "no checkpoint to resume from")
    if not zipfile.is_zipfile(path):  # numpy's own message would offer to unpickle it
        raise CheckpointError(path, "not a dda checkpoint (not a zip of numpy arrays)")
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
        meta = json.loads(arrays.pop(META).tobytes().decode("utf-8"))
    except (OSError, ValueError, KeyError, UnicodeDecodeError) as exc:
        raise CheckpointError(path, f"not a dda checkpoint ({exc})") from None
    except Exception as exc:  # zipfile.BadZipFile and what a damaged zip raises
        raise CheckpointError(path, f"not a dda checkpoint ({exc})") from None
    if meta.get("format") != FORMAT:
        raise CheckpointError(path, f"format {meta.get('format')!r}, this dda reads {FORMAT}")
    return Checkpoint(arrays, meta, str(path))


# --------------------------------------------------------------------------- state


def capture(run: Any, wall_seconds: float = 0.0) -> Checkpoint:
    """The state of ``run`` (a ``dda.run.simulation`` run), copied.

    Parameters
    ----------
    run
        The run state: ``model`` (with ``effects``, ``fracture`` and ``scene``),
        ``step``, ``time`` and any other attributes.
    wall_seconds
        Wall time the run has taken so far.
    """
    saver = _Saver()
    saver.save(run.model.effects, "effects")
    saver.save(run.model.fracture, "fracture")
    for name, value in vars(run).items():
        if name not in NOT_SAVED:
            saver.save(value, f"run/{name}")
    _save_solver(saver, run.linear)
    meta = {
        "format": FORMAT,
        "step": int(run.step),
        "time": float(run.time),
        "wall_seconds": float(wall_seconds),
        "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "scene": scene_fingerprint(run.model.scene),
        "state": saver.meta,
    }
    arrays = {key: np.array(value, copy=True) for key, value in saver.arrays.items()}
    return Checkpoint(arrays, meta)


def restore(run: Any, checkpoint: Checkpoint) -> None:
    """Put the state of ``checkpoint`` into ``run``, freshly built from the same scene.

    Raises
    ------
    CheckpointError
        The checkpoint's entries are not the ones this run holds.
    """
    loader = _Loader(checkpoint)
    try:
        loader.load(run.model.effects, "effects")
        loader.load(run.model.fracture, "fracture")
        for name, value in list(vars(run).items()):
            if name not in NOT_SAVED:
                setattr(run, name, loader.load(value, f"run/{name}"))
        _restore_solver(loader, run.linear)
    except (KeyError, ValueError, TypeError, AttributeError, ImportError) as exc:
        reason = f"cannot restore the run's state ({exc})"
        raise CheckpointError(checkpoint.source, reason) from None
    loader.check_complete()
    damage = _damage(run.blocks, run.contacts)
    if damage:
        raise CheckpointError(checkpoint.source, f"cannot restore the run's state ({damage})")


# the blocks' arrays of one row a block, which must be finite (a fragment's acceleration
# is not known until its first step: NaN)
_PER_BLOCK = ("ids", "material", "velocity", "stress", "rotation", "displacement", "fixed",
              "centroid", "area", "ixx", "iyy", "ixy", "origin", "mass_area")  # fmt: skip


def _damage(blocks: Any, contacts: Any) -> str:
    """What makes the restored blocks and contacts unusable (arrays of other lengths than
    their blocks' and contacts' count, non-finite geometry or motion, contacts naming
    vertices or blocks that are not there), or "" (a checkpoint damaged inside a valid
    zip)."""
    n, vertices = len(blocks.names), len(blocks.vertices)
    for name in (*_PER_BLOCK, "acceleration"):
        values = getattr(blocks, name)
        if len(values) != n:
            return f"blocks.{name} has {len(values)} rows for {n} blocks"
        if name in _PER_BLOCK and values.dtype.kind == "f" and not np.all(np.isfinite(values)):
            return f"blocks.{name} is not finite"
    offsets = blocks.offsets
    if len(offsets) != n + 1 or offsets[-1] != vertices or len(blocks.edge_joint) != vertices:
        return "the blocks' vertex offsets do not match their vertices"
    if np.any(np.diff(offsets) < 3) or not np.all(np.isfinite(blocks.vertices)):
        return "blocks.vertices are not polygons"
    m = len(contacts.vertex)
    for f in dataclasses.fields(contacts):
        if len(getattr(contacts, f.name)) != m:
            return f"contacts.{f.name} has {len(getattr(contacts, f.name))} rows for {m}"
    indices = (contacts.vertex, contacts.edge, contacts.block_a, contacts.block_b)
    if m and any(
        np.any((i < 0) | (i >= top))
        for i, top in zip(indices, (vertices,) * 2 + (n,) * 2, strict=True)
    ):
        return "the contacts name vertices or blocks that are not there"
    return ""


# --------------------------------------------------------------------------- solver cache


def _save_solver(saver: _Saver, cache: Any) -> None:
    """The run's linear cache (:class:`dda.solve.step.LinearCache`): its pattern and
    springs as they are, what its solver learned, and the factorised matrix, which
    :func:`_restore_solver` factorises again."""
    for name, value in _attributes(cache):
        if name not in CACHE_NOT_SAVED:
            saver.save(value, f"solver/cache/{name}")
    for name, value in cache.solver.learned().items():
        saver.save(value, f"solver/{name}")
    k = cache.solver.factored
    matrix = None if k is None else {"data": k.data, "indices": k.indices, "indptr": k.indptr,
                                     "shape": list(k.shape)}  # fmt: skip
    saver.save(matrix, "solver/factored")


def _restore_solver(loader: _Loader, cache: Any) -> None:
    """The interrupted run's linear cache, its matrix factorised again (the same numbers
    with a deterministic solver): the resumed run's solves repeat the uninterrupted one's."""
    import scipy.sparse as sp

    for name, value in _attributes(cache):
        if name not in CACHE_NOT_SAVED:
            setattr(cache, name, loader.load(value, f"solver/cache/{name}"))
    learned = {name: loader.load(None, f"solver/{name}") for name in cache.solver.learned()}
    matrix = loader.load(None, "solver/factored")
    k = None
    if matrix is not None:
        shape = tuple(matrix["shape"])
        k = sp.csc_matrix((matrix["data"], matrix["indices"], matrix["indptr"]), shape=shape)
    cache.solver.resume(learned, k)


# --------------------------------------------------------------------------- walking


def _attributes(obj: Any) -> list[tuple[str, Any]]:
    if dataclasses.is_dataclass(obj):
        return [(f.name, getattr(obj, f.name)) for f in dataclasses.fields(obj)]
    return list(vars(obj).items())


def _is_object(value: Any) -> bool:
    """An object whose attributes hold state (not a function, class, module or compiled kernel)."""
    if isinstance(value, _CODE) or type(value).__module__.startswith("numba"):
        return False
    return hasattr(value, "__dict__")


def _kind(value: Any) -> str:
    """How a value is stored: by type, and for sequences by what they hold."""
    if isinstance(value, np.ndarray | array):
        return "array"
    if isinstance(value, _SCALARS):
        return "scalar"
    if isinstance(value, bytes):
        return "bytes"
    if isinstance(value, Mapping):
        return "scalars" if all(isinstance(v, _SCALARS) for v in value.values()) else "mapping"
    if isinstance(value, list | tuple):
        if all(isinstance(v, str) for v in value):
            return "scalars"
        if value and all(type(v).__name__ in NAMED_TUPLES for v in value):
            return "records"
        if all(isinstance(v, int | float | np.number) and not isinstance(v, bool) for v in value):
            return "array"  # a list of numbers
        if all(v is None or isinstance(v, np.ndarray) for v in value):
            return "arrays"
        return "objects"
    return "object" if _is_object(value) else "skip"


class _Saver:
    """Flattens a state into ``arrays`` and self-describing JSON ``meta`` by attribute path."""

    def __init__(self) -> None:
        self.arrays: dict[str, np.ndarray] = {}
        self.meta: dict[str, Any] = {}
        self._seen: dict[int, str] = {}  # object (or ndarray) id -> key it was saved under

    def save(self, value: Any, key: str) -> None:
        kind = _kind(value)
        if kind == "array" and isinstance(value, np.ndarray) and id(value) in self._seen:
            self.meta[key] = {"same_as": self._seen[id(value)]}  # one array, shared
        elif kind == "array":
            if isinstance(value, np.ndarray):
                self._seen[id(value)] = key
            self.arrays[key] = np.asarray(value)
        elif kind in ("scalar", "scalars"):
            self.meta[key] = _plain(value)
        elif kind == "bytes":
            self.meta[key] = {"bytes": value.hex()}
        elif kind == "records":
            rows = [[_plain(v) for v in row] for row in value]
            self.meta[key] = {"records": type(value[0]).__name__, "rows": rows}
        elif kind == "arrays":
            self.meta[key] = {"arrays": [v is not None for v in value]}
            for k, v in enumerate(value):
                if v is not None:
                    self.arrays[f"{key}/{k}"] = v
        elif kind == "mapping":
            self.meta[key] = {"mapping": list(value)}
            for name, v in value.items():
                self.save(v, f"{key}/{name}")
        elif kind == "objects":
            self.meta[key] = {"list": len(value)}
            for k, v in enumerate(value):
                self.save(v, f"{key}/{k}")
        elif kind == "object":
            self._save_object(value, key)

    def _save_object(self, value: Any, key: str) -> None:
        if id(value) in self._seen:  # shared: saved once, referred to after
            self.meta[key] = {"same_as": self._seen[id(value)]}
            return
        self._seen[id(value)] = key
        attributes = _attributes(value)
        kind = f"{type(value).__module__}:{type(value).__qualname__}"
        self.meta[key] = {"object": kind, "attributes": [name for name, _ in attributes]}
        for name, v in attributes:
            self.save(v, f"{key}/{name}")


class _Loader:
    """Rebuilds values from a checkpoint into the live values of a fresh run."""

    def __init__(self, checkpoint: Checkpoint) -> None:
        self.checkpoint = checkpoint
        self.meta = checkpoint.meta.get("state", {})
        self.used: set[str] = set()
        self.missing: list[str] = []
        self._objects: dict[str, Any] = {}

    def load(self, live: Any, key: str) -> Any:
        if key in self.checkpoint.arrays:
            self.used.add(key)
            return _like(live, self.checkpoint.arrays[key])
        if key not in self.meta:
            if _kind(live) != "skip":
                self.missing.append(key)
            return live
        self.used.add(key)
        value = self.meta[key]
        if not isinstance(value, dict) or isinstance(live, Mapping) and "mapping" not in value:
            return _like_scalar(live, value)
        if "bytes" in value:
            return bytes.fromhex(value["bytes"])
        if "records" in value:
            kind = NAMED_TUPLES[value["records"]]
            return [kind(*(_tuples(v) for v in row)) for row in value["rows"]]
        if "arrays" in value:
            out = [self.load(None, f"{key}/{k}") if present else None
                   for k, present in enumerate(value["arrays"])]  # fmt: skip
            return tuple(out) if isinstance(live, tuple) else out
        if "mapping" in value:
            out = live if isinstance(live, Mapping) else {}
            for name in value["mapping"]:
                out[name] = self.load(out.get(name), f"{key}/{name}")
            return out
        if "list" in value:
            old = list(live) if isinstance(live, list | tuple) else []
            out = [self.load(old[k] if k < len(old) else None, f"{key}/{k}")
                   for k in range(value["list"])]  # fmt: skip
            if isinstance(live, list):
                live[:] = out
                return live
            return out
        if "same_as" in value:
            first = value["same_as"]
            return (
                self.checkpoint.arrays[first]
                if first in self.checkpoint.arrays
                else (self._objects[first])
            )
        return self._load_object(live, key, value)

    def _load_object(self, live: Any, key: str, value: dict) -> Any:
        kind = _class(value["object"])
        obj = live if type(live) is kind else object.__new__(kind)
        self._objects[key] = obj
        names = value["attributes"]
        if live is not None and type(live) is kind:
            self.missing += [f"{key}/{n}" for n, v in _attributes(live) if n not in names
                             and _kind(v) != "skip"]  # fmt: skip
        for name in names:
            object.__setattr__(obj, name, self.load(getattr(obj, name, None), f"{key}/{name}"))
        return obj

    def check_complete(self) -> None:
        unknown = sorted((set(self.checkpoint.arrays) | set(self.meta)) - self.used)
        if self.missing or unknown:
            detail = f"lacks {self.missing[:3]}" if self.missing else f"has extra {unknown[:3]}"
            raise CheckpointError(
                self.checkpoint.source,
                f"written by another version of dda (the run's state {detail})",
            )


def _class(path: str) -> type:
    """The class ``module:qualname`` of a saved object; only dda's own classes."""
    module, _, name = path.partition(":")
    if module != "dda" and not module.startswith("dda."):
        raise ValueError(f"a checkpoint may only hold dda's own objects, not {path}")
    value: Any = importlib.import_module(module)
    for part in name.split("."):
        value = getattr(value, part)
    return value


def _like(live: Any, values: np.ndarray) -> Any:
    """``values`` in the container type of ``live`` (array.array, list or ndarray)."""
    if isinstance(live, array):
        return array(live.typecode, values.astype(np.dtype(live.typecode)).tobytes())
    if isinstance(live, list):
        return values.tolist()
    return values


def _like_scalar(live: Any, value: Any) -> Any:
    """A JSON value back in the type of ``live`` (a dict updated in place, a tuple)."""
    if isinstance(live, Mapping) and isinstance(value, dict):
        live.clear()
        live.update(value)
        return live
    if isinstance(live, tuple) and isinstance(value, list):
        return tuple(value)
    return value


def _plain(value: Any) -> Any:
    """JSON types (NaN and infinities kept: the checkpoint's JSON allows them)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def _tuples(value: Any) -> Any:
    return tuple(value) if isinstance(value, list) else value
