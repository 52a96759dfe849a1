"""The results cache of the grid runner (mmlib.experiment.grid): never stale, never fatal.

An edited job recomputes (its code is in the key, recursively through what it uses outside mmlib); another
machine fingerprint recomputes; a damaged entry (not UTF-8, an edited number) is recomputed with one warning
naming the file; a folder that cannot be written warns once and the study runs uncached without losing a
result; a paper name cannot leave the cache folder.
"""
from __future__ import annotations

import dataclasses
import importlib
import json
import sys
import textwrap

import pytest

import experiment_jobs as toy
from mmlib.experiment import UniverseResult, grid, machine, run_grid

READINGS = toy.SPACE.full()[:3]


def _run(job, tmp_path, **kw):
    opts = dict(paper="toy", algorithms=["alg"], n_runs=20, seed=3, cache_dir=tmp_path / "cache", progress=False,
                workers=1)
    opts.update(kw)
    return run_grid(job, READINGS, **opts)


def _entries(tmp_path, paper="toy"):
    return sorted((tmp_path / "cache" / paper).glob("*.json"))


def _script_module(tmp_path, monkeypatch, offset: float, name="user_script"):
    """A user's script module on disk (outside mmlib) defining a job that calls a helper and reads a constant."""
    (tmp_path / f"{name}.py").write_text(textwrap.dedent(f"""
        import dataclasses
        import experiment_jobs as toy
        OFFSET = {offset!r}

        def shift(values):
            return tuple(v if v.replicated is None else v._replace(replicated=v.replicated + OFFSET)
                         for v in values)

        def job(reading, n_runs, seed):
            res = toy.toy_universe(reading, n_runs, seed)
            return dataclasses.replace(res, values=shift(res.values))
    """))
    monkeypatch.syspath_prepend(str(tmp_path))
    sys.modules.pop(name, None)
    return importlib.import_module(name)


def test_a_script_job_edited_between_two_runs_recomputes(tmp_path, monkeypatch):
    first = _run(_script_module(tmp_path, monkeypatch, 0.0).job, tmp_path)
    second = _run(_script_module(tmp_path, monkeypatch, 0.5).job, tmp_path)      # the constant it reads changed
    assert [v.replicated for v in second[0].values] == [v.replicated + 0.5 for v in first[0].values]
    assert len(_entries(tmp_path)) == 2 * len(READINGS)


def test_lambdas_closures_and_helpers_are_keyed_by_their_code():
    def make(k):
        return lambda reading, n_runs, seed: toy.toy_universe(reading, n_runs + k, seed)
    assert grid.job_code(make(0)) == grid.job_code(make(0))          # same code, same closure: one key
    assert grid.job_code(make(0)) != grid.job_code(make(1))          # a closure value
    assert grid.job_code(lambda r, n, s: toy.toy_universe(r, n, s)) != \
        grid.job_code(lambda r, n, s: toy.toy_universe(r, n, s + 1))  # the code itself
    assert grid.job_code(toy.toy_universe) == grid.job_code(toy.toy_universe)


def test_a_notebook_job_keeps_its_key_across_kernels():
    """Functions defined in a notebook get a new file name per kernel: the key ignores it (else never a hit)."""
    src = "def job(reading, n_runs, seed):\n    return {'n': n_runs + {1, 2, 3}.__len__()}\n"
    keys = set()
    for filename in ("/tmp/ipykernel_1/111.py", "/tmp/ipykernel_2/222.py"):
        ns = {"__name__": "__main__"}
        exec(compile(src, filename, "exec"), ns)
        keys.add(grid.job_code(ns["job"]))
    assert len(keys) == 1


def test_an_mmlib_job_is_keyed_by_name_and_source():
    from mmlib.papers import REGISTRY
    universe = REGISTRY["zhu2016"].universe
    assert grid.job_code(universe) == grid.job_code(universe)
    base = dict(paper="toy", job=toy.toy_universe, reading=READINGS[0], algorithms=["alg"], n_runs=5, seed=1)
    assert grid.key_document(**base)["machine"] == machine.fingerprint_id()


def test_another_machine_fingerprint_is_not_served(tmp_path, monkeypatch):
    _run(toy.toy_universe, tmp_path)
    monkeypatch.setattr(grid, "fingerprint_id", lambda fp=None: "another-cpu")
    calls = []
    monkeypatch.setattr(grid, "_run_job", lambda *a: calls.append(a) or {"result": toy.toy_universe(*a[1:]),
                                                                         "machine": machine.fingerprint(),
                                                                         "cpu_s": 0.0})
    _run(toy.toy_universe, tmp_path)
    assert len(calls) == len(READINGS)


