"""Run the reproducibility tests again as if on other CPUs (part of ``make test``).

Two things choose their code by CPU at run time: OpenBLAS its kernels (``OPENBLAS_CORETYPE`` forces a core)
and numpy its SIMD functions (``NPY_DISABLE_CPU_FEATURES`` switches targets off; numpy >= 2.4 knows the
x86-64 levels ``X86_V3``/``X86_V4`` and ignores older names such as ``AVX512F`` with a warning).  Forcing both
emulates a common machine without AVX-512 (``avx2``) and an SSE-only one (``sse4.2``: numpy's build baseline,
x86-64-v2) on the reference machine, so a change that holds only on AVX-512 is caught there.

Under each emulation it runs the committed-digest test (``tests/tolerance/test_digest.py``: the committed
outputs reproduced to the stated round-off, and the round-off rule, not the bit-for-bit one, is what applied)
and the batch-independence tests (``tests/test_batch_independence.py``: bit for bit in any batch on that
machine).  Elsewhere than x86-64 it says so and runs nothing.

Usage: ``python tools/emulated_tests.py [pytest options]``; the emulations run at once (each a single-process
pytest; two on the reference machine's two cores), each one's output printed whole when it ends; exit status that
of the first failing run in the order of :data:`EMULATIONS`.

``python tools/emulated_tests.py --measure`` (run by ``make bench``) instead measures how far each paper's
headline digest moves under each emulated CPU of :data:`MEASURED` and writes ``data/bench/cross_cpu.json``: per
machine and paper, whether the bits are equal, whether the divergences are, and the largest per-run RMSE
difference relative to the state scale S (the quantity ``RTOL_MACHINE`` bounds) and to the RMSE.
"""
from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

#: emulated machine -> environment (numba's kernels follow the host CPU; they are not a source of
#: cross-CPU differences: NUMBA_CPU_NAME=generic gives the same digests)
EMULATIONS = {
    "avx2": {"OPENBLAS_CORETYPE": "Haswell", "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR"},
    "sse4.2": {"OPENBLAS_CORETYPE": "Nehalem", "NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR"},
}
#: the machines measured by --measure: the two tested ones and an older OpenBLAS core (SSE3's)
MEASURED = {**EMULATIONS, "sse4.2-prescott": {**EMULATIONS["sse4.2"], "OPENBLAS_CORETYPE": "Prescott"}}
TESTS = ("tests/tolerance/test_digest.py", "tests/test_batch_independence.py")
MEASURE_OUT = REPO / "data" / "bench" / "cross_cpu.json"

_DIGESTS = """
import json, sys
from mmlib.papers import REGISTRY
from mmlib.experiment import machine
from mmlib.experiment.results import read_results
out = {"machine": machine.fingerprint(), "digests": {}}
for p in REGISTRY:
    committed = read_results(f"data/results/{p}.json")["digest"]
    out["digests"][p] = REGISTRY[p].headline_digest(committed["n_runs"])
json.dump(out, sys.stdout)
"""


def _digests(env: dict) -> dict:
    """Every paper's headline digest and the machine fingerprint, computed in a process under ``env``."""
    out = subprocess.run([sys.executable, "-c", _DIGESTS], cwd=REPO, env={**os.environ, **env}, capture_output=True,
                         text=True, check=True).stdout
    return json.loads(out)


def movement(ours: dict, base: dict) -> dict:
    """How far a digest moved from a reference digest of the same runs: ``bits_equal``, ``divergences_equal``
    and the largest per-run RMSE differences ``max_over_scale`` (over the state scale S) and ``max_over_rmse``."""
    over_s = over_r = 0.0
    div_equal = True
    for alg, a in ours["runs"].items():
        b = base["runs"][alg]
        div_equal &= a["diverged_step"] == b["diverged_step"] and a["divergence_cause"] == b["divergence_cause"]
        for x, y in zip(a["rmse"], b["rmse"]):
            if x is not None and y is not None and x != y:
                over_s = max(over_s, abs(x - y) / b["scale"])
                over_r = max(over_r, abs(x - y) / abs(y))
    return {"bits_equal": ours["sha256"] == base["sha256"], "divergences_equal": div_equal,
            "max_over_scale": over_s, "max_over_rmse": over_r}


def measure() -> dict:
    """The report written by ``--measure`` (see the module docstring)."""
    from mmlib.experiment.digests import RTOL_MACHINE
    native = _digests({})
    report = {"rtol_machine": RTOL_MACHINE, "native": native["machine"], "machines": {}}
    for name, env in MEASURED.items():
        print(f"emulated_tests: measuring {name}", flush=True)
        got = _digests(env)
        report["machines"][name] = {
            "environment": env, "fingerprint": got["machine"],
            "papers": {p: movement(d, native["digests"][p]) for p, d in got["digests"].items()}}
    report["largest_over_scale"] = max(m["max_over_scale"] for r in report["machines"].values()
                                       for m in r["papers"].values())
    return report


def _fingerprint(env: dict) -> str:
    """The machine fingerprint (:func:`mmlib.experiment.machine.fingerprint`) a process sees under ``env``."""
    code = "from mmlib.experiment import machine; print(machine.fingerprint_id())"
    return subprocess.run([sys.executable, "-c", code], cwd=REPO, env={**os.environ, **env}, capture_output=True,
                          text=True, check=True).stdout.strip().splitlines()[-1]


def main(argv: list[str]) -> int:
    if argv[:1] == ["--measure"] and platform.machine() in ("x86_64", "AMD64"):
        from mmlib.experiment.writing import atomic_write_text
        report = measure()
        atomic_write_text(MEASURE_OUT, json.dumps(report, indent=1, sort_keys=True) + "\n")
        print(f"emulated_tests: wrote {MEASURE_OUT.relative_to(REPO)} (largest per-run RMSE difference "
              f"{report['largest_over_scale']:.2g} of the state scale; RTOL_MACHINE {report['rtol_machine']:g})")
        return 0
    if platform.machine() not in ("x86_64", "AMD64"):
        print(f"emulated_tests: {platform.machine()} is not x86-64; the CPU emulations do not apply, "
              "nothing to run", flush=True)
        return 0
    native = _fingerprint({})
    # the emulations are independent single-process pytest runs: they run at once (one per core on the
    # reference machine's two), each one's output printed whole when it ends, in the order of EMULATIONS
    runs = {}
    for name, env in EMULATIONS.items():
        shown = " ".join(f'{k}="{v}"' for k, v in env.items())
        if _fingerprint(env) == native:
            print(f"emulated_tests: {name}: this machine already is one ({shown} changes nothing), skipped",
                  flush=True)
            continue
        log = tempfile.TemporaryFile("w+")
        proc = subprocess.Popen([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *TESTS, *argv],
                                cwd=REPO, env={**os.environ, **env, "MMLIB_EXPECT_EMULATED": name},
                                stdout=log, stderr=subprocess.STDOUT, text=True)
        runs[name] = (shown, proc, log)
    first = 0
    for name, (shown, proc, log) in runs.items():
        code = proc.wait()
        log.seek(0)
        print(f"emulated_tests: {name} machine ({shown})", flush=True)
        print(log.read(), end="", flush=True)
        log.close()
        if code:
            print(f"emulated_tests: the {name} emulation failed (exit {code})", file=sys.stderr, flush=True)
            first = first or code
    return first

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
