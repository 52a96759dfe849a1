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
# # Tseng, Chang & Jwo 2011 — fuzzy adaptive IMM-UKF for integrated navigation (a documented reconstruction)
#
# C.-H. Tseng, C.-W. Chang, D.-J. Jwo, *Fuzzy Adaptive Interacting Multiple Model Nonlinear Filter for Integrated
# Navigation Sensor Fusion*, Sensors 11(2):2090–2111, 2011, [doi:10.3390/s110202090](https://doi.org/10.3390/s110202090).
#
# **This notebook is a reconstruction, not a replication.** What survives of the paper is the UKF and IMM algorithm
# (Sections 2, Appendix A), a description of the fuzzy logic adaptive system (FLAS) with its two degree-of-divergence
# (DOD) inputs (Section 3), the table of the vehicle's seven motion segments over 1800 s, the captions of Figures 13
# and 15, and the table of East/North position RMS errors (UKF 7.9530 / 6.3195, IMMUKF 2.9967 / 2.3021, FUZZY-IMMUKF
# 1.0184 / 0.7286). The whole simulation set-up (Section 4), the fuzzy membership functions and rules, the filters'
# noise settings and the integration model were lost. Everything reconstructed is a numbered deviation (T-1 … T-14),
# chosen from first principles *before* looking at the results and never fitted to the table.
#
# Because the absolute errors depend on every lost setting, the verdicts judge what a reconstruction can test: the
# **ranking** of the three filters and the **size of the relative improvements** (IMMUKF 62–64 % below UKF,
# FUZZY-IMMUKF 66–68 % below IMMUKF), each with its Monte Carlo uncertainty, and how both move with the most
# influential unknowns.
#
# **Library pieces** (all in `mmlib`): the constellation, frames (via `pymap3d`), pseudoranges and clock model in
# `mmlib/gnss.py`; zero-order Takagi–Sugeno inference in `mmlib/fuzzy.py`; the FLAS and the IMM whose modes' noise
# levels are set online in `mmlib/adaptive_imm.py`; the measurement model changes every epoch with the satellites in
# view (`run(..., measurement_models=...)`).
#
# **Verdict rule** (`mmlib/report.py`): *reproduced* within 3 combined standard errors; *qualitatively reproduced*
# within 25 %; *not reproduced* otherwise; *not replicable* when method or data are not published. Claims are judged
# on paired differences over common random numbers.

# %% tags=["parameters"]
PROFILE = "full"          # "full" (100 runs) or "smoke" (a prefix of the full runs)
N_RUNS = None             # override the profile's Monte Carlo count
SEED = None               # override the paper's root seed
OUTPUT_ROOT = ""          # folder that receives figures/ and data/results/; empty means the repository root
N_TIMING_RUNS = None      # unused here (the paper reports no times); kept for a uniform interface
PROGRESS = True

# %%
import math

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Markdown, display

import mmlib
from mmlib import metrics, report
from mmlib.experiment import evaluation
from mmlib.scenarios import tseng2011 as paper
from mmlib.montecarlo import MonteCarlo
from mmlib.scenarios.presentation import (NotebookRun, deviations_table, markdown_table, plot_style, rows_table,
                                         shade_intervals, value_pm)

PROFILES = {"full": dict(n_runs=paper.N_RUNS, timing_runs=1, timing_repeats=1, sweep_runs=50, sweep_variants=None),
            "smoke": dict(n_runs=20, timing_runs=1, timing_repeats=1, sweep_runs=20, sweep_variants=3)}
nb = NotebookRun(paper.PAPER, paper.ROOT_SEED, PROFILES, PROFILE=PROFILE, N_RUNS=N_RUNS, SEED=SEED,
                 OUTPUT_ROOT=OUTPUT_ROOT, N_TIMING_RUNS=N_TIMING_RUNS)
if not isinstance(PROGRESS, bool):
    raise ValueError(f"PROGRESS: expected True or False, got {PROGRESS!r}")
mc = MonteCarlo(nb.seed, nb.n_runs)
mc_sweep = MonteCarlo(nb.seed, min(nb.n_runs, PROFILES[nb.profile]["sweep_runs"]))
plot_style()
print(nb)

