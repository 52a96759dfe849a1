"""What every notebook shares: :class:`NotebookRun` (a paper's or a study's validated papermill parameters, output
locations, reading-space run and results file) and small rendering helpers (Markdown tables, figure styling).

Paper-agnostic: it reaches a paper only through the contract (:class:`mmlib.experiment.paper.Paper`).  Like
:mod:`mmlib.experiment.views`, nothing a universe computes uses it (the cache key leaves it out)."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Iterable, Mapping

from mmlib.core._lazy import lazy_attributes
from mmlib.experiment.paper import Paper, Study
from mmlib.experiment.readings import Deviation
from mmlib.experiment.report import PartVerdict, Row, joint_tests

__all__ = [
    "NotebookRun", "rows_table", "claims_table", "claim_matrix", "deviations_table", "shade_intervals", "plot_style",
    "PART_SYMBOLS", "CORE_PROVENANCE", "PARAMETER_MINIMUM", "STABILITY_UNIVERSES", "DESIGNS"
]

# mmlib.experiment.views (and through it the multiverse and the metrics: 1.4 s with scipy.stats) is imported by the
# functions that draw a table, and its two table helpers the notebooks import from here on first use (PEP 562): the
# notebook runner imports NotebookRun for its parameter rules alone, once per run
__getattr__, __dir__ = lazy_attributes(__name__, globals(),
                                       objects={"mmlib.experiment.views": ("markdown_table", "value_pm")})


if TYPE_CHECKING:
    from mmlib.experiment.montecarlo import MonteCarlo
    from mmlib.experiment.multiverse import Multiverse
    import matplotlib.axes
    import matplotlib.figure


def deviations_table(deviations: Iterable[Deviation]) -> str:
    """A Markdown table of :class:`~mmlib.experiment.readings.Deviation` s: id, topic, what the paper gives, our
    choice, why, and the sweep that tests it."""
    from mmlib.experiment.views import markdown_table
    return markdown_table(["id", "topic", "paper", "our choice", "why", "sweep"],
                          [[d.id, d.topic, d.paper, d.choice, d.reason, d.sweep or ""] for d in deviations])


def rows_table(rows: Iterable[Row]) -> str:
    """A Markdown table of :class:`~mmlib.experiment.report.Row` s, joint-tested as the results file writes them
    (:func:`~mmlib.experiment.verdicts.joint_tests`): item, algorithm, quantity, the printed value, ours ± its
    standard error, the standardized distance z, the verdict and the deviations that bear on it; then one line per
    table and row that fails its joint test."""
    from mmlib.experiment.views import markdown_table, value_pm
    judged, tests = joint_tests(list(rows))
    table = markdown_table(["item", "algorithm", "quantity", "paper", "replicated ± s.e.", "z", "verdict",
                            "deviations"],
                           [[r.item, r.algorithm, r.quantity, r.paper or "--", value_pm(r.replicated, r.stderr),
                             "--" if r.distance is None else f"{r.distance:+.1f}", r.verdict, ", ".join(r.deviations)]
                            for r in judged])
    failing = [t for t in tests if not t["passes"]]
    if not failing:
        return table
    lines = [f"- {t['item']}{'' if t['algorithm'] is None else ', ' + t['algorithm']}: Σz² = {t['statistic']:.3g} "
             f"on {t['dof']} cells, p = {t['p_value']:.2g}: fails the joint test"
             + (f" ({t['n_isolated']} reproduced cell(s) isolated)" if t["n_isolated"] else "") for t in failing]
    return table + "\n\nJoint tests (χ², one degree of freedom per cell, level 0.0027):\n\n" + "\n".join(lines)


#: the symbols of the claim x comparison matrix, by part verdict
PART_SYMBOLS = {PartVerdict.HOLDS: "✓", PartVerdict.HOLDS_NEGLIGIBLE: "(✓)", PartVerdict.CONTRADICTED: "✗",
                PartVerdict.CONTRADICTED_NEGLIGIBLE: "(✗)", PartVerdict.NO_DIFFERENCE: "·",
                PartVerdict.IDENTICAL: "≡", PartVerdict.NOT_COMPARABLE: "?"}


def claims_table(claims: Iterable[Mapping]) -> str:
    """A Markdown table of judged claims (:meth:`mmlib.experiment.verdicts.Claims.as_list` entries): the claim, its
    one verdict and the decisive number that produced it."""
    from mmlib.experiment.views import markdown_table
    return markdown_table(["claim", "verdict", "decisive"],
                          [[c["claim"], c["verdict"], c.get("decisive", "")] for c in claims])


def claim_matrix(claims: Iterable[Mapping]) -> str:
    """The claim x comparison matrix: one row per claim with parts, one column per comparison and quantity, a
    symbol per part verdict (:data:`PART_SYMBOLS`: ✓ holds, ✗ contradicted, (✓)/(✗) negligible (< 1 %),
    · no detectable difference, ≡ identical to round-off, ? not comparable) with the part's percentage or ratio."""
    from mmlib.experiment.views import markdown_table
    claims = [c for c in claims if c.get("parts")]
    columns: list = []
    for c in claims:
        for p in c["parts"]:
            col = f"{p['comparison']}: {p['quantity']}"
            if col not in columns:
                columns.append(col)
    rows = []
    for c in claims:
        cells = {f"{p['comparison']}: {p['quantity']}": p for p in c["parts"]}
        row = [c["claim"], c["verdict"]]
        for col in columns:
            p = cells.get(col)
            if p is None:
                row.append("")
                continue
            sym = PART_SYMBOLS[PartVerdict(p["verdict"])]
            if p["kind"] == "ratio" and p["difference"] is not None:
                row.append(f"{sym} {1 + p['difference']:.2f}×")
            elif p["reference"] and p["difference"] is not None and p["verdict"] != PartVerdict.IDENTICAL:
                row.append(f"{sym} {100 * p['difference'] / abs(p['reference']):+.2g} %")
            else:
                row.append(sym)
        rows.append(row)
    legend = "✓ holds · ✗ contradicted · (✓)/(✗) detected but negligible (< 1 %) · · no detectable difference · " \
             "≡ identical to round-off · ? not comparable"
    return markdown_table(["claim", "verdict", *columns], rows) + "\n\n" + legend


