"""The verification report: a console table, ``report.md`` and ``report.json``."""

from __future__ import annotations

import json
import math
from pathlib import Path

from verify.cases import CaseResult
from verify.convergence import ConvergencePoint, observed_rates


def verdict_table(results: list[CaseResult]) -> list[list[str]]:
    """Rows: case, quantity, largest error, tolerance, PASS/FAIL."""
    rows = []
    for r in results:
        for v in r.verdicts:
            rows.append(
                [
                    r.case.name,
                    v.quantity,
                    f"{v.error:.2e}",
                    f"{v.tolerance:.2g}",
                    "PASS" if v.passed else "FAIL",
                ]
            )
    return rows


def format_console(results: list[CaseResult]) -> str:
    """Plain-text table for the terminal."""
    header = ["case", "quantity", "error", "tolerance", "result"]
    rows = [header] + verdict_table(results)
    widths = [max(len(row[k]) for row in rows) for k in range(len(header))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)) for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    failed = sum(not r.passed for r in results)
    lines.append(f"{len(results) - failed}/{len(results)} cases within their tolerances")
    return "\n".join(lines)


def _markdown_table(header: list[str], rows: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return lines


def case_section(result: CaseResult, image: str | None) -> list[str]:
    """Markdown for one case: what it is, verdicts with reasons, block numbers, picture."""
    e = result.expectation
    lines = [f"## {result.case.name}", "", e.summary, ""]
    lines += [
        f"DDA: {result.dda.summary.get('steps', '?')} steps, "
        f"settled to {result.dda.settled:.1e} (stress change over the last saved frames), "
        f"{result.seconds.get('dda', 0):.2f} s. FEM: P{e.fem_order}, "
        f"{result.fem.basis.N} DOFs, {len(result.fem.contact)} contact points, "
        f"{result.fem.iterations} active-set solve(s), {result.seconds.get('fem', 0):.2f} s.",
        "",
    ]
    verdicts = [
        [
            v.quantity,
            f"{v.error:.2e}",
            f"{v.tolerance:.2g}",
            "PASS" if v.passed else "FAIL",
            v.why.replace("\n", " "),
        ]
        for v in result.verdicts
    ]
    lines += _markdown_table(["quantity", "error", "tolerance", "result", "why"], verdicts)
    for quantity, note in e.notes.items():
        lines += ["", f"*{quantity}*: " + note.replace("\n", " ")]
    stress = [r for r in result.rows if r.quantity in ("stress", "contact_force", "penetration")]
    lines += [
        "",
        *_markdown_table(
            ["quantity", "item", "component", "DDA", "FEM", "error"],
            [
                [r.quantity, r.item, r.component, f"{r.dda:.6g}", f"{r.fem:.6g}", f"{r.error:.1e}"]
                for r in stress
            ],
        ),
    ]
    if image:
        lines += ["", f"![{result.case.name}]({image})"]
    return lines + [""]


def convergence_section(points: list[ConvergencePoint]) -> list[str]:
    """Markdown for the FEM convergence study."""
    rates = observed_rates(points)
    rows = [
        [
            f"P{p.order}",
            f"{p.size:g}",
            str(p.dofs),
            f"{p.displacement_error:.3e}",
            f"{p.stress_error:.3e}",
        ]
        for p in points
    ]
    return [
        "## FEM convergence (self-weight closed form)",
        "",
        "Block 1 x 2 under self-weight on a uniform base pressure, plane stress: "
        "σyy = −ρg(h − y). Relative L² errors (displacement without its rigid motion).",
        "",
        *_markdown_table(["element", "size", "DOFs", "displacement", "stress"], rows),
        "",
        f"Observed P1 rates: displacement {rates['displacement']:.2f} (expected 2), "
        f"stress {rates['stress']:.2f} (expected 1). P2 reproduces the quadratic closed-form "
        "displacement to round-off.",
        "",
    ]


def write_markdown(
    results: list[CaseResult],
    path: Path,
    images: dict[str, str] | None = None,
    convergence: list[ConvergencePoint] | None = None,
    summary_image: str | None = None,
) -> Path:
    """Write ``report.md``."""
    images = images or {}
    lines = ["# DDA verification against FEM (scikit-fem)", ""]
    lines += _markdown_table(
        ["case", "quantity", "error", "tolerance", "result"], verdict_table(results)
    )
    if summary_image:
        lines += ["", f"![summary]({summary_image})"]
    lines.append("")
    for r in results:
        lines += case_section(r, images.get(r.case.name))
    if convergence:
        lines += convergence_section(convergence)
    path = Path(path)
    path.write_text("\n".join(lines))
    return path


def _clean(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    return value


def write_json(
    results: list[CaseResult], path: Path, convergence: list[ConvergencePoint] | None = None
) -> Path:
    """Write ``report.json``: verdicts and every compared row of every case."""
    data = {
        "passed": all(r.passed for r in results),
        "cases": [
            {
                "name": r.case.name,
                "summary": r.expectation.summary,
                "passed": r.passed,
                "seconds": r.seconds,
                "dda_settled": r.dda.settled,
                "fem_dofs": int(r.fem.basis.N),
                "verdicts": [
                    {
                        "quantity": v.quantity,
                        "error": v.error,
                        "tolerance": v.tolerance,
                        "passed": v.passed,
                        "why": v.why,
                    }
                    for v in r.verdicts
                ],
                "rows": [row.as_dict() for row in r.rows],
            }
            for r in results
        ],
    }
    if convergence:
        data["convergence"] = {
            "points": [
                {
                    "order": p.order,
                    "size": p.size,
                    "dofs": int(p.dofs),
                    "displacement_error": p.displacement_error,
                    "stress_error": p.stress_error,
                }
                for p in convergence
            ],
            "p1_rates": observed_rates(convergence),
        }
    path = Path(path)
    path.write_text(json.dumps(_clean(data), indent=2))
    return path
