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
# # Zhu, Wang & Yuan 2016 — IMM with the fifth-degree cubature Kalman filter (IMM5CKF)
#
# W. Zhu, W. Wang, G. Yuan, *An Improved Interacting Multiple Model Filtering Algorithm Based on the
# Cubature Kalman Filter for Maneuvering Target Tracking*, Sensors 16(6):805, 2016,
# [doi:10.3390/s16060805](https://doi.org/10.3390/s16060805).
#
# The paper proposes IMM5CKF (an IMM whose mode filters use the fifth-degree cubature rule of Jia, Xin & Cheng 2013)
# and compares it with IMMCKF, IMMUKF, a single-model 5CKF and OMTM-IMM in Section 4 (Table 1, Figures 2–7).
# This notebook regenerates every figure and table of Section 4, side by side with the published values, under a
# *headline* reading of the paper, and then runs the paper's whole *reading space*: every combination of the declared
# readings of its ambiguities (a multiverse), to show which results depend on how the paper is read.
# The algorithms live in `mmlib`; the paper's declared text (Table 1, numbered deviations, reading space), its set-up
# and the one-universe evaluation live in the package `mmlib/papers/zhu2016/` (`text`, `setup`, `study`).
#
# **Verdict rule** (one rule for the whole repository, `mmlib/experiment/report.py`): a printed value is *reproduced* if
# it lies within 3 combined standard errors of ours (our Monte Carlo error, the paper's estimated from its run count,
# and half a unit of its last printed digit), unless those 3 standard errors are wider than 25 % of it, when it is
# *inconclusive* (never counted as reproduced); *qualitatively reproduced* if not within 3 standard errors, but within
# 25 %; *not reproduced* otherwise; *not replicable* when the method or data is not published.
# Claims are tested on paired differences over common random numbers (same truth and measurements for every filter).

# %% tags=["parameters"]
PROFILE = "full"          # "full" (the paper's 100 runs) or "smoke" (quick check, a prefix of the full runs)
N_RUNS = None             # override the profile's Monte Carlo count
SEED = None               # override the paper's root seed
OUTPUT_ROOT = ""          # folder that receives figures/ and data/results/; empty means the repository root
N_TIMING_RUNS = None      # runs timed batched in every repeat (the first timing.TIMING_PER_REPEAT also one at a time)
WORKERS = None            # worker processes of the multiverse (None: one per core)
MULTIVERSE_RUNS = None    # override the profile's Monte Carlo runs per universe
MULTIVERSE_DESIGN = None  # override the profile's design: "auto", "full", "sampled", "fractional" or "star"
MULTIVERSE_UNIVERSES = None  # override the size of the uniform sample of universes (a "sampled" design)
PROGRESS = True

# %%
import time

import matplotlib.pyplot as plt
from IPython.display import Markdown, display

from mmlib.experiment import digests, evaluation, metrics, report, views
from mmlib.papers import REGISTRY
from mmlib.experiment.notebook import (NotebookRun, claim_matrix, claims_table, deviations_table, markdown_table,
                                       plot_style, rows_table, shade_intervals, value_pm)
from mmlib.papers.zhu2016 import diagnostics, study, text, timing
from mmlib.papers.zhu2016.setup import build

paper = REGISTRY["zhu2016"]

nb = NotebookRun(paper, PROFILE=PROFILE, N_RUNS=N_RUNS, SEED=SEED, OUTPUT_ROOT=OUTPUT_ROOT,
                 N_TIMING_RUNS=N_TIMING_RUNS, WORKERS=WORKERS, MULTIVERSE_RUNS=MULTIVERSE_RUNS,
                 MULTIVERSE_DESIGN=MULTIVERSE_DESIGN, MULTIVERSE_UNIVERSES=MULTIVERSE_UNIVERSES, PROGRESS=PROGRESS)
n_runs, timing_runs, timing_repeats = nb.n_runs, nb.timing_runs, nb.timing_repeats
mc = nb.mc()
plot_style()
print(nb)

# %% [markdown]
# ## Set-up and deviations
#
# Section 4: state $[x, \dot x, y, \dot y]$, $T = 1$ s, 100 s, three modes — constant velocity and coordinated turns
# at $\mp 3^\circ$/s (Eq. 61) — observed through a linear position sensor (Eq. 62), transition matrix Eq. 63.
# Every interpretation we had to make is numbered below. Those that can move a result are the *factors* of the
# reading space (last column; the section "Reading space" runs all their combinations); the others say why they
# cannot move one. The headline reading, used for Table 1 and Figures 2–7, is the first option of every factor.

