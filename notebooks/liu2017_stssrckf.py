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
# # Liu & Wu 2017 — strong tracking spherical simplex-radial CKF (STSSRCKF)
#
# H. Liu, W. Wu, *Strong Tracking Spherical Simplex-Radial Cubature Kalman Filter for Maneuvering Target Tracking*,
# Sensors 17(4):741, 2017, [doi:10.3390/s17040741](https://doi.org/10.3390/s17040741).
#
# The paper puts the strong-tracking fading factor of Zhou & Frank on top of the spherical simplex-radial CKF and
# compares SSRCKF, STF (EKF-based), STUKF, STCKF and STSSRCKF on a constant-acceleration target seen by a
# range-bearing radar: Figures 1–3 and Table 1 (Example 1, high maneuver), Table 2 (complexity and time), Table 3
# (Example 2, medium and weak maneuvers). In `mmlib` strong tracking is one layer
# (`mmlib/core/layers/strong_tracking.py`) that any filter can wear, so the four ST filters are configurations of one
# layer over four base filters.
#
# **Verdict rule** (`mmlib/experiment/verdicts.py`): *reproduced* within 3 combined standard errors (ours, the
# paper's estimated from its run count, half a unit of the last printed digit); *qualitatively reproduced* within
# 25 %; *not reproduced* otherwise; *not replicable* when method or data are not published. Claims are judged on
# paired differences over common random numbers, in the claim vocabulary of `mmlib.experiment.report` (holds /
# partly / contradicted / not supported / not assessable).
#
# The paper is ambiguous in several places (time line, process noise, truth noise, UKF κ, initial estimate). Each
# ambiguity is a declared factor of the reading space `text.SPACE`; the tables and claims below are the *headline*
# reading, and the section "Reading space" runs the other readings as a multiverse and reports every verdict across it.

# %% tags=["parameters"]
PROFILE = "full"          # "full" (the paper's 200 runs) or "smoke" (a prefix of the full runs)
N_RUNS = None             # override the profile's Monte Carlo count
SEED = None               # override the paper's root seed
OUTPUT_ROOT = ""          # folder that receives figures/ and data/results/; empty means the repository root
N_TIMING_RUNS = None      # runs timed one at a time, the paper's way
WORKERS = None            # worker processes of the multiverse (None: one per core)
MULTIVERSE_RUNS = None    # Monte Carlo runs per universe (None: the profile's)
MULTIVERSE_DESIGN = None  # "auto", "full", "sampled", "fractional" or "star" (None: the profile's)
MULTIVERSE_UNIVERSES = None  # size of the uniform sample of universes (None: the paper's)
PROGRESS = True

# %%
import time

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Markdown, display

from mmlib.experiment import digests, evaluation, metrics, report, views
from mmlib.papers import REGISTRY
from mmlib.experiment.notebook import (NotebookRun, deviations_table, markdown_table, plot_style, rows_table,
                                       shade_intervals, value_pm)

paper = REGISTRY["liu2017"]
from mmlib.papers.liu2017 import diagnostics, setup, study, table2, text
from mmlib.papers.liu2017.claims import after_onset, judge_claims

nb = NotebookRun(paper, PROFILE=PROFILE, N_RUNS=N_RUNS, SEED=SEED, OUTPUT_ROOT=OUTPUT_ROOT,
                 N_TIMING_RUNS=N_TIMING_RUNS, WORKERS=WORKERS, MULTIVERSE_RUNS=MULTIVERSE_RUNS,
                 MULTIVERSE_DESIGN=MULTIVERSE_DESIGN, MULTIVERSE_UNIVERSES=MULTIVERSE_UNIVERSES, PROGRESS=PROGRESS)
mc = nb.mc()
plot_style()
print(nb)

# %% [markdown]
# ## Set-up and deviations
#
# State $[x, \dot x, \ddot x, y, \dot y, \ddot y]$, CA model (Eqs. 37–39), radar at the origin (Eq. 40) with
# $\sigma_r = 30$ m, $\sigma_\theta = 10$ mrad, $T = 1$ s, softening factor β = 4.5, forgetting factor ρ = 0.95.
# Example 1: start at (100, 400) m with (15, 20) m/s, then an acceleration of (15, 25) m/s² is switched on.
# The time line is contradictory (L-1): the headline reads it from the set-up paragraph (onset 150 s), chosen before
# running anything; the discussion's onset (100 s) is the other option of factor L-1.

