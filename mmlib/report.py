"""Paper-versus-replication comparison rows, the verdict rule, and atomic output.

The verdict rule (the only one in this repository)
--------------------------------------------------
For a printed value ``p`` and our Monte Carlo estimate ``r`` with standard
error ``s`` from ``N`` runs, where the paper used ``N_p`` runs:

* the paper's own Monte Carlo error is unknown; it is estimated as
  ``s_p = s * sqrt(N / N_p)`` (same estimator, same spread), and the printed
  value is only known to half a unit of its last digit, ``u``;
* ``sigma = sqrt(s^2 + s_p^2 + u^2)``;
* **reproduced**            if ``|r - p| <= 3 sigma``  (consistent within Monte Carlo noise);
* **qualitatively reproduced** if not, but ``|r - p| <= 0.25 |p|``  (same value within 25 %,
  i.e. the effect sizes the papers argue about are preserved);
* **not reproduced**        otherwise;
* **not replicable**        when no replicated value can be produced (method or data
  not published); the reason is part of the verdict text.

Claims (rankings, "A is better than B") get a separate verdict from a paired
comparison on common random numbers: :func:`claim_verdict`.  Paired differences
can detect effects far too small to matter, so a detected difference smaller than
1 % of the reference mean squared error is labelled *negligible*.
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

REPRODUCED = "reproduced"
QUALITATIVE = "qualitatively reproduced"
NOT_REPRODUCED = "not reproduced"
NOT_REPLICABLE = "not replicable"
VERDICTS = (REPRODUCED, QUALITATIVE, NOT_REPRODUCED, NOT_REPLICABLE)
SIGMA_FACTOR = 3.0
RELATIVE_BAND = 0.25


def printed_half_unit(printed: str) -> float:
    """Half a unit of the last printed digit of a number given as text ('2.6675' -> 5e-5)."""
    text = printed.strip().lower().split("e")[0]
    decimals = len(text.split(".")[1]) if "." in text else 0
    return 0.5 * 10.0 ** (-decimals)


def verdict(paper: str | float | None, replicated, stderr, n_runs: int | None = None,
            n_runs_paper: int | None = None, reason: str = "") -> str:
    """Apply the verdict rule of this module's docstring."""
    if replicated is None or paper is None or (isinstance(replicated, float) and math.isnan(replicated)):
        return f"{NOT_REPLICABLE}: {reason}" if reason else NOT_REPLICABLE
    p = float(paper)
    u = printed_half_unit(paper) if isinstance(paper, str) else 0.0
    s = float(stderr) if stderr is not None and np.isfinite(stderr) else 0.0
    s_p = s * math.sqrt(n_runs / n_runs_paper) if (n_runs and n_runs_paper) else 0.0
    sigma = math.sqrt(s * s + s_p * s_p + u * u)
    diff = abs(float(replicated) - p)
    if diff <= SIGMA_FACTOR * sigma:
        return REPRODUCED
    if diff <= RELATIVE_BAND * abs(p):
        return QUALITATIVE
    return NOT_REPRODUCED


NEGLIGIBLE = 0.01


def claim_verdict(difference: float, stderr: float, expected_sign: int, reference: float | None = None) -> str:
    """Verdict on a claim "A < B" (``expected_sign=-1``) or "A > B" (``+1``) from a paired
    difference A - B with its standard error: 'holds' if the difference has the expected sign
    and is at least 3 standard errors from 0, 'contradicted' if it has the opposite sign
    by at least 3 standard errors, 'no detectable difference' otherwise."""
    if stderr == 0.0 and difference == 0.0:
        return "no detectable difference (identical)"
    z = difference / stderr if stderr > 0 else math.copysign(math.inf, difference)
    small = reference is not None and abs(difference) < NEGLIGIBLE * abs(reference)
    if z * expected_sign >= SIGMA_FACTOR:
        return "holds, but negligible (< 1 %)" if small else "holds"
    if z * expected_sign <= -SIGMA_FACTOR:
        return "contradicted, but negligible (< 1 %)" if small else "contradicted"
    return "no detectable difference"


@dataclass
class Row:
    item: str
    algorithm: str
    quantity: str
    paper: str | None
    replicated: float | None
    stderr: float | None
    verdict: str
    deviations: list = field(default_factory=list)
    note: str = ""