# %%
head = paper.headline
setup = paper.setup(head)
display(Markdown(deviations_table(paper.deviations)))
display(Markdown(views.factors_table(paper.space)))
display(Markdown(views.options_table(paper.space)))

# %% [markdown]
# ## Why IMM5CKF, IMMCKF and IMMUKF must coincide here
#
# All three mode models are **linear** in the state: $x_k = F_j x_{k-1} + G w_k$ with $F_j$ the CV matrix or the
# coordinated-turn matrix of Eq. 61 with a *known* turn rate; and the measurement $z = Hx + v$ (Eq. 62) is linear.
# For a linear map $y = Ax + b$ with $x \sim N(m, P)$, mean, covariance and cross-covariance are polynomials of
# degree ≤ 2 in $x$. The third-degree rules (CKF, UKF for any valid $\alpha,\beta,\kappa$) and the fifth-degree rule are
# exact for such polynomials, so each returns $Am + b$, $APA^T$ and $PA^T$ — exactly the Kalman filter moments.
# Hence, under the paper's own set-up, **IMM5CKF ≡ IMMCKF ≡ IMMUKF ≡ IMM-KF** (same mixing, same likelihoods,
# same fusion), and any difference between their Table 1 columns can only be Monte Carlo noise from different
# random draws or an implementation difference. The check below (and `tests/test_zhu2016.py`) confirms it on
# every run and step; the fifth-degree rule's extra accuracy has no nonlinearity to act on.

# %%
t0 = time.perf_counter()
results = study.evaluate_reading(head, mc, progress=PROGRESS)
print(f"headline Monte Carlo: {n_runs} runs x {len(results)} estimators in {time.perf_counter() - t0:.2f} s")
make_batch, estimators = paper.batch(setup, mc)      # for the timing, trajectory and NEES cells
schedule = build(setup)[0]                           # the truth's manoeuvre schedule (time axis of the figures)
coincide = study.coincidence(results)
display(Markdown(markdown_table(["algorithm", "max |estimate − IMM-KF estimate| (m, m/s)", "max |μ − μ(IMM-KF)|"],
                                [[k, f"{v:.2e}", f"{coincide['max_abs_mode_probability_difference_vs_IMM_KF'][k]:.2e}"]
                                 for k, v in coincide["max_abs_estimate_difference_vs_IMM_KF"].items()])))
diverged = {name: int((~rs.valid).sum()) for name, rs in results.items()}
print("diverged runs per estimator:", diverged)
print(evaluation.divergence_report(results))       # the step at which each diverged and why

# %% [markdown]
# ## Table 1 — RMSE (Eq. 64) and run time
#
# Run times are compared as ratios to IMMCKF (absolute MATLAB seconds cannot be compared across languages and
# machines, Z-15). The verdict is on a deterministic measure: the floating-point operations per step of each filter
# as it runs (`mmlib.core.cost.step_flops`), so it cannot flip between identical runs; a claim holds beyond a ±10 %
# equivalence margin. Measured CPU times of the computing thread (the algorithms taking turns run by run in every
# repeat; a repeat's one-at-a-time time is the fastest of its runs) stay as context: the median ratio with its range
# over the repeats, each a separate timing of all algorithms.

# %%
rows = study.table1_rows(results)
rmse = study.rmse_values(results)

# Run time (Z-15): rows and the timing claim from the cost model's flop ratios to IMMCKF; CPU time per run, one run at a
# time (the paper's way) and batched, the algorithms taking turns in every one of `timing_repeats` repeats, as context.
timing_batch = make_batch(range(timing_runs))
per_run, batched = evaluation.time_algorithms({alg: estimators[alg] for alg in text.RMSE_ALGORITHMS}, timing_batch[2],
                                              timing_batch[1], repeats=timing_repeats,
                                              per_repeat=min(timing.TIMING_PER_REPEAT, timing_runs))
timing_claims = report.Claims()
timing_table1_rows, timing_rows = timing.judge_timing(estimators, per_run, batched, timing_claims)
rows += timing_table1_rows