# %%
display(Markdown(deviations_table(paper.deviations)))

# %% [markdown]
# ## Example 1 — Figures 1–3 and Table 1
#
# The headline reading, evaluated by the same functions as every universe of the multiverse below
# (`study.evaluate_reading`, `study.summarise`); the headline run also records every filter's NEES and NIS
# (`consistency=True`: the estimates are the same bits).

# %%
t0 = time.perf_counter()
headline = study.evaluate_reading(paper.headline, mc, progress=PROGRESS, consistency=True)
summary = study.summarise(headline, nb.n_runs)
ex1, ex2 = headline.runs["Example 1"], {case: headline.runs[case] for case in ("Case 1", "Case 2")}
print(f"headline reading: {nb.n_runs} runs, Example 1 and both cases of Example 2 in {time.perf_counter() - t0:.1f} s; "
      f"diverged runs: { {k: v for k, v in summary.diverged.items() if v} or 'none'}")
print(evaluation.divergence_report(headline.runs))  # the step at which each diverged and why
rows = study.table_rows(summary)
display(Markdown(rows_table([r for r in rows if r.item == "Table 1"])))

# %%
verdict_of = {c.claim: c.verdict for c in summary.claims}
setup1 = headline.setups["Example 1"]
t = np.arange(1, setup1.n_steps + 1) * setup1.T
man = [(setup1.onset, t[-1])]
styles = {"SSRCKF": dict(color="C1", lw=1.4, ls="-"), "STF": dict(color="C7", lw=1.4, ls="-."),
          "STUKF": dict(color="C2", lw=1.2, ls=":"), "STCKF": dict(color="C0", lw=1.4, ls="--"),
          "STSSRCKF": dict(color="C3", lw=2.2, ls="-")}
for fignum, ((quantity, idx), unit, what) in enumerate(zip(text.QUANTITIES, ("m", "m/s", "m/s²"),
                                                          ("position", "velocity", "acceleration")), start=1):
    fig, ax = plt.subplots(figsize=(7.5, 4))
    shade_intervals(ax, man, label="maneuver")
    for alg, st in styles.items():
        e = metrics.rmse_over_time(ex1[alg].errors[..., list(idx)], ex1[alg].valid)
        ax.plot(t, e.value, label=alg, **st)
    ax.set(xlabel="time (s)", ylabel=f"RMSE of {what} ({unit})", yscale="log",
           title=f"Fig. {fignum} — RMSE of the estimated {what} (Eq. 41, {nb.n_runs} runs; the ST filters overlap)")
    ax.legend(fontsize=8)
    after = {alg: metrics.armse(after_onset(ex1[alg], setup1.onset_index).errors[..., list(idx)], ex1[alg].valid)
             for alg in styles}
    nb.show(fig, f"fig{fignum:02d}_rmse_{what}",
            "similar errors before the maneuver; after it the ST filters converge quickly while SSRCKF degrades; "
            "STSSRCKF lowest (Figs. 1-3).",
            f"after the onset: SSRCKF {value_pm(after['SSRCKF'].value, after['SSRCKF'].stderr, 3)}, STSSRCKF "
            f"{value_pm(after['STSSRCKF'].value, after['STSSRCKF'].stderr, 3)}, STCKF "
            f"{value_pm(after['STCKF'].value, after['STCKF'].stderr, 3)}, STUKF "
            f"{value_pm(after['STUKF'].value, after['STUKF'].stderr, 3)}, STF "
            f"{value_pm(after['STF'].value, after['STF'].stderr, 3)} {unit}. Claim verdicts: STSSRCKF more accurate "
            f"than SSRCKF — {verdict_of['STSSRCKF is more accurate than SSRCKF (Example 1, Table 1)'].split(':')[0]}; "
            f"than STCKF — {verdict_of['STSSRCKF is more accurate than STCKF (Example 1, Table 1)'].split(':')[0]}.")

