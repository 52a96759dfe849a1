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

Usage: ``python tools/emulated_tests.py [pytest options]``; exit status that of the first failing run.
"""
from __future__ import annotations

import os
import platform
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

#: emulated machine -> environment (numba's kernels follow the host CPU; they are not a source of
#: cross-CPU differences: NUMBA_CPU_NAME=generic gives the same digests)
EMULATIONS = {
    "avx2": {"OPENBLAS_CORETYPE": "Haswell", "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR"},
    "sse4.2": {"OPENBLAS_CORETYPE": "Nehalem", "NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR"},
}
TESTS = ("tests/tolerance/test_digest.py", "tests/test_batch_independence.py")


def _fingerprint(env: dict) -> str:
    """The machine fingerprint (:func:`mmlib.experiment.machine.fingerprint`) a process sees under ``env``."""
    code = "from mmlib.experiment import machine; print(machine.fingerprint_id())"
    return subprocess.run([sys.executable, "-c", code], cwd=REPO, env={**os.environ, **env}, capture_output=True,
                          text=True, check=True).stdout.strip().splitlines()[-1]


def main(argv: list[str]) -> int:
    if platform.machine() not in ("x86_64", "AMD64"):
        print(f"emulated_tests: {platform.machine()} is not x86-64; the CPU emulations do not apply, "
              "nothing to run", flush=True)
        return 0
    native = _fingerprint({})
    for name, env in EMULATIONS.items():
        shown = " ".join(f'{k}="{v}"' for k, v in env.items())
        if _fingerprint(env) == native:
            print(f"emulated_tests: {name}: this machine already is one ({shown} changes nothing), skipped",
                  flush=True)
            continue
        print(f"emulated_tests: {name} machine ({shown})", flush=True)
        code = subprocess.call([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *TESTS, *argv],
                               cwd=REPO, env={**os.environ, **env, "MMLIB_EXPECT_EMULATED": name})
        if code:
            print(f"emulated_tests: the {name} emulation failed (exit {code})", file=sys.stderr, flush=True)
            return code
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