# %% [markdown]
# ## Reconstructed set-up and deviations
#
# The filter state is `[e, ve, n, vn, u, vu, b, d]` (local East-North-Up position and velocity, receiver clock bias
# and drift in metres) on raw pseudoranges $\rho_i = \lVert s_i - p\rVert + b + v_i$ — the *tightly coupled*
# measurement. The process model is position–velocity with continuous white-noise acceleration of spectral density
# $S_p$ on each axis plus the two-state clock; the IMM's two modes differ only in $S_p$ (T-7).

# %%
setup = paper.Setup()
display(Markdown(deviations_table(paper.DEVIATIONS)))
ex = paper.experiment(setup, names=("UKF", "IMMUKF", "FUZZY-IMMUKF", "EKF"))
n_vis = ex.sky.visible.sum(axis=1)
print(f"satellites in view: {n_vis.min()}–{n_vis.max()} (mask {setup.mask_deg:g} deg); "
      f"UKF S_p = {setup.ukf_level:g}, IMM S_p = {setup.s_lower:g} / {setup.s_upper:g} m^2/s^3")

# %% [markdown]
# ## The vehicle and the sky
#
# The seven segments of the paper's table, driven at 20 m/s (T-1), and the satellites of a nominal 24-satellite
# constellation above a 10° mask (T-3).

# %%
t = setup.times
plane = ex.truth_plane
turns = paper.maneuver_intervals(setup)
fig, axes = plt.subplots(1, 3, figsize=(14, 4.3), gridspec_kw={"width_ratios": [1.1, 1.0, 1.0]})
ax = axes[0]
seg_t = np.arange(setup.n_steps + 1) * setup.T
for (a, b, label), col in zip(paper.SEGMENTS, ["C0", "C1", "C0", "C2", "C0", "C3", "C0"]):
    sel = (seg_t >= max(a - 1, 0)) & (seg_t <= b)
    ax.plot(plane[sel, 0] / 1e3, plane[sel, 2] / 1e3, color=col, lw=2, label=label if col != "C0" or a == 0 else None)
ax.plot(plane[0, 0] / 1e3, plane[0, 2] / 1e3, "ko", label="start")
ax.set(xlabel="East (km)", ylabel="North (km)", title="Vehicle trajectory (segment table)", aspect="equal")
ax.legend(fontsize=7, loc="best")
ax = axes[1]
ax.step(t, n_vis, where="post", color="k")
shade_intervals(ax, turns, label="turning")
ax.set(xlabel="time (s)", ylabel="satellites in view", title=f"Satellites above {setup.mask_deg:g}°",
       ylim=(0, n_vis.max() + 2))
ax.legend(fontsize=8)
ax = axes[2]
ax = fig.add_subplot(1, 3, 3, projection="polar")
axes[2].remove()
az = np.arctan2(ex.sky.satellites_enu[..., 0], ex.sky.satellites_enu[..., 1])
el = np.degrees(ex.sky.elevation)
for s_ in range(len(ex.sky.names)):
    vis = ex.sky.visible[:, s_]
    if vis.any():
        ax.plot(az[vis, s_], 90 - el[vis, s_], ".", ms=1.5)
        k = np.flatnonzero(vis)[-1]
        ax.text(az[k, s_], 90 - el[k, s_], ex.sky.names[s_], fontsize=7)
ax.set_theta_zero_location("N")
ax.set_theta_direction(-1)
ax.set_rlim(0, 90 - setup.mask_deg)
ax.set_yticks([30, 60])
ax.set_yticklabels(["60°", "30°"], fontsize=7)
ax.set_title("Sky plot over 30 min", fontsize=10)
fig.tight_layout()
nb.show(fig, "reconstruction_trajectory_satellites",
        "seven motion segments over 1800 s (table); no trajectory or satellite figure survives.",
        f"reconstruction (T-1, T-3): {n_vis.min()}–{n_vis.max()} satellites in view; the set changes "
        f"{int((np.diff(ex.sky.visible.astype(int), axis=0) != 0).any(axis=1).sum())} time(s) in 30 minutes.")

