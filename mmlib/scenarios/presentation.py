"""Small rendering helpers shared by the paper notebooks (Markdown tables, figure styling)."""
from __future__ import annotations

import numpy as np


def markdown_table(header, rows) -> str:
    def cell(v):
        if v is None:
            return "--"
        if isinstance(v, float):
            return "nan" if not np.isfinite(v) else f"{v:.4g}"
        return str(v).replace("|", "\\|")
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(v) for v in r) + " |" for r in rows]
    return "\n".join(lines)


def value_pm(value, stderr, digits=3) -> str:
    if value is None:
        return "--"
    if stderr is None or not np.isfinite(stderr):
        return f"{value:.{digits}f}"
    return f"{value:.{digits}f} ± {stderr:.{digits}f}"


def deviations_table(deviations) -> str:
    return markdown_table(["id", "topic", "paper", "our choice", "why", "sweep"],
                          [[d.id, d.topic, d.paper, d.choice, d.reason, d.sweep or ""] for d in deviations])


def rows_table(rows) -> str:
    return markdown_table(["item", "algorithm", "quantity", "paper", "replicated ± s.e.", "verdict", "deviations"],
                          [[r.item, r.algorithm, r.quantity, r.paper or "--", value_pm(r.replicated, r.stderr),
                            r.verdict, ", ".join(r.deviations)] for r in rows])


def shade_intervals(ax, intervals, label="true maneuver", color="0.9"):
    for i, (a, b) in enumerate(intervals):
        ax.axvspan(a, b, color=color, zorder=0, label=label if i == 0 else None)
