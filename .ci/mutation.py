"""Mutation campaign over the physics modules: cosmic-ray, judged by `dda verify --quick`.

A random sample (fixed seed) of the mutants cosmic-ray makes in the physics
modules is run, one at a time, under ``nice -n 19``:

1. stage 1 — ``dda verify --quick --no-images -o DIR``: a mutant is killed when
   the command exits non-zero (a failed check, an ERROR row, a crash) or runs
   past the timeout (3 x the unmutated run);
2. stage 2 — each survivor of stage 1 is applied again and the unit tests of
   its module (:data:`TESTS`, ``pytest -n 0``) are run: killed when they fail.

The mutation score is the fraction killed with a 95 % Wilson interval:
p = (k + z²/2) / (n + z²) ± z √(k(n-k)/n + z²/4) / (n + z²), z = 1.96.

Usage (from the repository root, with the ``mutation`` extra installed:
``pip install -e '.[test,mutation]'``)::

    python .ci/mutation.py --sample 40 --seed 37 --workdir /tmp/mutation

It writes ``WORKDIR/results.json`` (one record per mutant: module, operator,
occurrence, diff, verify / tests outcome) and ``WORKDIR/table.md``. Rerunning
with the same workdir resumes the pending mutants; ``--stop`` leaves them out
(cosmic-ray runs them in random order: those run are still a random sample).
It is not part of the test suite: each mutant costs a full ``dda verify --quick``
(about 20 s of CPU without the pictures).
"""

from __future__ import annotations

import argparse
import ast
import hashlib
import json
import math
import os
import random
import shlex
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BIN = Path(sys.executable).parent

# the physics modules: contact law and potential, integrator, update, kinematics,
# assembly and the effects (not dda/effects/__init__.py)
MODULES = [
    "dda/contact/law.py",
    "dda/contact/law_kernels.py",
    "dda/contact/potential.py",
    "dda/solve/integrator.py",
    "dda/solve/update.py",
    "dda/solve/assembly.py",
    "dda/solve/dense_system.py",
    "dda/solve/contact_pieces.py",
    "dda/solve/line_step.py",
    "dda/solve/band_newton.py",
    "dda/solve/band_system.py",
    "dda/kinematics.py",
    "dda/effects/base.py",
    "dda/effects/bolts.py",
    "dda/effects/damping.py",
    "dda/effects/elastic.py",
    "dda/effects/fixed_points.py",
    "dda/effects/gravity.py",
    "dda/effects/inertia.py",
    "dda/effects/loads.py",
    "dda/effects/pair_springs.py",
    "dda/effects/points.py",
    "dda/effects/seismic.py",
    "dda/effects/water.py",
]

_MOTION = ["tests/solve/test_integrator.py", "tests/run/test_energy.py"]
_EFFECTS = ["tests/effects/test_effects.py"]
_CASE = "tests/test_cases.py::test_case_runs_and_matches_stored_number[{}]"  # a shipped case
# stage 2: the unit tests of each module (a fast subset, seconds to a minute)
TESTS = {
    "dda/contact/law.py": [
        "tests/contact/test_law.py",
        "tests/contact/test_augmented_lagrangian.py",
        "tests/contact/test_law_kernels.py",
    ],
    # the law's compiled twins against its numpy bodies
    "dda/contact/law_kernels.py": [
        "tests/contact/test_law_kernels.py",
        "tests/contact/test_augmented_lagrangian.py",
    ],
    "dda/contact/potential.py": ["tests/contact/test_potential.py", "tests/solve/test_newton.py"],
    "dda/solve/integrator.py": _MOTION,
    "dda/solve/update.py": _MOTION,
    "dda/kinematics.py": _MOTION + _EFFECTS,
    # the springs between two blocks (rock bolts) are assembled here too
    "dda/solve/assembly.py": ["tests/solve/test_assembly.py", "tests/effects/test_bolts.py"],
    # the compiled Newton pieces against their numpy oracles
    "dda/solve/dense_system.py": ["tests/solve/test_dense_system.py"],
    "dda/solve/contact_pieces.py": ["tests/solve/test_band_newton.py"],
    "dda/solve/line_step.py": ["tests/solve/test_line_step.py"],
    "dda/solve/band_newton.py": ["tests/solve/test_band_newton.py"],
    "dda/solve/band_system.py": ["tests/solve/test_band_newton.py"],
    "dda/effects/pair_springs.py": _EFFECTS
    + ["tests/effects/test_bolts.py", _CASE.format("bolted_block")],
    "dda/effects/bolts.py": _EFFECTS
    + ["tests/effects/test_bolts.py", _CASE.format("bolted_block")],
    "dda/effects/seismic.py": _EFFECTS
    + ["tests/effects/test_seismic.py", _CASE.format("seismic_slope")],
    "dda/effects/water.py": _EFFECTS + ["tests/effects/test_water.py", _CASE.format("wet_slope")],
}