table1 = [r for r in rows if r.item == "Table 1"]
display(Markdown(rows_table(table1)))
display(Markdown(markdown_table(
    ["algorithm", "paper time (s)", "paper ratio", "ours: model flop ratio (the verdict)",
     "ours: measured ratio, one run at a time (median [range])", "ours: CPU ms per run (one at a time)",
     "ours: CPU ms per run (batched)", "ours: measured ratio, batched"], timing_rows)))
order = sorted((a for a in per_run), key=lambda a: per_run[a].mean())
t_claim = [c for c in timing_claims][0]
display(Markdown(f"Measured one run at a time, the algorithms rank {' < '.join(order)} in CPU time per run; "
                 f"IMM5CKF / IMMCKF = {timing_rows[0][3]} in model flops per step (paper {timing_rows[0][2]}), "
                 f"measured {timing_rows[0][4]} one at a time and {timing_rows[0][7]} batched; "
                 f"the claim *{t_claim['claim']}* {t_claim['verdict']}: {t_claim['decisive']}."))

# %% [markdown]
# **Reading Table 1.** The IMM5CKF, IMMCKF and IMMUKF columns are one number each in our replication (they are the
# same algorithm here, see above); the paper's columns differ by up to a factor of 2 in velocity, which this set-up
# cannot produce. With R = diag(20, 0.1) as printed, our y-position error is ~0.3 m, an order of magnitude below the
# paper's, which with RMSE_Y ≈ RMSE_X points to equal measurement variances in the authors' code (factor Z-5; the
# reading space below shows that equal variances alone do not reproduce the y cells either).
# The single-model 5CKF is clearly the worst, as claimed, but by far less than printed (the paper does not say which
# model it used; none of the declared single models — CV or either coordinated turn of Eq. 61, factor Z-10 — comes
# near the paper's 27.5 m, see the reading space below).
# The point counts predict the run-time ordering 5CKF < IMMCKF ≈ IMMUKF < IMM5CKF: 2n² + 1 = 33 points against
# 2n = 8 (CKF) and 2n + 1 = 9 (UKF) for n = 4 (the measured ranking is printed under the timing table). The *size* of
# the IMM5CKF penalty depends on the implementation: the paper's ≈ 2× matches a point-by-point loop (MATLAB); run one
# at a time in numpy, the cost per step is dominated by a fixed number of array calls, not by the point count, so the
# ratio is closer to 1; batched, where arithmetic dominates, the ratio grows again (second timing table). The verdict
# on the ratio is therefore about implementation, not about the method.

# %% [markdown]
# ## A lower bound implied by the printed parameters (not in the paper)
#
# With linear-Gaussian modes, the Kalman filter that is *told* the true mode of every step ("clairvoyant KF") is the
# minimum-mean-square-error estimator when the simulated truth follows the filters' own model (process noise Q, initial
# error drawn from N(0, P0)); no filter that has to infer the mode — IMM5CKF included — can then have a lower
# expected squared error. Its RMSE under the printed Q and R is therefore a floor for every IMM column of Table 1.
# The steady-state solution of the Riccati equation for a CV target gives nearly the same floor in closed form.

# %%
riccati = diagnostics.cv_steady_state_sd(setup)
floor = study.floor_check(results)
lower_bound = {f["quantity"]: {"clairvoyant_kf": [f["floor"], f["floor_stderr"]], "cv_steady_state_sd": riccati[comp],
                               "smallest_paper_imm": f["paper_min_imm"], "z": f["z"]}
               for f, (_, comp) in zip(floor, text.QUANTITIES)}
bound_rows = [[f["quantity"], value_pm(f["floor"], f["floor_stderr"]), f"{riccati[comp]:.3f}",
               value_pm(rmse[("IMM5CKF", f["quantity"])].value, rmse[("IMM5CKF", f["quantity"])].stderr),
               ", ".join(text.TABLE1[a][qi] for a in ("IMM5CKF", "IMMCKF", "IMMUKF")), f"{f['z']:+.1f}",
               fp.verdict]
              for qi, (f, fp, (_, comp)) in enumerate(zip(floor, study.floor_parts(floor), text.QUANTITIES))]
display(Markdown(markdown_table(["quantity", "clairvoyant KF (floor)", "CV steady-state s.d.", "our IMM5CKF",
                                 "paper IMM5CKF, IMMCKF, IMMUKF", "z = (floor − smallest paper value) / σ",
                                 "part verdict: printed value above the floor"], bound_rows)))