# %% [markdown]
# ## The fuzzy logic adaptive system (T-10, T-11)
#
# Inputs: the paper's two DOD parameters at the present epoch (window size one), divided by the *predicted*
# innovation variance per satellite $s = \mathrm{tr}(S)/m$ (of the IMM's mixture prior) and by $\sqrt{s}$, so that
# the sets are dimensionless: $\xi/s = \upsilon^T\upsilon/(m s)$ and $\eta/\sqrt s = \sum_i|\upsilon_i|/(m\sqrt s)$.
# For a consistent filter $\xi/s$ is close to $\chi^2_m/m$ (mean 1; 95 % quantile ≈ 2, 99.9 % ≈ 3.5–3.7 for the
# 6–7 satellites in view) and $\eta/\sqrt s \approx 0.80\sqrt{\xi/s}$. Hence the sets *Normal*, *Moderate*, *Large*
# peak at 1, 2, 4 for $\xi/s$ and at 0.80 × the square roots for $\eta/\sqrt s$. (A first version divided by the
# pseudorange variance $\sigma^2$; its mean under consistency is $1 + \mathrm{tr}(HPH^T)/(m\sigma^2) \approx 1.25$,
# not 1, as a review pointed out, so the justification did not hold. It was corrected and is kept as a sweep row.)
# The nine zero-order Takagi–Sugeno rules move a
# one-decade band of process noise along the plain IMM's two-decade range: the band's position is the larger of the
# two inputs' levels — either sign of divergence raises the noise — and the fuzzy bounds never leave the IMM's
# range, so the comparison with the IMM is fair. Output = product-weighted average of the rule consequents, in
# $\log_{10} S_p$. The inference is `mmlib/fuzzy.py` (~20 lines of numpy evaluated for all runs at once):
# scikit-fuzzy is built for Mamdani inference and simpful evaluates one input vector per call, which would put a
# Python loop over runs inside the filter loop.

# %%
ts = paper.fuzzy_system(setup)
display(Markdown(markdown_table(["IF ξ/s is", "AND η/√s is", "THEN lower S_p", "upper S_p"],
                                [[a, b, f"{10 ** c[0]:.3g}", f"{10 ** c[1]:.3g}"] for (a, b), c in ts.rules()])))
fig, axes = plt.subplots(1, 3, figsize=(14, 3.8))
for i, (ax, xmax) in enumerate(zip(axes[:2], (6.0, 2.4))):
    x = np.linspace(0, xmax, 400)
    for s_, col in zip(ts.inputs[i], ("C2", "C1", "C3")):
        ax.plot(x, s_(x), color=col, lw=2, label=s_.name)
    ax.set(xlabel=ts.input_names[i], ylabel="membership", title=f"Input {i + 1}: {ts.input_names[i]}", ylim=(-0.03, 1.05))
    ax.legend(fontsize=8)
g1, g2 = np.meshgrid(np.linspace(0, 6, 121), np.linspace(0, 2.4, 121))
out = ts(np.stack([g1.ravel(), g2.ravel()], axis=-1))
im = axes[2].contourf(g1, g2, (10 ** out[:, 1]).reshape(g1.shape), levels=20, cmap="viridis")
fig.colorbar(im, ax=axes[2], label="upper bound S_p (m²/s³)")
axes[2].set(xlabel=ts.input_names[0], ylabel=ts.input_names[1], title="Rule surface: upper bound (lower = upper / 10)")
fig.tight_layout()
nb.show(fig, "reconstruction_fuzzy_membership_functions",
        "Takagi-Sugeno FLAS with DOD inputs (Sec. 3); its membership functions and rules did not survive.",
        "reconstruction (T-10): sets from the chi-square behaviour of consistent innovations; not fitted.")

# %% [markdown]
# ## Monte Carlo: UKF, IMMUKF, FUZZY-IMMUKF
#
# All filters see the same runs (common random numbers). The EKF runs alongside to check a coincidence theory
# predicts: the dynamics are linear and a pseudorange is linear to within $\sigma_p^2/(2r) \approx 10^{-6}$ m over the
# filter's spread ($\sigma_p \approx 10$ m, $r \approx 2\times10^7$ m), so the UKF *is* the EKF here up to that.

# %%
mb = paper.make_batch_fn(ex, mc)
res = evaluation.evaluate(ex.estimators, mb, mc, label="tseng2011", progress=PROGRESS,
                      measurement_models=ex.measurement_models)
diverged = {a: int((~r.valid).sum()) for a, r in res.items()}
ukf_ekf = float(np.abs(res["UKF"].errors[..., [0, 2, 4]] - res["EKF"].errors[..., [0, 2, 4]]).max())
print(f"diverged runs: {diverged}")
print(f"largest |UKF - EKF| position difference over all runs and epochs: {ukf_ekf:.2e} m")

