"""A small reading space and module-level jobs for the experiment-layer tests (importable by the
spawned worker processes of the grid runner, hence a module of its own)."""
import dataclasses
import time

import numpy as np

from mmlib.experiment import metrics
from mmlib.experiment import Factor, Option, PublishedNumber, ReadingSpace, UniverseResult
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.experiment.report import Claims, judge, part

SPACE = ReadingSpace("toy", (
    Factor("A", "bias", (Option("zero", "no bias", "Sec. 1", {"bias": 0.0}),
                         Option("one", "bias of one", "Eq. 2", {"bias": 1.0})), "zero", "Sec. 1"),
    Factor("B", "scale", (Option("s1", "scale 1", "Sec. 2", {"scale": 1.0}),
                          Option("s2", "scale 2", "Eq. 3", {"scale": 2.0}),
                          Option("s3", "scale 3", "Fig. 1", {"scale": 3.0})), "s1", "Sec. 2"),
    Factor("C", "offset of an unused quantity", (Option("c1", "c = 1", "Sec. 3", {"c": 1}),
                                                 Option("c2", "c = 2", "Sec. 4", {"c": 2})), "c1", "Sec. 3",
           influential=False),
), budget=6)

PUBLISHED = (PublishedNumber("Table 1", "T1", "alg", "mean", "1.0"),
             PublishedNumber("Table 1", "T1", "alg", "sd", "2.0"),
             PublishedNumber("Table 2", "T2", "alg", "never computed", "5"))


def toy_universe(reading, n_runs, seed):
    """mean and s.d. of bias + scale * N(0, 1) from the TRUTH stream; claim "the mean is positive"."""
    ch = SPACE.changes(reading)
    mc = MonteCarlo(seed, n_runs)
    x = ch["bias"] + ch["scale"] * mc.standard_normal(range(n_runs), Stream.TRUTH, ())
    m = metrics.mean_with_se(x)
    claims = Claims()
    claims.add("the mean is positive", judge([part("mean − 0", "value", float(m.value), float(m.stderr), +1)]),
               key="mean_positive")
    sd = float(np.std(x, ddof=1))
    return UniverseResult.build(values=[("T1", "alg", "mean", m.value, m.stderr),
                                        ("T1", "alg", "sd", sd, sd / np.sqrt(2 * n_runs))],
                                claims=claims, effects=[("mean", m.value, m.stderr, 1.0)],
                                diverged={"alg": int(ch["c"] == 2)}, n_runs=n_runs)


#: CPU seconds each :func:`spinning_universe` spends on its own thread
SPIN = 0.02


def spinning_universe(reading, n_runs, seed):
    """:func:`toy_universe` after spinning for :data:`SPIN` CPU-seconds of its thread (a job of known CPU time)."""
    start = time.thread_time()
    while time.thread_time() - start < SPIN:
        pass
    return toy_universe(reading, n_runs, seed)


def not_a_dict(reading, n_runs, seed):
    """Returns neither a UniverseResult nor a dict: refused by run_grid."""
    return [1, 2, 3]


def a_dict(reading, n_runs, seed):
    """The toy universe in its JSON form (what jobs returned before UniverseResult): refused by run_grid unless
    it is called with ``result_type=None``."""
    return toy_universe(reading, n_runs, seed).as_json()


#: the toy space with a metric-only factor M: it changes only how the reported s.d. is computed
METRIC_SPACE = ReadingSpace("toy-metric", SPACE.factors + (
    Factor("M", "which s.d. estimator", (Option("unbiased", "ddof = 1", "Table 1", {"ddof": 1}),
                                         Option("ml", "ddof = 0", "Eq. 9", {"ddof": 0})), "unbiased", "Table 1",
           metric_only=True),))


def metric_universe(reading, n_runs, seed):
    ch = METRIC_SPACE.changes(reading)
    base = toy_universe({k: v for k, v in reading.items() if k != "M"}, n_runs, seed)
    mc = MonteCarlo(seed, n_runs)
    x = ch["bias"] + ch["scale"] * mc.standard_normal(range(n_runs), Stream.TRUTH, ())
    sd = base.values[1]._replace(replicated=float(np.std(x, ddof=ch["ddof"])))
    return dataclasses.replace(base, values=(base.values[0], sd, *base.values[2:]))


#: a space of 3 x 3 x 2 x 4 = 72 universes for the share estimator (tests/test_shares.py); budget 20: sampled
SHARE_SPACE = ReadingSpace("toy-shares", tuple(
    Factor(f"S{i}", f"factor {i}", tuple(Option(f"o{j}", f"option {j}", "Sec. 1", {f"s{i}": j}) for j in range(n)),
           "o0", "Sec. 1") for i, n in enumerate((3, 3, 2, 4))), budget=20)

SHARE_PUBLISHED = (PublishedNumber("Table S", "S", "alg", "x", "3.0"),)


def share_verdict(reading) -> str:
    """The claim's verdict as a known function of the reading: "holds" when s0 + s1 + s3 >= 3, else "contradicted"
    when s2 = 1, else "not supported" (so each verdict's share of the 72 universes is known exactly)."""
    ch = SHARE_SPACE.changes(reading)
    if ch["s0"] + ch["s1"] + ch["s3"] >= 3:
        return "holds"
    return "contradicted" if ch["s2"] == 1 else "not supported"


def share_universe(reading, n_runs, seed):
    """A universe without simulation: the claim of :func:`share_verdict` and a value x = 1 + s0 + s1/2 +- 0.05
    (no randomness; ``n_runs`` and ``seed`` unused)."""
    ch = SHARE_SPACE.changes(reading)
    return UniverseResult.build(values=[("S", "alg", "x", 1.0 + ch["s0"] + ch["s1"] / 2, 0.05)],
                                claims=[{"claim": "the claim", "verdict": share_verdict(reading)}],
                                diverged={}, n_runs=n_runs)
