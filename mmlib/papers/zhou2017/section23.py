"""Section 2.3 of Zhou et al. 2017: the 1-D interaction example (Table 1, Fig. 2), analytic.

Three scalar Gaussians, means ``EXAMPLE_MEANS``, s.d. ``EXAMPLE_SD``, weights ``EXAMPLE_U``
(:mod:`~mmlib.papers.zhou2017.text`).  "MSE" (Eqs. 11-12) gives the moments of the mixture
sum_i u_i N(x_i, S_i^2), which the IMM interaction produces; "CP" (Eqs. 14-19,
:class:`~mmlib.core.mixing.CubatureMixing`) those of the weighted sum of independent x_i; the paper's "MC" samples
the weighted sum.  The claims about the example are judged against the mixture's moments by quadrature (no reading
changes them).
"""
from __future__ import annotations

import functools
import math

import numpy as np

from mmlib.core.mixing import CubatureMixing
from mmlib.experiment import report
from mmlib.experiment.montecarlo import Stream
from mmlib.papers.zhou2017.text import EXAMPLE_MEANS, EXAMPLE_SD, EXAMPLE_U, TABLE1

__all__ = [
    "section23_moments", "section23_parts", "section23_claims", "section23_rows"
]


def section23_moments() -> dict:
    """Closed forms of the Section 2.3 example: the mixture's mean and s.d. (Eqs. 11-12, 'MSE'), and the
    cubature rule on the interaction (Eqs. 14-19, 'CP'; exact for the linear f, i.e. the weighted sum
    of independent Gaussians: s.d. sqrt(sum u_i^2 S_i^2)); and, independently of both, the mean and
    variance of the interacted variable itself -- the mixture sum_i u_i N(x_i, S_i^2) that the IMM
    interaction produces -- by adaptive quadrature of its density (``mixture_*``), with the quadrature's
    error estimate (``quadrature_error``, an absolute bound on the variance's error).  Computed once per process (the
    quadrature takes a tenth of a second, and every universe of the reading space judges the claims about the example,
    which no reading changes); a new dict each call."""
    return dict(_section23_moments())


@functools.lru_cache(maxsize=1)
def _section23_moments() -> dict:
    """:func:`section23_moments`, computed."""
    from scipy import integrate, stats
    u, xs, sds = np.array(EXAMPLE_U), np.array(EXAMPLE_MEANS), np.array(EXAMPLE_SD)
    mse_mean = float(u @ xs)
    mse_sd = float(np.sqrt(u @ (sds ** 2 + (xs - mse_mean) ** 2)))
    cp_mean, cp_cov = CubatureMixing()(xs[None, :, None], (sds ** 2)[None, :, None, None],
                                       np.tile(u[:, None], (1, 3))[None])
    pdf = (lambda x: float(u @ stats.norm.pdf(x, xs, sds)))
    m1, e1 = integrate.quad(lambda x: x * pdf(x), -np.inf, np.inf, epsabs=1e-12, epsrel=1e-12)
    var, e2 = integrate.quad(lambda x: (x - m1) ** 2 * pdf(x), -np.inf, np.inf, epsabs=1e-12, epsrel=1e-12)
    return {"mse_mean": mse_mean, "mse_sd": mse_sd, "cp_mean": float(cp_mean[0, 0, 0]),
            "cp_sd": float(np.sqrt(cp_cov[0, 0, 0, 0])), "mixture_mean": float(m1), "mixture_var": float(var),
            "quadrature_error": float(e1 + e2)}


def section23_parts() -> dict:
    """The parts (:func:`mmlib.experiment.verdicts.part`) of the two claims about the Section 2.3 example, from
    :func:`section23_moments`: each compares a method's moment of the interacted variable with the quadrature value,
    an exact part (:func:`mmlib.experiment.verdicts.exact_part`: no z-score) judged beyond the quadrature's error
    bound, relative to the mixture's variance (a difference within it is *identical*).

    * ``"overestimates"`` ("MSE overestimates the covariance ...; CP is accurate"): MSE's variance minus the
      mixture's (claimed > 0), and CP's absolute variance error minus MSE's (claimed < 0: CP closer);
    * ``"second order"`` ("CPIMM's interaction ... second-order accuracy", Sec. 3.1.3, which cites this example as
      'much closer ... than the MSE method'): CP's absolute error minus MSE's, for the mean and for the variance
      (claimed < 0 or at least no worse; a detectably larger error contradicts it)."""
    m = section23_moments()
    mix_m, mix_v, se = m["mixture_mean"], m["mixture_var"], max(m["quadrature_error"], np.finfo(float).eps)
    mse_v, cp_v = m["mse_sd"] ** 2, m["cp_sd"] ** 2
    err = {("MSE", "var"): abs(mse_v - mix_v), ("CP", "var"): abs(cp_v - mix_v),
           ("MSE", "mean"): abs(m["mse_mean"] - mix_m), ("CP", "mean"): abs(m["cp_mean"] - mix_m)}
    cp_var = report.exact_part("CP − MSE", "absolute variance error", err["CP", "var"] - err["MSE", "var"], -1,
                               tolerance=se, reference=mix_v)
    return {"overestimates": [report.exact_part("MSE − mixture", "variance", mse_v - mix_v, +1, tolerance=se,
                                                reference=mix_v), cp_var],
            "second order": [report.exact_part("CP − MSE", "absolute mean error",
                                               err["CP", "mean"] - err["MSE", "mean"], -1, tolerance=se,
                                               reference=mix_v), cp_var],
            "moments": m}