# %% [markdown]
# ### Figure 13 — navigation errors of the three filters (first run)

# %%
fig, axes = plt.subplots(2, 2, figsize=(13, 6.5), sharex=True)
for (r_, c_), comp, lab in zip(((0, 0), (0, 1), (1, 0), (1, 1)), (0, 2, 1, 3),
                               ("East position error (m)", "North position error (m)", "East velocity error (m/s)",
                                "North velocity error (m/s)")):
    ax = axes[r_, c_]
    for alg, col in zip(paper.ALGORITHMS, ("C3", "C0", "C2")):
        ax.plot(t, res[alg].errors[0, :, comp], color=col, lw=0.8, label=alg)
    shade_intervals(ax, turns, label="turning")
    ax.set(ylabel=lab)
axes[1, 0].set(xlabel="time (s)")
axes[1, 1].set(xlabel="time (s)")
axes[0, 0].legend(fontsize=8, ncol=2)
fig.suptitle("Fig. 13 — navigation accuracy of FUZZY-IMMUKF, IMMUKF and UKF (run 1)")
fig.tight_layout()
nb.show(fig, "fig13_navigation_errors", "FUZZY-IMMUKF is the most accurate, then IMMUKF, then UKF.",
        "all three filters' errors grow in the turns; the UKF, with one compromise noise level, is noisier on the "
        "straight legs; IMMUKF and FUZZY-IMMUKF look alike (quantified below).")

# %% [markdown]
# ### Figure 15 — East and North position RMS errors over time

# %%
fig, axes = plt.subplots(2, 1, figsize=(12, 6.5), sharex=True)
for ax, comp, lab in zip(axes, (0, 2), ("East", "North")):
    for alg, col in zip(paper.ALGORITHMS, ("C3", "C0", "C2")):
        r_ = metrics.rmse_over_time(res[alg].errors[..., comp], res[alg].valid)
        ax.plot(t, r_.value, color=col, lw=1.0, label=f"{alg} (RMS {paper.rms(res[alg], comp).value:.2f} m)")
    shade_intervals(ax, turns, label="turning")
    ax.set(ylabel=f"{lab} RMS error (m)")
    ax.legend(fontsize=8, ncol=2)
axes[1].set(xlabel="time (s)")
fig.suptitle(f"Fig. 15 — East and North position RMS errors ({nb.n_runs} runs)")
fig.tight_layout()
nb.show(fig, "fig15_rms_errors", "RMS errors of UKF > IMMUKF > FUZZY-IMMUKF (7.95 > 3.00 > 1.02 m East).",
        "same order for UKF vs the IMMs, but IMMUKF and FUZZY-IMMUKF nearly coincide and the gaps are far smaller.")

# %% [markdown]
# ### Model probabilities and the fuzzy-adapted bounds

# %%
fig, axes = plt.subplots(2, 1, figsize=(12, 6.5), sharex=True)
ax = axes[0]
for alg, col in (("IMMUKF", "C0"), ("FUZZY-IMMUKF", "C2")):
    ax.plot(t, res[alg].mode_probabilities[:, :, 1].mean(axis=0), color=col, lw=1.0,
            label=f"{alg}: upper-noise mode (mean over runs)")
shade_intervals(ax, turns, label="turning")
ax.set(ylabel="mode probability", ylim=(0, 1))
ax.legend(fontsize=8)
ax = axes[1]
lv = res["FUZZY-IMMUKF"].diagnostics
for j, (lab, col) in enumerate((("lower bound", "C2"), ("upper bound", "C1"))):
    q = np.nanquantile(lv[:, :, j], [0.1, 0.5, 0.9], axis=0)
    ax.fill_between(t, q[0], q[2], color=col, alpha=0.25, lw=0)
    ax.plot(t, q[1], color=col, lw=1.0, label=f"fuzzy {lab} (median, 10–90 % of runs)")
for v, lab in ((setup.s_lower, "IMMUKF lower"), (setup.s_upper, "IMMUKF upper"), (setup.ukf_level, "UKF")):
    ax.axhline(v, color="k", ls=":" if "IMM" in lab else "--", lw=1)
    ax.text(t[-1], v, f" {lab}", va="center", fontsize=7)
