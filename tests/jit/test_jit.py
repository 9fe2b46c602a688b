"""numba's kernels run where they pay: large runs and direct calls, not small runs."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from dda import jit
from dda.contact import rows as rows_module

needs_numba = pytest.mark.skipif(not jit.numba_enabled(), reason="numba is not in use")


@needs_numba
def test_kernels_are_used_outside_a_run_and_in_runs_with_enough_work():
    kernel = rows_module._rows_kernel
    assert jit.compiled(kernel)
    with jit.run_work(blocks=2, steps=300) as used:  # 600 block-steps
        assert not used and not jit.compiled(kernel)
        with jit.run_work(blocks=900, steps=100) as inner:
            assert inner and jit.compiled(kernel)
        assert not jit.compiled(kernel)
    assert jit.compiled(kernel)
    assert not jit.compiled(None)


@needs_numba
def test_helpers_that_building_a_model_calls_use_their_kernels_only_inside_a_run():
    """Polygon moments and the energy account are computed when a model is built too
    (before any run's work is known): there they stay numpy, so that a small run does
    not load numba for them."""
    from dda.blocks import moments_kernel

    assert jit.compiled(moments_kernel) and not jit.compiled_in_run(moments_kernel)
    with jit.run_work(blocks=900, steps=100):
        assert jit.compiled_in_run(moments_kernel)
    with jit.run_work(blocks=2, steps=300):
        assert not jit.compiled_in_run(moments_kernel)
    assert not jit.compiled_in_run(None)


@needs_numba
def test_a_long_run_of_a_few_blocks_uses_the_kernels():
    """Their saving a step does not shrink with the blocks: 1,000 steps of six blocks pay
    for loading them (the stack: 3.9-5.2 s of CPU against 6.7-7.0 without)."""
    kernel = rows_module._rows_kernel
    with jit.run_work(blocks=6, steps=1000) as used:
        assert used and jit.compiled(kernel)
    with jit.run_work(blocks=2, steps=315) as used:  # the paper's two blocks: they do not
        assert not used


@needs_numba
def test_a_run_inside_a_block_of_more_work_uses_the_kernels():
    """The benchmark times a few steps standing for a long run: the larger work counts."""
    kernel = rows_module._rows_kernel
    with jit.run_work(blocks=26, steps=10_000):
        with jit.run_work(blocks=26, steps=100) as used:  # the run's own figure
            assert used and jit.compiled(kernel)
    with jit.run_work(blocks=26, steps=100):
        assert not jit.compiled(kernel)


def test_a_small_run_imports_neither_numba_nor_pardiso_nor_scipys_solvers():
    """The paper's two blocks: the numpy path and numpy's dense solve (start-up as without
    them: scipy.sparse and scipy.linalg are 0.13 s of the process); its summary says it
    compiled nothing."""
    code = (
        "import sys, dda; s = dda.simulate('cases/paper_two_blocks.toml').summary; "
        "print(*(name in sys.modules for name in ('numba', 'pypardiso', 'scipy.sparse', "
        "'scipy.linalg')), s['compile_seconds'])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False", "False", "False", "0.0"]


def test_a_small_run_that_starts_in_contact_imports_no_numba():
    """The sliding block starts loaded (equilibrium start): the contact rows of its first
    frame come from numpy as its steps' do, not from kernels loaded for that one frame."""
    code = (
        "import sys, dda; dda.simulate('cases/sliding_block.toml'); print('numba' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False"]


@needs_numba
def test_a_kernel_binds_the_compiled_helpers_it_calls():
    """The rows kernel calls the helper ``_project``: compiling it compiles the helper."""
    kernel = rows_module._rows_kernel
    assert kernel.dispatcher is kernel.dispatcher  # made once
    assert not isinstance(rows_module._project, jit.Kernel)
    assert hasattr(rows_module._project, "py_func")  # a numba dispatcher


_ONE_KERNEL = """
import logging, numpy as np
logging.basicConfig(format="%(levelname)s %(name)s: %(message)s")
from dda.contact.broad import _still_overlapping_kernel as overlapping
boxes = np.array([[0, 0, 1, 1], [0.5, 0.5, 2, 2]], float)
for _ in range(2):
    print(overlapping(boxes, np.array([[0, 1]], np.int64)).tolist())
from dda import jit
print(jit.compile_seconds() > 0)
"""


@needs_numba
def test_compiling_a_kernel_is_announced_once_and_loading_it_from_the_cache_is_not(tmp_path):
    """A first run after installing waits for numba to compile: a warning says so, once;
    a later process that loads the kernel from numba's cache says nothing."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    runs = [
        subprocess.run(
            [sys.executable, "-c", _ONE_KERNEL], capture_output=True, text=True, check=True, env=env
        )
        for _ in range(2)
    ]
    outputs = [run.stdout.split() for run in runs]
    assert outputs == [["[True]", "[True]", "True"], ["[True]", "[True]", "False"]]
    assert runs[0].stderr.count("compiling the kernels this run needs for this machine") == 1
    assert runs[0].stderr.startswith("WARNING dda.jit:")
    assert runs[1].stderr == ""


def _kernels() -> dict[str, object]:
    """Every kernel of the package, by qualified name (every module imported): its
    :class:`dda.jit.Kernel`, or the numba dispatcher a compiled kernel bound in its place."""
    import importlib
    import pkgutil

    import dda

    found = {}
    for info in pkgutil.walk_packages(dda.__path__, "dda."):
        if not info.name.endswith("__main__"):
            module = importlib.import_module(info.name)
            for value in vars(module).values():
                if isinstance(value, jit.Kernel):
                    function = value.function
                elif type(value).__name__.endswith("Dispatcher"):  # bound once it compiled
                    function = value.py_func
                else:
                    continue
                found[f"{function.__module__}.{function.__qualname__}"] = function
    return found


def _slice_assignments_of_arrays(function) -> list[str]:
    """The statements of ``function`` that assign a non-constant to a slice."""
    import ast
    import inspect
    import textwrap

    def slices(target) -> bool:
        return isinstance(target, ast.Subscript) and any(
            isinstance(part, ast.Slice) for part in ast.walk(target.slice)
        )

    found = []
    for node in ast.walk(ast.parse(textwrap.dedent(inspect.getsource(function)))):
        if isinstance(node, ast.Assign | ast.AugAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            flat = [t for target in targets for t in getattr(target, "elts", [target])]
            constant = isinstance(node.value, ast.Constant)
            if not constant and any(slices(target) for target in flat):
                found.append(ast.unparse(node))
    return found


@needs_numba
def test_kernels_copy_arrays_into_slices_by_loops():
    """A slice assignment of an array in a kernel makes numba compile its shape-mismatch
    error message, about 6 s of CPU in a process's first compile (dda.jit's docstring)."""
    kernels = _kernels()
    assert len(kernels) >= 70
    found = {
        name: lines for name, f in kernels.items() if (lines := _slice_assignments_of_arrays(f))
    }
    assert found == {}


@needs_numba
def test_formulas_of_numbers_compile_to_branches_that_allocate_nothing():
    """A formula called on one contact's numbers inside a kernel must not build arrays:
    numba's ``np.where`` of numbers makes a 0-d array on the heap per call (it made the
    contact law's loops several times slower), so :func:`dda.jit.select` compiles to a
    plain choice for numbers, and the formulas read one contact's strengths as numbers
    (:func:`~dda.contact.strength.joint_of`); the machine code of a kernel calling them
    holds no allocation. Arrays still take ``np.where``."""
    import numba
    import numpy as np

    from dda.contact import formulas
    from dda.contact.strength import joint_of

    jit._register_formulas()

    @numba.njit
    def one_contact(base, penalty, bound, value):
        return (
            formulas.shear_piece(base, penalty, bound, value)
            + formulas.normal_offset(base, penalty, bound, value, formulas.NORMAL_ELASTIC)
            + formulas.shear_spring(penalty, formulas.STICK)
            + formulas.tension_held(joint_of(STRENGTH, 0), value > 0.0, value > 5.0)
            + formulas.friction_bound(joint_of(STRENGTH, 0), value, value > 0.0)
        )

    STRENGTH = _strength_of_one_joint()
    assert one_contact(1.0, 2.0, 3.0, 4.0) == pytest.approx(
        formulas.shear_piece(1.0, 2.0, 3.0, 4.0)
        + formulas.normal_offset(1.0, 2.0, 3.0, 4.0, formulas.NORMAL_ELASTIC)
        + formulas.shear_spring(2.0, formulas.STICK)
        + formulas.tension_held(joint_of(STRENGTH, 0), True, False)
        + formulas.friction_bound(joint_of(STRENGTH, 0), 4.0, True)
    )
    machine_code = "".join(one_contact.inspect_llvm().values())
    assert "NRT_MemInfo_alloc" not in machine_code

    @numba.njit
    def many(condition, a, b):
        return jit.select(condition, a, b)

    chosen = many(np.array([True, False]), np.array([1.0, 2.0]), np.array([3.0, 4.0]))
    assert np.array_equal(chosen, [1.0, 4.0])


def _strength_of_one_joint():
    """A joint-strength tuple of one contact, as the law passes the kernels."""
    import numpy as np

    from dda.contact.strength import Strength

    values = {name: np.ones(1) for name in Strength._fields}
    values.update(barton=np.zeros(1, bool), any_barton=False)
    return Strength(**values)


@needs_numba
@pytest.mark.parametrize("preset, expected", [(None, 1), ("2", 2)])
def test_kernels_compile_at_the_quick_optimisation_level_unless_the_environment_sets_one(
    preset, expected
):
    """dda sets numba's NUMBA_OPT to 1 before numba's first import (the same numbers
    and speed as numba's default 3, about a tenth less compile time: dda/jit), and
    leaves a level the environment gives alone."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_OPT"}
    if preset is not None:
        env["NUMBA_OPT"] = preset
    code = (
        "from dda.contact import rows\n"
        "rows._rows_kernel.dispatcher\n"
        "from numba.core import config\n"
        "print(int(config.OPT))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert int(out.stdout.split()[-1]) == expected
