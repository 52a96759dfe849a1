# Two commands on a fresh machine (Python 3.11 and make):
#   make figures                  full-fidelity figures, tables and executed notebooks
#   make test                     unit tests + smoke profile of every notebook + tolerance tests
# Also: make figures PROFILE=smoke (writes under build/smoke/), make bench, make clean

PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
PROFILE ?= full

.PHONY: figures test unit smoke bench clean venv

venv: $(STAMP)

$(STAMP): requirements.lock pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements.lock
	@# mmlib is pure Python and used in place: a .pth file puts the repository on the venv's path
	$(PY) -c "import sysconfig, pathlib; pathlib.Path(sysconfig.get_paths()['purelib'], 'mmlib-repo.pth').write_text(str(pathlib.Path.cwd()) + '\n')"
	$(PY) -m ipykernel install --sys-prefix --name mmlib --display-name "mmlib (.venv)" >/dev/null
	@touch $(STAMP)

figures: $(STAMP)
	$(PY) tools/run_notebooks.py --profile $(PROFILE)

smoke: $(STAMP)
	$(PY) tools/run_notebooks.py --profile smoke

unit: $(STAMP)
	$(PY) -m pytest -q tests --ignore=tests/tolerance

test: $(STAMP)
	$(PY) tools/run_notebooks.py --profile smoke
	$(PY) -m pytest -q tests

bench: $(STAMP)
	$(PY) bench/imm_ukf.py

clean:
	rm -rf build