shade_intervals(ax, turns, label=None)
ax.set(yscale="log", ylabel="S_p (m²/s³)", xlabel="time (s)")
ax.legend(fontsize=8, loc="lower left")
fig.tight_layout()
nb.show(fig, "reconstruction_mode_probabilities_bounds",
        "the FLAS sets the lower and upper process-noise bounds online from the innovations (Sec. 3).",
        "the IMMs move to the upper mode in the turns (FUZZY-IMMUKF more decisively, its modes being closer); the "
        "median fuzzy bounds sit at the 'Normal' band and rise briefly at the onsets of the turns at 300 s and 800 s; "
        "single runs jitter every epoch, since with a one-epoch window the DOD is a chi-square sample (s.d. ~0.55 of "
        "its mean).")

# %% [markdown]
# ## Table — East/North position RMS errors
#
# Absolute values are shown for scale (their verdict is *not replicable*: T-14). The judged rows are the relative
# improvements, $100\,(1 - \mathrm{RMS}_a/\mathrm{RMS}_b)$, on common random numbers with jackknife standard errors;
# the published improvements are computed from the printed table.

# %%
rows = []
axes_ = (("East", 0, paper.EAST), ("North", 1, paper.NORTH))
for alg in paper.ALGORITHMS:
    for lab, ax_i, comp in axes_:
        v = paper.rms(res[alg], comp)
        rows.append(report.Row("Table (RMS errors)", alg, f"{lab} position RMS error (m)", paper.TABLE[alg][ax_i],
                               float(v.value), float(v.stderr),
                               f"{report.NOT_REPLICABLE}: absolute errors depend on the unpublished set-up",
                               ["T-14"], "shown for scale"))
for a, b in (("IMMUKF", "UKF"), ("FUZZY-IMMUKF", "IMMUKF"), ("FUZZY-IMMUKF", "UKF")):
    for lab, ax_i, comp in axes_:
        v = paper.rms_reduction(res[a], res[b], comp)
        rows.append(report.make_row("Table (RMS errors)", f"{a} vs {b}", f"{lab} RMS reduction (%)",
                                    f"{paper.published_reduction(a, b, ax_i):.2f}", v.value, v.stderr,
                                    n_runs=v.n_runs, deviations=["T-7", "T-8", "T-10", "T-14"],
                                    note="published value computed from the printed RMS errors"))
display(Markdown(rows_table(rows)))

# %% [markdown]
# ## How far could *any* online adaptation of Q go?
#
# A reference that does not depend on the fuzzy design: the UKF told **when** the vehicle turns, with one process-noise
# level on the straight legs and another in the turns, for a small grid of levels; the best schedule in hindsight
# (labelled *oracle*, not a filter anyone can run) shows what adapting Q to the maneuvers can buy here. It is a
# reference, not a strict bound: other schedules, or an IMM whose modes are adapted, could do somewhat better.

# %%
oracles = paper.clairvoyant_schedules(ex)
ex_or = paper.Experiment(setup, ex.truth_plane, ex.sky, oracles)
res_or = evaluation.evaluate(oracles, paper.make_batch_fn(ex_or, mc_sweep), mc_sweep, label="tseng2011 oracle",
                         progress=PROGRESS, measurement_models=ex.measurement_models)
or_rows, oracle_json = [], []
imm_head = evaluation.first_runs(res["IMMUKF"], mc_sweep.n_runs)
for name, r_ in res_or.items():
    e_, n_ = paper.rms(r_, 0), paper.rms(r_, 2)
    red_e, red_n = paper.rms_reduction(r_, imm_head, 0), paper.rms_reduction(r_, imm_head, 2)
    or_rows.append([name, value_pm(float(e_.value), float(e_.stderr), 3), value_pm(float(n_.value), float(n_.stderr), 3),
                    value_pm(float(red_e.value), float(red_e.stderr), 1), value_pm(float(red_n.value), float(red_n.stderr), 1)])
    oracle_json.append({"schedule": name, "east": [float(e_.value), float(e_.stderr)],
                        "north": [float(n_.value), float(n_.stderr)],
                        "reduction_vs_immukf_percent": [[float(red_e.value), float(red_e.stderr)],
                                                        [float(red_n.value), float(red_n.stderr)]]})
best = min(res_or, key=lambda k: paper.rms(res_or[k], 0).value + paper.rms(res_or[k], 2).value)
best_red = {lab: paper.rms_reduction(res_or[best], imm_head, comp) for lab, _, comp in axes_}
display(Markdown(markdown_table(["schedule (straight / turning S_p)", "East RMS (m)", "North RMS (m)",
                                 "East reduction vs IMMUKF (%)", "North reduction vs IMMUKF (%)"], or_rows)))
