"""The experiment layer (mmlib.experiment) and the arena (mmlib.arena): bad input is a ValueError whose message starts
with the argument the caller wrote, or the call works -- never a silently truncated, split or ignored value, a raw
numpy/Python error (TypeError, AttributeError, KeyError, IndexError, a broadcasting error) or a late failure in JSON.

Every case below failed on the code before this change: the input was accepted (a float index truncated, a bare
string split into letters, a segment beyond the horizon ignored, a count of 1.7 stored as 1, ...) or the error was
another exception, or a ValueError naming something else (e.g. ``root_seed`` for the ``seed`` the caller wrote)."""
import functools
import tempfile

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import experiment_jobs as toy  # noqa: E402
import mmlib as m  # noqa: E402
from mmlib.arena import recipes, study  # noqa: E402
from mmlib.arena import views as arena_views  # noqa: E402
from mmlib.core import models  # noqa: E402
from mmlib.core.estimation import select_runs  # noqa: E402
from mmlib.experiment import evaluation, executors, metrics, report, views  # noqa: E402
from mmlib.experiment.montecarlo import MonteCarlo, Progress, Stream, say_progress  # noqa: E402
from mmlib.experiment.multiverse import Multiverse, PublishedNumber, from_dict, run_multiverse  # noqa: E402
from mmlib.experiment.readings import Deviation, Design, Factor, Option, ReadingSpace  # noqa: E402
from mmlib.experiment.scenario import Scenario  # noqa: E402
from mmlib.experiment.simulate import ManeuverSchedule, propagate, simulate  # noqa: E402
from mmlib.experiment.universe import UniverseResult  # noqa: E402
from conftest import raises_naming  # noqa: E402

B, K = 3, 6
CV = models.constant_velocity(1.0, 2.0)
CA = models.constant_acceleration(1.0, 2.0)
POS = models.position_measurement([25.0, 16.0])
X0 = np.array([100.0, 10.0, -50.0, 5.0])
MC = MonteCarlo(1, B)


# ----------------------------------------------------------------------------------------------------- fixtures
def _scenario(**kw):
    args = dict(name="t", title="a test scenario", source="controlled", root_seed=1, T=1.0, n_steps=K,
                simulator=lambda mc: None, P0=np.eye(4), position=(0, 2), velocity=(1, 3), single=CV,
                measurement=POS)
    args.update(kw)
    return Scenario(**args)


def _schedule(**kw):
    args = dict(models=[CV], segments=[], default=0, T=1.0, n_steps=K)
    args.update(kw)
    return ManeuverSchedule(**args)


def _opt(name, **changes):
    return Option(name, f"option {name}", "Sec. 1", changes)


def _factor(**kw):
    args = dict(id="F", label="a factor", options=(_opt("a"), _opt("b")), headline="a", source="Sec. 2")
    args.update(kw)
    return Factor(**args)


def _universe(**kw):
    args = dict(values=[("T1", "alg", "mean", 1.0, 0.1)], claims=[], diverged={"alg": 0}, n_runs=20)
    args.update(kw)
    return UniverseResult.build(**args)


@functools.lru_cache(maxsize=1)
def _mv():
    """A small multiverse of the toy reading space (20 runs, no cache)."""
    return run_multiverse(toy.SPACE, toy.toy_universe, published=toy.PUBLISHED, n_runs=20, seed=3,
                          algorithms=["alg"], design="star", use_cache=False, progress=False, workers=1)


def _multiverse(**kw):
    mv = _mv()
    args = dict(space=mv.space, design=mv.design, universes=mv.universes, published=mv.published, n_runs=20)
    args.update(kw)
    return Multiverse(**args)


def _run_multiverse(**kw):
    args = dict(published=toy.PUBLISHED, n_runs=20, seed=3, algorithms=["alg"], design="star", use_cache=False,
                progress=False, workers=1)
    args.update(kw)
    return run_multiverse(toy.SPACE, toy.toy_universe, **args)


def _state():
    return m.SigmaPointFilter(m.Unscented()).init(np.tile(X0, (B, 1)), np.eye(4))


