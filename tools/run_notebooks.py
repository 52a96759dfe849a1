#!/usr/bin/env python
"""Execute the paper notebooks headlessly with papermill.

Each notebook (jupytext percent source in notebooks/*.py) is converted to
.ipynb, executed with the ``mmlib`` kernel into a fresh *staging* folder, and
only if every cell succeeds are its outputs promoted into place:

* profile ``full``:  figures/<paper>/, data/results/<paper>.json, notebooks/executed/<name>.ipynb,
  and reports/<paper>.md rendered from the results
* profile ``smoke``: the same layout under build/smoke/

Promotion renames whole folders/files (``os.replace``), so a failed or
interrupted run never leaves a half-written results file or figure that looks
current.  On failure the script names the notebook and the cell and exits 1.
"""
from __future__ import annotations

import argparse
import ast
import logging
import os
import shutil
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
KERNEL = "mmlib"


def sanitize(executed: Path, staging: Path, final_root: Path) -> None:
    """Strip machine-local paths from an executed notebook before it is promoted: the staging folder
    becomes the folder the outputs are promoted to, and every path inside the repository becomes
    relative to it (papermill's metadata, the injected parameters, printed output paths)."""
    text = executed.read_text()
    text = text.replace(str(staging), str(final_root))
    text = text.replace(str(REPO) + "/", "").replace(str(REPO), ".")
    executed.write_text(text)


def promote(staging: Path, final_root: Path, executed: Path, name: str) -> list[str]:
    moved = []
    for fig_dir in sorted((staging / "figures").glob("*")):
        target = final_root / "figures" / fig_dir.name
        target.parent.mkdir(parents=True, exist_ok=True)
        old = target.with_name(f".{target.name}.old")
        if old.exists():
            shutil.rmtree(old)
        if target.exists():
            os.replace(target, old)
        os.replace(fig_dir, target)
        if old.exists():
            shutil.rmtree(old)
        moved.append(str(target.relative_to(REPO)))
    for res in sorted((staging / "data" / "results").glob("*.json")):
        target = final_root / "data" / "results" / res.name
        target.parent.mkdir(parents=True, exist_ok=True)
        os.replace(res, target)
        moved.append(str(target.relative_to(REPO)))
    target = final_root / ("notebooks/executed" if final_root == REPO else "executed") / f"{name}.ipynb"
    target.parent.mkdir(parents=True, exist_ok=True)
    os.replace(executed, target)
    moved.append(str(target.relative_to(REPO)))
    return moved


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--profile", default="full", choices=["full", "smoke"])
    ap.add_argument("--timeout", type=int, default=900, help="seconds per cell")
    ap.add_argument("-p", "--param", action="append", default=[], metavar="NAME=VALUE",
                    help="extra notebook parameter (value parsed as Python literal, else string)")
    ap.add_argument("notebooks", nargs="*", help="notebook sources (default: notebooks/*.py)")
    args = ap.parse_args(argv)
    extra = {}
    for item in args.param:
        if "=" not in item:
            ap.error(f"--param: expected NAME=VALUE, got {item!r}")
        key, value = item.split("=", 1)
        try:
            extra[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            extra[key] = value

    import jupytext
    import papermill as pm
    from papermill.exceptions import PapermillExecutionError

    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    sources = [Path(p).resolve() for p in args.notebooks] or sorted((REPO / "notebooks").glob("*.py"))
    if not sources:
        print("no notebooks found", file=sys.stderr)
        return 1
    build = REPO / "build" / args.profile
    final_root = REPO if args.profile == "full" else build
    t_all = time.perf_counter()
    for i, src in enumerate(sources, 1):
        name = src.stem
        staging = build / "staging" / name
        if staging.exists():
            shutil.rmtree(staging)
        staging.mkdir(parents=True)
        nb_in = build / "converted" / f"{name}.ipynb"
        nb_in.parent.mkdir(parents=True, exist_ok=True)
        jupytext.write(jupytext.read(src), nb_in)
        executed = staging / f"{name}.ipynb"
        print(f"[{i}/{len(sources)}] {name}: executing (profile={args.profile}, kernel={KERNEL})", flush=True)
        t0 = time.perf_counter()
        try:
            pm.execute_notebook(str(nb_in), str(executed), kernel_name=KERNEL,
                                parameters={**extra, "PROFILE": args.profile, "OUTPUT_ROOT": str(staging)},
                                cwd=str(REPO / "notebooks"), execution_timeout=args.timeout,
                                progress_bar=False, log_output=False, stdout_file=sys.stdout,
                                stderr_file=sys.stderr)
        except PapermillExecutionError as exc:
            print(f"\nFAILED: notebook {src.relative_to(REPO)}, cell {exc.cell_index} "
                  f"(execution count {exc.exec_count}): {exc.ename}: {exc.evalue}\n"
                  f"  partial output kept for inspection: {executed.relative_to(REPO)}\n"
                  f"  nothing was promoted; committed outputs are untouched.", file=sys.stderr)
            return 1
        except Exception as exc:  # kernel death, timeout, missing kernel
            print(f"\nFAILED: notebook {src.relative_to(REPO)}: {type(exc).__name__}: {exc}\n"
                  f"  nothing was promoted.", file=sys.stderr)
            return 1
        sanitize(executed, staging, final_root)
        moved = promote(staging, final_root, executed, name)
        shutil.rmtree(staging, ignore_errors=True)
        print(f"[{i}/{len(sources)}] {name}: done in {time.perf_counter() - t0:.1f} s -> " + ", ".join(moved),
              flush=True)
    import make_report
    make_report.main(["--root", str(final_root)])
    print(f"all {len(sources)} notebook(s) done in {time.perf_counter() - t_all:.1f} s (profile={args.profile})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
