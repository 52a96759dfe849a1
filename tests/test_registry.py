"""The paper registry and the contract (mmlib.experiment.paper): every registered paper fulfils it, the registry is the
one list of papers in the repository, and a new paper joins through it alone (the worked example of
docs/new-paper.md, docs/examples/minimal_paper.py, is registered, run, written and rendered without touching the
arena, the runner or these tests)."""
from __future__ import annotations

import ast
import dataclasses
import importlib.util
import pkgutil
import sys
from pathlib import Path

import pytest

from mmlib.experiment import digests
from mmlib.experiment.paper import Paper
from mmlib.experiment.scenario import Scenario
from mmlib.experiment.universe import UniverseResult
from mmlib.papers import PACKAGES, REGISTRY

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name", PACKAGES)
def test_registered_paper_fulfils_the_contract(name):
    paper = REGISTRY[name]
    assert isinstance(paper, Paper) and paper.name == name == paper.space.paper
    assert (REPO / "notebooks" / f"{paper.notebook}.py").is_file()
    setup = paper.headline_setup()
    assert isinstance(setup, paper.setup_type)
    s = paper.scenario(setup)
    assert isinstance(s, Scenario) and s.name == name and s.root_seed == paper.root_seed
    assert paper.runs("smoke") <= paper.runs("full")
    with pytest.raises(ValueError, match="E-99"):                       # a reading outside the space is refused
        paper.setup({**paper.headline, "E-99": "x"})
    with pytest.raises(dataclasses.FrozenInstanceError):
        paper.root_seed = 1
    # what the committed results hold is what the contract declares
    from mmlib.experiment.results import read_results
    doc = read_results(REPO / "data" / "results" / f"{name}.json")
    assert doc["paper"] == name and doc["provenance"]["root_seed"] == paper.root_seed
    assert doc["provenance"]["n_runs"] == paper.runs("full")
    head = UniverseResult.from_json(doc["multiverse"]["universes"][0])
    head.effect(paper.key_effect)                                       # ValueError if the key effect is missing
    assert {v.key for v in head.values} >= {p.key for p in paper.published}
    # every estimator's diverged runs are counted (a paper with several cases keys them "<case> <algorithm>")
    assert all(any(k == a or k.endswith(" " + a) for a in paper.algorithms) for k in head.diverged)
    assert all(any(k == a or k.endswith(" " + a) for k in head.diverged) for a in paper.algorithms)
    assert {d["id"] for d in doc["deviations"]} == {d.id for d in paper.deviations}


def test_every_paper_package_is_registered():
    import mmlib.papers as papers
    found = sorted(i.name for i in pkgutil.iter_modules(papers.__path__) if i.ispkg)
    assert found == sorted(PACKAGES), "a paper package outside mmlib.papers.PACKAGES, or a name without a package"
    assert list(REGISTRY) == list(PACKAGES) and len(REGISTRY) == len(PACKAGES)
    with pytest.raises(KeyError, match="not a registered paper"):
        REGISTRY["nosuchpaper"]


