import numpy as np
import pytest

from mmlib.core import models


def raises_naming(name: str):
    """``pytest.raises`` for the library's bad-input contract: a ValueError whose message starts with the
    argument the caller wrote, ``"<name>: ..."`` (``name`` is a regular expression)."""
    return pytest.raises(ValueError, match=rf"^{name}: ")


def textbook_kf(x0, P0, F, Q, H, R, zs):
    """Independent reference: the closed-form Kalman filter, one run at a time, explicit inverse."""
    x, P = np.array(x0, float), np.array(P0, float)
    means, covs, logliks = [], [], []
    for z in zs:
        x = F @ x
        P = F @ P @ F.T + Q
        S = H @ P @ H.T + R
        K = P @ H.T @ np.linalg.inv(S)
        nu = z - H @ x
        x = x + K @ nu
        P = (np.eye(len(x)) - K @ H) @ P
        logliks.append(-0.5 * (nu @ np.linalg.solve(S, nu) + np.log(np.linalg.det(2 * np.pi * S))))
        means.append(x)
        covs.append(P)
    return np.array(means), np.array(covs), np.array(logliks)


def random_mode_states(seed, B=4, r=3, n=4, scale=100.0):
    """Random mode means (B, r, n), SPD covariances (B, r, n, n) and mode probabilities (B, r)."""
    rng = np.random.default_rng(seed)
    means = rng.standard_normal((B, r, n)) * scale
    A = rng.standard_normal((B, r, n, n))
    covs = A @ np.swapaxes(A, -1, -2) + np.eye(n)
    return means, covs, rng.dirichlet(np.ones(r), size=B)


@pytest.fixture
def linear_problem():
    """CV target, position sensor, 3 runs x 25 steps of deterministic pseudo-random data."""
    rng = np.random.default_rng(12345)
    T = 1.0
    dyn = models.constant_velocity(T, 2.0)
    meas = models.position_measurement([25.0, 16.0])
    B, K = 3, 25
    x_true = np.tile([100.0, 10.0, -50.0, 5.0], (B, 1))
    zs = []
    for _ in range(K):
        x_true = x_true @ dyn.F.T + rng.standard_normal((B, 2)) @ dyn.noise_factor.T
        zs.append(x_true @ meas.H.T + rng.standard_normal((B, 2)) * [5.0, 4.0])
    zs = np.stack(zs, axis=1)
    x0 = np.tile([90.0, 8.0, -45.0, 4.0], (B, 1)) + rng.standard_normal((B, 4))
    P0 = np.diag([100.0, 25.0, 100.0, 25.0])
    return dyn, meas, x0, P0, zs



#: the files whose tests take longest (minutes: a site built and driven in a browser, a fresh venv, the runner's
#: notebooks in subprocesses, the schema mutations), by measured duration on the reference machine.  `make test` runs
#: the suite with ``-n 2 --dist loadfile --no-loadscope-reorder``: a file's tests stay in one process and files are
#: handed out in collection order, so these start first and the many short files fill in around them; left to
#: pytest-xdist's default order (most tests first) the one-test install file and the few-test site file started last
#: and ran alone at the end.  The order changes no test, only when it starts.
LONGEST_FIRST = ("test_site.py", "test_install.py", "test_runner.py", "test_results_contract.py",
                 "test_runner_parallel.py", "test_arena.py", "test_dask.py", "test_tseng2011.py", "test_fused.py",
                 "tolerance/test_pipeline.py", "test_experiment.py")


def _longest_first_rank(item) -> int:
    path = item.path.as_posix()
    return next((i for i, name in enumerate(LONGEST_FIRST) if path.endswith("/" + name)), len(LONGEST_FIRST))


def pytest_collection_modifyitems(config, items):
    items.sort(key=_longest_first_rank)            # stable: each file's own order is kept