print(f"best oracle ({best}): reduction vs IMMUKF East {value_pm(best_red['East'].value, best_red['East'].stderr, 1)} %, "
      f"North {value_pm(best_red['North'].value, best_red['North'].stderr, 1)} % (paper's FUZZY-IMMUKF: 66.0 / 68.4 %)")

# %% [markdown]
# ## Sensitivity to the influential unknowns
#
# Each row changes one reconstructed choice (on the first runs of the same streams). The UKF's own process noise
# decides the IMM's advantage; the fuzzy bounds' design decides whether the FLAS helps or hurts. (The smoke profile
# runs the first three rows only.)

# %%
# Each entry: (label, change, the algorithms the change affects); the others are unchanged by construction, so
# their results are reused from the headline (same runs, same streams) instead of being recomputed.
ALL = paper.ALGORITHMS
variants = [("headline", {}, ()),
            ("T-8: UKF S_p = 0.01 (the IMM's lower bound)", dict(s_ukf=0.01), ("UKF",)),
            ("T-8: UKF S_p = 0.001 (10x below the lower bound)", dict(s_ukf=0.001), ("UKF",)),
            ("T-8: UKF S_p = 0.03", dict(s_ukf=0.03), ("UKF",)),
            ("T-8: UKF S_p = 0.3", dict(s_ukf=0.3), ("UKF",)),
            ("T-8: UKF S_p = 1 (the IMM's upper bound)", dict(s_ukf=1.0), ("UKF",)),
            ("T-7: IMM bounds 0.001 / 0.1", dict(s_lower=0.001, s_upper=0.1, s_ukf=0.1), ("IMMUKF", "FUZZY-IMMUKF")),
            ("T-7: IMM bounds 0.1 / 10", dict(s_lower=0.1, s_upper=10.0, s_ukf=0.1), ("IMMUKF", "FUZZY-IMMUKF")),
            ("T-10: fuzzy breakpoints x0.5", dict(mf_scale=0.5), ("FUZZY-IMMUKF",)),
            ("T-10: fuzzy breakpoints x2", dict(mf_scale=2.0), ("FUZZY-IMMUKF",)),
            ("T-10: DOD over the pseudorange variance (first design)", dict(dod_normalise="measurement"),
             ("FUZZY-IMMUKF",)),
            ("T-1: speed 10 m/s", dict(speed=10.0), ALL),
            ("T-1: speed 30 m/s", dict(speed=30.0), ALL),
            ("T-4: pseudorange s.d. 1 m", dict(sigma_pr=1.0), ALL),
            ("T-4: pseudorange s.d. 10 m", dict(sigma_pr=10.0), ALL)][:PROFILES[nb.profile]["sweep_variants"]]
headline_sweep = {alg: evaluation.first_runs(res[alg], mc_sweep.n_runs) for alg in ALL}
sweep_rows, sweep_json = [], []
for label, change, affected in variants:
    rs_ = dict(headline_sweep)
    if affected:
        ex_v = paper.experiment(paper.variant(setup, **change), names=affected)
        rs_.update(evaluation.evaluate(ex_v.estimators, paper.make_batch_fn(ex_v, mc_sweep), mc_sweep, progress=False,
                                   measurement_models=ex_v.measurement_models))
    entry = {"variant": label, "changes": change, "recomputed": list(affected)}
    cells = [label]
    for alg in ALL:
        entry[alg] = {"east": float(paper.rms(rs_[alg], 0).value), "north": float(paper.rms(rs_[alg], 2).value),
                      "diverged": int((~rs_[alg].valid).sum())}
        cells.append(f"{entry[alg]['east']:.2f} / {entry[alg]['north']:.2f}")
    for a, b in (("IMMUKF", "UKF"), ("FUZZY-IMMUKF", "IMMUKF")):
        red = [paper.rms_reduction(rs_[a], rs_[b], c) for c in (0, 2)]
        entry[f"{a} vs {b} reduction %"] = [[float(r.value), float(r.stderr)] for r in red]
        cells.append(" / ".join(value_pm(float(r.value), float(r.stderr), 1) for r in red))
    sweep_rows.append(cells)
    sweep_json.append(entry)
    if PROGRESS:
        print(f"  [sweep] {label}", flush=True)
