"""What a measurement model computes from its immutable parameters is computed once (issue 25): the noise factor of
:class:`~mmlib.core.models.LinearMeasurement`, :class:`~mmlib.core.models.RangeBearing` and
:class:`~mmlib.core.gnss.Pseudoranges` (a Cholesky factor, asked for at every bootstrap step and by every protocol
check) is the one ``numpy.linalg.cholesky(R)`` gives, bit for bit, read-only and kept; a model of the library is
checked once per process and state dimension (``run`` over Tseng et al. 2011's 1800 per-step models checked them at
every chunk and, inside a layer, at every step), while another object -- a duck-typed model, a subclass -- is checked
every time, and a bad model is still refused with the argument's name."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mmlib.core import estimation, gnss, models

SATS = np.array([[2e7, 0.0, 1e7], [0.0, 2e7, 1e7], [-2e7, 0.0, 1e7], [0.0, -2e7, 1e7]])
R4 = np.diag([25.0, 16.0, 9.0, 4.0]) + 1.0


def measurement_models():
    return [models.LinearMeasurement(np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]]), np.array([[4.0, 1.0], [1.0, 9.0]])),
            models.RangeBearing(np.diag([100.0, 1e-4])),
            gnss.Pseudoranges(SATS, R4)]


@pytest.mark.parametrize("model", measurement_models(), ids=lambda m: type(m).__name__)
def test_the_noise_factor_is_the_cholesky_of_r_computed_once(model):
    L = model.noise_factor
    fresh = np.linalg.cholesky(model.R)
    assert L.dtype == fresh.dtype and L.shape == fresh.shape and L.tobytes() == fresh.tobytes()
    assert model.noise_factor is L
    with pytest.raises(ValueError, match="read-only"):
        L[0, 0] = 1.0
    other = dataclasses.replace(model, R=2 * model.R)                 # a new model: its own factor
    assert other.noise_factor.tobytes() == np.linalg.cholesky(2 * model.R).tobytes()


class CountingH:
    """Wraps a model; counts the calls of ``h`` (check_applies probes it)."""

    def __init__(self, base):
        self.base, self.calls = base, 0
        self.dim, self.R, self.angular = base.dim, base.R, base.angular
        self.noise_factor, self.jacobian, self.residual, self.average = (base.noise_factor, base.jacobian,
                                                                         base.residual, base.average)

    def h(self, x):
        self.calls += 1
        return self.base.h(x)


def test_a_library_model_is_checked_once_per_dimension_another_every_time(monkeypatch):
    model = gnss.Pseudoranges(SATS, R4)
    probes = []
    monkeypatch.setattr(estimation, "check_applies", lambda m, name, n: probes.append((m, n)))
    for _ in range(3):
        assert estimation._check_measurement_model(model, n=8) is model
    assert probes == [(model, 8)]
    estimation._check_measurement_model(model, n=5)                  # another dimension: its own check
    assert probes == [(model, 8), (model, 5)]
    duck = CountingH(model)
    for _ in range(3):
        estimation._check_measurement_model(duck, n=8)
    assert probes[2:] == [(duck, 8)] * 3


def test_a_bad_model_is_still_refused_each_time():
    wrong = models.LinearMeasurement(np.eye(2, 6), np.eye(2))       # a 6-state sensor
    for _ in range(2):
        with pytest.raises(ValueError, match="measurement_models"):
            estimation._check_measurement_model(wrong, "measurement_models", n=4)
    assert estimation._check_measurement_model(wrong, n=6) is wrong
    for _ in range(2):
        with pytest.raises(ValueError, match="measurement: expected a measurement model"):
            estimation._check_measurement_model("radar", n=4)