# %% [markdown]
# σ is the combined standard error of the verdict rule (our Monte Carlo error, the paper's estimated from its 100 runs,
# half a unit of the printed digit). The last column is the part verdict (`study.floor_parts`) on "the smallest
# of the three printed IMM values lies above the floor": *holds* if it lies ≥ 3σ above (z ≤ −3), *contradicted* if
# ≥ 3σ below (z ≥ 3, below the floor), *no detectable difference* otherwise; the parts combine into the floor claim
# below, which is judged only where the floor is a bound (noisy truth, sampled start), and is *not assessable*
# elsewhere.
# Where the paper's IMM values lie below the floor, no filter could have produced them under the printed Q and R:
# the printed set-up and Table 1 are mutually inconsistent. The reading space below asks whether *any* declared
# reading of the set-up lifts this inconsistency. Our headline numbers sit just above the floor, as a well-tuned IMM
# should.

# %% [markdown]
# ## Figures 2–7

# %%
t = schedule.times
maneuvers = [setup.right_turn, setup.left_turn]
styles = {"IMM5CKF": dict(color="C3", lw=2.2, ls="-"), "IMMCKF": dict(color="C0", lw=1.4, ls="--"),
          "IMMUKF": dict(color="C2", lw=1.2, ls=":"), "5CKF": dict(color="C1", lw=1.2, ls="-")}
show = nb.show


truth0, z0, _ = make_batch(range(1))
fig, ax = plt.subplots(figsize=(6.4, 5))
ax.plot(truth0[0, :, 0] / 1e3, truth0[0, :, 2] / 1e3, "-", color="0.75", lw=6, label="truth (run 1)")
for alg in styles:
    est = results[alg].example_mean
    ax.plot(est[:, 0] / 1e3, est[:, 2] / 1e3, label=alg, **styles[alg])
ax.plot(z0[0, ::5, 0] / 1e3, z0[0, ::5, 1] / 1e3, "k.", ms=4, label="measurements (every 5th)")
ax.set(xlabel="x (km)", ylabel="y (km)", title="Fig. 2 — target trajectory and estimates (run 1)")
ax.legend()
show(fig, "fig02_trajectory", "all algorithms track the trajectory (Fig. 2).",
     "reproduced: every estimate follows the truth; IMM5CKF/IMMCKF/IMMUKF overlap exactly (OMTM-IMM not replicable).")


def rmse_figure(components, labels, unit, fignum, stem, claim):
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharex=True)
    for ax, comp, lab in zip(axes, components, labels):
        shade_intervals(ax, maneuvers)
        for alg, st in styles.items():
            rs = results[alg]
            e = metrics.rmse_over_time(rs.errors[..., comp], rs.valid)
            ax.plot(t, e.value, label=alg, **st)
            ax.fill_between(t, e.value - 2 * e.stderr, e.value + 2 * e.stderr, color=st["color"], alpha=0.12)
        ax.set(xlabel="time (s)", ylabel=f"RMSE of {lab} ({unit})", title=f"Fig. {fignum}({'ab'[comp // 2]}) — {lab}")
        ax.set_ylim(bottom=0)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"Fig. {fignum} — RMSE over {n_runs} runs (bands: ±2 s.e.; IMM5CKF, IMMCKF and IMMUKF overlap)")
    fig.tight_layout()
    return fig


fig = rmse_figure([0, 2], ["x-position", "y-position"], "m", 3, "fig03_rmse_position", "")
show(fig, "fig03_rmse_position",
     "IMM5CKF has the lowest position RMSE and is the most stable; 5CKF the largest; no divergence (Figs. 3-4).",
     "partly: no divergence and 5CKF largest during turns (reproduced); IMM5CKF is indistinguishable from IMMCKF "
     "and IMMUKF at every step (not reproduced).")
fig = rmse_figure([1, 3], ["x-velocity", "y-velocity"], "m/s", 4, "fig04_rmse_velocity", "")
show(fig, "fig04_rmse_velocity", "IMM5CKF has the lowest velocity RMSE (Fig. 4).",
     "not reproduced: identical to IMMCKF and IMMUKF; all IMMs beat the single-model 5CKF in the turns.")