def _ladder():
    return study.scenario("ladder-linear")


def _runset(n=4, dim=4):
    rng = np.random.default_rng(0)
    return evaluation.RunSet(rng.standard_normal((n, K, dim)), None, np.full(n, -1), np.zeros((K, dim)))


def _arena_result():
    per_run = {("s1", "A"): np.array([1.0, 2.0, 3.0]), ("s1", "B"): np.array([1.5, 2.5, 3.5])}
    cells = [{"scenario": "s1", "algorithm": a, "n_runs": 3} for a in ("A", "B")]
    return study.ArenaResult(cells, per_run, 3, {})


def _arena_cells():
    stat = {"value": 4.0, "stderr": 0.1, "dof": 4.0, "band": [3.0, 5.0], "inside": True}
    return [{"algorithm": a, "scenario": "ladder-nl1", "n_runs": 10, "diverged": 0,
             "rmse_position": {"value": 5.0, "stderr": 0.1}, "anees": stat, "anis": stat} for a in ("UKF", "IMMUKF")]


def _arena_rows():
    return [{"scenario": "ladder-nl1", "nonlinearity_index": {"median": 0.01},
             "properties": {"axis": "nonlinearity", "sigma_theta_mrad": 1.0, "omega_deg_s": 3.0}}]


#: the cases' scratch folders, under one folder removed when the test process ends (a finalizer of
#: TemporaryDirectory), so no mmlib-bad-input-* folder is left in the system's temporary folder
_SCRATCH = tempfile.TemporaryDirectory(prefix="mmlib-bad-input-")


def _tmp():
    return tempfile.mkdtemp(dir=_SCRATCH.name)


def _one_arena_cell(**kw):
    args = dict(scenarios=["ladder-linear"], algorithms=["EKF"], use_cache=False, progress=False, workers=1)
    args.update(kw)
    return study.run_arena(2, **args)


def _chi2(N=4):
    return np.random.default_rng(1).chisquare(3, (N, K))


# ----------------------------------------------------------------------------------------------------- cases
SCENARIO_CASES = {
    "T negative": (lambda: _scenario(T=-1), "T"),
    "T NaN": (lambda: _scenario(T=float("nan")), "T"),
    "n_steps 0": (lambda: _scenario(n_steps=0), "n_steps"),
    "n_steps a string": (lambda: _scenario(n_steps="80"), "n_steps"),
    "n_steps a float": (lambda: _scenario(n_steps=6.0), "n_steps"),
    "root_seed negative": (lambda: _scenario(root_seed=-5), "root_seed"),
    "root_seed a float": (lambda: _scenario(root_seed=1.5), "root_seed"),
    "ukf alpha negative": (lambda: _scenario(ukf=(-1.0, 2.0, 0.0)), "ukf"),
    "ukf of two numbers": (lambda: _scenario(ukf=(1.0, 2.0)), "ukf"),
    "ukf with n + lambda <= 0": (lambda: _scenario(ukf=(1.0, 2.0, -10.0)), "ukf"),
    "ukf a string": (lambda: _scenario(ukf="abc"), "ukf"),
    "noise_levels a string": (lambda: _scenario(noise_levels="high"), "noise_levels"),
    "position float indices": (lambda: _scenario(position=(0.9, 2.5)), "position"),
    "velocity bool index": (lambda: _scenario(velocity=(True, 3)), "velocity"),
    "position repeated": (lambda: _scenario(position=(0, 0)), "position"),
    "position a bare int": (lambda: _scenario(position=2), "position"),
    "title not a string": (lambda: _scenario(title=3), "title"),
    "source not a string": (lambda: _scenario(source=None), "source"),
    "modes a bare string": (lambda: _scenario(single=None, modes="cv", transition=[[1.0]],
                                              mode_probabilities=[1.0]), "modes"),
    "modes empty": (lambda: _scenario(modes=(), transition=np.zeros((0, 0)), mode_probabilities=[]), "modes"),
    "transition without modes": (lambda: _scenario(transition=[[1.0]]), "transition, mode_probabilities"),
    "measurement for another state size": (lambda: _scenario(single=CA, P0=np.eye(6)), "measurement"),
    "measurement_models a bare string": (lambda: _scenario(measurement=None, measurement_models="pospos"),
                                         "measurement_models"),
    "measurement_models entry a string": (lambda: _scenario(measurement=None,
                                                            measurement_models=[POS, POS, "x", POS, POS, POS]),
                                          r"measurement_models\[2\]"),
    "properties a string": (lambda: _scenario(properties="x"), "properties"),
    "notes value not a string": (lambda: _scenario(notes={"single": 3}), r"notes\['single'\]"),
}

