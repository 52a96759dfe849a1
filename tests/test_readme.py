"""Every ```python block of README.md runs: each block is one test case (named by the line of its opening fence),
executed in a fresh interpreter (``sys.executable``) with the repository root as its working directory.

A block that is not meant to run can be marked by an HTML comment ``<!-- not-executed -->`` on the line before its
opening fence (blank lines in between are allowed); it is then skipped.  No block of the README is marked today:
prefer making a block runnable to marking it.
"""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
NOT_EXECUTED = "<!-- not-executed -->"
TIMEOUT_S = 300


def python_blocks(text: str) -> list[tuple[int, str, bool]]:
    """``(line of the opening fence (1-based), code, marked not-executed)`` of every ```python fenced block of
    ``text``.  Fences are the CommonMark ones of this README: three or more backticks at the start of a line (up to
    three spaces of indentation), the block closed by a fence of at least as many backticks."""
    lines = text.splitlines()
    blocks = []
    i = 0
    while i < len(lines):
        opening = re.match(r"^ {0,3}(`{3,})\s*([^\s`]*)", lines[i])
        if not opening:
            i += 1
            continue
        fence, lang = opening.group(1), opening.group(2).lower()
        start = i
        j = i + 1
        while j < len(lines) and not re.match(rf"^ {{0,3}}{fence}`*\s*$", lines[j]):
            j += 1
        if lang in ("python", "py", "python3"):
            before = next((lines[k].strip() for k in range(start - 1, -1, -1) if lines[k].strip()), "")
            blocks.append((start + 1, "\n".join(lines[start + 1:j]) + "\n", before == NOT_EXECUTED))
        i = j + 1
    return blocks


BLOCKS = python_blocks(README.read_text(encoding="utf-8"))


def test_readme_has_python_blocks():
    """The README shows the library in at least one python block, and at least one of them runs (otherwise the
    parametrised test below would pass vacuously)."""
    assert BLOCKS, f"{README.name}: no ```python block found"
    assert any(not skipped for _, _, skipped in BLOCKS), f"{README.name}: every python block is marked {NOT_EXECUTED}"


def test_block_parser():
    """The fence parser on a small document: languages, a longer fence holding a shorter one, the marker."""
    doc = ("text\n```sh\nls\n```\n```python\na = 1\n```\n<!-- not-executed -->\n\n```python\nb = 2\n```\n"
           "````python\nprint('```')\n```\nc = 3\n````\n")
    assert python_blocks(doc) == [(5, "a = 1\n", False), (10, "b = 2\n", True),
                                  (13, "print('```')\n```\nc = 3\n", False)]


@pytest.mark.parametrize("line, code, skipped", BLOCKS, ids=[f"README.md:{line}" for line, _, _ in BLOCKS])
def test_readme_block_runs(line, code, skipped):
    if skipped:
        pytest.skip(f"README.md:{line} is marked {NOT_EXECUTED}")
    proc = run_block(code, line, sys.executable, ROOT)
    if proc is None:
        pytest.fail(f"README.md:{line}: the python block did not finish within {TIMEOUT_S} s", pytrace=False)
    if proc.returncode != 0:
        pytest.fail(f"README.md:{line}: the python block failed (exit status {proc.returncode}):\n{proc.stderr}"
                    f"stdout:\n{proc.stdout}", pytrace=False)


#: Executes the code read from stdin as ``__main__`` of a fresh interpreter, compiled under the README's path, so that
#: a traceback names README.md and, the code being padded to its place, the README's own line numbers.
RUNNER = ("import sys; exec(compile(sys.stdin.read(), sys.argv[1], 'exec'), "
          "{'__name__': '__main__'})")


def run_block(code: str, line: int, python: str, cwd: Path, timeout: float = TIMEOUT_S):
    """Run the block that opens at README line ``line`` with the interpreter ``python`` in ``cwd``: the finished
    ``subprocess.CompletedProcess`` (text stdout and stderr), or None on timeout."""
    try:
        return subprocess.run([python, "-c", RUNNER, str(README)], input="\n" * line + code, cwd=cwd,
                              capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None


def test_the_numbers_quoted_after_the_example_are_the_ones_it_prints():
    """The prose after the end-to-end example quotes its results as the block prints them, digit for digit (a run of
    the same code gives the same bits, so a quoted number that differs is out of date)."""
    text = README.read_text()
    line, code, _ = next(b for b in BLOCKS if "mmlib.run(" in b[1])
    proc = run_block(code, line, sys.executable, ROOT)
    assert proc is not None and proc.returncode == 0, proc and proc.stderr
    prose = text[text.index(code) + len(code):]
    number = r"(\d+(?:\.\d+)?%?)"
    pairs = {"RMSE": (rf"position RMSE {number} \+/- {number} m", rf"position RMSE of {number} ± {number} m"),
             "ANEES": (rf"ANEES {number} \+/- {number}", rf"time-averaged NEES is\s+{number} ± {number}"),
             "inside": (rf"at {number} of the", rf"at only {number} of the"),
             "peak": (rf"peak {number}", rf"peak of\s+{number}")}
    for key, (printed, quoted) in pairs.items():
        got, said = re.search(printed, proc.stdout), re.search(quoted, prose)
        assert got, f"{key}: the example no longer prints {printed!r}:\n{proc.stdout}"
        assert said, f"{key}: the prose after the example no longer quotes {quoted!r}"
        assert said.groups() == got.groups(), \
            f"{key}: the example prints {got.groups()}, the README says {said.groups()}"