display(Markdown(markdown_table(["variant", "UKF E/N (m)", "IMMUKF E/N (m)", "FUZZY-IMMUKF E/N (m)",
                                 "IMMUKF vs UKF: reduction E / N (%)", "FUZZY vs IMMUKF: reduction E / N (%)"],
                                sweep_rows)))

fig, axes = plt.subplots(1, 2, figsize=(14, 5), sharey=True)
ypos = np.arange(len(sweep_json))[::-1]
for ax, key, pub, title in ((axes[0], "IMMUKF vs UKF reduction %", (paper.published_reduction("IMMUKF", "UKF", 0),
                                                                      paper.published_reduction("IMMUKF", "UKF", 1)),
                             "IMMUKF vs UKF"),
                            (axes[1], "FUZZY-IMMUKF vs IMMUKF reduction %",
                             (paper.published_reduction("FUZZY-IMMUKF", "IMMUKF", 0),
                              paper.published_reduction("FUZZY-IMMUKF", "IMMUKF", 1)), "FUZZY-IMMUKF vs IMMUKF")):
    for off, (i, lab, col) in zip((0.15, -0.15), ((0, "East", "C0"), (1, "North", "C1"))):
        vals = np.array([e[key][i] for e in sweep_json])
        ax.errorbar(vals[:, 0], ypos + off, xerr=2 * vals[:, 1], fmt="o", color=col, ms=4, label=f"{lab} (±2 s.e.)")
        ax.axvline(pub[i], color=col, ls="--", lw=1, label=f"paper, {lab} ({pub[i]:.1f} %)")
    ax.axvline(0, color="k", lw=0.8)
    ax.set(xlabel="RMS reduction (%)", title=title)
    ax.legend(fontsize=7, loc="lower right")
axes[0].set_yticks(ypos)
axes[0].set_yticklabels([e["variant"] for e in sweep_json], fontsize=8)
fig.suptitle(f"Relative improvements under each reconstructed choice ({mc_sweep.n_runs} runs)")
fig.tight_layout()
nb.show(fig, "reconstruction_sweep_improvements",
        "IMMUKF ~62 % below UKF; FUZZY-IMMUKF ~66 % below IMMUKF.",
        "the IMM's gain is set by how poorly the single UKF is tuned (from a few % to > 80 %); the fuzzy gain stays "
        "within a few % of zero, or negative, under every variant.")

# %% [markdown]
# ## Claims of the abstract and conclusions

# %%
claims = []


def claim(text, verdict, evidence):
    claims.append({"claim": text, "verdict": verdict, "evidence": evidence})


qEN = [("East", paper.EAST), ("North", paper.NORTH)]
ukf_sweep = [e for e in sweep_json if e["variant"].startswith("T-8")]
fz_sweep = [e["FUZZY-IMMUKF vs IMMUKF reduction %"] for e in sweep_json]
claim("IMMUKF is more accurate than the UKF (conclusions: 'superior navigation accuracy')",
      *evaluation.better_claim(res, "IMMUKF", "UKF", qEN))
for other, note in (("IMMUKF", ""), ("UKF", ", nearly all of it the IMM's")):
    red_o = [r for r in rows if r.algorithm == f"FUZZY-IMMUKF vs {other}"]
    direction, evidence_o = evaluation.better_claim(res, "FUZZY-IMMUKF", other, qEN)
    claim(f"FUZZY-IMMUKF shows remarkable improvement over {other} (abstract)",
          f"direction: {direction}; size: " + ", ".join(f"{r.quantity.split()[0]} {r.verdict}" for r in red_o),
          evidence_o + "; RMS reductions " + ", ".join(value_pm(r.replicated, r.stderr, 1) + " %" for r in red_o)
          + f" against the published {red_o[0].paper} / {red_o[1].paper} %{note}")
red_imm = [r for r in rows if r.algorithm == "IMMUKF vs UKF"]
red_fz = [r for r in rows if r.algorithm == "FUZZY-IMMUKF vs IMMUKF"]
claim("IMMUKF's errors are about 62-64 % below the UKF's (table)",
      "depends on the UKF's tuning: " + "; ".join(f"{r.quantity} {r.verdict}" for r in red_imm),
      "headline " + ", ".join(value_pm(r.replicated, r.stderr, 1) + " %" for r in red_imm) + "; the published value "
      "needs a UKF tuned well below the IMM's quiet mode -- UKF-tuning sweep: "
      + "; ".join(f"{e['variant'].split(': ')[1]} -> " + value_pm(*e["IMMUKF vs UKF reduction %"][0], 1) + " %"
                  for e in ukf_sweep) + " (East)")