SIMULATE_CASES = {
    "segment beyond the horizon": (lambda: _schedule(segments=[(10.0, 20.0, 0)]), r"segments\[0\]"),
    "segment between two steps": (lambda: _schedule(segments=[(2.2, 2.8, 0)]), r"segments\[0\]"),
    "jump beyond the horizon": (lambda: _schedule(jumps=[(10.0, [1], [1.0])]), r"jumps\[0\]"),
    "jump between two steps": (lambda: _schedule(jumps=[(2.5, [1], [1.0])]), r"jumps\[0\]"),
    "segments not a sequence": (lambda: _schedule(segments=5), "segments"),
    "truncate does not excuse a segment between two steps": (
        lambda: _schedule(segments=[(2.2, 2.8, 0)], truncate=True), r"segments\[0\]"),
    "truncate does not excuse a jump between two steps": (
        lambda: _schedule(jumps=[(2.5, [1], [1.0])], truncate=True), r"jumps\[0\]"),
    "propagate schedule a string": (lambda: propagate("schedule", np.tile(X0, (B, 1))), "schedule"),
    "propagate x0 of another dimension": (lambda: propagate(_schedule(), np.zeros((B, 3))), "x0"),
    "propagate process_noise too short": (lambda: propagate(_schedule(), np.tile(X0, (B, 1)),
                                                            np.zeros((B, K - 1, 2))), "process_noise"),
    "simulate schedule a string": (lambda: simulate("schedule", X0, POS, MC, range(B)), "schedule"),
    "simulate measurement_noise_fn not callable": (
        lambda: simulate(_schedule(), X0, POS, MC, range(B), measurement_noise_fn=3), "measurement_noise_fn"),
    "simulate runs an int": (lambda: simulate(_schedule(), X0, POS, MC, 3), "runs"),
}

MONTECARLO_CASES = {
    "gaussian mean of another batch": (lambda: MC.gaussian(range(B), Stream.INITIAL, np.zeros((2, 4)), np.eye(4)),
                                       "mean"),
    "gaussian mean NaN": (lambda: MC.gaussian(range(B), Stream.INITIAL, np.full(4, np.nan), np.eye(4)), "mean"),
    "gaussian mean 3-D": (lambda: MC.gaussian(range(B), Stream.INITIAL, np.zeros((1, B, 4)), np.eye(4)), "mean"),
    "select_runs float index": (lambda: select_runs(_state(), 1.5), "index"),
    "select_runs index beyond the runs": (lambda: select_runs(_state(), [0, 7]), "index"),
    "select_runs negative index": (lambda: select_runs(_state(), [-1]), "index"),
    "select_runs mask of another length": (lambda: select_runs(_state(), np.array([True, False])), "index"),
    "select_runs a bare int": (lambda: select_runs(_state(), 1), "index"),
    "select_runs state a string": (lambda: select_runs("state", slice(0, 1)), "state"),
    "progress label not a string": (lambda: Progress(3, 10), "label"),
    "progress total negative": (lambda: Progress("x", -1), "total"),
    "progress enabled not a bool": (lambda: Progress("x", 10, enabled="no"), "enabled"),
    "progress advance by a float": (lambda: Progress("x", 10, enabled=False).advance(1.5), "n"),
    "say_progress line not a string": (lambda: say_progress(3), "line"),
}