for j, (fignum, label) in enumerate([(5, "model 1 (CV)"), (6, "model 2 (right turn, −3°/s)"),
                                     (7, "model 3 (left turn, +3°/s)")]):
    fig, ax = plt.subplots(figsize=(7, 3.6))
    shade_intervals(ax, [setup.right_turn] if j == 1 else [setup.left_turn] if j == 2 else
                    [(0, setup.right_turn[0]), (setup.right_turn[1], setup.left_turn[0]), (setup.left_turn[1], 100)],
                    label="true mode active")
    for alg in ("IMM5CKF", "IMMCKF", "IMMUKF"):
        rs = results[alg]
        ax.plot(t, rs.mode_probabilities[rs.valid, :, j].mean(axis=0), label=alg, **styles[alg])
    ax.set(xlabel="time (s)", ylabel="probability", ylim=(-0.02, 1.02),
           title=f"Fig. {fignum} — mean probability of {label} ({n_runs} runs)")
    ax.legend(fontsize=8, loc="center right")
    show(fig, f"fig{fignum:02d}_mode_probability_{j + 1}",
         "IMM5CKF captures the mode switches at t = 20, 40, 60, 80 s in time, better than the others (Figs. 5-7).",
         "the switches are captured within a few steps (reproduced), but the three curves are identical: "
         "no IMM5CKF advantage (not reproduced); OMTM-IMM is not replicable (Z-14).")

# %% [markdown]
# ## Filter consistency (not in the paper)
#
# The paper reports only RMSE. Whether the filters' own covariances are honest is a separate question: the average
# NEES $\tilde x^T P^{-1} \tilde x$ over runs should stay inside the 95 % χ² band of a 4-dof statistic averaged over
# the runs. Shown for IMM5CKF (identical for IMMCKF/IMMUKF) and for the single-model 5CKF.

# %%
truth_c, z_c, init_c = make_batch(range(n_runs))
fig, ax = plt.subplots(figsize=(7, 3.6))
shade_intervals(ax, maneuvers)
nees_summary = {}
for alg in ("IMM5CKF", "5CKF"):
    prof = evaluation.nees_profile(estimators[alg], init_c[alg], z_c, truth_c)
    ax.plot(t, prof.per_step, label=alg, **styles[alg])
    nees_summary[alg] = [float(prof.time_average.value), float(prof.time_average.stderr)]
lo, hi = metrics.chi2_band(4, n_runs)
ax.axhspan(lo, hi, color="C2", alpha=0.15, label="95 % χ² band")
ax.set(yscale="log", xlabel="time (s)", ylabel="average NEES (4 dof)",
       title=f"NEES averaged over {n_runs} runs (consistent filter: inside the band)")
ax.legend(fontsize=8)
show(fig, "extra_nees_consistency", "(not in the paper)",
     "IMM5CKF: time-averaged NEES " + value_pm(*nees_summary["IMM5CKF"], 2) + "; 5CKF: "
     + value_pm(*nees_summary["5CKF"], 2) + " (4 = consistent); the single model is overconfident in the turns.")

# %% [markdown]
# ## Claims of the abstract and conclusions
#
# Accuracy claims are tested on paired differences of mean squared error over common random numbers; "switches more
# quickly" on the probability given to the true mode in the 10 steps after each of the four switches; the timing claim
# on the cost model's flop ratio (`mmlib/core/cost.py`), with a ±10 % equivalence margin. Every verdict is in the claim
# vocabulary of `mmlib/experiment/report.py`, with the one number that decided it; the matrix shows every part
# (✓ holds, ✗ contradicted, (✓)/(✗) negligible, · no detectable difference, ≡ identical to round-off: IMM5CKF, IMMCKF
# and IMMUKF are one algorithm on these linear models). The accuracy, switching, divergence and floor claims come from
# the same function (`study.judge_claims`) that judges them in every universe of the reading space below.

# %%
claims = study.judge_claims(results, setup)
claims.extend(timing_claims)      # judged from the timings above (timing.judge_timing)
display(Markdown(claims_table(claims.as_list())))
display(Markdown(claim_matrix(claims.as_list())))
display(Markdown(markdown_table(["claim", "evidence"], [[c["claim"], c["evidence"]] for c in claims])))