def shade_intervals(ax: matplotlib.axes.Axes, intervals: Iterable[tuple[float, float]],
                    label: str | None = "true maneuver", color: str = "0.9") -> None:
    """Shade each ``(start, end)`` of ``intervals`` (in the x axis's unit, e.g. s) on the matplotlib axes ``ax``,
    behind the data; only the first span carries ``label`` in the legend."""
    for i, (a, b) in enumerate(intervals):
        ax.axvspan(a, b, color=color, zorder=0, label=label if i == 0 else None)


#: the provenance keys every results file gets from :func:`mmlib.experiment.writing.provenance`
CORE_PROVENANCE = frozenset({"git_commit", "root_seed", "n_runs", "profile", "python", "packages", "kernel"})

#: Least value of each integer notebook parameter (two runs for a standard error).
PARAMETER_MINIMUM = {"N_RUNS": 2, "SEED": 0, "N_TIMING_RUNS": 1, "WORKERS": 1, "MULTIVERSE_RUNS": 2,
                     "MULTIVERSE_UNIVERSES": 1}

#: the default number of universes, besides the headline, of the run-count stability check
#: (:meth:`NotebookRun.multiverse`) by profile, when the profile sets no ``stability_universes``
STABILITY_UNIVERSES = {"full": 8, "smoke": 2}

#: the values of the MULTIVERSE_DESIGN parameter (None: the profile's)
DESIGNS = (None, "auto", "full", "sampled", "fractional", "star")