# %% [markdown]
# ## Degenerate universes and consistency (not in the paper)
#
# A simulation is *degenerate* when every filter's position ARMSE is at least that of the measurement-only estimate
# (each radar measurement inverted alone, polar to Cartesian: no dynamics, no prior): no filter then does better
# than ignoring the dynamics, and comparing them measures only how they fail. A universe is degenerate when every
# simulation its claims use (Example 1 and both cases of Example 2) is (`study.degenerate`); its comparisons are then
# kept out of the reading space's shares.

# %%
baseline_rows = []
for case, why in study.degenerate_cases(headline).items():
    b = metrics.armse(headline.measurement_only[case])
    rm = {alg: float(v.value) for alg, v in study.position_rmse(headline, case).items()}
    baseline_rows.append([case, value_pm(float(b.value), float(b.stderr), 1), f"{min(rm.values()):.1f}",
                          f"{max(rm.values()):.1f}", "yes" if why else "no"])
display(Markdown(markdown_table(["simulation", "measurement-only position ARMSE (m)", "best filter (m)",
                                 "worst filter (m)", "degenerate"], baseline_rows)))
print("headline universe degenerate:", repr(summary.degenerate) if summary.degenerate else "no")

# %% [markdown]
# **NEES and NIS of every filter.** The average NEES (6 degrees of freedom, the state) and NIS (2, range and
# bearing) over the runs that did not diverge, with their standard errors and 95 % χ² bands
# (`diagnostics.consistency`, the results file's `consistency` section). The NIS band is exact for a consistent
# filter (white innovations: χ² with N·K·2 degrees of freedom, over N·K); the NEES band is that of a run-average at
# one step, χ²(6N)/N, which the time average of a consistent filter lies inside with at least 95 % probability.
# A strong-tracking filter's NEES is that of the faded covariance it reports.

# %%
consistency = diagnostics.consistency(headline)
display(Markdown(views.consistency_table(consistency)))

# %% [markdown]
# ## Why STUKF, STCKF, STSSRCKF (and even STF) cannot differ materially here
#
# The dynamics are linear, so every rule predicts exactly; the rules differ only in how they integrate the radar
# function $h$. All three are third-degree rules: they agree on every polynomial term up to degree 3 and differ
# in the fourth-order terms of $h$'s Taylor expansion. For a range-bearing sensor these scale like
# $(\sigma_{\rm pos}/r)^2$ relative to the first-order terms, where $\sigma_{\rm pos}$ is the predicted position
# standard deviation and $r$ the range. The EKF (STF) drops the second-order terms too, which scale like
# $\sigma_{\rm pos}/r$.

# %%
ratio = diagnostics.nonlinearity_index(setup1, mc)
d_rules, near_equal = diagnostics.near_equality(ex1)
fig, ax = plt.subplots(figsize=(7, 3.4))
ax.plot(t, ratio, "k-")
ax.set(yscale="log", xlabel="time (s)", ylabel="median σ_pos / range",
       title="Nonlinearity of the radar at these ranges")
nb.show(fig, "extra_nonlinearity_index", "(not in the paper)",
        f"σ/r falls from {ratio[0]:.2g} to {ratio[-1]:.1g}; fourth-order rule differences ~(σ/r)² ≤ "
        f"{ratio.max() ** 2:.1g}. "
        f"Largest position difference from STSSRCKF over all runs and steps: "
        + ", ".join(f"{k} {v:.2g} m" for k, v in d_rules.items()))

# %% [markdown]
# ## Table 2 — computational complexity and time
#
# Per time step, with state dimension n = 6 and measurement dimension 2, each filter does (counted from
# `mmlib/core/filters.py` and `mmlib/core/layers/strong_tracking.py`, which follow the paper's Eqs. 20–36) the
# operations below.
# The time ratios to SSRCKF are judged on the floating-point operations per step of each filter as it runs
# (`mmlib.core.cost.step_flops`, deterministic); measured CPU times (repeats, all filters interleaved within each)
# are context: the median ratio with its range over the repeats.

