"""Machine fingerprints and the digest comparison rule (mmlib.experiment.machine, mmlib.experiment.digests).

The rule: bit for bit on equal fingerprints, to ``RTOL_MACHINE * S`` per run (same divergences) across
machines.  These tests show that it accepts a round-off difference, rejects a difference beyond it, and
rejects a real swap of the random streams even when the round-off rule applies.
"""
from __future__ import annotations

import copy
import importlib.util
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mmlib.experiment import digests, machine
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.papers import REGISTRY

N = 6
REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def native():
    return REGISTRY["hu2017"].headline_digest(N)


def elsewhere(d: dict, **fields) -> dict:
    """The same digest as if it had been computed on another machine (an older OpenBLAS core by default)."""
    out = copy.deepcopy(d)
    out["machine"].update(fields or {"openblas_core": "SomeOtherCore"})
    return out


def test_same_machine_is_bit_for_bit(native):
    res = digests.compare_digests(native, copy.deepcopy(native))
    assert res.rule == "bit for bit" and res.ok and not res.machine_differences
    changed = copy.deepcopy(native)
    changed["sha256"] = "0" * 64                      # any change of a per-run number on the same machine
    res = digests.compare_digests(changed, native)
    assert not res.ok and "sha256" in res.problems[0] and "DIFFER" in res.message()


def test_other_machine_accepts_round_off_and_rejects_more(native):
    committed = elsewhere(native)
    res = digests.compare_digests(native, committed)
    assert res.rule == "round-off across machines" and res.ok and res.largest == 0.0
    assert len(res.machine_differences) == 1 and res.machine_differences[0].startswith("openblas_core: ")
    alg = native["algorithms"][0]
    scale = native["runs"][alg]["scale"]
    for factor, ok in ((0.5, True), (2.0, False)):
        ours = copy.deepcopy(native)
        ours["sha256"] = "f" * 64                     # the bits differ, as they do across CPUs
        ours["runs"][alg]["rmse"][3] += factor * digests.RTOL_MACHINE * scale
        res = digests.compare_digests(ours, committed)
        assert res.ok is ok, res.message()
        assert res.largest == pytest.approx(factor, rel=1e-3)
        if not ok:
            assert f"{alg}: run 3 RMSE" in res.problems[0]
            assert "openblas_core" in res.message()


def test_other_machine_requires_the_same_divergences(native):
    ours = copy.deepcopy(native)
    alg = native["algorithms"][1]
    ours["runs"][alg]["diverged_step"][2] = 17
    res = digests.compare_digests(ours, elsewhere(native))
    assert not res.ok and f"{alg}: diverged_step differs in runs [2]" in res.problems[0]


def test_other_kernel_uses_the_kernel_bound(native):
    ours = copy.deepcopy(native)
    ours["kernel"] = ours["machine"]["kernel"] = "numpy" if native["kernel"] == "numba" else "numba"
    alg = native["algorithms"][0]
    ours["runs"][alg]["rmse"][0] += 0.5 * digests.RTOL_KERNEL * native["runs"][alg]["scale"]
    res = digests.compare_digests(ours, native)
    assert res.rule == "round-off across kernels" and res.ok, res.message()


def test_run_count_and_names_must_match_everywhere(native):
    ours = {**copy.deepcopy(native), "version": "x"}
    assert not digests.compare_digests(ours, elsewhere(native)).ok
    fewer = copy.deepcopy(native)
    fewer["algorithms"] = native["algorithms"][:-1]
    del fewer["runs"][native["algorithms"][-1]]
    assert not digests.compare_digests(fewer, elsewhere(native)).ok


@pytest.mark.parametrize("damage", ["an algorithm missing from runs", "a short rmse list", "no kernel", "scale None",
                                    "machine None"])
def test_an_incomplete_digest_is_refused_by_name(native, damage):
    bad = elsewhere(native)
    alg = native["algorithms"][0]
    if damage == "an algorithm missing from runs":
        del bad["runs"][alg]
    elif damage == "a short rmse list":
        bad["runs"][alg]["rmse"] = bad["runs"][alg]["rmse"][:-1]
    elif damage == "no kernel":
        del bad["kernel"]
    elif damage == "scale None":
        bad["runs"][alg]["scale"] = None
    else:
        bad["machine"] = None
    with pytest.raises(ValueError, match="^committed: "):
        digests.compare_digests(native, bad)


def test_nan_rmse_and_edited_per_run_numbers_fail(native):
    alg = native["algorithms"][0]
    ours, committed = copy.deepcopy(native), elsewhere(native)
    ours["runs"][alg]["rmse"][0] = committed["runs"][alg]["rmse"][0] = float("inf")
    ours["runs"][alg]["rmse"][1] = float("nan")
    assert not digests.compare_digests(ours, committed).ok
    edited = copy.deepcopy(native)                      # same machine, same SHA-256, an edited per-run number
    edited["runs"][alg]["rmse"][2] *= 2
    res = digests.compare_digests(native, edited)
    assert res.rule == "bit for bit" and not res.ok and "edited" in res.problems[0]


def test_committed_digest_without_fingerprint_compares_bit_for_bit(native):
    old = {k: v for k, v in native.items() if k not in ("machine", "runs")}
    res = digests.compare_digests(native, old)
    assert res.rule == "bit for bit" and res.ok and "no machine fingerprint" in res.message()