READINGS_CASES = {
    "factor influential 'no'": (lambda: _factor(influential="no"), "influential"),
    "factor metric_only 1": (lambda: _factor(metric_only=1), "metric_only"),
    "factor options not a sequence": (lambda: _factor(options=5), "options"),
    "option change NaN": (lambda: _opt("a", q=float("nan")), r"changes\['q'\]"),
    "option change an array": (lambda: _opt("a", q=np.zeros(2)), r"changes\['q'\]"),
    "option change inf inside a tuple": (lambda: _opt("a", q=(1.0, np.inf)), r"changes\['q'\]\[1\]"),
    "option change key not a string": (lambda: Option("a", "x", "Sec. 1", {1: 2.0}), "changes"),
    "deviation id not a string": (lambda: Deviation(3, "topic", "paper", "choice", "reason"), "id"),
    "deviation topic empty": (lambda: Deviation("Z-1", "", "paper", "choice", "reason"), "topic"),
    "space paper not a string": (lambda: ReadingSpace(3, (_factor(),)), "paper"),
    "space factors not a sequence": (lambda: ReadingSpace("p", 5), "factors"),
    "design kind unknown": (lambda: Design("bogus", "x", ({"F": "a"},)), "kind"),
    "design without readings": (lambda: Design("star", "x", ()), "readings"),
}

MULTIVERSE_CASES = {
    "diverged count 1.7": (lambda: _universe(diverged={"alg": 1.7}), r"diverged\['alg'\]"),
    "diverged count NaN": (lambda: _universe(diverged={"alg": float("nan")}), r"diverged\['alg'\]"),
    "diverged count beyond n_runs": (lambda: _universe(diverged={"alg": 30}), r"diverged\['alg'\]"),
    "diverged a string": (lambda: _universe(diverged="alg"), "diverged"),
    "universe n_runs 0": (lambda: _universe(n_runs=0), "n_runs"),
    "universe n_runs a float": (lambda: _universe(n_runs=2.5), "n_runs"),
    "value item NaN": (lambda: _universe(values=[(float("nan"), "alg", "mean", 1.0, 0.1)]), r"values\[0\]\.item"),
    "value replicated a string": (lambda: _universe(values=[("T1", "alg", "mean", "1.2", 0.1)]),
                                  r"values\[0\]\.replicated"),
    "value of four fields": (lambda: _universe(values=[("T1", "alg", "mean", 1.0)]), r"values\[0\]"),
    "values a bare string": (lambda: _universe(values="abc"), "values"),
    "effect value a string": (lambda: _universe(effects=[("e", "x", 0.1)]), r"effects\[0\]\.value"),
    "claim text NaN": (lambda: _universe(claims=[{"claim": float("nan"), "verdict": "holds"}]),
                       r"claims\[0\]\.claim"),
    "claim without a verdict": (lambda: _universe(claims=[{"claim": "c"}]), r"claims\[0\]"),
    "run_multiverse algorithms a bare string": (lambda: _run_multiverse(algorithms="IMM"), "algorithms"),
    "run_multiverse published plain tuples": (lambda: _run_multiverse(published=[("T", "i", "a", "q", "1.0")]),
                                              r"published\[0\]"),
    "run_multiverse n_runs_paper 0": (lambda: _run_multiverse(n_runs_paper=0), "n_runs_paper"),
    "multiverse n_runs 0": (lambda: _multiverse(n_runs=0), "n_runs"),
    "multiverse space a string": (lambda: _multiverse(space="space"), "space"),
    "multiverse printed not a number": (
        lambda: _multiverse(published=(PublishedNumber("Table 1", "T1", "alg", "mean", "abc"),)),
        r"published\[0\]\.printed"),
    "multiverse universe not a result": (lambda: _multiverse(universes=[{}] * len(_mv().universes)),
                                         r"universes\[0\]"),
    "from_dict without universes": (lambda: from_dict(toy.SPACE, {"design": "star"}, toy.PUBLISHED), "doc"),
    "multiverse value of a string universe": (lambda: _mv().value("u", ("T1", "alg", "mean")), "universe"),
    "multiverse value key a string": (lambda: _mv().value(_mv().universes[0], "T1"), "key"),
    "multiverse number_verdict of a tuple": (lambda: _mv().number_verdict(tuple(toy.PUBLISHED[0]), _mv().universes[0]),
                                             "pub"),
    "multiverse table_distances unknown table": (lambda: _mv().table_distances("Table 9"), "table"),
}