# %%
make_batch, estimators, _ = setup.make_batch_fn(setup1, mc, names=text.FILTERS)
timing_batch = make_batch(range(nb.timing_runs))
per_run, batched = evaluation.time_algorithms(estimators, timing_batch[2], timing_batch[1], repeats=nb.timing_repeats)
t2_rows, time_claim, t2 = table2.table2(estimators, per_run, batched)
rows += t2_rows
display(Markdown(markdown_table(
    ["filter", "paper complexity", "points", "Cholesky / step", "f evaluations", "h evaluations (λ > 1)",
     "other n×n×n products / solves", "counted order", "paper time (s)", "paper ratio",
     "ours: model flop ratio (the verdict)", "ours: measured ratio, one run at a time (median [range])",
     "ours: measured ratio, batched"], t2)))

# %% [markdown]
# **Reading Table 2's complexity column.** Each complexity row is judged from the counts above
# (`table2.complexity_rows`): the printed complexity's order in the number of points and in n against the orders
# the counted operations per step give — the evaluations' growth with the points fitted across the three
# strong-tracking sigma-point filters, which differ only in their rule. The verdicts and findings:

# %%
display(Markdown(markdown_table(["filter", "printed", "verdict", "finding"],
                                [[r.algorithm, r.paper, report.verdict_category(r.verdict), r.note]
                                 for r in t2_rows if "complexity" in r.quantity])))

# %% [markdown]
# ## Example 2 — Table 3 (medium and weak maneuvers)
#
# Example 2's time line is explicit (150 s / 200 s), so factor L-1 does not apply to it; every other factor does.

# %%
display(Markdown(rows_table([r for r in rows if r.item.startswith("Table 3")])))

# %% [markdown]
# ## Claims of the abstract and conclusions
#
# Every verdict comes from paired differences on common random numbers (`mmlib.experiment.report`): one verdict per
# claim with the one number that decided it, then the claim × comparison matrix of its parts (each part's symbol and
# relative difference; ≡ marks a difference within the round-off floor, never judged as an effect). The paper never
# defines robustness; we judge it operationally (stated with the two robustness claims below): the position error after
# the abrupt change in each of the three maneuvers, and divergence counts where any run diverges.

# %%
from mmlib.experiment.notebook import claim_matrix, claims_table

claims = judge_claims(headline)
claims.add(*time_claim, key=table2.TIME_CLAIM_KEY)
display(Markdown(claims_table(claims.as_list())))
display(Markdown(claim_matrix(claims.as_list())))

# %% [markdown]
# ## Reading space — every defensible reading of the paper
#
# The factors below are the paper's ambiguities; each option is a reading its text supports (where is stated), the
# headline in bold. The reading space is their full factorial product; when it exceeds the paper's budget of
# universes, the design runs the headline, every option alone (the star, reported apart) and a uniform random sample
# of the whole space drawn with a recorded seed, from which each claim's share of the space is estimated with a 95 %
# Wilson interval (every universe of the full factorial weighing the same). Every universe is an independent Monte
# Carlo job on the paper's root
# seed and per-run streams (common random numbers across universes). No continuous parameter is fitted: only these
# declared options are run. L-2 (the filters' √q over four decades) is a *sensitivity* factor, an unstated tuning
# value swept over a range rather than a reading of the text: the table match and "the readings that reproduce" keep
# it at its headline, and its levels are reported as their own curve.

# %%
display(Markdown(views.factors_table(paper.space)))
display(Markdown(views.options_table(paper.space)))
t0 = time.perf_counter()
mv = nb.multiverse()
print(f"{mv.design.description}; {nb.mv_runs} runs per universe; {time.perf_counter() - t0:.1f} s")
degenerate_universes = [i for i, u in enumerate(mv.universes) if u.degenerate]
print(f"degenerate universes (every filter no better than the measurement-only estimate in every simulation): "
      f"{len(degenerate_universes)} of {len(mv.universes)}"
      + "".join(f"\n  {paper.space.describe(mv.readings[i])}" for i in degenerate_universes))

# %%
fig = views.specification_curve(mv, paper.key_effect, ylabel="paired Δ position MSE (m²), symlog",
                                title="Does strong tracking help? Paired STSSRCKF − SSRCKF position MSE in Example 1\n"
                                      f"(negative: strong tracking lowers the error), every universe, {nb.mv_runs} "
                                      "runs each", symlog=True)
