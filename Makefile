# Two commands on a fresh machine (Python 3.11 and make):
#   make figures                  full-fidelity figures, tables and executed notebooks
#   make test                     ruff, unit tests + smoke profile of every notebook + tolerance tests
# Also: make figures PROFILE=smoke (writes under build/smoke/), make site, make bench, make clean
# One paper, other settings: make figures PAPER=zhu2016 N_RUNS=500 SEED=7 MULTIVERSE_RUNS=100
#   (PAPER: one or more paper names; N_RUNS: the headline's Monte Carlo runs, SEED: the root seed, MULTIVERSE_RUNS:
#    the reading space's runs per universe (N_RUNS leaves it alone); any of the three sends the outputs to
#    build/custom/<profile>-<settings>/, never over the committed ones)
# Where it runs (outputs unchanged): make figures WORKERS=1, make figures SCHEDULER=tcp://host:8786 (Dask);
#   VERBOSE=1 prints every universe of a reading space with its levels
# make recover finishes an interrupted promotion and removes leftovers.  An upper-case variable on the command line
# that is not one of ACCEPTED_VARIABLES below (a misspelt NRUNS=200, say) is refused before anything runs.

# The command-line variables this Makefile and the scripts it runs read (bench/: BENCH_*; mmlib: MMLIB_*)
ACCEPTED_VARIABLES := PAPER N_RUNS SEED MULTIVERSE_RUNS PROFILE WORKERS SCHEDULER VERBOSE TEST_WORKERS PYTHON \
	BENCH_THREADS BENCH_REPEATS BENCH_MAX_RUNS BENCH_COST_REPEATS BENCH_COST_STEPS BENCH_COST_WORK \
	BENCH_PAPER_REPEATS BENCH_PAPER_RUNS BENCH_PAPER_STEPS MMLIB_SCHEDULER MMLIB_CACHE MMLIB_KERNEL MMLIB_FUSED \
	MMLIB_THREADS
# make's own (set on the command line only by hand); lower-case names are left alone (make's and the user's own)
MAKE_OWN_VARIABLES := MAKEFLAGS MFLAGS MAKEOVERRIDES GNUMAKEFLAGS MAKEFILES MAKELEVEL
# a variable set on the command line (origin "command line": never one from the environment) whose name has no
# lower-case letter and is not accepted: a misspelling would otherwise be dropped silently, rerunning the full
# profile over the committed outputs
_LOWER := a b c d e f g h i j k l m n o p q r s t u v w x y z
UNKNOWN_VARIABLES := $(strip $(foreach v,$(filter-out $(ACCEPTED_VARIABLES) $(MAKE_OWN_VARIABLES),$(.VARIABLES)),\
	$(if $(filter command line,$(origin $(v))),$(if $(strip $(foreach c,$(_LOWER),$(findstring $(c),$(v)))),,$(v)))))
ifneq ($(UNKNOWN_VARIABLES),)
$(error unknown variable(s) on the command line: $(UNKNOWN_VARIABLES); nothing was run. Accepted: \
$(ACCEPTED_VARIABLES))
endif

PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
PROFILE ?= full
# processes of make test's pytest run (pytest-xdist): the reference machine's two cores
TEST_WORKERS ?= 2
# passed through to tools/run_notebooks.py: the papers to run (default all) and notebook parameter overrides
# (results-changing: any of them sends the outputs to build/custom/, and no bench or site is made of them)
CUSTOM = $(N_RUNS)$(SEED)$(MULTIVERSE_RUNS)
RUN_ARGS = $(if $(N_RUNS),-p N_RUNS=$(N_RUNS)) $(if $(SEED),-p SEED=$(SEED)) \
	$(if $(MULTIVERSE_RUNS),-p MULTIVERSE_RUNS=$(MULTIVERSE_RUNS)) $(PAPER)
# execution settings (never change a result, so never send the outputs to build/custom/): WORKERS=n worker
# processes in all (a WORKERS environment variable is read by the runner itself), SCHEDULER=tcp://host:8786 a Dask
# scheduler receiving the Monte Carlo chunks and universes (the kernels see it as MMLIB_SCHEDULER); VERBOSE=1 the
# progress of every universe with its levels (default: universe k/N and the time left)
EXEC_ARGS = $(if $(filter command line,$(origin WORKERS)),--workers $(WORKERS)) $(if $(SCHEDULER),--scheduler $(SCHEDULER)) \
	$(if $(filter 1 true yes,$(VERBOSE)),-v)

.PHONY: figures test unit smoke site bench clean venv recover

venv: $(STAMP)

$(STAMP): requirements.lock pyproject.toml
	@echo "make venv: installing into $(VENV)/ the locked packages of requirements.lock (numpy, numba, scipy, jupyter,"
	@echo "  papermill, sphinx, ...) and mmlib itself (editable): about 1 minute on a fresh machine"
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	@# --no-compile: no .pyc written ahead for the tens of thousands of modules of the lock (three quarters of the
	@# install's time: 43 s against 161 s measured); Python compiles what a process imports, on its first import
	$(PY) -m pip install --quiet --disable-pip-version-check --no-compile -r requirements.lock
	@# mmlib used in place: an editable install of this checkout, built offline by the lock's setuptools (a venv made
	@# before this had a hand-written mmlib-repo.pth doing the same: removed)
	$(PY) -c "import sysconfig, pathlib; pathlib.Path(sysconfig.get_paths()['purelib'], 'mmlib-repo.pth').unlink(missing_ok=True)"
	$(PY) -m pip install --quiet --disable-pip-version-check --no-compile --no-deps --no-build-isolation -e .
	$(PY) -m ipykernel install --sys-prefix --name mmlib --display-name "mmlib (.venv)" >/dev/null
	@touch $(STAMP)

figures: $(STAMP)
	$(PY) tools/run_notebooks.py --profile $(PROFILE) $(EXEC_ARGS) $(RUN_ARGS)
	@# the README's 'What we found' lines from the results just promoted (tools/make_report.py, which also re-renders
	@# reports/ from data/results/ as the runner did)
	$(if $(CUSTOM),,$(if $(filter full,$(PROFILE)),$(PY) tools/make_report.py))
	@# wall time per notebook and universes per minute per paper, from the run just promoted (data/bench/notebooks.json)
	$(if $(CUSTOM),,$(if $(filter full,$(PROFILE)),$(PY) -m bench.notebooks))
	@# the site of what was just promoted (a run with N_RUNS, SEED or MULTIVERSE_RUNS went to build/custom/: no site of it; after
	@# PAPER=... the site is rebuilt when every paper's outputs exist, and otherwise says which are missing)
	$(if $(CUSTOM),,$(PY) tools/build_site.py --profile $(PROFILE) --if-complete)

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
	@# e.g. the site built once, are not built twice; files handed out in collection order, the longest first:
	@# tests/conftest.py LONGEST_FIRST)
	$(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder tests

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
