"""Every compiled twin of the engine, declared, and one parametrised test that holds each
to the numpy code beside it.

A compiled twin is a kernel that a ``compiled(kernel)`` / ``compiled_in_run(kernel)``
branch chooses over numpy code that computes the same thing (docs/design.md, "Compiled
kernels and start-up"). :data:`TWINS` declares every such branch of dda/ with a short
run that takes it; the test runs that scene with every kernel, then with the one kernel
switched off (its branch's ``compiled`` answers False for it: the branch takes the numpy
code, and the kernels that call it compiled stay as they are), and asks for the same
blocks, contact forces and energies. A twin that sums in another order than numpy agrees
to rounding, the others to the bit (the energies, summed in another order by their
kernel, to rounding always): the runs are a few steps, too short for rounding to grow
but where a contact sits at a kink (:data:`ROUNDING`).
``test_every_compiled_branch_is_declared`` fails on a branch that is not in the table.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import re
from pathlib import Path

import numpy as np
import pytest

import dda
from dda import jit
from dda.bench.scenes import wall_scene

pytestmark = pytest.mark.skipif(not jit.numba_enabled(), reason="numba is not in use")

PACKAGE = Path(dda.__file__).resolve().parent

# (file of the branch, the kernel as the branch names it) -> the run that takes it; the
# runs (scene, DDA_SYSTEMS, the kernels switched off in both of the test's runs):
#   wall: a 4 x 4 wall (augmented Lagrangian, equilibrium start, material damping) on
#         band systems: the step's loop and Newton compiled, the contacts refreshed in
#         one compiled call
#   sparse: the same wall on the sparse systems: the loop and Newton in Python
#   ringing: the wall from the unloaded start, penalty contacts, its joints with
#         restitution 0.5 (the contact dashpots couple blocks: the numpy line search),
#         on the sparse systems
#   pieces: the ringing wall with its contacts refreshed stage by stage (the compiled
#         refresh off); numpy sift, numpy detect: likewise, with the compiled sifting of
#         the pairings, or the narrow phase's one compiled call, off too
#   slope sift: cases/rock_slope.toml, its pairings sifted in numpy (some need the
#         distance of a vertex to a block: contacts that open and close on the slope)
REFRESH = ("contact/pipeline.py", "_refresh_kernel")
RUNS = {
    "wall": ("wall", None, ()),
    "sparse": ("wall", "sparse", ()),
    "ringing": ("ringing", "sparse", ()),
    "pieces": ("ringing", None, (REFRESH,)),
    "numpy sift": ("ringing", None, (REFRESH, ("contact/pipeline.py", "_sift_kernel"))),
    "numpy detect": ("ringing", None, (REFRESH, ("contact/narrow.py", "_detect_kernel"))),
    "slope sift": ("rock_slope", None, (REFRESH, ("contact/pipeline.py", "_sift_kernel"))),
}  # fmt: skip

TWINS = {
    ("blocks.py", "moments_kernel"): "wall",
    ("contact/broad.py", "_grid_kernel"): "wall",
    ("contact/broad.py", "_kept_kernel"): "wall",
    ("contact/broad.py", "_still_overlapping_kernel"): "wall",
    ("contact/contact_set.py", "merge_kernel"): "pieces",
    ("contact/law.py", "law_kernels.augment_kernel"): "sparse",
    ("contact/law.py", "law_kernels.broken_kernel"): "sparse",
    ("contact/law.py", "law_kernels.forces_and_bounds_kernel"): "sparse",
    ("contact/law.py", "law_kernels.recorded_kernel"): "sparse",
    ("contact/law.py", "law_kernels.terms_kernel"): "sparse",
    ("contact/line_search.py", "_line_minimum_kernel"): "ringing",
    ("contact/narrow.py", "_detect_kernel"): "pieces",
    ("contact/narrow.py", "_fans_kernel"): "numpy detect",
    ("contact/narrow.py", "_screen_kernel"): "numpy detect",
    ("contact/node.py", "separated_corners_kernel"): "numpy detect",
    ("contact/pipeline.py", "_refresh_kernel"): "wall",
    ("contact/pipeline.py", "_sift_kernel"): "pieces",
    ("contact/point_distance.py", "_distances_kernel"): "slope sift",
    ("contact/rows.py", "_carried_once_kernel"): "wall",
    ("contact/rows.py", "_edge_geometry_kernel"): "numpy sift",
    ("contact/rows.py", "_gaps_kernel"): "sparse",
    ("contact/rows.py", "_rows_kernel"): "wall",
    ("effects/damping.py", "slowest_frequencies_kernel"): "wall",
    ("effects/inertia.py", "masses_kernel"): "wall",
    ("run/energy.py", "block_energies_kernel"): "ringing",
    ("solve/assembly.py", "_find_slots_kernel"): "sparse",
    ("solve/assembly.py", "_scatter_kernel"): "sparse",
    ("solve/assembly.py", "_subtract_pairs_kernel"): "sparse",
    ("solve/band_system.py", "_columns_kernel"): "wall",
    ("solve/band_system.py", "band_newton.band_minimise_kernel"): "wall",
    ("solve/interior_point.py", "direction_kernel"): "wall",
    ("solve/interior_point.py", "matrix_values_kernel"): "wall",
    ("solve/newton.py", "line_step.line_step_kernel"): "sparse",
    ("solve/update.py", "apply_kernel"): "wall",
    ("solve/update.py", "moves_kernel"): "wall",
}

# the twins that sum in another order than numpy (or, for the band Newton, solve in
# another numbering; for the damping's slowest frequencies, by Jacobi rotations where
# numpy asks LAPACK): the same runs to rounding, not to the bit
ROUNDING = {
    ("contact/line_search.py", "_line_minimum_kernel"),
    ("contact/rows.py", "_gaps_kernel"),
    ("effects/damping.py", "slowest_frequencies_kernel"),
    ("solve/assembly.py", "_scatter_kernel"),
    ("solve/assembly.py", "_subtract_pairs_kernel"),
    ("solve/band_system.py", "band_newton.band_minimise_kernel"),
    ("solve/newton.py", "line_step.line_step_kernel"),
}

BRANCH = re.compile(r"\bcompiled(?:_in_run)?\(\s*([\w.]+)\s*\)")


def branches() -> set[tuple[str, str]]:
    """(file, kernel) of every compiled() / compiled_in_run() branch in dda/."""
    found = set()
    for path in PACKAGE.rglob("*.py"):
        if path.relative_to(PACKAGE).parts[0] == "jit":
            continue  # the switch itself
        for name in BRANCH.findall(path.read_text()):
            found.add((path.relative_to(PACKAGE).as_posix(), name))
    return found


def test_every_compiled_branch_is_declared():
    assert branches() == set(TWINS)


def _scene(name: str):
    if name == "rock_slope":
        scene = dda.load_scene(PACKAGE.parent / "cases" / "rock_slope.toml")
        analysis = dataclasses.replace(scene.analysis, duration=None, steps=6)
        return dataclasses.replace(scene, analysis=analysis)
    start = "equilibrium" if name == "wall" else "unloaded"
    method = "penalty" if name == "ringing" else "augmented-lagrangian"  # restitution's
    scene = wall_scene(4, method=method, steps=6, start=start)
    if name == "ringing":
        scene["joints"]["default"]["restitution"] = 0.5
    return dda.load_scene(scene)


def _run(name: str, monkeypatch, off: tuple = ()) -> dda.Result:
    """The run ``name`` with the kernels of its own list and of the sites ``off``
    switched off."""
    scene, systems, run_off = RUNS[name]
    monkeypatch.setenv("DDA_THREADS", "1")  # PARDISO's sums in one order: runs repeat
    if systems is not None:
        monkeypatch.setenv("DDA_SYSTEMS", systems)
    skipped = {_function_of(getattr(*_kernel_owner(*site))) for site in (*run_off, *off)}
    _wrap_switches(monkeypatch, lambda function, original: function not in skipped)
    with jit.run_work(10**6, 10**6):  # the kernels, as in a long run
        return dda.simulate(_scene(scene))


def _wrap_switches(monkeypatch, decide) -> None:
    """Every ``compiled`` / ``compiled_in_run`` of the modules in :data:`TWINS` answers
    False where it did or where ``decide(the kernel's function, the switch it wraps)`` is
    false (wrappers nest)."""
    for file, _ in TWINS:
        module = importlib.import_module("dda." + file.removesuffix(".py").replace("/", "."))
        for switch in ("compiled", "compiled_in_run"):
            original = getattr(module, switch, None)
            if original is None:
                continue

            def answer(kernel, original=original):
                return original(kernel) and decide(_function_of(kernel), original)

            monkeypatch.setattr(module, switch, answer)


def _kernel_owner(file: str, name: str):
    """(object holding the kernel's name, the attribute) of a branch's kernel."""
    module = importlib.import_module("dda." + file.removesuffix(".py").replace("/", "."))
    *path, attribute = name.split(".")
    for part in path:
        module = getattr(module, part)
    return module, attribute


def _function_of(kernel) -> object:
    """The Python function of a :class:`dda.jit.Kernel` or of the numba dispatcher that
    replaces it in the modules of kernels that call it."""
    return getattr(kernel, "function", None) or getattr(kernel, "py_func", None)


@functools.cache
def _asked(name: str) -> frozenset:
    """The functions of the kernels whose branches the run ``name`` asked about."""
    asked = set()
    patch = pytest.MonkeyPatch()
    try:
        _wrap_switches(patch, lambda function, original: asked.add(function) or True)
        _run(name, patch)
    finally:
        patch.undo()
    return frozenset(asked)


def _outcome(result: dda.Result) -> dict[str, np.ndarray]:
    """The blocks' vertices, the contacts' forces (in their order) and the last energies."""
    final = result.final
    energies = [result.history[f"{term}_energy"][-1] for term in ENERGIES]
    return {
        "vertices": np.concatenate(final.vertices),
        "normal": np.asarray(final.contacts.normal_force),
        "shear": np.asarray(final.contacts.shear_force),
        "energies": np.array(energies),
    }


ENERGIES = ("kinetic", "potential", "elastic", "contact", "springs")


@pytest.mark.parametrize("site", sorted(TWINS), ids=lambda s: f"{s[0]}:{s[1]}")
def test_a_compiled_twin_gives_the_run_of_its_numpy_code(site, monkeypatch):
    name = TWINS[site]
    kernel = getattr(*_kernel_owner(*site))
    assert _function_of(kernel) in _asked(name), f"the {name} run takes no branch of {site}"
    with monkeypatch.context() as patch:
        expected = _outcome(_run(name, patch))
    with monkeypatch.context() as patch:
        got = _outcome(_run(name, patch, off=(site,)))
    assert got["normal"].shape == expected["normal"].shape, "other contacts"
    # the energy kernel sums over the blocks in another order than numpy
    np.testing.assert_allclose(got["energies"], expected["energies"], rtol=1e-9, atol=1e-12)
    if site in ROUNDING:  # six steps of rounding: 1e-12 m (blocks of 1 m) measured
        np.testing.assert_allclose(got["vertices"], expected["vertices"], rtol=0.0, atol=1e-10)
        # ... and forces to 1e-7 of the largest: a side contact of the wall at its
        # open/closed kink (6.5e-9 N against 30 N) takes its state by rounding, and the
        # forces beside it then move by up to 1.1e-8 of the largest in the six steps
        # (measured; the bound is this scene's: the 8 x 8 wall's six steps with every
        # kernel and with none differ by 3.9e-7 of the largest)
        scale = 1e-7 * max(np.abs(expected["normal"]).max(initial=0.0), 1.0)
        for force in ("normal", "shear"):
            np.testing.assert_allclose(got[force], expected[force], rtol=1e-8, atol=scale)
    else:
        for key in ("vertices", "normal", "shear"):
            np.testing.assert_array_equal(got[key], expected[key])
