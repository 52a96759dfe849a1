"""Wall times of the committed executed notebooks (``notebooks/executed/*.ipynb``), from papermill's
metadata: the notebook's start and end times and each cell's ``metadata.papermill.duration``.

Per paper: the wall time (papermill's ``duration``, end - start, kernel start-up included), its
*headline* part (the cells before the first code cell that calls ``nb.multiverse()``: set-up, the
headline reading's Monte Carlo evaluation, figures, claims) and its *multiverse* part (that cell and
every later one: the reading-space universes and their tables and figures); the rest of the wall
time is papermill's own (kernel start, between cells).  These are the times of the run that produced
the committed notebooks, not of this benchmark's run.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

from mmlib.experiment.results import read_results

#: the call that starts a notebook's reading space (``nb.multiverse()`` of NotebookRun; ``run_multiverse(`` before it)
MULTIVERSE_CALL = re.compile(r"\brun_multiverse\(|\.multiverse\(")
CACHE_LINE = re.compile(r"(\d+)/(\d+) universes from the cache")


def _text(outputs) -> str:
    parts = []
    for o in outputs or ():
        t = o.get("text") if "text" in o else o.get("data", {}).get("text/plain", "")
        parts.append("".join(t) if isinstance(t, list) else str(t or ""))
    return "".join(parts)


def notebook_time(path: Path) -> dict:
    """The times of one executed notebook (see the module docstring)."""
    nb = json.loads(Path(path).read_text())
    pm = nb.get("metadata", {}).get("papermill", {})
    durations, split, cached = [], None, 0
    for cell in nb.get("cells", []):
        src = "".join(cell.get("source", ""))
        if split is None and cell.get("cell_type") == "code" and MULTIVERSE_CALL.search(src):
            split = len(durations)
            cached = sum(int(m.group(1)) for m in CACHE_LINE.finditer(_text(cell.get("outputs"))))
        durations.append(float(cell.get("metadata", {}).get("papermill", {}).get("duration") or 0.0))
    cells = sum(durations)
    head = sum(durations[:split]) if split is not None else cells
    return {
        "notebook": str(Path(path).name),
        "start_time": pm.get("start_time"), "end_time": pm.get("end_time"),
        "wall_s": pm.get("duration"),
        "cells_s": cells,
        "headline_s": head,
        "multiverse_s": cells - head if split is not None else None,
        "papermill_overhead_s": (pm.get("duration") - cells) if pm.get("duration") is not None else None,
        "multiverse_first_cell": split,
        "universes_from_cache": cached if split is not None else None,
        "parameters": pm.get("parameters"),
    }


def _throughput(doc: dict, t: dict) -> dict:
    """The reading space's universes of a paper's results (``multiverse.universes``), those computed in this run (the
    rest came from the cache) and the computed ones per minute of the multiverse part's wall time (with its pool of
    workers: per minute of the machine, not of one core); {} without a multiverse.  Where the run recorded how it
    obtained its universes (the provenance's ``multiverse_computed``, ``multiverse_from_cache`` and
    ``multiverse_cpu_s``, from :func:`mmlib.experiment.grid.run_grid`'s ``stats``), those counts replace the ones
    parsed from the notebook (``universes_from_cache``), and the computed universes per CPU-minute of their own jobs
    follow (``universes_per_cpu_minute``: the rate of the computation itself, whatever the workers and the load)."""
    universes = (doc.get("multiverse") or {}).get("universes")
    if not isinstance(universes, list) or not t.get("multiverse_s"):
        return {}
    prov = doc.get("provenance") or {}
    out = {}
    recorded = all(isinstance(prov.get(k), (int, float)) and not isinstance(prov.get(k), bool)
                   for k in ("multiverse_computed", "multiverse_from_cache", "multiverse_cpu_s"))
    if recorded:
        computed, cpu = int(prov["multiverse_computed"]), float(prov["multiverse_cpu_s"])
        out.update(universes_from_cache=int(prov["multiverse_from_cache"]), multiverse_cpu_s=cpu,
                   universes_per_cpu_minute=60.0 * computed / cpu if computed > 0 and cpu > 0 else None)
    else:
        computed = len(universes) - int(t.get("universes_from_cache") or 0)
    return {"universes": len(universes), "universes_computed": computed,
            "universes_per_minute": 60.0 * computed / t["multiverse_s"] if computed > 0 else None, **out}


def notebook_times(executed_dir: Path, results_dir: Path | None = None) -> dict:
    """Every ``*.ipynb`` of ``executed_dir``, keyed by paper (the file name up to its first ``_``), with the
    git commit recorded in the paper's results file (``results_dir/<paper>.json``) when there is one; and
    the sums over the papers.  Studies that are not a paper's replication (the arena: its results file says
    ``"kind": "arena"``) are listed apart, under ``studies``, and are not in the sums."""
    papers, studies = {}, {}
    for path in sorted(Path(executed_dir).glob("*.ipynb")):
        paper = path.stem.split("_")[0]
        t = notebook_time(path)
        res = Path(results_dir) / f"{paper}.json" if results_dir is not None else None
        kind = None
        if res is not None and res.exists():
            doc = read_results(res, name=f"{Path(results_dir).name}/{res.name}")
            t["results_git_commit"] = doc.get("provenance", {}).get("git_commit")
            kind = doc.get("kind")
            t.update(_throughput(doc, t))
        (studies if kind == "arena" else papers)[paper] = t

    def total(key):
        vals = [t[key] for t in papers.values()]
        return None if any(v is None for v in vals) else sum(vals)
    starts = [t["start_time"] for t in papers.values() if t["start_time"]]
    ends = [t["end_time"] for t in papers.values() if t["end_time"]]
    return {
        "what": "wall times of the run that produced the committed executed notebooks (notebooks/executed/), read "
                "from papermill's metadata; not times of this benchmark's run. headline = the cells before the first "
                "code cell calling nb.multiverse() ; multiverse = that cell and all later ones; papermill_overhead = "
                "wall - sum of the cells (kernel start-up). The multiverse's universes run in a pool of $WORKERS "
                "processes (default: the usable cores) with one BLAS thread each; the notebooks do not record the "
                "worker count. universes_from_cache: universes read from the multiverse cache instead of computed (0:"
                " all computed); universes_per_minute: the computed universes per minute of the multiverse part's "
                "wall time (all its workers together, the run-count stability check's universes included in that "
                "time); multiverse_cpu_s: the CPU seconds of the computed universes' own jobs (each on one thread, "
                "where it ran), universes_per_cpu_minute: the computed universes per minute of that CPU time (the "
                "rate of the computation, whatever the workers and the load; from the results' provenance, where the "
                "run recorded it). Written by make figures after the notebooks run (python -m bench.notebooks) and by"
                " make bench.",
        "papers": papers,
        "studies": studies,
        "sum": {"wall_s": total("wall_s"), "headline_s": total("headline_s"), "multiverse_s": total("multiverse_s"),
                "cells_s": total("cells_s"), "papermill_overhead_s": total("papermill_overhead_s")},
        "first_start": min(starts) if starts else None, "last_end": max(ends) if ends else None,
    }


def main() -> int:
    """Write ``data/bench/notebooks.json`` from the executed notebooks and results in place (``make figures`` runs
    this after the notebooks)."""
    import sys
    repo = Path(__file__).resolve().parent.parent
    sys.path.insert(0, str(repo))
    from bench.provenance import provenance
    from mmlib.experiment.writing import atomic_write_text
    doc = notebook_times(repo / "notebooks" / "executed", repo / "data" / "results")
    doc.update(provenance())
    (repo / "data" / "bench").mkdir(parents=True, exist_ok=True)
    atomic_write_text(repo / "data" / "bench" / "notebooks.json", json.dumps(doc, indent=1) + "\n")
    for paper, t in doc["papers"].items():
        rate, cpu_rate = t.get("universes_per_minute"), t.get("universes_per_cpu_minute")
        print(f"  {paper}: {t['wall_s']:.0f} s wall" + (f", {t['universes_computed']} universes computed, "
                                                        f"{rate:.1f} per minute" if rate else "")
              + (f", {cpu_rate:.1f} per CPU-minute" if cpu_rate else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
