"""``pip install .`` into a fresh virtual environment gives a working mmlib with its core dependencies only.

The repository's ``pyproject.toml``, ``README.md``, ``LICENSE`` and ``mmlib/`` are copied under pytest's tmp_path and
installed from there (so the build writes no ``mmlib.egg-info`` or ``build/`` into the checkout) into a new
``python -m venv`` (no system site-packages), which pulls only the ``dependencies`` of pyproject.toml (numpy, scipy,
numba, cloudpickle) and setuptools for the build, from PyPI: the test needs the network.  In that environment:
``import mmlib`` works, ``mmlib.__version__`` is the version setuptools resolved, none of the optional packages
(matplotlib, pymap3d, dask, IPython) is installed, ``py.typed`` is installed, and the README's library example runs
against the installed package (working directory outside the repository).
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

from test_readme import BLOCKS, run_block

ROOT = Path(__file__).resolve().parents[1]
TIMEOUT_S = 600
OPTIONAL = ("matplotlib", "pymap3d", "dask", "IPython")
#: the README block run here: the library example, the one block that calls mmlib.run(
EXAMPLE_MARKER = "mmlib.run("

CHECK = r"""
import importlib.metadata, importlib.util, json, sys
import mmlib
print(json.dumps({
    "version": mmlib.__version__,
    "metadata_version": importlib.metadata.version("mmlib"),
    "file": mmlib.__file__,
    "prefix": sys.prefix,
    "py_typed": [str(f.locate()) for f in importlib.metadata.files("mmlib") if f.name == "py.typed"],
    "schema_rows": __import__("mmlib.experiment.report", fromlist=["x"]).results_schema()["properties"]["rows"]["type"],
    "optional_found": {m: importlib.util.find_spec(m) is not None for m in %r},
    "optional_imported": sorted(m for m in %r if m in sys.modules),
}))
""" % (OPTIONAL, OPTIONAL)


def _env() -> dict:
    """The environment of the fresh venv's processes: nothing pointing at the checkout or another environment."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP", "PYTHONUSERBASE", "VIRTUAL_ENV")}
    env["PYTHONNOUSERSITE"] = "1"
    return env


def _run(cmd, cwd, timeout=TIMEOUT_S) -> subprocess.CompletedProcess:
    proc = subprocess.run(cmd, cwd=cwd, env=_env(), capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, f"{' '.join(map(str, cmd))} failed ({proc.returncode}):\n{proc.stderr}\n{proc.stdout}"
    return proc


def test_pip_install_core_only(tmp_path):
    t0 = time.perf_counter()
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(ROOT / name, src / name)
    shutil.copytree(ROOT / "mmlib", src / "mmlib", ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))

    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", str(venv)], cwd=tmp_path)
    py = venv / ("Scripts/python.exe" if os.name == "nt" else "bin/python")
    # --no-compile: no .pyc written ahead for the thousands of modules of numpy, scipy and numba (half of the install's
    # CPU time); Python compiles what the checks and the example import, as on any first import
    _run([str(py), "-m", "pip", "install", "--disable-pip-version-check", "--no-compile", "-q", str(src)], cwd=tmp_path)
    t_install = time.perf_counter() - t0

    outside = tmp_path / "elsewhere"                    # not the repository: `import mmlib` must find the install
    outside.mkdir()
    info = json.loads(_run([str(py), "-c", CHECK], cwd=outside).stdout.strip().splitlines()[-1])
    print(f"\ninstalled mmlib {info['version']} at {info['file']}")
    venv_dir = venv.resolve()
    assert Path(info["prefix"]).resolve() == venv_dir
    assert Path(info["file"]).resolve().is_relative_to(venv_dir), info["file"]
    assert not Path(info["file"]).resolve().is_relative_to(ROOT), info["file"]
    assert info["version"] == info["metadata_version"], info
    assert info["optional_found"] == {m: False for m in OPTIONAL}, \
        f"optional packages installed by `pip install .`: {[m for m, v in info['optional_found'].items() if v]}"
    assert info["optional_imported"] == []
    assert len(info["py_typed"]) == 1 and Path(info["py_typed"][0]).is_file(), info["py_typed"]
    assert info["schema_rows"] == "array", "the results contract's JSON Schema is not installed with the package"
    assert Path(info["py_typed"][0]).resolve().parent == Path(info["file"]).resolve().parent

    examples = [(line, code) for line, code, _ in BLOCKS if EXAMPLE_MARKER in code]
    assert len(examples) == 1, f"expected one README python block containing {EXAMPLE_MARKER!r}, " \
                               f"found {[line for line, _ in examples]}"
    line, code = examples[0]
    # after the example, say which mmlib it imported
    probe = code + "import sys as _sys\nprint('MMLIB_FILE=' + _sys.modules['mmlib'].__file__)\n"
    t1 = time.perf_counter()
    proc = run_block(probe, line, str(py), outside, timeout=TIMEOUT_S, env=_env())   # no PYTHONPATH to the checkout
    t_example = time.perf_counter() - t1
    assert proc is not None, f"README.md:{line}: the example did not finish within {TIMEOUT_S} s"
    assert proc.returncode == 0, f"README.md:{line}: the example failed in the fresh venv:\n{proc.stderr}"
    used = [ln.split("=", 1)[1] for ln in proc.stdout.splitlines() if ln.startswith("MMLIB_FILE=")]
    assert used and Path(used[0]).resolve().is_relative_to(venv_dir), used
    assert "position RMSE" in proc.stdout, proc.stdout
    print(proc.stdout)
    # the first run compiled the numba kernels (cache=True: into the installed package); a second run loads them
    t2 = time.perf_counter()
    again = run_block(code, line, str(py), outside, timeout=TIMEOUT_S, env=_env())
    t_cached = time.perf_counter() - t2
    assert again is not None and again.returncode == 0, again and again.stderr
    assert again.stdout == proc.stdout.split("MMLIB_FILE=")[0], "the example's output changed between two runs"
    print(f"pip install: {t_install:.1f} s; README example in the fresh venv: {t_example:.1f} s (first run, numba "
          f"compiles), {t_cached:.1f} s (second run, cached kernels); test in all: {time.perf_counter() - t0:.1f} s")