REPORT_CASES = {
    "verdict n_runs 1.7": (lambda: report.verdict("1.0", 1.0, 0.1, n_runs=1.7), "n_runs"),
    "verdict n_runs negative": (lambda: report.verdict("1.0", 1.0, 0.1, n_runs=-3, n_runs_paper=10), "n_runs"),
    "verdict n_runs_paper 0": (lambda: report.verdict("1.0", 1.0, 0.1, n_runs=10, n_runs_paper=0), "n_runs_paper"),
    "verdict paper not a number": (lambda: report.verdict("abc", 1.0, 0.1), "paper"),
    "standardized_distance paper None": (lambda: report.standardized_distance(None, 1.0, 0.1), "paper"),
    "claim_verdict expected_sign 0": (lambda: report.claim_verdict(1.0, 0.1, 0), "expected_sign"),
    "claim_verdict difference a string": (lambda: report.claim_verdict("1", 0.1, -1), "difference"),
    "make_row deviations a bare string": (
        lambda: report.make_row("T1", "alg", "mean", "1.0", 1.0, 0.1, deviations="Z-1"), "deviations"),
    "make_row item not a string": (lambda: report.make_row(3, "alg", "mean", "1.0", 1.0, 0.1), "item"),
    "analytic_row holds 'no'": (lambda: report.analytic_row("T1", "alg", "O(n)", "O(n)", "finding", "no"), "holds"),
    "analytic_row deviations a bare string": (
        lambda: report.analytic_row("T1", "alg", "O(n)", "O(n)", "finding", True, deviations="Z-1"), "deviations"),
    "provenance root_seed negative": (lambda: report.provenance(root_seed=-5, n_runs=10, profile="full"),
                                      "root_seed"),
    "provenance n_runs 0": (lambda: report.provenance(root_seed=1, n_runs=0, profile="full"), "n_runs"),
    "provenance profile not a string": (lambda: report.provenance(root_seed=1, n_runs=10, profile=3), "profile"),
    "printed_half_unit of a float": (lambda: report.printed_half_unit(2.5), "printed"),
    "claims evidence not a string": (lambda: report.Claims().add("c", "holds", evidence=3, key="c"), "evidence"),
    "claims key missing": (lambda: report.Claims().add("c", "holds", key=None), "key"),
    "claims key with capitals": (lambda: report.Claims().add("c", "holds", key="Cpimm"), "key"),
    "claims key with a space": (lambda: report.Claims().add("c", "holds", key="a b"), "key"),
    "save_figure formats a bare string": (lambda: report.save_figure(plt.figure(), _tmp(), "x", formats="png"),
                                          "formats"),
    "save_figure fig a string": (lambda: report.save_figure("fig", _tmp(), "x"), "fig"),
    "claim_verdict reference a string": (lambda: report.claim_verdict(1.0, 0.1, -1, reference="x"), "reference"),
    "verdict stderr a string": (lambda: report.verdict("1.0", 1.0, "0.1"), "stderr"),
    "verdict reason not a string": (lambda: report.verdict("1.0", None, None, reason=3), "reason"),
    "provenance extra a list": (lambda: report.provenance(root_seed=1, n_runs=2, profile="p", extra=[1]), "extra"),
    "save_figure unknown format": (lambda: report.save_figure(plt.figure(), _tmp(), "x", formats=["nope"]), "formats"),
    "save_figure out_dir a number": (lambda: report.save_figure(plt.figure(), 5, "x"), "out_dir"),
    "save_figure narrow a string": (lambda: report.save_figure(plt.figure(), _tmp(), "x", narrow="yes"), "narrow"),
    "save_figure stem with a space": (lambda: report.save_figure(plt.figure(), _tmp(), "fig 1"), "stem"),
    "narrow_image fig a string": (lambda: __import__("mmlib.experiment.writing").experiment.writing.narrow_image("x"),
                                  "fig"),
    "narrow_image dpi 0": (lambda: __import__("mmlib.experiment.writing").experiment.writing.narrow_image(
        plt.figure(), dpi=0), "dpi"),
    "atomic_write_text text a number": (lambda: report.atomic_write_text(f"{_tmp()}/x", 3), "text"),
}

