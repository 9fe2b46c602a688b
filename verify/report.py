"""The verification report: a console table, ``report.md`` and ``report.json``."""

from __future__ import annotations

import json
import math
from dataclasses import asdict
from pathlib import Path

from verify.harness.cases import CaseError, CaseResult
from verify.studies.convergence import ConvergencePoint, observed_rates


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


def error_table(errors: list[CaseError]) -> list[list[str]]:
    """Rows: case, "-", "-", "-", ERROR: message (a case that raised has no verdicts)."""
    return [[e.name, "-", "-", "-", f"ERROR: {e.message}"] for e in errors]


def format_console(results: list[CaseResult], errors: list[CaseError] = ()) -> str:
    """Plain-text table for the terminal; a case that raised is a row ERROR."""
    header = ["case", "quantity", "error", "tolerance", "result"]
    rows = [header] + verdict_table(results) + error_table(list(errors))
    widths = [max(len(row[k]) for row in rows) for k in range(len(header))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)) for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    failed = sum(not r.passed for r in results)
    lines.append(f"{len(results) - failed}/{len(results)} cases within their tolerances")
    if errors:
        lines.append(f"{len(errors)} raised (ERROR): {', '.join(e.name for e in errors)}")
    return "\n".join(lines)


def _markdown_table(header: list[str], rows: list[list[str]]) -> list[str]:
    """A Markdown table; a ``|`` in a cell (a contact row's "base|lower") escaped, so that
    it does not split the cell."""
    lines = ["| " + " | ".join(_cells(header)) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cells(row)) + " |" for row in rows]
    return lines


def _cells(row: list[str]) -> list[str]:
    return [str(cell).replace("|", "\\|") for cell in row]


def case_section(result: CaseResult, image: str | None) -> list[str]:
    """Markdown for one case: what it is, verdicts with reasons, numbers, picture."""
    e = result.expectation
    lines = [f"## {result.case.name}", "", e.summary, ""]
    lines += [_kind_line(result), ""]
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
    shown = [r for r in result.rows if _shown(r, e)]
    lines += [
        "",
        *_markdown_table(
            [
                "quantity",
                "item",
                "component",
                "DDA",
                "reference",
                "predicted offset",
                "signed error",
            ],
            [
                [
                    r.quantity,
                    r.item,
                    r.component,
                    f"{r.dda:.6g}",
                    f"{r.fem:.6g}",
                    f"{r.offset:.4g}",
                    f"{r.signed_error:+.1e}",
                ]
                for r in shown
            ],
        ),
    ]
    if image:
        lines += ["", f"![{result.case.name}]({image})"]
    return lines + [""]


def _kind_line(result: CaseResult) -> str:
    """How the case ran: DDA steps and seconds; the FEM side, or the motion study."""
    e = result.expectation
    line = (
        f"Kind: {e.kind}. DDA: {result.dda.summary.get('steps', '?')} steps, "
        f"{result.seconds.get('dda', 0):.2f} s"
        + (f", settled to {result.dda.settled:.1e}" if e.kind == "static" else "")
        + ". "
    )
    if result.fem is None:  # motion: the closed form at several time steps
        study = result.series
        errors = study["errors"]
        line += f"Reference: closed form '{e.reference}'; largest |DDA − reference| at Δt = " + (
            "; ".join(
                f"{study['time_steps'][f]:g} s: "
                + ", ".join(f"{c} {v:.2e}" for c, v in errors[f].items())
                for f in sorted(errors, reverse=True)
            )
        )
        orders = ", ".join(f"{c} {p:.2f}" for c, p in study["orders"].items())
        line += f"; observed order in Δt (two finest): {orders or 'none'}."
    else:
        state = result.fem.state
        line += (
            f"FEM: P{e.fem_order}, {result.fem.basis.N} DOFs, {len(result.fem.contact)} contact "
            f"points ({int(state.closed.sum())} closed, {int(state.slip.sum())} slipping), "
            f"{result.fem.iterations} linear solve(s), {result.seconds.get('fem', 0):.2f} s."
        )
    return line + (f" Catches: {', '.join(e.catches)}." if e.catches else "")


def _motion_study(result: CaseResult) -> dict | None:
    """report.json's ``dt_study`` of a motion case: Δt, errors per Δt, observed orders."""
    if result.fem is not None:
        return None
    s = result.series
    return {
        "reference": result.expectation.reference,
        "time_steps": [s["time_steps"][f] for f in sorted(s["errors"], reverse=True)],
        "errors": [s["errors"][f] for f in sorted(s["errors"], reverse=True)],
        "observed_order": s["orders"],
        "expected_order": result.expectation.order,
        "events": s["events"],
        **_rebound(s),
    }