# %% [markdown]
# ## Reading space: every declared reading at once
#
# The factors above (table of factors, headline options in bold) span a full factorial reading space of
# 2⁶ × 3 = 192 universes. Each universe is an independent Monte Carlo job (`study.universe`) on the paper's root seed
# and its per-run random streams, so every universe sees the same truth noise, measurement noise and initial-estimate
# draws wherever its reading leaves them alone (common random numbers), and the headline universe is computed by the
# same functions as the headline rows above. In the full profile the design is the full factorial at the paper's 100
# runs per universe, so the headline universe is the headline above bit for bit and every share of the reading space
# below is exact (no sampling interval). The smoke profile runs the star design (the headline and every option varied
# alone) at the smoke run count; the star gives no share of the space.

# %%
t0 = time.perf_counter()
mv = nb.multiverse()
print(f"{mv.design.description}; {nb.mv_runs} runs per universe; {time.perf_counter() - t0:.1f} s wall")
if nb.mv_runs == n_runs:
    # the headline universe and the headline rows and claims above are the same computation
    same = study.summarise(results, n_runs, setup)
    assert digests.same_numbers(mv.headline, same), "the headline universe differs from the headline computed above"
    assert [v.replicated for v in mv.headline.values[:16]] == [r.replicated for r in rows[:16]]
    print("headline universe == headline rows above (bit for bit)")

# %% [markdown]
# ### The key effect in every universe: IMM5CKF against IMMCKF
#
# The specification curve sorts the universes by the paired difference of position mean squared error (x² + y²,
# IMM5CKF − IMMCKF, m²) with ± 3 standard errors; below it, which option of each factor every universe uses. Table 1's
# counterpart is RMSE_X² + RMSE_Y² of IMM5CKF minus that of IMMCKF.

# %%
key = [mv.effect(u, paper.key_effect) for u in mv.universes]
key_pub = key[0].published
fig = views.specification_curve(
    mv, paper.key_effect, ylabel="Δ position MSE (m²)\nIMM5CKF − IMMCKF",
    title=f"Specification curve: IMM5CKF − IMMCKF position MSE, {len(mv.universes)} readings\n"
          f"Table 1 implies {key_pub:.2f} m²; every reading gives 0 ± round-off")
fig.set_size_inches(max(10.0, fig.get_size_inches()[0]), fig.get_size_inches()[1])
fig.tight_layout()
max_abs_key = max(abs(e.value) for e in key)
max_key_se = max(e.stderr for e in key)
max_coincide = max(mv.effect(u, "max |IMM5CKF − IMM-KF| estimate (m, m/s)").value for u in mv.universes)
nb.show(fig, "extra_specification_curve",
        "IMM5CKF is more accurate than IMMCKF (Table 1: position MSE lower by " f"{-key_pub:.2f} m²).",
        f"not supported in any reading: |Δ| ≤ {max_abs_key:.1e} m² (standard errors ≤ {max_key_se:.1e} m², round-off) "
        f"in all {len(mv.universes)} universes; the largest |IMM5CKF − IMM-KF| estimate difference in any universe is "
        f"{max_coincide:.1e} (m, m/s).")

# %% [markdown]
# ### Does some reading reproduce Table 1?
#
# For each universe, the sum over Table 1's 16 replicated RMSE cells of the squared standardized distance
# z = (ours − paper) / σ of the verdict rule; a universe reproducing every cell would lie below the dotted line.

# %%
fig = views.table_match_figure(mv, title=f"How closely each of the {len(mv.universes)} readings matches Table 1\n"
                                         f"(Σz² over its 16 RMSE cells; smaller = closer)")
fig.set_size_inches(7.0, 4.6)
fig.tight_layout()
tm = mv.table_match()[0]
best_text = (f"the closest whole-table match is '{tm['best_describe']}' (Σz² = {tm['best_sum']:.3g}, reproducing "
             f"{tm['best_n_reproduced']} cells; headline Σz² = {tm['headline_sum']:.3g})" if tm["best_sum"] is not None
             else "no universe whose every cell is precise enough (s.e. ≤ 10 % of the printed value) can be ranked "
                  "as a whole-table match")
nb.show(fig, "extra_table_match", "Table 1 (RMSE of IMM5CKF, IMMCKF, IMMUKF and 5CKF).",
        (f"no reading reproduces Table 1: no reading reproduces more than {tm['most_n_reproduced']} of "
         f"{tm['n_cells']} cells (headline {tm['headline_n_reproduced']}); {best_text}."
         if tm["most_n_reproduced"] < tm["n_cells"] else
         f"the reading '{tm['most_describe']}' reproduces all {tm['n_cells']} cells; {best_text}."))