key = [mv.effect(u, paper.key_effect) for u in mv.universes]
nb.show(fig, "extra_specification_curve",
        "STSSRCKF lowers the position error of SSRCKF (Table 1: 119.3² − 152.1² = −8902 m²).",
        f"headline {value_pm(key[0].value, key[0].stderr, 0)} m²; across the {len(key)} universes "
        f"{min(e.value for e in key):.3g} to {max(e.value for e in key):.3g} m², negative by more than 3 "
        f"standard errors in {sum(e.value + 3 * e.stderr < 0 for e in key)} of {len(key)} universes "
        f"(by factor: see the notebook's reading-space section).")

# %%
fig = views.table_match_figure(mv, title="Which reading matches the printed tables? Σ of squared standardized "
                                         "distances over each table's cells, per universe")
tm = mv.table_match()
nb.show(fig, "extra_table_match", "(not in the paper) Tables 1 and 3 as printed.",
        "; ".join(f"{x['table']}: at most {x['most_n_reproduced']}/{x['n_cells']} cells reproduced by any one reading "
                  f"({x['most_describe']}; headline {x['headline_n_reproduced']}); forensic best match by Σz² "
                  + (f"{x['best_describe']} (Σz² {x['best_sum']:.3g} against the headline's {x['headline_sum']:.3g}, "
                     f"{x['best_n_reproduced']} cells reproduced)" if x["best_universe"] is not None else
                     "none (no universe has every cell precise enough: s.e. ≤ 10 % of the printed value)")
                  for x in tm))

# %% [markdown]
# ### Claim verdicts across the reading space
#
# Each claim's share of the declared space per verdict with its 95 % interval, then the claim × option table: which
# option drives each claim.

# %%
display(Markdown(views.claims_table(mv)))
display(Markdown(views.claim_option_table(mv)))

# %% [markdown]
# ### Which readings reproduce the published numbers

# %%
display(Markdown(views.numbers_table(mv)))
display(Markdown(views.table_match_table(mv)))

# %% [markdown]
# ### One factor at a time (the former sweeps, as a view of the multiverse)
#
# Position ARMSE (m) of Example 1 and of Example 2's cases, and the key effect, for the headline and each option
# varied alone; every universe uses the same runs.

# %%
P = text.QUANTITIES[0][0]
display(Markdown(views.one_factor_table(mv, [
    ("T1 SSRCKF", ("Table 1", "SSRCKF", P)), ("T1 STF", ("Table 1", "STF", P)),
    ("T1 STUKF", ("Table 1", "STUKF", P)), ("T1 STSSRCKF", ("Table 1", "STSSRCKF", P)),
    ("T1 STSSRCKF velocity", ("Table 1", "STSSRCKF", text.QUANTITIES[1][0])),
    ("T3 C1 STSSRCKF", ("Table 3 Case 1", "STSSRCKF", P)), ("T3 C2 STSSRCKF", ("Table 3 Case 2", "STSSRCKF", P)),
    ("key effect (m²)", ("effect", paper.key_effect))])))

# %% [markdown]
# ### What the multiverse says
#
# The paragraphs below are computed from the universes (`diagnostics.findings`).

# %%
display(Markdown(diagnostics.findings(mv)))

# %% [markdown]
# ## Results file

# %%
# digest of the headline's per-run numbers over the first smoke-size runs (the same runs in every profile):
# tests/tolerance/test_digest.py recomputes it (study.headline_digest) and compares it with the committed one
doc = nb.write_results(rows=rows, claims=claims, deviations=[d.as_dict() for d in paper.deviations],
                       digest=digests.run_digest(headline.runs, nb.digest_runs), multiverse=mv,
                       headline_reading=paper.headline, consistency=consistency,
                       near_equality_position_armse_difference_vs_STSSRCKF=near_equal,
                       max_position_difference_vs_STSSRCKF=d_rules,
                       diverged_runs={k.split(" ", 2)[-1]: v for k, v in summary.diverged.items()
                                      if k.startswith("Example 1 ")},
                       timing_ms_per_run={a: {"one_at_a_time": 1e3 * float(per_run[a].mean()),
                                              "batched": 1e3 * float(batched[a].mean())} for a in per_run})