def make_row(item, algorithm, quantity, paper, replicated, stderr, *, n_runs=None,
             n_runs_paper=None, deviations=(), reason="", note="") -> Row:
    rep = None if replicated is None else float(replicated)
    se = None if stderr is None else float(stderr)
    return Row(item, algorithm, quantity, paper, rep, se,
               verdict(paper, rep, se, n_runs, n_runs_paper, reason), list(deviations), note)


def analytic_row(item, algorithm, quantity, paper, finding: str, holds: bool, *, deviations=()) -> Row:
    """A row judged by analysis rather than by Monte Carlo (e.g. a complexity class): no number,
    verdict 'reproduced' or 'not reproduced', with the finding as the note."""
    return Row(item, algorithm, quantity, paper, None, None,
               REPRODUCED if holds else f"{NOT_REPRODUCED}: {finding}", list(deviations), finding)


def combine_claim_verdicts(verdicts) -> str:
    """One verdict for a claim tested on several quantities (each from :func:`claim_verdict`)."""
    verdicts = list(verdicts)
    kinds = {v.split(" (")[0] for v in verdicts}
    if kinds <= {"no detectable difference", "holds, but negligible", "contradicted, but negligible"} \
            and kinds != {"no detectable difference"}:
        return "not supported: differences negligible or undetectable; " + "; ".join(verdicts)
    if kinds == {"holds"}:
        return "holds"
    if kinds == {"contradicted"}:
        return "contradicted"
    if kinds == {"no detectable difference"}:
        return "not supported: no detectable difference"
    return "partly: " + "; ".join(verdicts)


def git_commit(repo: Path | None = None) -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                             cwd=repo, check=True).stdout.strip()
        # generated outputs (promoted notebook by notebook) do not make the code "dirty"
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".",
                                ":(exclude)data", ":(exclude)figures", ":(exclude)notebooks/executed",
                                ":(exclude)reports"],
                               capture_output=True, text=True, cwd=repo).stdout.strip()
        return out + ("-dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def provenance(*, root_seed: int, n_runs: int, profile: str, extra: dict | None = None) -> dict:
    import matplotlib
    import scipy
    info = {
        "git_commit": git_commit(Path(__file__).resolve().parent.parent),
        "root_seed": int(root_seed),
        "n_runs": int(n_runs),
        "profile": profile,
        "python": sys.version.split()[0],
        "packages": {"numpy": np.__version__, "scipy": scipy.__version__,
                     "matplotlib": matplotlib.__version__},
    }
    info.update(extra or {})
    return info


def _jsonable(obj):
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Row):
        return asdict(obj)
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def atomic_write_text(path: Path, text: str) -> None:
    """Write via a temporary file in the same folder and ``os.replace``: never half-written."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def write_results(path, *, paper: str, provenance: dict, rows, **sections) -> dict:
    """Write ``data/results/<paper>.json`` (the results contract) atomically."""
    rows = [asdict(r) if isinstance(r, Row) else dict(r) for r in rows]
    for r in rows:
        for key in ("item", "algorithm", "quantity", "paper", "replicated", "stderr", "verdict", "deviations"):
            if key not in r:
                raise ValueError(f"rows: row {r!r} lacks required key {key!r}")
    doc = {"paper": paper, "provenance": provenance, "rows": rows, **sections}
    text = json.dumps(doc, indent=1, default=_jsonable, allow_nan=False, sort_keys=False)
    atomic_write_text(Path(path), text + "\n")
    return doc


def save_figure(fig, out_dir, stem: str, formats=("png", "svg")) -> list[str]:
    """Save a figure as PNG and SVG (deterministic SVG ids, no date), atomically per file."""
    import matplotlib
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    with matplotlib.rc_context({"svg.hashsalt": "mmlib", "svg.fonttype": "none"}):
        for fmt in formats:
            target = out_dir / f"{stem}.{fmt}"
            fd, tmp = tempfile.mkstemp(dir=out_dir, prefix=f".{stem}.", suffix=f".{fmt}")
            os.close(fd)
            try:
                fig.savefig(tmp, format=fmt, dpi=150, bbox_inches="tight",
                            metadata={"Date": None} if fmt == "svg" else {"Software": None})
                os.replace(tmp, target)
            except BaseException:
                os.unlink(tmp)
                raise
            written.append(str(target))
    return written
