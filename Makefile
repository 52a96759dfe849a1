# Two commands on a fresh machine (Python 3.11 and make):
#   make figures                  full-fidelity figures, tables and executed notebooks
#   make test                     ruff, unit tests + smoke profile of every notebook + tolerance tests
# Also: make figures PROFILE=smoke (writes under build/smoke/), make site, make bench, make clean
# One paper, other settings: make figures PAPER=zhu2016 N_RUNS=500 SEED=7
# Where it runs (outputs unchanged): make figures WORKERS=1, make figures SCHEDULER=tcp://host:8786 (Dask)
#   (PAPER: one or more paper names; any N_RUNS or SEED sends the outputs to build/custom/<profile>-<settings>/,
#    never over the committed ones); make recover finishes an interrupted promotion and removes leftovers

PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
PROFILE ?= full
# processes of make test's pytest run (pytest-xdist): the reference machine's two cores
TEST_WORKERS ?= 2
# passed through to tools/run_notebooks.py: the papers to run (default all) and notebook parameter overrides
RUN_ARGS = $(if $(N_RUNS),-p N_RUNS=$(N_RUNS)) $(if $(SEED),-p SEED=$(SEED)) $(PAPER)
# execution settings (never change a result, so never send the outputs to build/custom/): WORKERS=n worker
# processes in all (a WORKERS environment variable is read by the runner itself), SCHEDULER=tcp://host:8786 a Dask
# scheduler receiving the Monte Carlo chunks and universes (the kernels see it as MMLIB_SCHEDULER)
EXEC_ARGS = $(if $(filter command line,$(origin WORKERS)),--workers $(WORKERS)) $(if $(SCHEDULER),--scheduler $(SCHEDULER))

.PHONY: figures test unit smoke site bench clean venv recover

venv: $(STAMP)

$(STAMP): requirements.lock pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements.lock
	@# mmlib used in place: an editable install of this checkout, built offline by the lock's setuptools (a venv made
	@# before this had a hand-written mmlib-repo.pth doing the same: removed)
	$(PY) -c "import sysconfig, pathlib; pathlib.Path(sysconfig.get_paths()['purelib'], 'mmlib-repo.pth').unlink(missing_ok=True)"
	$(PY) -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation -e .
	$(PY) -m ipykernel install --sys-prefix --name mmlib --display-name "mmlib (.venv)" >/dev/null
	@touch $(STAMP)

figures: $(STAMP)
	$(PY) tools/run_notebooks.py --profile $(PROFILE) $(EXEC_ARGS) $(RUN_ARGS)
	@# wall time per notebook and universes per minute per paper, from the run just promoted (data/bench/notebooks.json)
	$(if $(N_RUNS)$(SEED),,$(if $(filter full,$(PROFILE)),$(PY) -m bench.notebooks))
	@# the site of what was just promoted (a run with N_RUNS or SEED went to build/custom/: no site of it; after
	@# PAPER=... the site is rebuilt when every paper's outputs exist, and otherwise says which are missing)
	$(if $(N_RUNS)$(SEED),,$(PY) tools/build_site.py --profile $(PROFILE) --if-complete)

# The offline site (build/site/index.html; PROFILE=smoke: build/site-smoke/) from the outputs in place: the papers'
# executed notebooks as pages, the cross-paper summary, the reading spaces, the arena and the API reference
site: $(STAMP)
	$(PY) tools/build_site.py --profile $(PROFILE)

smoke: $(STAMP)
	$(PY) tools/run_notebooks.py --profile smoke $(EXEC_ARGS) $(RUN_ARGS)

recover: $(STAMP)
	$(PY) tools/run_notebooks.py --recover

unit: $(STAMP)
	$(PY) -m pytest -q tests --ignore=tests/tolerance

test: $(STAMP)
	$(PY) -m ruff check .
	$(PY) tools/run_notebooks.py --profile smoke $(EXEC_ARGS)
	@# the committed-digest and batch-independence tests again as on an AVX2 and an SSE4.2 machine (x86-64 only)
	$(PY) tools/emulated_tests.py
	@# the suite in TEST_WORKERS processes (pytest-xdist; a file's tests stay in one process, so its module fixtures,
	@# e.g. the site built once, are not built twice)
	$(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadfile tests

# The benchmark report (data/bench/: imm_ukf.json, scaling.json, scaling.png, notebooks.json, cost_model.json (state
# sizes 2..12 and the papers' timed filters against the cost model), papers.json (every paper's filters against the
# flop floor, fused steps on and off); cross_cpu.json: how far
# each paper's headline moves on emulated AVX2/SSE4.2 CPUs, x86-64 only), single-threaded:
# the script sets OMP/OPENBLAS/MKL/BLIS/NUMBA_NUM_THREADS to BENCH_THREADS (default 1) before numpy loads.
# Options: BENCH_REPEATS (interleaved repeats per library, default 5), BENCH_MAX_RUNS (largest size, default 100000)
bench: $(STAMP)
	$(PY) bench/imm_ukf.py
	$(PY) bench/cost_model.py
	$(PY) bench/papers.py
	$(PY) tools/emulated_tests.py --measure

clean:
	@# an interrupted promotion of the committed outputs is journaled under build/: finish it before deleting
	@if [ -x $(PY) ]; then $(PY) tools/run_notebooks.py --recover; fi
	rm -rf build