@pytest.mark.parametrize("swap", ["runs 0 and 1", "measurement and initial streams"])
def test_a_swap_of_the_random_streams_fails_on_any_machine(native, monkeypatch, swap):
    """A real swap of the random-stream keys (every draw goes through MonteCarlo.generator) changes some run's
    RMSE far beyond the round-off bound: rejected under the cross-machine rule too."""
    original = MonteCarlo.generator

    def swapped(self, run, stream):
        if swap == "runs 0 and 1":
            run = {0: 1, 1: 0}.get(int(run), run)
        else:
            swap_streams = {Stream.MEASUREMENT: Stream.INITIAL, Stream.INITIAL: Stream.MEASUREMENT}
            stream = swap_streams.get(Stream(stream), stream)
        return original(self, run, stream)

    monkeypatch.setattr(MonteCarlo, "generator", swapped)
    ours = REGISTRY["hu2017"].headline_digest(N)
    res = digests.compare_digests(ours, elsewhere(native))
    assert not res.ok and res.largest > 1e3, res.message()


def test_digest_records_per_run_numbers(native):
    assert native["machine"] == machine.fingerprint()
    for alg in native["algorithms"]:
        runs = native["runs"][alg]
        assert len(runs["rmse"]) == len(runs["diverged_step"]) == len(runs["divergence_cause"]) == N
        assert all(r is None or (np.isfinite(r) and r >= 0) for r in runs["rmse"])
    json.dumps(native, allow_nan=False)                # JSON-ready


def _fingerprint_under(env: dict) -> dict:
    code = "import json; from mmlib.experiment import machine; print(json.dumps(machine.fingerprint()))"
    out = subprocess.run([sys.executable, "-c", code], env={**os.environ, **env}, capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="the emulation variables are x86-64's")
def test_fingerprint_sees_the_emulated_cpu():
    """OPENBLAS_CORETYPE and NPY_DISABLE_CPU_FEATURES change the code the libraries run, so they must change
    the fingerprint (else a cache filled on one CPU would be served on another)."""
    spec = importlib.util.spec_from_file_location("emulated_tests", REPO / "tools" / "emulated_tests.py")
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    EMULATIONS = tool.EMULATIONS
    seen = {}
    for name, env in EMULATIONS.items():
        fp = _fingerprint_under(env)
        seen[name] = machine.fingerprint_id(fp)
        assert (fp["openblas_core"] or "").lower() == env["OPENBLAS_CORETYPE"].lower(), (name, fp)
        assert not {"X86_V4", "AVX512_ICL", "AVX512_SPR"} & set(fp["numpy_simd"]), (name, fp)
    assert "X86_V3" not in _fingerprint_under(EMULATIONS["sse4.2"])["numpy_simd"]
    assert len(set(seen.values())) == len(seen), seen           # the two emulated machines differ


def test_fingerprint_differences_are_named():
    a = machine.fingerprint()
    b = {**a, "numpy_simd": ["X86_V2"]}
    assert machine.differences(a, a) == []
    assert machine.differences(a, b) == [f"numpy_simd: {a['numpy_simd']!r} vs ['X86_V2']"]
    assert machine.fingerprint_id(a) != machine.fingerprint_id(b)


def test_same_numbers_bit_for_bit_on_this_machine_and_round_off_from_another():
    local = {"values": [{"replicated": 12.5, "stderr": 0.25, "verdict": "reproduced"}], "n_runs": 20,
             "effects": [{"value": 1e-13}]}
    assert digests.same_numbers(dict(local), local)
    nudged = copy.deepcopy(local)
    nudged["values"][0]["replicated"] += 12.5 * 1e-12                    # round-off
    assert not digests.same_numbers(nudged, local)                      # this machine: bits must be equal
    assert digests.same_numbers({**nudged, "machine": {"openblas_core": "Haswell"}}, local)
    moved = copy.deepcopy(local)
    moved["values"][0]["replicated"] += 12.5 * 1e-4                       # beyond round-off
    assert not digests.same_numbers({**moved, "machine": {"openblas_core": "Haswell"}}, local)
    flipped = copy.deepcopy(local)
    flipped["values"][0]["verdict"] = "not reproduced"
    assert not digests.same_numbers({**flipped, "machine": {}}, local)
    with pytest.raises(ValueError, match="^universe: "):
        digests.same_numbers([], local)
    with pytest.raises(ValueError, match="^local: "):
        digests.same_numbers(local, None)


def test_the_machine_tolerance_sits_above_the_measured_cross_cpu_differences():
    """RTOL_MACHINE is an empirical margin: the committed measurement (make bench: data/bench/cross_cpu.json) must
    show every paper's headline diverging identically on every emulated CPU, with per-run RMSE differences at least
    100 times below the tolerance, measured against the tolerance now in force."""
    report = json.loads((REPO / "data" / "bench" / "cross_cpu.json").read_text())
    assert report["rtol_machine"] == digests.RTOL_MACHINE
    assert set(report["machines"]) >= {"avx2", "sse4.2"}
    for name, m in report["machines"].items():
        assert set(m["papers"]) == set(REGISTRY), name
        for paper, moved in m["papers"].items():
            assert moved["divergences_equal"], (name, paper)
            assert moved["max_over_scale"] <= digests.RTOL_MACHINE / 100, (name, paper, moved)