def test_a_result_from_another_machine_says_so(tmp_path, monkeypatch):
    other = {**machine.fingerprint(), "openblas_core": "Prescott"}
    monkeypatch.setattr(grid, "_run_job", lambda *a: {"result": toy.toy_universe(*a[1:]), "machine": other,
                                                           "cpu_s": 0.0})
    got = _run(toy.toy_universe, tmp_path)
    assert all(r.machine == other for r in got)
    monkeypatch.undo()
    again = _run(toy.toy_universe, tmp_path)                            # from the cache: still says so
    assert again == got and all(r.machine == other for r in again)     # (== leaves the machine out)
    assert [r.as_json() for r in again] == [r.as_json() for r in got]
    native = _run(toy.toy_universe, tmp_path, use_cache=False)
    assert all(r.machine is None and "machine" not in r.as_json() for r in native)


@pytest.mark.parametrize("damage", ["non-UTF-8 bytes", "an edited number", "NaN in the result"])
def test_a_damaged_entry_is_recomputed_with_one_warning_naming_it(tmp_path, damage):
    first = _run(toy.toy_universe, tmp_path)
    path = _entries(tmp_path)[0]
    if damage == "non-UTF-8 bytes":
        path.write_bytes(path.read_bytes()[:40] + b"\xff\xfe" + path.read_bytes()[40:])
    else:
        entry = json.loads(path.read_text())
        entry["result"]["values"][0]["replicated"] = 123.0 if damage == "an edited number" else float("nan")
        path.write_text(json.dumps(entry))
    with pytest.warns(grid.CacheWarning, match=rf"cache entry {path} ") as caught:
        again = _run(toy.toy_universe, tmp_path)
    assert len(caught) == 1 and again == first and all(type(r) is UniverseResult for r in again)
    assert json.loads(path.read_text())["sha256"] == grid.result_checksum(json.loads(path.read_text())["result"])


def test_a_cache_folder_that_cannot_be_created_warns_once_and_loses_nothing(tmp_path):
    (tmp_path / "blocker").write_text("a file where the cache folder should be")
    with pytest.warns(grid.CacheWarning, match="cannot be written") as caught:
        got = _run(toy.toy_universe, tmp_path, cache_dir=tmp_path / "blocker" / "cache")
    assert len(caught) == 1 and all(r is not None for r in got)
    assert got == _run(toy.toy_universe, tmp_path, use_cache=False)


def test_a_read_only_cache_folder_warns_once_and_loses_nothing(tmp_path, monkeypatch):
    """A read-only folder (as a user who is not root sees it: the write raises PermissionError)."""
    def refuse(path, doc):
        raise PermissionError(13, "Permission denied", str(path))
    monkeypatch.setattr(grid, "_write_json_atomic", refuse)
    with pytest.warns(grid.CacheWarning, match="Permission denied") as caught:
        got = _run(toy.toy_universe, tmp_path)
    assert len(caught) == 1 and len(got) == len(READINGS) and all(r is not None for r in got)


@pytest.mark.parametrize("paper", ["../../x", "a/b", "", ".hidden", "..", 3, None])
def test_the_paper_name_cannot_leave_the_cache_folder(tmp_path, paper):
    with pytest.raises(ValueError, match="^paper: "):
        _run(toy.toy_universe, tmp_path, paper=paper)
    assert not (tmp_path / "x").exists() and not list(tmp_path.rglob("*.json"))


@pytest.mark.parametrize("kw, name", [
    (dict(algorithms="IMM"), "algorithms"), (dict(algorithms=[1, 2]), "algorithms"),
    (dict(use_cache="no"), "use_cache"), (dict(progress="yes"), "progress"), (dict(cache_dir=3), "cache_dir"),
    (dict(n_runs=2.5), "n_runs"), (dict(seed=-1), "seed"), (dict(algorithms=["a", "a"]), "algorithms"),
    (dict(label=3), "label"), (dict(unit=None), "unit"), (dict(result_keys=()), "result_keys")])
def test_run_grid_bad_input(tmp_path, kw, name):
    with pytest.raises(ValueError, match=f"^{name}: "):
        _run(toy.toy_universe, tmp_path, **kw)


def test_readings_bad_input_and_numpy_scalars(tmp_path):
    import numpy as np
    with pytest.raises(ValueError, match=r"^readings: "):
        run_grid(toy.toy_universe, "A", paper="toy", algorithms=[], n_runs=2, seed=1, progress=False, workers=1,
                 cache_dir=tmp_path)
    with pytest.raises(ValueError, match=r"^readings\[0\]\['A'\]: "):
        run_grid(toy.toy_universe, [{"A": object()}], paper="toy", algorithms=[], n_runs=2, seed=1, progress=False,
                 workers=1, cache_dir=tmp_path)
    seen = []
    plain = run_grid(lambda r, n, s: seen.append(r) or toy.toy_universe(toy.SPACE.headline, n, s),
                     [{"x": np.int64(3), "y": np.float64(0.5)}], paper="toy", algorithms=[], n_runs=2, seed=1,
                     progress=False, workers=1, cache_dir=tmp_path)
    assert plain[0].n_runs == 2 and seen == [{"x": 3, "y": 0.5}] and type(seen[0]["x"]) is int