EVALUATION_CASES = {
    "simulator schedule a string": (lambda: evaluation.simulator(MC, "schedule", POS, X0), "schedule"),
    "simulator measurement a string": (lambda: evaluation.simulator(MC, _schedule(), "pos", X0), "measurement"),
    "simulator x0 of another dimension": (lambda: evaluation.simulator(MC, _schedule(), POS, X0[:3]), "x0"),
    "evaluate label not a string": (
        lambda: evaluation.evaluate({"KF": m.SingleModel(m.KalmanFilter(), CV, POS)},
                                    evaluation.make_batches(MC, _schedule(), POS, X0,
                                                            {"KF": m.SingleModel(m.KalmanFilter(), CV, POS)},
                                                            lambda e, m0, runs: e.init(m0, np.eye(4))),
                                    MC, label=3, progress=False), "label"),
    "evaluate measurement_models a bare string": (
        lambda: evaluation.evaluate({"KF": m.SingleModel(m.KalmanFilter(), CV, None)}, lambda runs: None, MC,
                                    measurement_models="pos", progress=False), "measurement_models"),
    "run_tasks tasks a bare string": (lambda: executors.run_tasks(lambda *a: a, "ab", workers=1), "tasks"),
    "run_tasks task not a tuple": (lambda: executors.run_tasks(lambda *a: a, [1, 2], workers=1), "tasks"),
    "run_tasks fn not callable": (lambda: executors.run_tasks(3, [()], workers=1), "fn"),
    "run_tasks shared not a tuple": (lambda: executors.run_tasks(lambda *a: a, [()], shared=5, workers=1), "shared"),
    "run_tasks on_result not callable": (lambda: executors.run_tasks(lambda *a: a, [()], on_result=3, workers=1),
                                         "on_result"),
    "choose_executor n_tasks negative": (lambda: executors.choose_executor(-1, workers=1), "n_tasks"),
    "choose_executor n_tasks a float": (lambda: executors.choose_executor(1.5, workers=1), "n_tasks"),
    "dask_executor address a number": (lambda: executors.dask_executor(5), "address"),
    "with_initial_states simulate_runs not callable": (
        lambda: evaluation.with_initial_states(3, {}, lambda e, m0, runs: None), "simulate_runs"),
    "jackknife statistic returning an array": (
        lambda: metrics.jackknife(lambda s: s.mean(axis=0), np.ones((4, 2))), "statistic"),
}

VIEWS_CASES = {
    "markdown_table header a bare string": (lambda: views.markdown_table("abc", [[1, 2, 3]]), "header"),
    "markdown_table row a bare string": (lambda: views.markdown_table(["a", "b"], ["xy"]), r"rows\[0\]"),
    "markdown_table row too short": (lambda: views.markdown_table(["a", "b"], [[1]]), r"rows\[0\]"),
    "value_pm value a string": (lambda: views.value_pm("x", None), "value"),
    "value_pm digits negative": (lambda: views.value_pm(1.0, 0.1, digits=-1), "digits"),
    "value_pm digits a float": (lambda: views.value_pm(1.0, 0.1, digits=1.5), "digits"),
    "factors_table of a string": (lambda: views.factors_table("space"), "space"),
    "claims_table of a string": (lambda: views.claims_table("mv"), "mv"),
    "summary_line of a string": (lambda: views.summary_line("mv"), "mv"),
    "one_factor_table columns a bare string": (lambda: views.one_factor_table(_mv(), "abc"), "columns"),
    "specification_curve interval negative": (
        lambda: views.specification_curve(_mv(), "mean", ylabel="y", title="t", interval=-1.0), "interval"),
    "markdown_table rows a bare string": (lambda: views.markdown_table(["a"], "x"), "rows"),
    "markdown_table empty header": (lambda: views.markdown_table([], []), "header"),
    "options_table of a number": (lambda: views.options_table(3), "space"),
    "numbers_table of a string": (lambda: views.numbers_table("mv"), "mv"),
    "table_match_table of a string": (lambda: views.table_match_table("mv"), "mv"),
    "table_match_figure title a number": (lambda: views.table_match_figure(_mv(), title=3), "title"),
    "specification_curve symlog 'no'": (lambda: views.specification_curve(_mv(), "mean", ylabel="y", title="t",
                                                                           symlog="no"), "symlog"),
    "one_factor_table column key a string": (lambda: views.one_factor_table(_mv(), [("h", "mean")]), r"columns\[0\]"),
    "most_reading of a string": (lambda: views.most_reading("t"), "t"),
}

