# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     display_name: mmlib (.venv)
#     language: python
#     name: mmlib
# ---

# %% [markdown]
# # The arena: every algorithm of the five papers on every scenario
#
# Each paper notebook judges a paper on its own scenario, and all five scenarios are only weakly nonlinear, so the
# rules coincide there and the papers' claims about rules cannot be tested where they could matter. Here every
# algorithm of the five papers runs on every scenario where it applies — the papers' five headline scenarios and a
# controlled **ladder** of one target and one radar whose measurement nonlinearity and manoeuvre strength are stepped —
# and one table reports accuracy, consistency (NEES/NIS), divergence and cost.
#
# How it is built (`mmlib/arena/`): every algorithm is a **recipe** built from any scenario's models alone, with its
# parameters stated once (`recipes.py`: the layers' parameters are their proposing paper's headline); every scenario is
# data (`mmlib/experiment/scenario.py`; each paper's headline is `<paper>.scenario()`, in SI units, Hu et al.'s km
# converted at its boundary; the ladder is `ladder.py`); each (algorithm, scenario) **cell** is a Monte Carlo job run
# in parallel and cached (`study.py`). Within a scenario every algorithm sees the same truth, measurements and initial
# estimates (common random numbers), and a paper scenario uses its paper's root seed, so an arena cell's per-run
# errors are those of the paper notebook's headline evaluation of the same algorithm, bit for bit (Hu et al. 2017 to
# round-off, its km converted to m; `tests/test_arena.py`). The arena's metrics are its own — position RMSE over x
# and y together, for instance, where the papers tabulate each axis — so its numbers are not the papers' table cells.
#
# **Verdicts** come from the one rule of `mmlib/experiment/report.py`: a paired difference is detectable when it is
# at least 3 standard errors from zero (and *negligible* below 1 % of the reference mean squared error); otherwise *no
# detectable difference*. Ranks, among the cells of a scenario none of whose runs diverged: 1 + the number of them
# with a detectably and not negligibly smaller position error. Diverged runs are counted and excluded, never patched;
# a cell with diverged runs is not ranked.
#
# **Who takes part, and what is pooled.** The controls of the registry (`kind == "control"`, closed-form checks of the
# pipeline) take no part. Zhou et al. 2017's scenario is its Case 2 under the **per-step** fault reading
# (`mmlib.papers.zhou2017.setup.ARENA_FAULT_KIND`), not the paper notebook's headline: under the headline's
# accumulating bearing drift the fault is unobservable with one radar and every filter errs by as much as the raw
# measurements (see that notebook), so the arena would only compare failures. Per-step is chosen by the text (Sec.
# 4.1 writes the fault with the step index k, each value within the stated bounds), not by its numbers; the other
# candidate, the constant offset, was declared only after the drift reading's results were seen. Tallies *across*
# scenarios — a paper's claim judged across the arena, an idea's counts of verdicts, the consistency counts — leave out
# (and report apart) a scenario whose paper's verdicts judge a **reconstruction** (`Paper.qualifier`) and any
# **degenerate** scenario, on which no algorithm's position RMSE is detectably (3 paired standard errors) and more
# than 1 % below the measurement-only estimate's (`study.exclusions`); the per-scenario tables keep every scenario.

# %% [markdown]
# The runner (`make figures`) starts this notebook once every paper has started, on the first core to free, with every
# worker: its cells keep all the cores busy by themselves.
# mmlib-runner: exclusive

# %% tags=["parameters"]
PROFILE = "full"          # "full" (1000 runs per cell) or "smoke" (20 runs per cell, a prefix of the full runs)
N_RUNS = None             # override the profile's Monte Carlo runs per cell
SEED = None               # override every scenario's root seed (default: each paper's own, the arena's for the ladder)
OUTPUT_ROOT = ""          # folder that receives figures/ and data/results/; empty means the repository root
WORKERS = None            # worker processes for the cells (None: one per core)
PROGRESS = True

# %%
import time

from IPython.display import Markdown, display

from mmlib.arena import ladder, recipes, study, views as arena_views
from mmlib.experiment.notebook import NotebookRun, claims_table, markdown_table, plot_style
from mmlib.experiment.verdicts import format_pm

# profiles (study.STUDY): full runs 1000 per cell; smoke the first 20 runs of the same streams, so its digest equals
# the full study's.
nb = NotebookRun(study.STUDY, PROFILE=PROFILE, N_RUNS=N_RUNS, SEED=SEED, OUTPUT_ROOT=OUTPUT_ROOT, WORKERS=WORKERS)
n_runs, root = nb.n_runs, nb.root
plot_style()
print(nb)