def section23_claims() -> dict:
    """Judgements (:func:`mmlib.experiment.verdicts.judge` of :func:`section23_parts`) and evidence of the two claims
    about the Section 2.3 example: ``{"overestimates": (Judgement, evidence), "second order": (...)}``.  MSE's
    moments are the mixture's exactly (its part is *identical (to round-off)*), CP's variance is far off, so both
    claims are *contradicted* by the CP part."""
    p = section23_parts()
    m = p["moments"]
    mix_m, mix_v = m["mixture_mean"], m["mixture_var"]
    se = max(m["quadrature_error"], np.finfo(float).eps)
    numbers = (f"the interacted variable (the mixture sum u_i N(x_i, S_i^2)) by quadrature: mean {mix_m:.4f}, variance "
               f"{mix_v:.4f} (s.d. {math.sqrt(mix_v):.4f}; numerical error < {se:.1g}); MSE (Eqs. 11-12): mean "
               f"{m['mse_mean']:.4f}, variance {m['mse_sd'] ** 2:.4f}; CP (Eqs. 14-19): mean {m['cp_mean']:.4f}, "
               f"variance {m['cp_sd'] ** 2:.4f} (s.d. {m['cp_sd']:.4f}, the s.d. of the weighted sum of independent "
               "x_i, which the paper's MC sampled)")
    return {"overestimates": (report.judge(p["overestimates"]), numbers + "; analytic, no reading changes it"),
            "second order": (report.judge(p["second order"]),
                             numbers + "; the interaction function is linear, so the cubature rule is exact for "
                             "the weighted sum it evaluates, sum(mu^2 P), which is not the mixture the IMM "
                             "interaction produces (mmlib/core/mixing.py); analytic, no reading changes it")}


def section23_rows(seed: int, n_mc: int = 10_000) -> tuple[list, dict]:
    """Table 1 rows: MSE and CP in closed form (:func:`section23_moments`; exact rows,
    :func:`mmlib.experiment.verdicts.exact_row`: equal to the printed number to its printed precision or not), MC
    from ``n_mc`` samples of the weighted sum (the variable the paper's printed MC value describes; the verdict rule),
    on a stream of the root seed reserved for this example; also the samples of the mixture for comparison."""
    u, xs, sds = np.array(EXAMPLE_U), np.array(EXAMPLE_MEANS), np.array(EXAMPLE_SD)
    m = section23_moments()
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(10 ** 6, int(Stream.FILTER))))
    weighted_sum = (u * (xs + sds * rng.standard_normal((n_mc, 3)))).sum(axis=1)
    comp = rng.choice(3, size=n_mc, p=u)
    mixture = xs[comp] + sds[comp] * rng.standard_normal(n_mc)
    sd_ws = float(weighted_sum.std(ddof=1))
    rows = []
    for method, mean_v, sd_v, se_m, se_s in (
            ("MSE", m["mse_mean"], m["mse_sd"], None, None),
            ("MC", float(weighted_sum.mean()), sd_ws, sd_ws / math.sqrt(n_mc), sd_ws / math.sqrt(2 * n_mc)),
            ("CP", m["cp_mean"], m["cp_sd"], None, None)):
        note = {"MSE": "exact moments of the mixture",
                "MC": f"{n_mc:,} samples of the weighted sum (as the paper's value shows)",
                "CP": "exact moments of the weighted sum (closed form)"}[method]
        for quantity, printed, value, se in (("mean", TABLE1[method][0], mean_v, se_m),
                                             ("'covariance' (a standard deviation)", TABLE1[method][1], sd_v, se_s)):
            if se is None:        # analytic: judged by equality to the printed precision
                rows.append(report.exact_row("Table 1", method, quantity, printed, value, note=note))
            else:
                rows.append(report.make_row("Table 1", method, quantity, printed, value, se, n_runs=n_mc,
                                            n_runs_paper=n_mc, note=note))
    return rows, {"mixture_mean": float(mixture.mean()), "mixture_sd": float(mixture.std(ddof=1)), **m}