def test_a_result_that_is_not_json_names_the_job_and_reading(tmp_path):
    def nan_job(reading, n_runs, seed):
        res = toy.toy_universe(reading, n_runs, seed)           # the constructor, unlike build, lets NaN through
        return dataclasses.replace(res, values=(res.values[0]._replace(replicated=float("nan")), *res.values[1:]))
    with pytest.raises(ValueError, match=r"^job: .*nan_job returned a result that is not plain JSON for reading"):
        _run(nan_job, tmp_path)


@pytest.mark.parametrize("kw, name", [(dict(algorithms="IMM"), "algorithms"), (dict(n_runs=1.7), "n_runs"),
                                      (dict(seed=-5), "seed"), (dict(paper="../x"), "paper")])
def test_cache_key_bad_input(kw, name):
    base = dict(paper="toy", job=toy.toy_universe, reading=READINGS[0], algorithms=["alg"], n_runs=5, seed=1)
    with pytest.raises(ValueError, match=f"^{name}: "):
        grid.key_document(**{**base, **kw})


def _write_module(tmp_path, monkeypatch, name, text):
    (tmp_path / f"{name}.py").write_text(textwrap.dedent(text))
    monkeypatch.syspath_prepend(str(tmp_path))
    sys.modules.pop(name, None)
    return importlib.import_module(name)


def test_edits_reached_through_a_module_a_base_class_or_an_mmlib_object_change_the_key(tmp_path, monkeypatch):
    from mmlib.core.fuzzy import Trapezoid
    keys = []
    for version in (1, 2):
        helpers = _write_module(tmp_path, monkeypatch, "jc_helpers", f"def f():\n    return {version}\n")
        assert helpers.f() == version
        def job(reading, n_runs, seed, helpers=helpers):
            return helpers.f()
        keys.append(grid.job_code(job))
    assert keys[0] != keys[1]                                  # a user's module edited
    keys = []
    for version in (1, 2):
        mod = _write_module(tmp_path, monkeypatch, "jc_classes", f"""
            class Base:
                def value(self):
                    return {version}

            class Child(Base):
                pass

            def job(reading, n_runs, seed):
                return Child().value()
        """)
        keys.append(grid.job_code(mod.job))
    assert keys[0] != keys[1]                                  # a method of a base class edited
    a, b = Trapezoid("m", 0, 1, 2, 3), Trapezoid("m", 0, 1, 2, 30)
    assert grid.job_code(lambda r, n, s: a(r)) != grid.job_code(lambda r, n, s: b(r))   # an mmlib object's values


def test_job_code_is_the_same_in_every_process(tmp_path):
    """Objects, dataclasses and sets of strings are hashed canonically: the key does not move with the process
    (hash randomisation, addresses), so identical runs hit the cache."""
    (tmp_path / "jc_det.py").write_text(textwrap.dedent("""
        import dataclasses, types
        @dataclasses.dataclass
        class Settings:
            names: frozenset
            scale: float
        SETTINGS = Settings(frozenset({"alpha", "beta", "gamma", "delta"}), 2.0)
        NS = types.SimpleNamespace(tags={"x", "y", "z", "w"}, obj=object)
        def job(reading, n_runs, seed):
            return (SETTINGS, NS, {"u", "v"})
    """))
    code = ("import sys; sys.path.insert(0, %r); import jc_det; from mmlib.experiment import grid; "
            "print(grid.job_code(jc_det.job))" % str(tmp_path))
    import os
    import subprocess
    outs = {subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                           env={**os.environ, "PYTHONHASHSEED": str(seed)}).stdout.strip() for seed in (1, 2, 3)}
    assert len(outs) == 1, outs


def test_a_lazily_filled_private_memo_does_not_change_the_key():
    space = toy.SPACE
    before = grid.job_code(lambda r, n, s: space.headline)
    space.design("star")
    assert grid.job_code(lambda r, n, s: space.headline) == before


def test_shared_structure_is_hashed_once():
    import time
    x = [1.0]
    for _ in range(40):
        x = [x, x]                                           # 2**40 paths, 41 distinct lists
    t0 = time.perf_counter()
    grid.job_code(lambda r, n, s: x)
    assert time.perf_counter() - t0 < 5.0