def _literal_paper_lists(path: Path, root: Path = REPO) -> list[str]:
    """Tuple, list, set and dict literals naming two or more registered papers (``path:line: names``, relative to
    ``root``)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set(PACKAGES)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Dict):
            elts = [*node.keys, *node.values]
        elif isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            elts = node.elts
        elif isinstance(node, ast.BoolOp):                      # name == "a" or name == "b"
            elts = [c for v in node.values if isinstance(v, ast.Compare) for c in (v.left, *v.comparators)]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):      # "a b".split()
            elts = [ast.Constant(w) for w in node.value.replace(",", " ").split()]
        else:
            continue
        hit = {e.value for e in elts if isinstance(e, ast.Constant) and e.value in names}
        if len(hit) >= 2:
            out.append(f"{path.relative_to(root)}:{node.lineno}: {sorted(hit)}")
    return out


def test_no_hard_coded_paper_list_outside_the_registry():
    """The registry (mmlib/papers/__init__.py) is the one list of papers: a literal naming two or more papers anywhere
    else in the code, the tools, the notebooks or the tests means a sixth paper would have to be added there too."""
    files = [p for folder in ("mmlib", "tools", "tests", "notebooks", "bench", "docs")
             for p in (REPO / folder).rglob("*.py")]
    offenders = [hit for p in files if p != REPO / "mmlib" / "papers" / "__init__.py"
                 for hit in _literal_paper_lists(p)]
    assert not offenders, "hard-coded lists of papers:\n" + "\n".join(offenders)


def test_the_lint_finds_a_planted_list(tmp_path):
    planted = tmp_path / "planted.py"
    a, b, c, d = PACKAGES[:4]
    planted.write_text(f"X = 1\nPAPERS = ({a!r}, {b!r})\nRUNS = {{{c!r}: 1, {d!r}: 2}}\nONE = [{a!r}, 'other']\n"
                       f"S = {{{a!r}, {c!r}}}\nL = [p for p in [{b!r}, {d!r}]]\nif n == {a!r} or n == {b!r}: pass\n"
                       f"W = '{c} {d}'.split()\nV = {{'x': {a!r}, 'y': {d!r}}}\n")
    assert sorted(_literal_paper_lists(planted, tmp_path)) == [
        f"planted.py:2: {sorted([a, b])}", f"planted.py:3: {sorted([c, d])}", f"planted.py:5: {sorted([a, c])}",
        f"planted.py:6: {sorted([b, d])}", f"planted.py:7: {sorted([a, b])}", f"planted.py:8: {sorted([c, d])}",
        f"planted.py:9: {sorted([a, d])}"]


# ------------------------------------------------------------------------ a sixth paper, through the registry alone
def _minimal_paper():
    spec = importlib.util.spec_from_file_location("minimal_paper", REPO / "docs" / "examples" / "minimal_paper.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module                # dataclasses resolve the module's annotations through it
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def minimal():
    module = _minimal_paper()
    REGISTRY.register(module.PAPER)
    try:
        yield module
    finally:
        REGISTRY.unregister(module.PAPER.name)


def test_minimal_paper_runs_through_the_registry(minimal, tmp_path, monkeypatch):
    """Register the worked example and take the path its notebook would: NotebookRun (smoke profile), its reading
    space, the results file through the results contract, and the rendered report."""
    from mmlib.arena import study
    from mmlib.experiment import report
    from mmlib.experiment.notebook import NotebookRun
    sys.path.insert(0, str(REPO / "tools"))
    try:
        import make_report
    finally:
        sys.path.remove(str(REPO / "tools"))
    monkeypatch.setenv("MMLIB_CACHE", str(tmp_path / "cache"))
    paper = REGISTRY["example2026"]
    assert paper is minimal.PAPER and "example2026" in list(REGISTRY)
    # a registered paper lives in this process only: one worker
    nb = NotebookRun(paper, PROFILE="smoke", OUTPUT_ROOT=str(tmp_path), WORKERS=1, PROGRESS=False)
    runs = nb.n_runs
    assert runs == paper.runs("smoke") and nb.seed == paper.root_seed and nb.digest_runs == runs
    results = minimal.evaluate_reading(paper.headline, nb.mc())
    mv = nb.multiverse()
    assert len(mv.universes) == 2 and all(isinstance(u, UniverseResult) for u in mv.universes)
    # the headline universe is the job run in this process, bit for bit
    assert mv.headline == minimal.summarise(results, runs) == paper.universe(paper.headline, runs, paper.root_seed)
    # theory: on a linear-Gaussian model the CKF returns the Kalman moments, so the key effect is round-off
    for u in mv.universes:
        e = u.effect(paper.key_effect)
        assert abs(e.value) < 1e-9 and u.claim("the CKF is more accurate than the KF").startswith("not supported")
    # the arena reaches the new paper's scenario through the registry
    assert study.scenario("example2026").name == "example2026" and "example2026" in study.known_scenarios()
    digest = digests.run_digest(results, nb.digest_runs)
    assert digests.compare_digests(digest, paper.headline_digest(runs)).ok
    rows = [report.make_row(p.item, p.algorithm, p.quantity, p.printed, v.replicated, v.stderr, n_runs=runs,
                            n_runs_paper=paper.n_runs, deviations=["E-1"])
            for p in paper.published for v in [mv.headline.value(p.key)]]
    claims = report.Claims()
    for c in mv.headline.claims:
        claims.add(c.claim, c.verdict, "", key=c.key)
    with pytest.raises(ValueError, match="^provenance: .*git_commit"):
        nb.write_results(rows=rows, provenance={"git_commit": "forged"})
    doc = nb.write_results(rows=rows, digest=digest, claims=claims, multiverse=mv,
                           deviations=[d.as_dict() for d in paper.deviations])
    assert nb.results_path == tmp_path / "data" / "results" / "example2026.json" and nb.results_path.is_file()
    prov = doc["provenance"]
    assert prov["paper_citation"] == paper.citation and prov["multiverse_design"] == mv.design.kind == "star"
    assert prov["multiverse_runs"] == runs and "timing_runs" not in prov          # the profile times nothing
    # how the run obtained its universes (bench/notebooks.py's universes per CPU-minute): the grid runner's counts
    assert prov["multiverse_computed"] + prov["multiverse_from_cache"] == len(mv.universes) == 2
    assert prov["multiverse_computed"] == mv.compute["computed"] and prov["multiverse_cpu_s"] >= 0.0
    assert "compute" not in doc["multiverse"]          # a measurement of the machine: provenance only
    assert doc["multiverse"]["n_universes"] == 2 and doc["claims"][0]["claim"] == claims.as_list()[0]["claim"]
    page = make_report.render(doc, tmp_path, tmp_path / "reports")
    assert "example2026" in page and "Table 1" in page and "Reading space" in page
    for p in paper.published:
        assert p.printed in page


def test_register_refuses_what_is_not_a_new_paper(minimal):
    with pytest.raises(ValueError, match="paper: expected"):
        REGISTRY.register("example2026")
    clash = dataclasses.replace(minimal.PAPER)
    with pytest.raises(ValueError, match="already registered"):
        REGISTRY.register(clash)
    with pytest.raises(ValueError, match="cannot be removed"):
        REGISTRY.unregister(PACKAGES[0])


def test_paper_contract_rejects_bad_declarations():
    base = _minimal_paper().PAPER
    from mmlib.experiment.paper import ArenaEntry
    full, smoke = dict(base.profiles["full"]), dict(base.profiles["smoke"])
    for change, arg in (({"name": ""}, "name"), ({"name": "doe_2026"}, "name"), ({"root_seed": -1}, "root_seed"),
                        ({"n_runs": 1}, "n_runs"), ({"notebook": "other_topic"}, "notebook"),
                        ({"setup_type": "Setup"}, "setup_type"), ({"universe": None}, "universe"),
                        ({"published": list(base.published)}, "published"),
                        ({"published": base.published * 2}, "published"),
                        ({"deviations": base.deviations * 2}, "deviations"), ({"algorithms": ()}, "algorithms"),
                        ({"profiles": {"full": {"n_runs": 10}}}, "profiles"), ({"space": None}, "space"),
                        ({"profiles": {"full": full, "smoke": {**smoke, "mv_design": "bogus"}}}, "profiles"),
                        ({"profiles": {"full": full, "smoke": {**smoke, "n_runs": 1000}}}, "profiles"),
                        ({"arena": ArenaEntry("KF")}, "arena.algorithms"),
                        ({"arena": ArenaEntry(("KF",), ideas=(("idea", "KF"),))}, "arena.ideas"),
                        ({"arena": ArenaEntry(("KF",), claim="KF wins")}, "arena.claim")):
        with pytest.raises(ValueError, match=f"^{arg}"):
            dataclasses.replace(base, **change)


def test_nees_profile_of_a_correct_kalman_filter_averages_the_state_dimension():
    """evaluation.nees_profile on the worked example's KF (a linear-Gaussian model the filter knows exactly, initial
    error drawn from P0): the time-averaged NEES is the state dimension, 4, within 4 standard errors (a chi-square
    mean); the per-step curve has one value per step."""
    from mmlib.experiment import evaluation
    from mmlib.experiment.montecarlo import MonteCarlo
    minimal = _minimal_paper()
    mc = MonteCarlo(minimal.ROOT_SEED, 200)
    make_batch, estimators = minimal.batch(minimal.Setup(), mc)
    truth, z, init = make_batch(range(200))
    prof = evaluation.nees_profile(estimators["KF"], init["KF"], z, truth)
    assert prof.per_step.shape == (z.shape[1],) and prof.n_diverged == 0
    assert abs(float(prof.time_average.value) - 4.0) <= 4 * float(prof.time_average.stderr)