ARENA_CASES = {
    "recipe kind unknown": (lambda: recipes.Recipe("X", "bogus", recipes.ukf, "d"), "kind"),
    "recipe description not a string": (lambda: recipes.Recipe("X", "imm", recipes.ukf, ("zhu2016",)),
                                        "description"),
    "recipe ukf of a name": (lambda: recipes.ukf("ladder-nl1"), "s"),
    "requirement of a name": (lambda: recipes.requirement("IMMUKF", _ladder()), "recipe"),
    "initial_state mc not a MonteCarlo": (
        lambda: recipes.initial_state(recipes.build("EKF", _ladder()), _ladder(), np.tile(X0, (B, 1)), range(B), 3),
        "mc"),
    "seed_of negative": (lambda: study.seed_of(_ladder(), -5), "seed"),
    "seed_of a float": (lambda: study.seed_of(_ladder(), 1.7), "seed"),
    "seed_of of a name": (lambda: study.seed_of("ladder-linear", None), "s"),
    "cell reading without an algorithm": (lambda: study.cell({"scenario": "ladder-linear"}, 2, 0), "reading"),
    "cell reading seed negative": (
        lambda: study.cell({"scenario": "ladder-linear", "algorithm": "EKF", "seed": -5}, 2, 0), "seed"),
    "cost_per_run_step n 0": (lambda: study.cost_per_run_step(recipes.build("EKF", _ladder()), lambda runs: None,
                                                              _ladder(), 0), "n"),
    "consistency ok an index list": (lambda: study.consistency(_chi2(), 3, [1, 2], white=True), "ok"),
    "consistency white 'no'": (lambda: study.consistency(_chi2(), 3, np.ones(4, bool), white="no"), "white"),
    "consistency dof of another length": (lambda: study.consistency(_chi2(), [3, 3], np.ones(4, bool), white=True),
                                          "dof"),
    "cell_metrics cost negative": (lambda: study.cell_metrics(_runset(), _ladder(), -1.0), "cost_seconds"),
    "cell_metrics rs a string": (lambda: study.cell_metrics("rs", _ladder(), 1e-6), "rs"),
    "per_run_values errors of another dimension": (lambda: study.per_run_values(_runset(dim=2), _ladder()), "rs"),
    "rank_scenario of a string": (lambda: study.rank_scenario("cells"), "cells"),
    "ideas scenarios a bare string": (lambda: study.ideas(_arena_result(), scenarios="s1"), "scenarios"),
    "compare result a string": (lambda: study.compare("result", "A", "B", "s1"), "result"),
    "digest result a string": (lambda: study.digest("result", 2), "result"),
    "paper_claims result a string": (lambda: study.paper_claims("result"), "result"),
    "findings scenario_rows a string": (lambda: study.findings(_arena_result(), "rows"), "scenario_rows"),
    "idea_summary of a string": (lambda: study.idea_summary("idea"), "idea"),
    "run_arena use_cache 'no'": (lambda: _one_arena_cell(use_cache="no", cache_dir=_tmp()), "use_cache"),
    "run_arena cache_dir a number": (lambda: _one_arena_cell(cache_dir=5), "cache_dir"),
    "ladder_curves algorithms a bare string": (
        lambda: arena_views.ladder_curves(_arena_cells(), _arena_rows(), algorithms="IMMUKF"), "algorithms"),
    "rmse_heatmap ax a string": (lambda: arena_views.rmse_heatmap(_arena_cells(), ax="ax"), "ax"),
    "initial_state runs beyond the runs": (
        lambda: recipes.initial_state(recipes.build("EKF", _ladder()), _ladder(), np.tile(X0, (B, 1)), range(9), MC),
        "runs"),
    "compare a not a string": (lambda: study.compare(_arena_result(), 3, "B", "s1"), "a"),
}

