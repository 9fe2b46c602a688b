"""Penalty against augmented Lagrangian on the contact cases (docs/contact.md).

Run::

    python -m dda.bench.contact_methods --out docs/contact_table.md \
        --picture docs/images/paper_two_blocks.png

For each case and method it reports the largest penetration over the run, the
linear solves (Newton iterations and chord steps) per step, the
factorisations per step and the wall milliseconds per step.
"""

from __future__ import annotations

import argparse
import copy
import platform
import time
import tomllib
from pathlib import Path

import numpy as np

import dda
import dda.cases

METHODS = ("penalty", "augmented-lagrangian")


def case(name: str, **analysis) -> dict:
    raw = tomllib.loads(dda.cases.text(name))
    raw["analysis"].update(analysis)
    return raw


def scenarios() -> dict[str, dict]:
    """The comparison scenes (dicts in the scene format)."""
    fig2 = case("paper_two_blocks", steps=90)
    pushed = copy.deepcopy(fig2)
    pushed["loads"][0]["force"] = [4000.0, -1000.0]
    resting = case("paper_two_blocks", mode="static", time_step=1.0, steps=30)
    resting["loads"][0]["force"] = [0.0, -1000.0]
    stiff = copy.deepcopy(fig2)
    stiff["contact"]["penalty"] = 1e9
    return {
        "Fig. 2, p0 = 1e4 (90 steps)": fig2,
        "Fig. 2, p0 = 1e9 (90 steps)": stiff,
        "Fig. 2 pushed by 4,000 lb (90 steps)": pushed,
        "Fig. 2 resting, static (30 steps)": resting,
        "sliding block, 30° slope (100 steps)": case("sliding_block"),
        "stack of five, 1 s (1000 steps)": case("stack"),
    }


def measure(raw: dict, method: str) -> dict:
    scene = copy.deepcopy(raw)
    scene["contact"]["method"] = method
    start = time.perf_counter()
    result = dda.simulate(scene)
    wall = time.perf_counter() - start
    s = result.summary
    return {
        "max_penetration": s["max_penetration"],
        "solves_per_step": s["iterations_per_step"],
        "factorisations_per_step": s["factorisations"] / s["steps"],
        "ms_per_step": 1e3 * wall / s["steps"],
        "result": result,
    }


def table(rows: list[tuple[str, str, dict]]) -> str:
    lines = [
        "| case | method | max penetration | solves/step | factorisations/step | ms/step |",
        "|---|---|---|---|---|---|",
    ]
    for name, method, m in rows:
        lines.append(
            f"| {name} | {method} | {m['max_penetration']:.3g} | {m['solves_per_step']:.2f} "
            f"| {m['factorisations_per_step']:.2f} | {m['ms_per_step']:.2f} |"
        )
    return "\n".join(lines)


def picture(path: Path) -> None:
    """Fig. 2b/2c side by side: AL after 315 steps, penalty after 90 steps."""
    from dda.io.images import render_side_by_side

    al = dda.simulate(case("paper_two_blocks")).final
    pen = dda.simulate(case("paper_two_blocks_penalty")).final
    render_side_by_side(
        [al, pen],
        ["augmented Lagrangian, 315 steps", "penalty, 90 steps"],
        path,
        scalars="syy",
        scene_title="Paper Fig. 2: two blocks from an initial penalty of 1e4 lb/ft",
        units={"length": "ft", "force": "lb", "time": "s"},
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, help="write the markdown table here")
    parser.add_argument("--picture", type=Path, help="write the Fig. 2 picture here")
    args = parser.parse_args()
    rows = []
    for name, raw in scenarios().items():
        for method in METHODS:
            rows.append((name, method, measure(raw, method)))
            print(f"{name:40s} {method:22s} done", flush=True)
    text = (
        f"Machine: {platform.processor() or platform.machine()}, "
        f"{platform.python_implementation()} {platform.python_version()}, "
        f"numpy {np.__version__}. Command: `python -m dda.bench.contact_methods`.\n\n" + table(rows)
    )
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    if args.picture:
        picture(args.picture)


if __name__ == "__main__":
    main()