# %% [markdown]
# ## Scenarios
#
# The nonlinearity index is *computed* from each scenario's own runs (`ladder.nonlinearity_index`): the size, in
# innovation standard deviations, of the gap between the Gaussian mean of the measurement function and the
# measurement function at the mean, at a CKF's predicted moments (median over runs and steps). It is 0 for a linear
# sensor; the line under the table gives the range the papers' scenarios and the ladder span.

# %%
scenario_rows = study.scenario_table()
display(Markdown(markdown_table(
    ["scenario", "what", "steps", "n", "m", "nonlinearity index (median, p90)", "root seed"],
    [[r["scenario"], r["title"], r["n_steps"], r["dim"], r["measurement_dim"],
      f"{r['nonlinearity_index']['median']:.3g}, {r['nonlinearity_index']['p90']:.3g}", r["root_seed"]]
     for r in scenario_rows])))
index = {r["scenario"]: r["nonlinearity_index"]["median"] for r in scenario_rows}
papers_max = max(index[name] for name in study.paper_names())
ladder_nl = [index[name] for name in ladder.NAMES if name != "ladder-linear"]
print(f"nonlinearity index: the papers' scenarios at most {papers_max:.2g}; the ladder's radar rungs from "
      f"{min(ladder_nl):.2g} to {max(ladder_nl):.2g}")

# %% [markdown]
# ## Algorithms
#
# One recipe per algorithm; *kind* says what it needs of a scenario (an IMM's mode set, a single motion model, or a
# process-noise family whose level can be set online).

# %%
display(Markdown(markdown_table(["algorithm", "kind", "papers", "what"],
                                [[r.name, r.kind, ", ".join(r.papers), r.description]
                                 for r in recipes.RECIPES.values()])))

# %% [markdown]
# ## Every cell
#
# One Monte Carlo job per (algorithm, scenario), in parallel worker processes, cached by scenario, algorithm, runs,
# seed and mmlib's source (a re-run after an edit outside `mmlib/` recomputes nothing).

# %%
t0 = time.perf_counter()
result = study.run_arena(n_runs, seed=SEED, workers=nb.workers, progress=PROGRESS)
cells = result.cells
n_applicable = sum("reason" not in c for c in cells)
print(f"{len(cells)} cells ({n_applicable} applicable) at {n_runs} runs each in {time.perf_counter() - t0:.1f} s")

# %% [markdown]
# ### The no-information baseline, and the scenarios kept out of the pooled tallies
#
# Per scenario, the measurement-only estimate's position RMSE (each measurement converted to a position; none for a
# sensor that gives no position by itself, e.g. GNSS pseudoranges), the best applicable cell's, and why a scenario is
# kept out of the tallies across scenarios.

# %%
best_rmse = {}
for c in cells:
    r = c.get("rmse_position")
    if r and r.get("value") is not None and r["value"] < best_rmse.get(c["scenario"], (None, float("inf")))[1]:
        best_rmse[c["scenario"]] = (c["algorithm"], r["value"])
display(Markdown(markdown_table(
    ["scenario", "measurement-only RMSE (m)", "best cell (m)", "MSE removed by the best", "pooled?"],
    [[name, "--" if b is None else format_pm(b["value"], b["stderr"]),
      "--" if name not in best_rmse else f"{best_rmse[name][1]:.4g} ({best_rmse[name][0]})",
      "--" if b is None or name not in best_rmse else f"{100 * (1 - (best_rmse[name][1] / b['value']) ** 2):.1f} %",
      "no: " + result.excluded[name] if name in result.excluded else "yes"]
     for name, b in result.baselines.items()])))

# %% [markdown]
# ### Position error relative to the best algorithm of each scenario
#
# Grey cells: the algorithm does not apply to the scenario (the reason is in the tables below). A dagger marks cells
# with diverged runs (their RMSE is over the other runs, and they are not ranked); *div.* cells have fewer than two
# runs left. The best of a scenario is its best cell without diverged runs.

# %%
fig = arena_views.rmse_heatmap(cells, scenario_rows)
nb.show(fig, "rmse_heatmap", "(no paper: cross-paper comparison)",
        "position RMSE of every applicable cell relative to the best algorithm of its scenario")

# %% [markdown]
# ### Consistency: ANEES and ANIS relative to their degrees of freedom
#
# 1 is consistent; above 1 the filter is over-confident (its covariance is too small for its errors), below 1
# pessimistic. A marked cell's value lies inside its 95 % χ² band.

# %%
fig = arena_views.consistency_heatmap(cells, "anees", scenario_rows)
nb.show(fig, "anees_heatmap", "(no paper)", "time-averaged NEES over the state dimension, per cell")
fig = arena_views.consistency_heatmap(cells, "anis", scenario_rows)
nb.show(fig, "anis_heatmap", "(no paper)", "time-averaged NIS over the measurement dimension, per cell")

# %% [markdown]
# ### The ladder: where do the rules and layers separate?