ALL_CASES = {**SCENARIO_CASES, **SIMULATE_CASES, **MONTECARLO_CASES, **READINGS_CASES, **MULTIVERSE_CASES,
             **REPORT_CASES, **EVALUATION_CASES, **VIEWS_CASES, **ARENA_CASES}
assert len(ALL_CASES) == sum(map(len, (SCENARIO_CASES, SIMULATE_CASES, MONTECARLO_CASES, READINGS_CASES,
                                       MULTIVERSE_CASES, REPORT_CASES, EVALUATION_CASES, VIEWS_CASES, ARENA_CASES)))


@pytest.mark.parametrize("case", list(ALL_CASES), ids=list(ALL_CASES))
def test_bad_input_is_a_value_error_naming_the_argument(case):
    call, name = ALL_CASES[case]
    try:
        with raises_naming(name):
            call()
    finally:
        plt.close("all")


# ----------------------------------------------------------------------------------------------------- accepted
def test_numpy_scalars_in_readings_are_converted_to_python():
    """Option changes of numpy scalars become the Python equivalents (they reach JSON results as such)."""
    opt = Option("a", "x", "Sec. 1", {"q": np.float64(0.5), "n": np.int64(3), "flag": np.bool_(True),
                                      "pair": (np.float32(1.5), 2), "name": np.str_("cv")})
    assert opt.changes == {"q": 0.5, "n": 3, "flag": True, "pair": (1.5, 2), "name": "cv"}
    assert [type(v) for v in opt.changes.values()] == [float, int, bool, tuple, str]
    assert [type(v) for v in opt.changes["pair"]] == [float, int]
    assert ReadingSpace("p", (_factor(),), budget=np.int64(4)).budget == 4


def test_a_numpy_seed_reaches_the_arena_cache_key_as_an_int():
    """run_arena(seed=np.int64(...)) used to fail in JSON (the cache key) naming neither job nor argument."""
    result = _one_arena_cell(seed=np.int64(5))
    assert [c["n_runs"] for c in result.cells] == [2]


def test_valid_inputs_the_new_checks_must_not_reject():
    """Segments ending beyond the horizon, a jump at the last step, a reading dict with a seed, a list of pairs
    for the divergence counts and every shipped scenario are valid."""
    s = _schedule(models=[CV, CV], segments=[(4.0, 100.0, 1)], jumps=[(float(K), [1], [0.0])])
    assert list(s.modes()) == [0, 0, 0, 0, 1, 1]
    # the first K steps of a longer schedule (a paper's set-up run for fewer steps): what lies beyond is dropped
    s = _schedule(models=[CV, CV], segments=[(2.0, 3.0, 1), (10.0, 20.0, 1)], jumps=[(10.0, [1], [0.0])],
                  truncate=True)
    assert list(s.modes()) == [0, 0, 1, 0, 0, 0]
    assert _universe(diverged=[("alg", np.int64(2))]).diverged == {"alg": 2}
    assert _universe(values=[("T1", "alg", "mean", np.float64(np.nan), None)]).values[0].replicated is None
    for name in study.SCENARIOS:
        assert study.scenario(name).n_steps >= 1
    state = _state()
    assert select_runs(state, [2, 0]).mean.shape == (2, 4)
    assert select_runs(state, np.array([True, False, True])).mean.shape == (2, 4)
    assert views.markdown_table(("a", "b"), [(1, 2.0), iter(["x", None])]).count("\n") == 3