def _rebound(series: dict) -> dict:
    """A drop's rebound coefficient per time step (as ``time_steps``) and its limit."""
    if "rebound" not in series:
        return {}
    e = series["rebound"]["e"]
    return {
        "rebound": [e[f] for f in sorted(e, reverse=True)],
        "rebound_limit": series["rebound"]["limit"],
    }


def _shown(row, expectation) -> bool:
    """Rows listed in the report: checked ones, but only the worst of a history."""
    check = expectation.checks.get(row.quantity)
    if check is None or not check.applies_to(row.item, row.component):
        return False
    return (
        row.quantity not in ("history", "stress_history", "motion", "stress") or "@" not in row.item
    )


def refinement_section(refinement) -> list[str]:
    """Markdown for the block-refinement study: findings, errors and observed orders."""
    from verify.studies.refinement import observed_orders

    lines = ["## Block refinement (DDA blocks with locked joints against the continuum)", ""]
    lines += _markdown_table(
        ["body", "expectation", "value", "limit", "result"],
        [
            [f.body, f.claim, f"{f.value:.3g}", f"{f.limit:.3g}", "PASS" if f.passed else "FAIL"]
            for f in refinement.findings
        ],
    )
    for body, estimate in refinement.references.items():
        lines += [
            "",
            f"Reference ({body}): P2, {estimate['elements']} elements, {estimate['dofs']} DOFs; "
            f"one more refinement changes its displacement norm by {estimate['displacement']:.1e}, "
            f"its stress norm by {estimate['stress']:.1e}, its tip displacement by "
            f"{estimate['tip']:.1e}.",
        ]
    orders = {q: observed_orders(refinement.points, q) for q in ("displacement", "stress", "tip")}
    rows = []
    for p in sorted(refinement.points, key=lambda p: (p.body, p.series, p.k)):
        rows.append(
            [
                p.body,
                p.series,
                str(p.k),
                str(p.blocks),
                f"{p.displacement:.3e}",
                f"{p.stress:.3e}",
                f"{p.tip:.3e}",
            ]
        )
    lines += [""] + _markdown_table(
        ["body", "series", "k", "blocks", "displacement", "stress", "tip"], rows
    )
    lines += ["", "Observed orders log2(e_k / e_2k), k = 1→2, 2→4, ...:", ""]
    lines += _markdown_table(
        ["body", "series", "displacement", "stress", "tip"],
        [
            [body, series]
            + [", ".join(f"{o:.2f}" for o in orders[q][(body, series)]) for q in orders]
            for body, series in orders["displacement"]
        ],
    )
    picture = "verify_refinement.png"  # in the report's images/ folder
    return lines + ["", f"![refinement](images/{picture})", ""]


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
    refinement=None,
    errors: list[CaseError] = (),
) -> Path:
    """Write ``report.md``; cases that raised are ERROR rows and an "Errors" section."""
    images = images or {}
    lines = ["# DDA verification against FEM (scikit-fem)", ""]
    lines += _markdown_table(
        ["case", "quantity", "error", "tolerance", "result"],
        verdict_table(results) + error_table(list(errors)),
    )
    if errors:
        lines += ["", "## Errors", "", "These raised instead of giving verdicts:", ""]
        lines += [f"- **{e.name}**: `{e.message}`" for e in errors]
    if summary_image:
        lines += ["", f"![summary]({summary_image})"]
    lines.append("")
    for r in results:
        lines += case_section(r, images.get(r.case.name))
    if refinement:
        lines += refinement_section(refinement)
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
    results: list[CaseResult],
    path: Path,
    convergence: list[ConvergencePoint] | None = None,
    refinement=None,
    errors: list[CaseError] = (),
) -> Path:
    """Write ``report.json``: verdicts and every compared row of every case, and the
    cases that raised (``errors``: name and message)."""
    data = {
        "passed": not errors and all(r.passed for r in results),
        "errors": [{"name": e.name, "message": e.message} for e in errors],
        "cases": [
            {
                "name": r.case.name,
                "summary": r.expectation.summary,
                "passed": r.passed,
                "seconds": r.seconds,
                "kind": r.expectation.kind,
                "catches": list(r.expectation.catches),
                "dda_settled": r.dda.settled,
                "fem_dofs": None if r.fem is None else int(r.fem.basis.N),
                "dt_study": _motion_study(r),
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
    if refinement:
        data["refinement"] = {
            "points": [asdict(p) for p in refinement.points],
            "references": refinement.references,
            "findings": [asdict(f) for f in refinement.findings],
        }
    path = Path(path)
    path.write_text(json.dumps(_clean(data), indent=2))
    return path
