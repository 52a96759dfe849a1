"""Small rendering helpers shared by the paper notebooks (Markdown tables, figure styling)."""
from __future__ import annotations

from typing import TYPE_CHECKING, Iterable

from mmlib.experiment.readings import Deviation
from mmlib.experiment.report import Row
from mmlib.experiment.views import markdown_table, value_pm

if TYPE_CHECKING:
    import matplotlib.axes
    import matplotlib.figure


def deviations_table(deviations: Iterable[Deviation]) -> str:
    """A Markdown table of :class:`~mmlib.experiment.readings.Deviation` s: id, topic, what the paper gives, our
    choice, why, and the sweep that tests it."""
    return markdown_table(["id", "topic", "paper", "our choice", "why", "sweep"],
                          [[d.id, d.topic, d.paper, d.choice, d.reason, d.sweep or ""] for d in deviations])


def rows_table(rows: Iterable[Row]) -> str:
    """A Markdown table of :class:`~mmlib.experiment.report.Row` s: item, algorithm, quantity, the printed value,
    ours ± its standard error, the verdict and the deviations that bear on it."""
    return markdown_table(["item", "algorithm", "quantity", "paper", "replicated ± s.e.", "verdict", "deviations"],
                          [[r.item, r.algorithm, r.quantity, r.paper or "--", value_pm(r.replicated, r.stderr),
                            r.verdict, ", ".join(r.deviations)] for r in rows])


def shade_intervals(ax: matplotlib.axes.Axes, intervals: Iterable[tuple[float, float]],
                    label: str | None = "true maneuver", color: str = "0.9") -> None:
    """Shade each ``(start, end)`` of ``intervals`` (in the x axis's unit, e.g. s) on the matplotlib axes ``ax``,
    behind the data; only the first span carries ``label`` in the legend."""
    for i, (a, b) in enumerate(intervals):
        ax.axvspan(a, b, color=color, zorder=0, label=label if i == 0 else None)


#: Least value of each integer notebook parameter (two runs for a standard error).
PARAMETER_MINIMUM = {"N_RUNS": 2, "SEED": 0, "N_TIMING_RUNS": 1, "WORKERS": 1, "MULTIVERSE_RUNS": 2}


class NotebookRun:
    """Validated notebook parameters and output locations, shared by every paper notebook.

    ``profiles`` maps a profile name to defaults (``n_runs``, ``timing_runs``, ``timing_repeats``);
    the papermill parameters override them.  Bad parameters raise ``ValueError`` naming them."""

    def __init__(self, paper: str, root_seed: int, profiles: dict, *, PROFILE, N_RUNS=None, SEED=None,
                 OUTPUT_ROOT="", N_TIMING_RUNS=None, WORKERS=None, MULTIVERSE_RUNS=None, MULTIVERSE_DESIGN=None):
        from pathlib import Path
        if PROFILE not in profiles:
            raise ValueError(f"PROFILE: expected one of {sorted(profiles)}, got {PROFILE!r}")
        # the least value of each integer parameter: a standard error needs at least two Monte Carlo runs
        for name, value in (("N_RUNS", N_RUNS), ("SEED", SEED), ("N_TIMING_RUNS", N_TIMING_RUNS),
                            ("WORKERS", WORKERS), ("MULTIVERSE_RUNS", MULTIVERSE_RUNS)):
            least = PARAMETER_MINIMUM[name]
            if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < least):
                raise ValueError(f"{name}: expected an integer >= {least} or None, got {value!r}")
        if MULTIVERSE_DESIGN not in (None, "auto", "full", "fractional", "star"):
            raise ValueError(f"MULTIVERSE_DESIGN: expected None, 'auto', 'full', 'fractional' or 'star', "
                             f"got {MULTIVERSE_DESIGN!r}")
        if not isinstance(OUTPUT_ROOT, str):
            raise ValueError(f"OUTPUT_ROOT: expected a path string, got {OUTPUT_ROOT!r}")
        cfg = dict(profiles[PROFILE])
        self.paper, self.profile = paper, PROFILE
        self.n_runs = N_RUNS or cfg["n_runs"]
        self.seed = root_seed if SEED is None else SEED
        self.timing_runs = min(N_TIMING_RUNS or cfg.get("timing_runs", 1), self.n_runs)
        self.timing_repeats = cfg.get("timing_repeats")
        # the reading-space multiverse: Monte Carlo runs per universe and design (profile defaults)
        self.mv_runs = MULTIVERSE_RUNS or cfg.get("mv_runs", self.n_runs)
        self.mv_design = MULTIVERSE_DESIGN or cfg.get("mv_design", "auto")
        from mmlib.experiment.executors import default_workers
        self.workers = WORKERS or default_workers()
        cwd = Path.cwd().resolve()
        self.root = Path(OUTPUT_ROOT) if OUTPUT_ROOT else (cwd.parent if cwd.name == "notebooks" else cwd)
        self.fig_dir = self.root / "figures" / paper
        self.results_path = self.root / "data" / "results" / f"{paper}.json"
        self.figures: dict = {}

    def __repr__(self):
        return (f"profile={self.profile} runs={self.n_runs} seed={self.seed} multiverse: {self.mv_design} design, "
                f"{self.mv_runs} runs per universe, {self.workers} worker(s)")

    def show(self, fig: matplotlib.figure.Figure, stem: str, claim: str, ours: str) -> None:
        """Save ``fig`` as figures/<paper>/<stem>.{png,svg}, display it with the paper's claim and ours."""
        import os
        import matplotlib.pyplot as plt
        from IPython.display import Markdown, display
        from mmlib.experiment.report import save_figure
        paths = save_figure(fig, self.fig_dir, stem)
        self.figures[stem] = {"paper_claim": claim, "ours": ours,
                              "files": [os.path.relpath(p, self.root) for p in paths]}
        plt.show()
        display(Markdown(f"**Paper:** {claim}  \n**Ours:** {ours}"))


def plot_style() -> None:
    """Set the notebooks' matplotlib defaults (110 dpi, a light grid, 10 pt font) in ``plt.rcParams``."""
    import matplotlib.pyplot as plt
    plt.rcParams.update({"figure.dpi": 110, "axes.grid": True, "grid.alpha": 0.3, "font.size": 10})