claim("FUZZY-IMMUKF's errors are about 66-68 % below IMMUKF's (table)",
      "not reproduced" if all(r.verdict.startswith(report.NOT_REPRODUCED) for r in red_fz) else
      "; ".join(r.verdict for r in red_fz),
      "headline " + ", ".join(value_pm(r.replicated, r.stderr, 1) + " %" for r in red_fz)
      + f"; over the sweep {min(v[0][0] for v in fz_sweep):.0f} to {max(v[0][0] for v in fz_sweep):.0f} % (East, s.e. "
      f"<= {max(v[0][1] for v in fz_sweep):.1f}); a clairvoyant two-level Q schedule (a reference, not a bound) reaches "
      + value_pm(best_red["East"].value, best_red["East"].stderr, 1) + " / "
      + value_pm(best_red["North"].value, best_red["North"].stderr, 1) + " %")
# "at the claimed size": the best variant's improvement (+3 s.e.) against the published one less the verdict rule's 25 %
best_fz = max(fz_sweep, key=lambda v: v[0][0])
claimed = paper.published_reduction("FUZZY-IMMUKF", "IMMUKF", 0)
claim("The FLAS determines better lower and upper process-noise bounds online (Sec. 3, conclusions)",
      "not supported at the claimed size" if best_fz[0][0] + 3 * best_fz[0][1] < (1 - report.RELATIVE_BAND) * claimed
      else "partly",
      f"the fuzzy bounds move with the innovations (figure above), but the best variant improves on fixed bounds by "
      f"{best_fz[0][0]:.1f} ± {best_fz[0][1]:.1f} % (East) against the claimed {claimed:.0f} %; with a one-epoch window the "
      "DOD is mostly measurement noise (xi/s ~ chi2_m/m, s.d. ~0.55). The headline FLAS was designed before any "
      "run and not tuned (T-10)")
claim("The UKF avoids the EKF's linearisation errors (Sec. 2)", "not testable here (holds trivially)",
      f"pseudoranges are linear over the filter's spread: |UKF - EKF| <= {ukf_ekf:.1e} m over all runs and epochs")
claim("The approach prevents the divergence problem in high dynamic environments (conclusions)",
      "not testable here" if not any(diverged.values()) else "see evidence",
      "no filter diverged in the reconstruction (" + ", ".join(f"{a} {d}/{nb.n_runs}" for a, d in diverged.items())
      + "), nor in any sweep row (" + str(sum(e[a]["diverged"] for e in sweep_json for a in ALL))
      + " diverged runs in all), so there was no divergence to prevent")
claim("A lower-order filter model suffices with less computation (conclusions)", "not replicable",
      "no filter-order comparison survives in the text")
claim("Absolute RMS errors of the table (UKF 7.95/6.32, IMMUKF 3.00/2.30, FUZZY-IMMUKF 1.02/0.73 m)",
      "not replicable", "they depend on the unpublished set-up (T-14); the reconstruction's values are in the table")
display(Markdown(markdown_table(["claim", "verdict", "evidence"], [[c["claim"], c["verdict"], c["evidence"]] for c in claims])))

# %% [markdown]
# ## Results file

# %%
prov = report.provenance(root_seed=nb.seed, n_runs=nb.n_runs, profile=nb.profile,
                         extra={"paper_citation": paper.CITATION, "sweep_runs": mc_sweep.n_runs,
                                "mmlib": mmlib.__version__})
report.write_results(nb.results_path, paper=paper.PAPER, provenance=prov, rows=rows, claims=claims,
                     deviations=[d.as_dict() for d in paper.DEVIATIONS], figures=nb.figures, sweeps=sweep_json,
                     diverged_runs=diverged, oracle_schedules=oracle_json, ukf_minus_ekf_max_m=ukf_ekf,
                     satellites_in_view=[int(n_vis.min()), int(n_vis.max())])
counts_v = {v: sum(r.verdict.startswith(v) for r in rows) for v in report.VERDICTS}
print(f"wrote {nb.results_path} ({len(rows)} rows): {counts_v}")