class NotebookRun:
    """A notebook's validated parameters, output locations and results file, for a :class:`Paper` (or a
    :class:`Study`): ``NotebookRun(paper, PROFILE=..., N_RUNS=..., ...)`` with the papermill parameters.

    The profile (``paper.profiles[PROFILE]``) gives the defaults (``n_runs``, ``timing_runs``, ``timing_repeats``,
    ``mv_runs``, ``mv_design`` and optionally ``mv_universes`` and ``stability_universes``, the universes besides the
    headline of the run-count stability check, default :data:`STABILITY_UNIVERSES`); the parameters override them.
    ``MULTIVERSE_UNIVERSES`` is the size of the uniform sample of the reading space (default: the profile's
    ``mv_universes``, else the space's budget): more universes narrow the intervals of the shares, and a size at
    least the full factorial's runs the full factorial under the "auto" design.  Bad parameters raise
    ``ValueError`` naming them.
    :meth:`show` saves and captions a figure; :meth:`write_results` writes ``data/results/<name>.json``."""

    def __init__(self, paper: Paper | Study, *, PROFILE, N_RUNS=None, SEED=None, OUTPUT_ROOT="", N_TIMING_RUNS=None,
                 WORKERS=None, MULTIVERSE_RUNS=None, MULTIVERSE_DESIGN=None, MULTIVERSE_UNIVERSES=None,
                 PROGRESS=True):
        from pathlib import Path
        if not isinstance(paper, (Paper, Study)):
            raise ValueError(f"paper: expected a Paper (mmlib.papers.REGISTRY) or a Study, got {paper!r}")
        profiles = paper.profiles
        if PROFILE not in profiles:
            raise ValueError(f"PROFILE: expected one of {sorted(profiles)}, got {PROFILE!r}")
        # the least value of each integer parameter: a standard error needs at least two Monte Carlo runs
        for name, value in (("N_RUNS", N_RUNS), ("SEED", SEED), ("N_TIMING_RUNS", N_TIMING_RUNS),
                            ("WORKERS", WORKERS), ("MULTIVERSE_RUNS", MULTIVERSE_RUNS),
                            ("MULTIVERSE_UNIVERSES", MULTIVERSE_UNIVERSES)):
            least = PARAMETER_MINIMUM[name]
            if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < least):
                raise ValueError(f"{name}: expected an integer >= {least} or None, got {value!r}")
        if MULTIVERSE_DESIGN not in DESIGNS:
            raise ValueError(f"MULTIVERSE_DESIGN: expected None, 'auto', 'full', 'sampled', 'fractional' or 'star', "
                             f"got {MULTIVERSE_DESIGN!r}")
        if not isinstance(OUTPUT_ROOT, str):
            raise ValueError(f"OUTPUT_ROOT: expected a path string, got {OUTPUT_ROOT!r}")
        if not isinstance(PROGRESS, bool):
            raise ValueError(f"PROGRESS: expected True or False, got {PROGRESS!r}")
        cfg = dict(profiles[PROFILE])
        self.study, self.paper, self.profile, self.progress = paper, paper.name, PROFILE, PROGRESS
        self.config = cfg
        self.n_runs = N_RUNS or cfg["n_runs"]
        self.seed = paper.root_seed if SEED is None else SEED
        # run-time measurement (None where the profile measures none)
        self.timing_runs = min(N_TIMING_RUNS or cfg["timing_runs"], self.n_runs) if "timing_runs" in cfg else None
        self.timing_repeats = cfg.get("timing_repeats")
        # the reading-space multiverse: Monte Carlo runs per universe and design (profile defaults)
        self.mv_runs = MULTIVERSE_RUNS or cfg.get("mv_runs", self.n_runs)
        self.mv_design = MULTIVERSE_DESIGN or cfg.get("mv_design", "auto")
        #: the uniform sample's size (None: the reading space's budget)
        self.mv_universes = MULTIVERSE_UNIVERSES or cfg.get("mv_universes")
        #: the universes besides the headline whose claim verdicts are compared at the universe and headline run
        #: counts (:func:`mmlib.experiment.stability.run_count_stability`; 0: no check): the profile's
        #: ``stability_universes``, else STABILITY_UNIVERSES[profile] (the full default for another profile)
        self.stability_universes = cfg.get("stability_universes",
                                           STABILITY_UNIVERSES.get(PROFILE, STABILITY_UNIVERSES["full"]))
        if isinstance(self.stability_universes, bool) or not isinstance(self.stability_universes, int) \
                or self.stability_universes < 0:
            raise ValueError(f"PROFILE: the profile's stability_universes must be an integer >= 0, got "
                             f"{self.stability_universes!r}")
        #: the runs of the digest: the smoke profile's headline runs, the same first runs in every profile
        self.digest_runs = min(self.n_runs, int(profiles.get("smoke", cfg)["n_runs"]))
        from mmlib.experiment.executors import default_workers
        self.workers = WORKERS or default_workers()
        cwd = Path.cwd().resolve()
        self.root = Path(OUTPUT_ROOT) if OUTPUT_ROOT else (cwd.parent if cwd.name == "notebooks" else cwd)
        self.fig_dir = self.root / "figures" / paper.name
        self.results_path = self.root / "data" / "results" / f"{paper.name}.json"
        self.figures: dict = {}

    def __repr__(self):
        sample = "" if self.mv_universes is None else f", sample of {self.mv_universes} universes"
        return (f"profile={self.profile} runs={self.n_runs} seed={self.seed} multiverse: {self.mv_design} design"
                f"{sample}, {self.mv_runs} runs per universe, {self.workers} worker(s)")

    def mc(self) -> MonteCarlo:
        """The headline's :class:`~mmlib.experiment.montecarlo.MonteCarlo` (``seed``, ``n_runs``)."""
        from mmlib.experiment.montecarlo import MonteCarlo
        return MonteCarlo(self.seed, self.n_runs)

    def multiverse(self, **options: Any) -> Multiverse:
        """The paper's reading space run at this notebook's runs per universe, design, sample size, seed and workers
        (:func:`mmlib.experiment.multiverse.run_multiverse` with the paper's job, published numbers and algorithms;
        ``options`` go to it, e.g. ``executor``), then its run-count stability: unless :attr:`stability_universes`
        is 0, the headline and that many sampled universes rerun at the headline's ``n_runs`` (at half the
        universes' runs when the two counts coincide) and their claim verdicts compared with the multiverse's
        (:func:`mmlib.experiment.stability.run_count_stability`), set as ``mv.stability`` (None when not checked)
        and its statement printed with the progress lines."""
        from mmlib.experiment.multiverse import run_multiverse
        from mmlib.experiment.stability import GRID_OPTIONS, run_count_stability
        p = self.study
        if not isinstance(p, Paper):
            raise ValueError(f"multiverse: {p.name} is a study, not a paper: it has no reading space")
        mv = run_multiverse(p.space, p.universe, published=p.published, n_runs=self.mv_runs, seed=self.seed,
                            algorithms=p.algorithms, design=self.mv_design, n_runs_paper=p.n_runs,
                            sample_size=self.mv_universes, workers=self.workers, progress=self.progress, **options)
        mv.stability = None
        if self.stability_universes:
            # the headline's count; where it is the universes' own, half of it (the runs are a prefix: common
            # random numbers), so every paper shows whether its verdicts move with the run count
            other = self.n_runs if self.n_runs != self.mv_runs else max(2, self.mv_runs // 2)
            mv.stability = run_count_stability(mv, p.universe, n_runs=other, seed=self.seed,
                                               size=self.stability_universes, algorithms=p.algorithms,
                                               workers=self.workers, progress=self.progress,
                                               **{k: v for k, v in options.items() if k in GRID_OPTIONS})
            if self.progress:
                from mmlib.experiment.montecarlo import say_progress
                say_progress(f"  [{p.name} stability] {mv.stability['statement']}")
            mv.stability.update(n_runs_headline=self.n_runs, mode="headline" if other == self.n_runs else "half")
        return mv

    def show(self, fig: matplotlib.figure.Figure, stem: str, claim: str, ours: str) -> None:
        """Save ``fig`` as figures/<paper>/<stem>.{png,svg} (with panels side by side also <stem>.narrow.png, the
        panels stacked for a phone: :func:`mmlib.experiment.writing.save_figure`), display it with the paper's claim
        and ours."""
        import os
        import matplotlib.pyplot as plt
        from IPython.display import Markdown, display
        from mmlib.experiment.report import save_figure
        paths = save_figure(fig, self.fig_dir, stem)
        self.figures[stem] = {"paper_claim": claim, "ours": ours,
                              "files": [os.path.relpath(p, self.root) for p in paths]}
        plt.show()
        display(Markdown(f"**Paper:** {claim}  \n**Ours:** {ours}"))

    def write_results(self, *, rows: Iterable, provenance: Mapping[str, Any] | None = None, **sections: Any) -> dict:
        """Write ``data/results/<name>.json`` (:func:`mmlib.experiment.report.write_results`) with the provenance of
        this run (commit, seed, runs, profile, the citation, a paper's timing and multiverse settings, mmlib's version,
        updated with ``provenance``), the figures shown, ``rows`` and the other ``sections`` (``digest``,
        ``claims``, ``multiverse``, ...: a :class:`~mmlib.experiment.multiverse.Multiverse` is written with
        ``as_dict()``, a :class:`~mmlib.experiment.report.Claims` with ``as_list()``); prints the verdict counts and
        returns the document."""
        import mmlib
        from mmlib.experiment import report
        extra = {"paper_citation": self.study.citation} if self.study.citation else {}
        if self.timing_runs is not None:
            extra.update({"timing_runs": self.timing_runs, "timing_repeats": self.timing_repeats})
        extra["mmlib"] = mmlib.__version__
        if isinstance(self.study, Paper):
            mv = sections.get("multiverse")
            # the design run (e.g. "fractional"), not the profile's request ("auto")
            extra.update({"multiverse_runs": self.mv_runs,
                          "multiverse_design": mv.design.kind if hasattr(mv, "design") else self.mv_design})
            if hasattr(mv, "design") and mv.design.kind == "sampled":     # the sample actually drawn
                extra.update({"multiverse_universes": len(mv.design.sample), "multiverse_sample_seed": mv.design.seed})
            compute = getattr(mv, "compute", None)
            if compute:      # how this run obtained the universes: bench/notebooks.py's universes per CPU-minute
                extra.update({"multiverse_computed": int(compute["computed"]),
                              "multiverse_from_cache": int(compute["from_cache"]),
                              "multiverse_cpu_s": round(float(compute["cpu_s"]), 1)})
        clash = sorted(set(provenance or {}) & (set(extra) | CORE_PROVENANCE))
        if clash:
            raise ValueError(f"provenance: {clash} are written by NotebookRun itself")
        extra.update(provenance or {})
        prov = report.provenance(root_seed=self.seed, n_runs=self.n_runs, profile=self.profile, extra=extra)
        for key, value in list(sections.items()):
            if hasattr(value, "as_dict") and not isinstance(value, Mapping):
                sections[key] = value.as_dict()
            elif isinstance(value, report.Claims):
                sections[key] = value.as_list()
        qualifier = getattr(self.study, "qualifier", "")
        if qualifier and isinstance(sections.get("claims"), list):      # a verdict on a reconstruction says so
            sections["claims"] = [{**c, "qualifier": qualifier, "stated": report.qualified(c["verdict"], qualifier)}
                                  for c in sections["claims"]]
        if self.figures and "figures" not in sections:       # before the multiverse, where the notebooks put it
            keys = list(sections)
            at = keys.index("multiverse") if "multiverse" in keys else len(keys)
            sections = {**{k: sections[k] for k in keys[:at]}, "figures": self.figures,
                        **{k: sections[k] for k in keys[at:]}}
        rows = list(rows)
        doc = report.write_results(self.results_path, paper=self.paper, provenance=prov, rows=rows, **sections)
        # by category (verdict_category), so "reproduced (isolated)" is not also counted as "reproduced"; the rows as
        # written, joint-tested (write_results re-judges a coincidence in a failing table or row as isolated)
        cats = [report.verdict_category(str(r["verdict"])) for r in doc["rows"]]
        counts = {str(v): cats.count(v) for v in report.VERDICTS}
        print(f"wrote {self.results_path.name}" + (f" ({len(rows)} rows): {counts}" if rows else ""))
        return doc


def plot_style() -> None:
    """Set the notebooks' matplotlib defaults (110 dpi, a light grid, 10 pt font) in ``plt.rcParams``."""
    import matplotlib.pyplot as plt
    plt.rcParams.update({"figure.dpi": 110, "axes.grid": True, "grid.alpha": 0.3, "font.size": 10})