# operators left out: arithmetic turned into a bit operation (a TypeError on floats,
# killed by any run: it would only inflate the score) and the two operators that
# draw random numbers (not reproducible)
EXCLUDED_OPERATORS = [
    r"core/ReplaceBinaryOperator_(Add|Sub|Mul|Div|FloorDiv|Mod|Pow)_(RShift|LShift|BitOr|BitAnd|BitXor)",
    r"core/VariableReplacer",
    r"core/VariableInserter",
]


def wilson(killed: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of the fraction killed/n."""
    if n == 0:
        return (0.0, 1.0)
    centre = (killed + z * z / 2) / (n + z * z)
    half = z * math.sqrt(killed * (n - killed) / n + z * z / 4) / (n + z * z)
    return (max(0.0, centre - half), min(1.0, centre + half))


def _run(cmd: list[str], timeout: float | None = None) -> subprocess.CompletedProcess:
    # no .pyc written: a mutant's bytecode must never outlive the mutant
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    return subprocess.run(
        cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout, check=False
    )


def _verify_command(workdir: Path) -> list[str]:
    out = workdir / "verify-out"
    return [
        "nice",
        "-n",
        "19",
        str(BIN / "dda"),
        "verify",
        "--quick",
        "--no-images",
        "-o",
        str(out),
    ]


def write_config(workdir: Path, timeout: float) -> Path:
    """The cosmic-ray configuration: modules, test command, timeout, operator filter."""
    lines = [
        "[cosmic-ray]",
        f"module-path = {json.dumps(MODULES)}",
        f"timeout = {timeout:.0f}",
        "excluded-modules = []",
        f"test-command = {json.dumps(shlex.join(_verify_command(workdir)))}",
        "",
        "[cosmic-ray.distributor]",
        'name = "local"',
        "",
        "[cosmic-ray.filters.operators-filter]",
        f"exclude-operators = {json.dumps(EXCLUDED_OPERATORS)}",
        "",
    ]
    path = workdir / "cosmic-ray.toml"
    path.write_text("\n".join(lines))
    return path


def sample(session: Path, size: int, seed: int) -> int:
    """Mark all pending mutants but a random sample of ``size`` as skipped; the sample size.

    Mutants are ordered by (module, operator, occurrence) before drawing, so that a
    seed picks the same mutants whatever ids cosmic-ray gave them.
    """
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import WorkerOutcome, WorkResult

    with use_db(str(session), WorkDB.Mode.open) as db:
        items = list(db.pending_work_items)
        key = [
            (i.mutations[0].module_path, i.mutations[0].operator_name, i.mutations[0].occurrence)
            for i in items
        ]
        items = [i for _, i in sorted(zip(key, items, strict=True), key=lambda p: p[0])]
        chosen = set(random.Random(seed).sample(range(len(items)), min(size, len(items))))
        for index, item in enumerate(items):
            if index not in chosen:
                db.set_result(
                    item.job_id,
                    WorkResult(output="not in the sample", worker_outcome=WorkerOutcome.SKIPPED),
                )
        return len(chosen)


def stop(session: Path) -> int:
    """Mark the mutants not run yet as left out; how many.

    cosmic-ray runs the pending mutants in random order, so the ones run are a
    random subsample of the sample.
    """
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import WorkerOutcome, WorkResult

    with use_db(str(session), WorkDB.Mode.open) as db:
        pending = [item.job_id for item in db.pending_work_items]
        for job in pending:
            db.set_result(job, WorkResult(output="not run", worker_outcome=WorkerOutcome.SKIPPED))
    return len(pending)


def baseline(workdir: Path) -> float:
    """Wall time of the unmutated `dda verify --quick`; it must pass."""
    start = time.monotonic()
    done = _run(_verify_command(workdir))
    if done.returncode != 0:
        raise SystemExit(f"mutation: the unmutated `dda verify --quick` fails:\n{done.stdout}")
    return time.monotonic() - start


def _apply(module: str, operator: str, occurrence: int) -> None:
    done = _run([str(BIN / "cosmic-ray"), "apply", module, operator, str(occurrence)])
    if done.returncode != 0:
        raise RuntimeError(f"cosmic-ray apply failed: {done.stderr}")


def in_annotation(module: str, line: int, col: int) -> bool:
    """True when (line, col) of ``module`` lies in a type annotation.

    The physics modules import ``from __future__ import annotations``: an annotation
    is never evaluated, so a mutant there is equivalent (``X | None`` -> ``X % None``).
    """
    tree = ast.parse((ROOT / module).read_text())
    spans = []
    for node in ast.walk(tree):
        if isinstance(node, ast.arg | ast.AnnAssign) and node.annotation is not None:
            spans.append(node.annotation)
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and node.returns is not None:
            spans.append(node.returns)
    return any(
        (n.lineno, n.col_offset) <= (line, col) < (n.end_lineno, n.end_col_offset) for n in spans
    )


def tests_of(module: str) -> list[str]:
    """The unit tests stage 2 runs for a mutant of ``module``."""
    return TESTS.get(module, _EFFECTS if module.startswith("dda/effects/") else [])


def tests_hash(tests: list[str]) -> str:
    """Digest of the test files and node ids: a stage 2 outcome holds while it is unchanged."""
    digest = hashlib.sha256()
    for test in tests:
        digest.update(test.encode())
        digest.update((ROOT / test.split("::")[0]).read_bytes())
    return digest.hexdigest()[:16]


def tests_kill(module: str, operator: str, occurrence: int, timeout: float) -> str:
    """Stage 2: 'killed' or 'survived' by the module's unit tests (or 'no tests')."""
    tests = tests_of(module)
    if not tests:
        return "no tests"
    path = ROOT / module
    original = path.read_text()
    try:
        _apply(module, operator, occurrence)
        cmd = ["nice", "-n", "19", sys.executable, "-m", "pytest", "-n", "0", "-q", "-x"]
        cmd += ["-p", "no:cacheprovider", *tests]
        try:
            done = _run(cmd, timeout=timeout)
        except subprocess.TimeoutExpired:
            return "killed"
        return "killed" if done.returncode != 0 else "survived"
    finally:
        path.write_text(original)


def collect(session: Path) -> list[dict]:
    """One record per sampled mutant from the cosmic-ray session."""
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import WorkerOutcome

    records = []
    with use_db(str(session), WorkDB.Mode.open) as db:
        for item, result in db.completed_work_items:
            if result.worker_outcome == WorkerOutcome.SKIPPED:
                continue
            m = item.mutations[0]
            records.append(
                {
                    "job": item.job_id,
                    "module": str(m.module_path),
                    "operator": m.operator_name,
                    "occurrence": m.occurrence,
                    "line": m.start_pos[0],
                    "column": m.start_pos[1],
                    "worker": result.worker_outcome.value,
                    "verify": result.test_outcome.value if result.test_outcome else None,
                    "timeout": result.output == "timeout",
                    "diff": result.diff,
                }
            )
    return sorted(records, key=lambda r: (r["module"], r["line"], r["operator"]))


def table(records: list[dict]) -> str:
    """The markdown table: per module, sampled / killed by verify / by verify + tests."""
    rows = ["| module | sampled | in annotations | killed by `dda verify --quick` | + tests |"]
    rows.append("|---|---:|---:|---:|---:|")
    for module in MODULES + ["all"]:
        mine = [r for r in records if module in ("all", r["module"])]
        if not mine:
            continue
        eq = sum(str(r.get("tests")).startswith("equivalent") for r in mine)
        k1 = sum(r["verify"] == "killed" for r in mine)
        k2 = sum(r["verify"] == "killed" or r.get("tests") == "killed" for r in mine)
        name = "**all**" if module == "all" else f"`{module}`"
        rows.append(f"| {name} | {len(mine)} | {eq} | {k1} | {k2} |")
    # the score leaves out the mutants in annotations (equivalent by construction);
    # the other equivalent survivors are judged by reading their diff
    records = [r for r in records if not str(r.get("tests")).startswith("equivalent")]
    n = len(records)
    k1 = sum(r["verify"] == "killed" for r in records)
    k2 = sum(r["verify"] == "killed" or r.get("tests") == "killed" for r in records)
    lo1, hi1 = wilson(k1, n)
    lo2, hi2 = wilson(k2, n)
    rows.append("")
    rows.append(
        f"verify alone {k1}/{n} = {k1 / max(n, 1):.0%} (95 % Wilson {lo1:.0%}-{hi1:.0%}); "
        f"verify + tests {k2}/{n} = {k2 / max(n, 1):.0%} ({lo2:.0%}-{hi2:.0%})"
    )
    return "\n".join(rows) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sample", type=int, default=40, help="mutants drawn (default 40)")
    parser.add_argument("--seed", type=int, default=37, help="seed of the draw (default 37)")
    parser.add_argument("--workdir", type=Path, default=Path("/tmp/dda-mutation"))
    parser.add_argument("--timeout", type=float, default=None, help="s (default 3 x baseline)")
    parser.add_argument(
        "--stop",
        action="store_true",
        help="run no more mutants: leave the pending ones out, judge the survivors",
    )
    args = parser.parse_args(argv)
    workdir = args.workdir.resolve()
    workdir.mkdir(parents=True, exist_ok=True)
    session = workdir / "session.sqlite"
    if not session.exists():
        timeout = args.timeout or 3 * baseline(workdir)
        config = write_config(workdir, timeout)
        cr = str(BIN / "cosmic-ray")
        subprocess.run([cr, "init", str(config), str(session)], cwd=ROOT, check=True)
        filt = str(BIN / "cr-filter-operators")
        subprocess.run([filt, str(session), str(config)], cwd=ROOT, check=True)
        n = sample(session, args.sample, args.seed)
        print(f"mutation: {n} mutants sampled (seed {args.seed}), timeout {timeout:.0f} s")
    config = workdir / "cosmic-ray.toml"
    if args.stop:
        print(f"mutation: {stop(session)} mutants of the sample left out (not run)")
    cmd = ["nice", "-n", "19", str(BIN / "cosmic-ray"), "exec", str(config), str(session)]
    subprocess.run(cmd, cwd=ROOT, check=True)
    records = collect(session)
    done_path = workdir / "results.json"
    known = {}  # stage 2 outcomes of an earlier run, reused when made by the same tests
    if done_path.exists():
        known = {
            (r["job"], r.get("tests_hash")): r.get("tests")
            for r in json.loads(done_path.read_text())
        }
    for r in records:
        if r["verify"] == "killed":
            continue
        if in_annotation(r["module"], r["line"], r["column"]):
            r["tests"] = "equivalent (annotation)"
            continue
        r["test_files"] = tests_of(r["module"])
        r["tests_hash"] = tests_hash(r["test_files"])
        r["tests"] = known.get((r["job"], r["tests_hash"])) or tests_kill(
            r["module"], r["operator"], r["occurrence"], timeout=600
        )
        done_path.write_text(json.dumps(records, indent=1))
    done_path.write_text(json.dumps(records, indent=1))
    text = table(records)
    (workdir / "table.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