# %%
display(Markdown("**Claims across the reading space** (share of the declared space per verdict)"))
display(Markdown(views.claims_table(mv)))
display(Markdown("**Claim × option**: what drives each claim"))
display(Markdown(views.claim_option_table(mv)))
display(Markdown("**Published numbers across the reading space** (the closest universe is a forensic finding, "
                 "not a replication)"))
display(Markdown(views.numbers_table(mv)))
display(Markdown(views.table_match_table(mv)))

# %% [markdown]
# ### One factor at a time (the former sweeps, as a view of the reading space)

# %%
columns = [(f"{alg} {q}", ("Table 1", alg, q)) for alg in ("IMM5CKF", "5CKF") for q, _ in text.QUANTITIES]
columns.append(("Δ position MSE IMM5CKF − IMMCKF (m²)", ("effect", paper.key_effect)))
display(Markdown(views.one_factor_table(mv, columns)))

# %% [markdown]
# ### Table 1 against the minimum-MSE floor in every reading

# %%
floors = diagnostics.floor_summary(mv)
display(Markdown(markdown_table(
    ["quantity", "smallest paper IMM value", "floor across universes", "universes with the paper below the floor",
     "… of those where the floor is a bound (noisy truth, sampled start)"],
    [[f["quantity"], f["paper_min_imm"], f"{f['floor_min']:.3f} … {f['floor_max']:.3f}",
      f"{f['n_below']} / {f['n_universes']}", f"{f['n_below_where_bound']} / {f['n_bound']}"] for f in floors])))

# %% [markdown]
# ### What the reading space says

# %%
n_cells = tm["n_cells"]
ns = {s["algorithm"] + " " + s["quantity"]: s for s in mv.numbers_summary()}
ever = [k for k, s in ns.items() if s["n_reproduced"]]
never = [k for k, s in ns.items() if not s["n_reproduced"]]
cs = mv.claims_summary()
lines = [
    (f"- **Table 1.** No universe reproduces the whole table: no reading reproduces more than "
     f"{tm['most_n_reproduced']} of its {n_cells} cells (the headline reproduces {tm['headline_n_reproduced']}; "
     f"the first universe reaching "
     f"{tm['most_n_reproduced']}: '{tm['most_describe']}'); {best_text}"
     + (f" ({tm['n_excluded_imprecise']} universe(s) with a cell too imprecise to judge not ranked)"
        if tm["n_excluded_imprecise"] else "") + ", a forensic finding, not a replication."
     if tm["most_n_reproduced"] < n_cells else
     f"- **Table 1.** The reading '{tm['most_describe']}' reproduces every cell; {best_text}."),
    f"- Cells reproduced by at least one reading: {', '.join(ever) if ever else 'none'}; cells no reading reproduces: "
    f"{', '.join(never) if never else 'none'}"
    + (f" (inconclusive in some universes: {', '.join(k for k, s in ns.items() if s['n_inconclusive'])})"
       if any(s["n_inconclusive"] for s in ns.values()) else "") + ".",
    "- **Floor.** The smallest printed IMM value lies below the clairvoyant floor in "
    + "; ".join(f"{f['quantity']}: {f['n_below_where_bound']} of the {f['n_bound']} universes where the floor is a "
                f"bound ({f['n_below']} of {f['n_universes']} in all)" for f in floors) + ".",
]
for c in cs:
    lines.append(f"- Claim *{c['claim']}*: {views.robustness_text(c)}.")
div = mv.diverged_total()
lines.append(f"- Diverged runs across all universes: {div}.")
display(Markdown("\n".join(lines)))

# %% [markdown]
# ## Results file

# %%
# digest of the headline's per-run numbers over the first smoke-size runs (the same runs in every profile):
# tests/tolerance/test_results.py recomputes it in the smoke profile and compares it with the committed one exactly
doc = nb.write_results(rows=rows, digest=digests.run_digest(results, nb.digest_runs), claims=claims,
                       deviations=[d.as_dict() for d in paper.deviations], multiverse=mv, coincidence=coincide,
                       diverged_runs=diverged, nees_time_average=nees_summary, lower_bound=lower_bound,
                       timing_ms_per_run={alg: {"one_at_a_time": 1e3 * float(per_run[alg].mean()),
                                                "batched": 1e3 * float(batched[alg].mean())} for alg in per_run})
