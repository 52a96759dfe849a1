"""The arena's per-process memo of simulated batches (:func:`mmlib.arena.study.simulated`, issue 25): every algorithm
of a scenario is evaluated on the same runs, simulated once per process.  A remembered batch is the one a fresh
simulation gives, bit for bit (same values, dtype and shape); another key (runs, root seed, run count, scenario) is
another batch; the memo is bounded in batches and bytes; what it hands out is read-only and a caller's list is its
own."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mmlib.arena import study
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment.simulate import BatchMemo


@pytest.fixture(autouse=True)
def empty_memo():
    study._SIMULATIONS.clear()
    yield
    study._SIMULATIONS.clear()


def counting(s):
    """A copy of scenario ``s`` whose simulator counts the batches it simulates (``calls``)."""
    calls = []

    def simulator(mc):
        fresh = s.simulator(mc)

        def simulate_runs(runs):
            calls.append(list(runs))
            return fresh(runs)
        return simulate_runs
    return dataclasses.replace(s, simulator=simulator), calls


def assert_same_batch(a, b):
    assert type(a) is type(b) and len(a) == len(b)
    for x, y in zip(a, b):
        if isinstance(x, (list, tuple)):
            assert_same_batch(x, y)
        else:
            assert isinstance(x, np.ndarray) and x.dtype == y.dtype and x.shape == y.shape
            assert np.array_equal(x, y, equal_nan=True)
            assert x.tobytes() == y.tobytes()


@pytest.mark.parametrize("name", ["ladder-nl3", "tseng2011"])     # measurements (B, K, m); a list of K (B, m_k)
def test_a_remembered_batch_is_a_fresh_simulation_bit_for_bit(name):
    s = study.scenario(name)
    mc = MonteCarlo(s.root_seed, 6)
    memo = study.simulated(s, mc)
    first, second = memo(range(1, 4)), memo([1, 2, 3])
    fresh = s.simulator(mc)(range(1, 4))
    assert_same_batch(first, fresh)
    assert_same_batch(second, fresh)
    assert second[0] is first[0]                       # the same arrays: remembered, not simulated again


def test_the_memo_simulates_each_key_once_and_tells_keys_apart():
    s, calls = counting(study.scenario("ladder-linear"))
    mc = MonteCarlo(s.root_seed, 6)
    a = study.simulated(s, mc)(range(3))
    study.simulated(s, mc)(np.arange(3))               # another cell of the scenario: the same batch
    assert calls == [[0, 1, 2]]
    b = study.simulated(s, mc)(range(1, 4))            # other runs
    c = study.simulated(s, MonteCarlo(s.root_seed + 1, 6))(range(3))     # another root seed
    d = study.simulated(s, MonteCarlo(s.root_seed, 7))(range(3))         # another run count: its own key
    other, other_calls = counting(study.scenario("ladder-linear"))         # another scenario object
    e = study.simulated(other, mc)(range(3))
    assert len(calls) == 4 and len(other_calls) == 1
    assert not np.array_equal(a[0], b[0]) and not np.array_equal(a[1], c[1])
    assert_same_batch(a, d)
    assert_same_batch(a, e)


def test_the_memo_is_bounded(monkeypatch):
    s, calls = counting(study.scenario("ladder-linear"))
    mc = MonteCarlo(s.root_seed, 20)
    memo = study.simulated(s, mc)
    for r in range(study.SIMULATION_MEMO + 3):
        memo([r])
        assert len(study._SIMULATIONS) <= study.SIMULATION_MEMO
    memo([study.SIMULATION_MEMO + 2])                  # the most recent: remembered
    memo([0])                                          # the oldest: forgotten, simulated again
    assert calls.count([study.SIMULATION_MEMO + 2]) == 1 and calls.count([0]) == 2
    study._SIMULATIONS.clear()
    size = sum(x.nbytes for x in memo(range(2)) if isinstance(x, np.ndarray))
    study._SIMULATIONS.clear()
    monkeypatch.setattr(study, "_SIMULATIONS", BatchMemo(study.SIMULATION_MEMO, size + size // 2))
    memo = study.simulated(s, mc)                      # (a simulator wraps the memo of its making)
    memo(range(2))
    memo(range(2, 4))                                  # the two together exceed the bytes: the older is dropped
    assert [k[2] for k in study._SIMULATIONS] == [(2, 3)]
    monkeypatch.setattr(study, "_SIMULATIONS", BatchMemo(study.SIMULATION_MEMO, size - 1))
    memo = study.simulated(s, mc)
    memo(range(2))                                     # larger than the bytes: not kept
    assert not study._SIMULATIONS


def test_what_the_memo_hands_out_is_read_only_and_a_callers_list_its_own():
    s = study.scenario("tseng2011")
    memo = study.simulated(s, MonteCarlo(s.root_seed, 4))
    truth, z, start = memo(range(2))
    for x in (truth, z[0], z[-1], start):
        with pytest.raises(ValueError, match="read-only"):
            x[...] = 0.0
    z.append("mine")
    _, z_again, _ = memo(range(2))
    assert len(z_again) == s.n_steps and z_again[0] is z[0]


def test_runs_it_cannot_key_go_to_the_simulator_unremembered():
    s, calls = counting(study.scenario("ladder-linear"))
    memo = study.simulated(s, MonteCarlo(s.root_seed, 6))
    with pytest.raises(ValueError, match="runs"):
        memo([0.0, 1.0])                               # not run indices: the simulator's own error, nothing kept
    with pytest.raises(ValueError, match="runs"):
        memo([0, 9])                                   # out of range: the same
    assert len(calls) == 2 and not study._SIMULATIONS
    with pytest.raises(ValueError, match="mc"):
        study.simulated(s, 6)


def test_batch_memo_names_bad_arguments_keeps_owners_apart_and_rebuilds_named_tuples():
    """The memo itself (mmlib.experiment.simulate.BatchMemo): a ValueError naming each bad argument; an entry held
    for one owner is no hit for another object under the same key, and that owner's batch replaces it; a NamedTuple
    batch comes back as its own type, read-only."""
    from typing import NamedTuple

    for args, name in (((0, 10), "max_batches"), ((2, -1), "max_bytes"), ((True, 10), "max_batches")):
        with pytest.raises(ValueError, match=f"^{name}: "):
            BatchMemo(*args)
    memo = BatchMemo(2, 10**6)
    with pytest.raises(ValueError, match="^simulate_runs: "):
        memo.wrap(3, "k")
    with pytest.raises(ValueError, match="^key: "):
        memo.wrap(lambda runs: np.zeros(1), ["unhashable"])
    calls = []

    class Batch(NamedTuple):
        truth: np.ndarray
        z: list

    def simulate(runs):
        calls.append(list(runs))
        return Batch(np.arange(3.0), [np.ones(2)])

    a, b = object(), object()
    first = memo.wrap(simulate, "k", owner=a)(range(2))
    assert isinstance(first, Batch) and not first.truth.flags.writeable
    assert memo.wrap(simulate, "k", owner=a)(range(2)).truth is first.truth and len(calls) == 1
    other = memo.wrap(simulate, "k", owner=b)(range(2))          # same key, another owner: simulated again
    assert other.truth is not first.truth and len(calls) == 2 and len(memo) == 1
    assert memo.wrap(simulate, "k", owner=b)(range(2)).truth is other.truth and len(calls) == 2
    memo.clear()
    assert len(memo) == 0 and list(memo) == []
    # another owner's batch takes the stale entry's place as the most recent: k3 then evicts k2, not it
    memo.wrap(simulate, "k", owner=a)(range(2))
    memo.wrap(simulate, "k2", owner=a)(range(2))
    memo.wrap(simulate, "k", owner=b)(range(2))
    memo.wrap(simulate, "k3", owner=a)(range(2))
    assert [k[0] for k in memo] == ["k", "k3"]