# %%
fig = arena_views.ladder_curves(cells, scenario_rows)
nb.show(fig, "ladder_curves", "(no paper)",
        "position RMSE against the computed nonlinearity index (left) and the turn rate (right)")

# %% [markdown]
# ## Per scenario
#
# Position and velocity RMSE (± standard error), ANEES and ANIS with their 95 % bands, diverged runs, cost, and the
# rank from paired differences; for an algorithm that cannot apply, why.

# %%
for row in scenario_rows:
    display(Markdown(f"### {row['scenario']}: {row['title']}"))
    display(Markdown(markdown_table(list(arena_views.cell_table(cells, row["scenario"])[0]),
                                    [list(r.values()) for r in arena_views.cell_table(cells, row["scenario"])])))

# %% [markdown]
# ## The papers' ideas, scenario by scenario
#
# Each idea is a paired comparison of the algorithm that adds it against the one without it, on every scenario where
# both apply: *helps* (position MSE detectably smaller), *hurts*, *no detectable difference*, *identical (to
# round-off)* (the difference and its standard error within the round-off floor of `report.identity_floor`: the two
# are one computation in exact arithmetic on that scenario, and no z-score is computed), or *diverges* (more runs
# diverged than without the idea).

# %%
idea_rows = study.ideas(result)
identical = study.ArenaVerdict.IDENTICAL          # round-off: its size only, no relative effect and no z-score
display(Markdown(markdown_table(
    ["idea", "A − B", "scenario", "Δ position MSE (m²) ± s.e.", "relative", "verdict", "diverged A / B"],
    [[i["idea"], f"{i['a']} − {i['b']}", c["scenario"],
      "--" if c["difference_m2"] is None else f"|Δ| {abs(c['difference_m2']):.0e} (round-off)"
      if c["verdict"] == identical else format_pm(c["difference_m2"], c["stderr_m2"], signed=True),
      "--" if c["relative"] is None or c["verdict"] == identical else f"{100 * c['relative']:+.2f} %", c["verdict"],
      f"{c['diverged_a']} / {c['diverged_b']}"] for i in idea_rows for c in i["comparisons"]])))
counts, apart = {}, {}
for i in idea_rows:
    for c in i["comparisons"]:
        tally = apart if c["scenario"] in result.excluded else counts
        tally[c["verdict"]] = tally.get(c["verdict"], 0) + 1
print("comparisons by verdict (pooled scenarios): " + ", ".join(f"{v} {n}" for v, n in sorted(counts.items())))
if apart:
    print(f"kept apart ({', '.join(result.excluded)}): " + ", ".join(f"{v} {n}" for v, n in sorted(apart.items())))

# %% [markdown]
# ## The papers' accuracy claims across the arena
#
# Each paper's claim "A is more accurate than B", judged once on the parts of every pair and every scenario where both
# apply, in the claim vocabulary of `mmlib/experiment/report.py`, with the one number that decided it: *holds* (every
# part detectably better), *partly*, *contradicted* (detectably worse, or A diverges more), *not supported* (no
# detectable difference, identical to round-off, or below 1 % of B's mean squared error). The matrix below it shows
# each pair on each scenario (✓ holds, ✗ contradicted, (✓)/(✗) negligible, · no detectable difference, ≡ identical
# to round-off) with the relative position-MSE difference; a scenario marked † is kept out of the pooled verdict and
# judged apart (listed under the table).

# %%
claims_in_arena = study.paper_claims(result)
arena_claims = study.arena_claims(result)
display(Markdown(claims_table(arena_claims.as_list())))
display(Markdown(arena_views.claim_scenario_matrix(claims_in_arena)))
kept_apart = [f"* {pc['paper']}'s claim on {e['scenario']} (kept out: {e['reason']}): **{e['verdict']}** "
              f"({e['decisive']})" for pc in claims_in_arena for e in pc["excluded"]]
if kept_apart:
    display(Markdown("Judged apart:\n\n" + "\n".join(kept_apart)))

# %% [markdown]
# ## Findings
#
# Every sentence below is generated from the numbers above.

# %%
finding_lines = study.findings(result, scenario_rows)
display(Markdown("\n".join(finding_lines)))

# %% [markdown]
# ## Results file

# %%
doc = nb.write_results(rows=[], provenance={"scenario_seeds": {r["scenario"]: r["root_seed"] for r in scenario_rows},
                                            "seed_override": SEED},
                       kind="arena", cells=cells, scenarios=scenario_rows,
                       algorithms=[{"algorithm": r.name, "kind": r.kind, "papers": list(r.papers),
                                    "description": r.description} for r in recipes.RECIPES.values()],
                       ideas=idea_rows, paper_claims=claims_in_arena, findings=finding_lines,
                       baselines=result.baselines, excluded_scenarios=result.excluded,
                       digest=study.digest(result, nb.digest_runs))
print(f"{len(cells)} cells, {n_applicable} applicable")
