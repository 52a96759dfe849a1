"""Tables and figures of a multiverse: factors, claim robustness, readings that reproduce the
published numbers, the one-factor-at-a-time view, the specification curve and the table match; and the forensic
sections of a results file: filter consistency (NEES/NIS against their chi-square bands), sensitivity curves
(verdict against a swept tuning value), planted-reading recovery of the table match, run-count stability,
degenerate universes and the controls of the pipeline.

Markdown tables are returned as text; figures as matplotlib figures (the caller saves them).  Every function reading
a stored section tolerates a results file written before the section existed: it says the section is absent instead
of failing.
"""
from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Any, Callable, Iterable, Sequence

import numpy as np

from mmlib.core._validate import check_bool, check_positive_int
from mmlib.experiment import verdicts
from mmlib.experiment.verdicts import format_pm
from mmlib.experiment.multiverse import PRECISION, ROBUST_FRACTION, Multiverse
from mmlib.experiment.readings import ReadingSpace

__all__ = [
    "paper_verdicts", "verdict_box_html", "findings_line", "findings_lines", "claim_class",
    "markdown_table", "value_pm", "summary_line", "claims_table", "claim_option_table", "numbers_table",
    "table_match_table", "table_match_sentence", "table_match_figure", "specification_curve", "one_factor_table",
    "factors_table", "options_table", "consistency_table", "sensitivity_table", "recovery_table", "recovery_text",
    "stability_text", "degenerate_list", "degenerate_text", "controls_text", "reading_text", "most_reading",
    "share_text", "robustness_text", "claim_words", "claim_cell", "percent"
]

if TYPE_CHECKING:
    import matplotlib.figure


def _cell(v) -> str:
    if v is None:
        return "--"
    if isinstance(v, float):
        return "nan" if not np.isfinite(v) else f"{v:.4g}"
    return str(v).replace("|", "\\|").replace("\n", " ")


def _cells(row, name: str) -> list:
    if isinstance(row, (str, bytes, dict)) or not hasattr(row, "__iter__"):
        raise ValueError(f"{name}: expected a sequence of cells, got {row!r}")
    return list(row)


def markdown_table(header: Sequence[Any], rows: Iterable[Sequence[Any]]) -> str:
    """A Markdown table; ``|`` in any cell (header included) is escaped, floats get 4 digits.  ``header`` and each
    row: sequences of cells of the header's length (a bare string is refused, never split into one letter a cell)."""
    header = _cells(header, "header")
    if not header:
        raise ValueError("header: expected at least one column")
    if isinstance(rows, (str, bytes)) or not hasattr(rows, "__iter__"):
        raise ValueError(f"rows: expected a sequence of rows (sequences of cells), got {rows!r}")
    rows = [_cells(r, f"rows[{i}]") for i, r in enumerate(rows)]
    for i, r in enumerate(rows):
        if len(r) != len(header):
            raise ValueError(f"rows[{i}]: {len(r)} cells for the {len(header)} columns of the header")
    lines = ["| " + " | ".join(_cell(h) for h in header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(v) for v in r) + " |" for r in rows]
    return "\n".join(lines)


def value_pm(value: float | None, stderr: float | None, digits: int = 3) -> str:
    """``"value ± stderr"`` as :func:`format_pm` writes it (the s.e. to two significant figures, the value to the
    same decimal); the value alone with ``digits`` decimals when ``stderr`` is None or not finite, "--" when
    ``value`` is None.  ``digits`` an integer >= 0."""
    verdicts._real(value, "value")
    verdicts._real(stderr, "stderr")
    check_positive_int(digits, "digits", minimum=0)
    if value is None:
        return "--"
    if stderr is None or not np.isfinite(stderr):
        return f"{value:.{digits}f}"
    return format_pm(value, stderr)


def _positive(x, name: str) -> float:
    """A finite real number > 0, returned unchanged."""
    verdicts._real(x, name, none=False)
    if not (math.isfinite(x) and x > 0):
        raise ValueError(f"{name}: expected a finite number > 0, got {x!r}")
    return x


def _summary(mv, key: str):
    """A summary list from a :class:`Multiverse` (computed) or from its ``as_dict()`` form (stored)."""
    if isinstance(mv, dict):
        if key not in mv:
            raise ValueError(f"mv: expected a Multiverse or its as_dict() form, got a dict without {key!r}")
        return mv[key]
    return getattr(_multiverse(mv), key)()


def _multiverse(mv) -> Multiverse:
    if not isinstance(mv, Multiverse):
        raise ValueError(f"mv: expected a Multiverse (run_multiverse), got {type(mv).__name__}")
    return mv


def _factors(space) -> list:
    """The ``factors`` list of a ReadingSpace or of a stored multiverse."""
    if isinstance(space, ReadingSpace):
        return space.as_dict()
    if not isinstance(space, list) or not all(isinstance(f, dict) and "option_details" in f for f in space):
        raise ValueError(f"space: expected a ReadingSpace or the 'factors' list of a stored multiverse, got "
                         f"{type(space).__name__}")
    return space


def factors_table(space: ReadingSpace | list[dict]) -> str:
    """One row per factor: id, what is ambiguous, options (headline in bold), where the paper says it.
    ``space``: a ReadingSpace or the ``factors`` list of a stored multiverse."""
    rows = []
    factors = _factors(space)
    for f in factors:
        opts = "; ".join((f"**{o['name']}**: {o['label']}" if o["name"] == f["headline"]
                          else f"{o['name']}: {o['label']}") for o in f["option_details"])
        rows.append([f["id"], f["label"], opts, f["source"], "yes" if f["influential"] else "no"])
    return markdown_table(["factor", "ambiguity", "options (headline in bold)", "where in the paper",
                           "influential"], rows)


def options_table(space: ReadingSpace | list[dict]) -> str:
    """One row per option: the factor, the option, what it reads, and where the paper's text supports it."""
    factors = _factors(space)
    rows = [[f["id"], o["name"] + (" (headline)" if o["name"] == f["headline"] else ""), o["label"], o["source"]]
            for f in factors for o in f["option_details"]]
    return markdown_table(["factor", "option", "reading", "where the paper's text supports it"], rows)


def percent(x: float) -> str:
    """A fraction in [0, 1] as a whole percentage: ``0.483 -> "48"``."""
    verdicts._real(x, "x", none=False)
    return f"{100 * x:.0f}"


def share_text(entry: dict, verdict: str | None = None) -> str:
    """One verdict's share of the reading space with its interval, ``"holds 48 % [38, 58]"`` (``"holds 100 %"``
    when exact), from an entry of :meth:`Multiverse.claims_summary`; ``verdict`` defaults to the most frequent
    one.  For a design that is not a uniform sample, the entry's robustness text (no share)."""
    if not isinstance(entry, dict) or "share" not in entry or "verdict_counts" not in entry:
        raise ValueError(f"entry: expected an entry of Multiverse.claims_summary(), got {entry!r}")
    if entry["share"] is None:
        return entry["robustness"]
    if verdict is None:
        verdict = max(entry["share"], key=lambda k: (entry["share"][k], k == entry["headline_verdict"]))
    if verdict not in entry["share"]:
        raise ValueError(f"verdict: expected one of {list(entry['share'])}, got {verdict!r}")
    lo, hi = entry["interval"][verdict]
    f = entry["share"][verdict]
    band = "" if lo == hi == f else f" [{percent(lo)}, {percent(hi)}]"
    return f"{verdict} {percent(f)} %{band}"


def robustness_text(entry: dict) -> str:
    """A claim's robustness in one line from an entry of :meth:`Multiverse.claims_summary`: ``"robust — holds 96 %
    [92, 98] (uniform sample of 400 of 10752, seed S)"`` or ``"depends on the reading — holds 48 % [38, 58];
    contradicted 52 % [42, 62] (...)"``; for a design that is not a uniform sample, the counts over its universes
    and the note that they are no share."""
    if not isinstance(entry, dict) or "verdict_counts" not in entry or "robustness" not in entry:
        raise ValueError(f"entry: expected an entry of Multiverse.claims_summary(), got {entry!r}")
    if entry["share"] is None:
        return (f"{entry['robustness']} (counts over the design's universes: "
                + ", ".join(f"{k} {n}" for k, n in entry["verdict_counts"].items()) + ")" + _motivated_note(entry))
    return (f"{entry['robustness']} — " + "; ".join(share_text(entry, k) for k in entry["verdict_counts"])
            + f" ({entry['weighting']})" + _motivated_note(entry))


def _motivated_counts(entry: dict) -> str:
    """The verdict counts among the universes with a motivated option (``entry["motivated"]``), "--" when none."""
    counts = entry.get("motivated") or {}
    if not isinstance(counts, dict):
        raise ValueError(f"entry: 'motivated' must map verdicts to counts, got {counts!r}")
    return ", ".join(f"{k} {n}" for k, n in counts.items() if n) or "--"


def _motivated_note(entry: dict) -> str:
    """``"; apart, universes with an option motivated by the results or another paper: holds 3"`` or ""."""
    counts = _motivated_counts(entry)
    return "" if counts == "--" else f"; apart, universes with an option motivated by the results or another " \
                                     f"paper (not counted): {counts}"


def claim_words(claim: dict) -> str:
    """The words a claim's verdict is stated in: its ``stated`` text when the results file gives one (a qualified
    verdict, "contradicted by the reconstruction"), else the verdict under its ``qualifier``
    (:func:`mmlib.experiment.verdicts.qualified`), else the bare verdict word of the claim vocabulary."""
    if not isinstance(claim, dict) or "verdict" not in claim:
        raise ValueError(f"claim: expected an entry of a results file's claims, got {claim!r}")
    stated = claim.get("stated")
    if stated:
        if not isinstance(stated, str):
            raise ValueError(f"claim: 'stated' must be the verdict's words (a string), got {stated!r}")
        return stated
    return verdicts.qualified(claim["verdict"], claim.get("qualifier") or "")


def claim_cell(claim: dict, across: dict | None) -> str:
    """A claim's verdict cell in a report: exactly one verdict (its words, :func:`claim_words`: qualified, e.g.
    "contradicted by the reconstruction", when the set-up is a reconstruction), the one decisive number and its
    share of the reading space with its interval, ``"holds — IMM5CKF − IMMCKF: position MSE +2.4e+03 % — holds 48 %
    [38, 58] of the space"``.  ``claim`` an entry of a results file's ``claims`` (``verdict``, ``decisive``,
    optionally ``qualifier`` and ``stated``); ``across`` the matching entry of the multiverse's ``claims_summary``
    (None: the paper has no reading space)."""
    words = claim_words(claim)
    word = str(verdicts.claim_category(claim["verdict"]))
    if across is not None and (not isinstance(across, dict) or "share" not in across or "robustness" not in across):
        raise ValueError(f"across: expected None or an entry of Multiverse.claims_summary(), got {across!r}")
    decisive = claim.get("decisive") or "--"
    if across is None:
        share = "no reading space"
    elif across["share"] is None:
        share = across["robustness"]
    else:
        share = share_text(across, word) + " of the space"
    return f"{words} — {decisive} — {share}"


def _weighting_note(summary: list) -> str:
    w = {c["weighting"] for c in summary}
    return "; ".join(sorted(w)) if w else "--"


def claims_table(mv: Multiverse | dict, qualifier: str = "") -> str:
    """Per claim (:meth:`Multiverse.claims_summary`, computed or stored): the headline verdict (qualified by
    ``qualifier``, :func:`mmlib.experiment.verdicts.qualified`, for a reconstructed set-up), each verdict's share
    of the reading space with its 95 % interval (``"holds 48 % [38, 58]"``; exact, without interval, when the full
    factorial is run), robust or not, the star universes' verdicts and those of the universes with an option
    motivated by the results or by another paper (both reported apart, never counted).  The header states the
    weighting (e.g. "uniform sample of 200 of 10752, seed S")."""
    if qualifier not in ("", verdicts.RECONSTRUCTION):
        raise ValueError(f"qualifier: expected '' or {verdicts.RECONSTRUCTION!r}, got {qualifier!r}")
    summary = _summary(mv, "claims_summary")
    rows = []
    for c in summary:
        if c["share"] is None:
            across = c["robustness"] + " (counts over the design: " + \
                ", ".join(f"{k} {n}" for k, n in c["verdict_counts"].items()) + ")"
        else:
            across = "; ".join(share_text(c, k) for k in c["verdict_counts"])
        star = ", ".join(f"{k} {n}" for k, n in c["star_counts"].items()) or "--"
        head = c["headline_verdict"] if not qualifier else verdicts.qualified(c["headline_verdict"], qualifier)
        rows.append([c["claim"], head, across, c["robustness"], star, _motivated_counts(c)])
    return markdown_table(["claim", "headline verdict", f"share of the reading space [95 % interval] "
                                                        f"({_weighting_note(summary)})",
                           f"robust (lower bound ≥ {100 * ROBUST_FRACTION:.0f} % for one verdict)",
                           "star: each option alone (not counted)",
                           "an option motivated by the results or another paper (not counted)"], rows)


def claim_option_table(mv: Multiverse | dict) -> str:
    """The claim x option view: one row per option of every factor, one column per claim (numbered C1, C2, ...:
    listed below the table), each cell the share of that claim's most frequent verdict among the counted universes
    with that option (and their number), so an option that drives a claim stands out.  Empty text with a note when
    the design is not a uniform sample."""
    summary = _summary(mv, "claims_summary")
    with_table = [c for c in summary if c.get("by_option")]
    if not with_table:
        return "No claim x option table: the design is not a uniform sample."
    modal = [max(c["verdict_counts"], key=c["verdict_counts"].get) for c in with_table]
    first = with_table[0]["by_option"]
    rows = []
    for fid, options in first.items():
        for opt in options:
            cells = [f"{fid}: {opt}", options[opt]["n"]]
            for c, v in zip(with_table, modal):
                cell = c["by_option"][fid][opt]
                cells.append("--" if not cell["n"] else f"{percent(cell['share'].get(v, 0.0))} %")
            rows.append(cells)
    header = ["option", "universes"] + [f"C{k + 1}: {v}" for k, v in enumerate(modal)]
    legend = "\n".join(f"- C{k + 1}: {c['claim']} (overall {share_text(c, v)})"
                        for k, (c, v) in enumerate(zip(with_table, modal)))
    return markdown_table(header, rows) + "\n\n" + legend


def _joint(t: dict | None) -> str:
    """A joint test as text: ``"Σz² 12.3 (2 cells, p 0.002): fails"``."""
    if t is None:
        return "--"
    return (f"Σz² {t['statistic']:.3g} ({t['dof']} cell{'s' if t['dof'] != 1 else ''}, p {t['p_value']:.2g}): "
            f"{'passes' if t['passes'] else 'fails'}")


def numbers_table(mv: Multiverse | dict) -> str:
    """Per published number: the headline verdict (a reproduced cell inside a row or table failing its joint test
    is *isolated*) with its row's joint test, the counted universes reproducing it (isolated ones apart), and the
    closest universe among those precise enough (s.e. ≤ ``PRECISION`` of the printed value), by relative
    distance."""
    rows = []
    summary = _summary(mv, "numbers_summary")
    for s in summary:
        c = s["closest"]
        iso = f" (+{s['n_isolated']} isolated)" if s["n_isolated"] else ""
        rows.append([s["item"], s["algorithm"], s["quantity"], s["paper"], s["headline_verdict"],
                     _joint(s["joint_test"]["row"]) if s["joint_test"] else "--",
                     f"{s['n_reproduced']} / {s['n_counted']}{iso}",
                     s["closest_status"] if c is None else value_pm(c["replicated"], c["stderr"]),
                     "--" if c is None else f"{100 * c['relative_distance']:.1f} %",
                     "--" if c is None else c["verdict"],
                     "--" if c is None else c["describe"]])
    prec = f"{100 * PRECISION:.0f} %"
    return markdown_table(["item", "algorithm", "quantity", "paper", "headline verdict", "headline row's joint test",
                           f"universes reproducing ({_weighting_note(summary)})",
                           f"closest precise universe (s.e. ≤ {prec} of the paper's)", "its relative distance",
                           "its verdict", "closest reading"], rows)


def _table_entry(t, name: str = "t") -> dict:
    if not isinstance(t, dict) or "most_describe" not in t or "most_n_reproduced" not in t:
        raise ValueError(f"{name}: expected an entry of Multiverse.table_match(), got {t!r}")
    return t


def _recovery_of(t: dict) -> dict | None:
    """The table's planted-reading recovery entry (``t["recovery"]``), None when the results hold none."""
    rec = t.get("recovery")
    if rec is not None and (not isinstance(rec, dict) or "top1" not in rec):
        raise ValueError(f"t: 'recovery' must be a table's recovery entry (planted, top1, top3, ...), got {rec!r}")
    return rec


def reading_text(t: dict, which: str = "best") -> str:
    """The ``which`` reading (``"best"``: the best-matching precise one; ``"most"``: the one reproducing the most
    cells) of a table-match entry, as the forensic sentence may name it: the options differing from the headline,
    except those of a factor the table cannot identify (its planted-reading recovery entry's ``unidentifiable``),
    which are never named as what the table is consistent with; such factors are listed as unidentifiable, and an
    option the table cannot tell from another (``indistinguishable``) says so.  Without a recovery entry (results
    written before it existed), the reading's description unchanged."""
    t = _table_entry(t)
    if which not in ("best", "most"):
        raise ValueError(f"which: expected 'best' or 'most', got {which!r}")
    describe = t.get(f"{which}_describe") or "--"
    reading = t.get(f"{which}_reading")
    rec = _recovery_of(t)
    if rec is None or not isinstance(reading, dict):
        return describe
    unident = [str(f) for f in rec.get("unidentifiable") or []]
    twins = rec.get("indistinguishable") or {}
    parts = [describe]
    if describe != "headline" and reading:
        ids = "|".join(re.escape(str(f)) for f in sorted(reading, key=lambda f: -len(str(f))))
        parts = re.split(rf"; (?=(?:{ids}): )", describe)
    kept = []
    for part in parts:
        fid = part.split(": ", 1)[0]
        if fid in unident:
            continue
        others = [o for pair in twins.get(fid, []) if reading.get(fid) in pair for o in pair if o != reading.get(fid)]
        kept.append(part + (f" (not told apart from {', '.join(dict.fromkeys(others))})" if others else ""))
    text = "; ".join(kept) if kept else "headline in every identifiable factor"
    if unident:
        text += f" ({', '.join(unident)} unidentifiable from the table)"
    return text


def most_reading(t: dict) -> str:
    """The reading that reproduces the most cells of a table (:func:`reading_text`: a factor the table cannot
    identify is named unidentifiable, never as part of the reading), or 'none' when no reading reproduces any."""
    t = _table_entry(t)
    return reading_text(t, "most") if t["most_n_reproduced"] else "none (no reading reproduces a cell)"


def _rate(x, interval=None) -> str:
    """``"34 % [25, 44]"`` from a fraction and its interval (fractions), ``"34 %"`` without one, "--" for None."""
    if x is None:
        return "--"
    verdicts._real(x, "rate", none=False)
    if interval is None:
        return f"{percent(x)} %"
    lo, hi = interval
    return f"{percent(x)} % [{percent(lo)}, {percent(hi)}]"


def recovery_text(entry: dict) -> str:
    """How well the table match recovers a reading planted at random in the declared space (issue 24), from a
    table's entry of ``multiverse.recovery["tables"]`` (or the paper-wide ``multiverse.recovery``): ``"planted
    readings recovered first in 34 % [25, 44] of 50 trials, in the top three 61 % [51, 70]; unidentifiable from the
    table: H-9, H-10"`` (95 % Wilson intervals when the entry gives them).  Each trial draws a universe of the space,
    makes a synthetic printed table from it at the paper's run count, seed stream and printed precision, and ranks
    the universes by the table match; a factor is unidentifiable when its options give the same table within
    noise."""
    if not isinstance(entry, dict) or "top1" not in entry or "planted" not in entry:
        raise ValueError(f"entry: expected a recovery entry (planted, top1, top3, ...), got {entry!r}")
    k = entry["planted"]
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 0:
        raise ValueError(f"entry: 'planted' must be the number of trials (an integer >= 0), got {k!r}")
    if not k or entry["top1"] is None:
        text = "no planted reading was tried"
    else:
        text = (f"planted readings recovered first in {_rate(entry['top1'], entry.get('top1_interval'))} of {k} "
                f"trials, in the top three {_rate(entry.get('top3'), entry.get('top3_interval'))}")
    unident = [str(f) for f in entry.get("unidentifiable") or []]
    return text + ("; unidentifiable from the table: " + ", ".join(unident) if unident
                   else "; every factor identifiable from the table")


def table_match_sentence(t: dict) -> str:
    """The forensic sentence of one published table, with the evidence it needs: ``"Table 1 is consistent with
    reading Z-7: noise-free truth (RMS relative distance 4.1 %, joint test passes; 3 readings searched); planted
    readings recovered first in 34 % [25, 44] of 50 trials, ...; unidentifiable from the table: Z-6"``.  The
    table is called *consistent* with its best-matching precise reading only when that reading's joint test passes;
    otherwise the sentence says the reading is the closest and that the table fails its joint test under every
    reading.  A factor the table cannot identify is never named (:func:`reading_text`)."""
    t = _table_entry(t)
    if t.get("best_reading") is None:
        head = f"{t['table']}: {t.get('best_describe') or 'no reading precise enough'}"
    else:
        rms = t.get("best_rms_relative")
        test = t.get("best_joint_test")
        evidence = ("--" if rms is None else f"RMS relative distance {100 * rms:.1f} %") + \
            ("" if test is None else f", {_joint(test)}")
        searched = t.get("n_candidates")
        evidence += "" if searched is None else f"; {searched} readings searched"
        verb = "is consistent with" if test is not None and test["passes"] else \
            "fails its joint test under every reading searched; the closest is"
        head = f"{t['table']} {verb} reading {reading_text(t, 'best')} ({evidence})"
    rec = _recovery_of(t)
    if rec is None:
        return head + "; the table match's recovery of planted readings is not in these results"
    return head + "; " + recovery_text(rec)


def table_match_table(mv: Multiverse | dict) -> str:
    """Per published table (:meth:`Multiverse.table_match`, computed or stored): its cells; the headline's cells
    reproduced (isolated ones apart), Σz² and joint test; the counted universes whose table passes its joint test;
    the best-matching precise reading (smallest root-mean-square relative distance among the universes whose every
    cell has s.e. ≤ ``PRECISION`` of the printed value) with its Σz² and joint test; and the reading that reproduces
    the most cells."""
    rows = []
    for t in _summary(mv, "table_match"):
        iso = f" (+{t['isolated']} isolated)" if t["isolated"] else ""
        rec = _recovery_of(t)
        rows.append([t["table"], t["n_cells"], f"{t['headline_n_reproduced']} / {t['n_cells']}{iso}",
                     _joint(t["joint_test"]), f"{t['n_passing']} / {t['n_counted']}",
                     "--" if t.get("n_candidates") is None else t["n_candidates"],
                     reading_text(t, "best"),
                     "--" if t["best_rms_relative"] is None else f"{100 * t['best_rms_relative']:.1f} %",
                     _joint(t["best_joint_test"]), f"{t['best_n_reproduced']} / {t['n_cells']}",
                     f"{t['most_n_reproduced']} / {t['n_cells']}", most_reading(t),
                     "not in these results" if rec is None else recovery_text(rec)])
    return markdown_table(["table", "cells", "headline universe: cells reproduced", "headline joint test",
                           "universes passing the joint test", "readings searched (sensitivity sweeps and "
                                                               "motivated options excluded)",
                           f"best-matching precise reading (s.e. ≤ {100 * PRECISION:.0f} %)",
                           "its RMS relative distance", "its joint test", "its cells reproduced",
                           "most cells any reading reproduces", "that reading",
                           "planted-reading recovery of the table match"], rows)


def one_factor_table(mv: Multiverse, columns: Sequence[tuple[str, tuple]]) -> str:
    """The one-factor-at-a-time view: ``columns`` is a list of (header, key) with key a value key
    (item, algorithm, quantity) or ``("effect", name)``."""
    _multiverse(mv)
    if isinstance(columns, (str, bytes, dict)) or not hasattr(columns, "__iter__"):
        raise ValueError(f"columns: expected a sequence of (header, key) pairs, got {columns!r}")
    columns = list(columns)
    for i, c in enumerate(columns):
        if not (isinstance(c, (tuple, list)) and len(c) == 2 and isinstance(c[0], str) and isinstance(c[1], tuple)
                and (len(c[1]) == 3 or (len(c[1]) == 2 and c[1][0] == "effect"))):
            raise ValueError(f"columns[{i}]: expected (header, (item, algorithm, quantity)) or (header, ('effect', "
                             f"name)), got {c!r}")
    rows = []
    for i, fid, reading in mv.one_factor_view():
        u = mv.universes[i]
        label = "headline" if fid is None else f"{fid}: {mv.space.factor(fid).option(reading[fid]).label}"
        cells = [label]
        for _, key in columns:
            if key[0] == "effect":
                e = mv.effect(u, key[1])
                cells.append(value_pm(e.value, e.stderr, 3 if abs(e.value or 0) < 100 else 0))
            else:
                v = mv.value(u, key)
                cells.append("--" if v is None else value_pm(v.replicated, v.stderr, 2))
        ndiv = sum(u.diverged.values())
        cells.append(str(ndiv) if ndiv else "")
        rows.append(cells)
    return markdown_table(["reading (one factor changed)"] + [h for h, _ in columns] + ["diverged runs"], rows)


def specification_curve(mv: Multiverse, effect: str, *, ylabel: str, title: str, published: float | None = None,
                        interval: float = verdicts.SIGMA_FACTOR, symlog: bool = False) -> matplotlib.figure.Figure:
    """Universes sorted by an effect (value ± ``interval`` standard errors; the verdict rule's band),
    the headline in red, the published value dashed, and below it which option each universe uses
    (Simonsohn, Simmons & Nelson 2020)."""
    import matplotlib
    import matplotlib.pyplot as plt
    _multiverse(mv)
    for value, arg in ((effect, "effect"), (ylabel, "ylabel"), (title, "title")):
        if not isinstance(value, str):
            raise ValueError(f"{arg}: expected a string, got {value!r}")
    if published is not None:
        verdicts._real(published, "published")
    interval = _positive(interval, "interval")
    check_bool(symlog, "symlog")
    vals = [mv.effect(u, effect) for u in mv.universes]
    y = np.array([np.nan if v.value is None else v.value for v in vals])
    se = np.array([0.0 if v.stderr is None else v.stderr for v in vals])
    order = np.argsort(np.where(np.isfinite(y), y, np.inf), kind="stable")
    n = len(order)
    factors = mv.space.factors
    n_rows = sum(len(f.options) for f in factors)
    fig, (ax, axp) = plt.subplots(2, 1, figsize=(max(7.5, min(16, 0.09 * n + 6)), 3.6 + 0.16 * n_rows),
                                  sharex=True, gridspec_kw={"height_ratios": [3.2, 0.16 * n_rows + 0.4]})
    x = np.arange(n)
    ys, ses = y[order], se[order]
    head_pos = int(np.where(order == 0)[0][0])
    has = np.isfinite(ys)
    no_se = has & np.array([vals[i].stderr is None for i in order])       # e.g. a single surviving run
    plain = has & ~no_se & (x != head_pos)
    ax.errorbar(x[has], ys[has], yerr=interval * ses[has], fmt="none", ecolor="0.6", elinewidth=0.8, zorder=1)
    ax.scatter(x[plain], ys[plain], c="C0", s=14, zorder=2, label="universe (± %g s.e.)" % interval)
    if no_se.any():
        ax.scatter(x[no_se], ys[no_se], facecolors="none", edgecolors="C0", s=30, zorder=2,
                   label=f"no standard error ({int(no_se.sum())}: a single run)")
    if has[head_pos]:
        ax.scatter([head_pos], [ys[head_pos]], c="C3", s=40, marker="D", zorder=3, label="headline reading")
    ax.axhline(0.0, color="k", lw=0.8)
    pub = published if published is not None else vals[0].published
    if pub is not None:
        ax.axhline(pub, color="C2", ls="--", lw=1.2, label=f"published ({pub:.3g})")
    if symlog:        # linear within the decade of the smallest |effect|, logarithmic beyond
        finite = np.abs(np.concatenate([y[np.isfinite(y) & (y != 0)], [pub] if pub else []]))
        linthresh = 10.0 ** np.floor(np.log10(np.min(finite))) if finite.size else 1.0
        ax.set_yscale("symlog", linthresh=linthresh, linscale=0.6)
        ax.yaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        ax.yaxis.set_major_locator(matplotlib.ticker.SymmetricalLogLocator(base=10, linthresh=linthresh,
                                                                          subs=[1.0]))
    # the limits hold every value, its band and the published value, with room at both ends
    ends = [v for v in np.concatenate([ys[has] - interval * ses[has], ys[has] + interval * ses[has]])] + \
        ([pub] if pub is not None else []) + [0.0]
    lo, hi = min(ends), max(ends)
    if symlog:
        grow = (lambda v, f: v * f if abs(v) > linthresh else v + np.sign(v or 1) * linthresh)
        ax.set_ylim(grow(lo, 3.0) if lo < 0 else -linthresh, grow(hi, 3.0) if hi > 0 else linthresh)
    else:
        pad = 0.08 * (hi - lo or 1.0)
        ax.set_ylim(lo - pad, hi + pad)
    missing = np.where(~has)[0]
    if missing.size:              # no universe is dropped silently: marked along the bottom, apart from the data
        strip = matplotlib.transforms.blended_transform_factory(ax.transData, ax.transAxes)
        ax.scatter(missing, np.full(missing.size, 0.03), transform=strip, marker="x", c="k", s=30, zorder=3,
                   clip_on=False, label=f"no value ({missing.size} universes: every run diverged)")
        if not has[head_pos]:
            ax.scatter([head_pos], [0.03], transform=strip, marker="D", facecolors="none", edgecolors="C3", s=60,
                       zorder=4, clip_on=False, label="headline reading (no value)")
    ax.set(ylabel=ylabel, title=title)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    axp.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    row, yt, ylab = 0, [], []
    for f in factors:
        for o in f.options:
            used = [j for j, i in enumerate(order) if mv.readings[i][f.id] == o.name]
            axp.scatter(used, [row] * len(used), s=8, marker="s",
                        c="C3" if o.name == f.headline else "0.25")
            yt.append(row)
            ylab.append(f"{f.id}: {o.label}"[:64])
            row += 1
        axp.axhline(row - 0.5, color="0.8", lw=0.6)
    axp.set_yticks(yt)
    axp.set_yticklabels(ylab, fontsize=7)
    axp.set_ylim(row - 0.5, -0.5)
    axp.set_xlabel(f"universe, sorted by the effect ({n} universes; headline options in red)")
    axp.grid(False)
    fig.tight_layout()
    return fig


def table_match_figure(mv: Multiverse, *, title: str) -> matplotlib.figure.Figure:
    """Per published table, the sum of squared standardized distances of each universe (sorted),
    the headline and the best match (:meth:`Multiverse.table_match`: among the precise universes, the smallest
    root-mean-square relative distance) marked; the universes with a cell not precise enough are ringed."""
    import matplotlib.pyplot as plt
    _multiverse(mv)
    if not isinstance(title, str):
        raise ValueError(f"title: expected a string, got {title!r}")
    tables = [t for t in mv.tables if any(s is not None for s in mv.table_distances(t))]
    fig, axes = plt.subplots(1, len(tables), figsize=(4.2 * len(tables) + 1, 3.8), squeeze=False)
    for ax, table in zip(axes[0], tables):
        sums = np.array([np.nan if s is None else s for s in mv.table_distances(table)])
        order = np.argsort(np.where(np.isfinite(sums), sums, np.inf), kind="stable")
        ax.plot(np.arange(len(order)), sums[order], ".", color="C0", ms=4, label="universe")
        hp = int(np.where(order == 0)[0][0])
        ax.plot([hp], [sums[0]], "D", color="C3", ms=7, label="headline")
        pubs = [p for p in mv.published if p.table == table]
        precise = mv.table_precise(table)
        vague = [k for k, i in enumerate(order) if not precise[i]]
        if vague:
            ax.plot(vague, sums[order][vague], "o", mfc="none", mec="0.5", ms=6,
                    label=f"a cell's s.e. > {100 * PRECISION:.0f} % ({len(vague)}; not eligible)")
        best = {t["table"]: t for t in mv.table_match()}[table]["best_universe"]
        if best is not None:
            bp = int(np.where(order == best)[0][0])
            ax.plot([bp], [sums[best]], "*", color="C2", ms=11, label="best match (precise; RMS relative distance)")
        n_cells = len(pubs)
        ax.axhline(9.0 * n_cells, color="0.4", ls=":", lw=1, label="every cell at 3 s.e.")
        failed = np.where(np.isinf(sums[order]))[0]      # a cell whose algorithm failed (e.g. diverged)
        if failed.size:
            finite = sums[np.isfinite(sums)]
            top = 3.0 * max(float(finite.max()) if finite.size else 1.0, 9.0 * n_cells)
            ax.plot(failed, np.full(failed.size, top), "x", color="k", ms=5,
                    label=f"a cell failed ({failed.size}; drawn at the top)")
            if np.isinf(sums[0]):
                ax.plot([hp], [top], "D", color="C3", ms=7)
        ax.xaxis.set_major_locator(__import__("matplotlib").ticker.MaxNLocator(integer=True))
        ax.set(yscale="log", xlabel="universe, sorted", ylabel="Σ z² over the table's cells",
               title=f"{table} ({n_cells} cells)")
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def summary_line(mv: Multiverse | dict) -> str:
    """Per paper, in one line: the most cells of each published table that one reading reproduces (isolated
    coincidences not counted; of the readings searched, and with the table match's planted-reading recovery when
    the results give them; a factor the table cannot identify is never named as part of the reading), how many claim
    verdicts are robust across the reading space with its weighting, and the universes not counted (degenerate, or
    with an option motivated by the results or another paper) (from a Multiverse or its stored form)."""
    parts = []
    for t in _summary(mv, "table_match"):
        by = f", by {most_reading(t)}" if t["most_n_reproduced"] else ""
        searched = "" if t.get("n_candidates") is None else f" of {t['n_candidates']} searched"
        rec = _recovery_of(t)
        recovered = "" if rec is None or rec.get("top1") is None else \
            f"; the table match ranks a planted reading first in {_rate(rec['top1'], rec.get('top1_interval'))}"
        parts.append(f"{t['table']}: {'a' if t['most_n_reproduced'] == t['n_cells'] else 'no'} reading{searched} "
                     f"reproduces all {t['n_cells']} cells (at most {t['most_n_reproduced']}{by}; headline universe "
                     f"{t['headline_n_reproduced']}{recovered})")
    claims = _summary(mv, "claims_summary")
    apart = []
    n_degenerate, n_motivated = _section(mv, "n_degenerate"), _section(mv, "n_motivated")
    if n_degenerate:
        apart.append(f"{n_degenerate} degenerate")
    if n_motivated:
        apart.append(f"{n_motivated} with an option motivated by the results or another paper")
    apart_text = f"; universes not counted: {', '.join(apart)}" if apart else ""
    if claims and all(c["share"] is None for c in claims):
        return "; ".join(parts + [f"claim verdicts: {claims[0]['robustness']}"]) + apart_text
    robust = sum(bool(c["robust"]) for c in claims)
    return "; ".join(parts + [f"{robust} of {len(claims)} claim verdicts robust across the reading space "
                              f"({_weighting_note(claims)})"]) + apart_text


# -- the forensic sections (issue 24) ---------------------------------------------------------------------------

def _section(mv, key: str):
    """A section of a multiverse: ``mv[key]`` of its stored form (None when the results predate it), or the
    attribute (called when a method) of a computed :class:`Multiverse` (None when it has none)."""
    if isinstance(mv, dict):
        return mv.get(key)
    value = getattr(_multiverse(mv), key, None)
    return value() if callable(value) else value


def _pm_sig(value, stderr) -> str:
    """``"4.02 ± 0.05"``: :func:`format_pm` (the value to the decimals of two significant digits of its standard
    error; 4 significant digits without one), "--" for None."""
    if value is None:
        return "--"
    verdicts._real(value, "value", none=False)
    return format_pm(value, stderr)


def _consistency_cells(stat, where: str) -> list:
    """``[value ± s.e. [band], inside?]`` of one :func:`mmlib.experiment.evaluation.consistency` summary."""
    if stat is None:
        return ["--", "--"]
    if not isinstance(stat, dict) or "value" not in stat:
        raise ValueError(f"{where}: expected a consistency summary (value, stderr, dof, band, inside, ...), got "
                         f"{stat!r}")
    if stat["value"] is None:
        return [f"-- (fewer than 2 valid runs: {stat.get('n_runs', '--')})", "--"]
    band = stat.get("band")
    text = _pm_sig(stat["value"], stat.get("stderr"))
    if band:
        text += f" [{band[0]:.3g}, {band[1]:.3g}]"
    if stat.get("dof") is not None:
        text += f" (dof {stat['dof']:.3g})"
    inside = stat.get("inside")
    cell = "--" if inside is None else ("yes" if inside else "no")
    detail = [f"{percent(stat[k])} % of {what}" for k, what in (("steps_inside", "steps"), ("runs_inside", "runs"))
              if stat.get(k) is not None]
    if detail:
        cell += f" ({', '.join(detail)})"
    return [text, cell]


def consistency_table(entries: Sequence[dict]) -> str:
    r"""The filters' consistency, one row per algorithm and case, from a results file's ``consistency`` section
    (:func:`mmlib.experiment.evaluation.consistency_entries`): the runs used, the ANEES and the ANIS each as value ±
    standard error with its 95 % chi-square band and degrees of freedom, and whether the value lies inside the band
    (with the share of time steps whose run-average, and of runs whose time average, lie inside their own bands).

    A consistent filter's NEES :math:`\tilde x^\top P^{-1}\tilde x` is :math:`\chi^2_n` (n the state dimension) and
    its NIS :math:`\nu^\top S^{-1}\nu` is :math:`\chi^2_m` (m the measurement dimension); ANEES and ANIS are their
    averages over runs and steps, whose mean is the degrees of freedom (Bar-Shalom, Li & Kirubarajan 2001, Sec.
    5.4.2).  ``entries``: a sequence of dicts with ``algorithm`` and optionally ``case``, ``anees``, ``anis`` (a
    missing statistic is shown as "--")."""
    if isinstance(entries, (str, bytes, dict)) or not hasattr(entries, "__iter__"):
        raise ValueError(f"entries: expected the list of a results file's 'consistency' section, got {entries!r}")
    entries = list(entries)
    if not entries:
        return "No NEES or NIS was recorded."
    rows = []
    for i, e in enumerate(entries):
        if not isinstance(e, dict) or "algorithm" not in e:
            raise ValueError(f"entries[{i}]: expected {{algorithm, case, anees, anis}}, got {e!r}")
        n = next((s.get("n_runs") for s in (e.get("anees"), e.get("anis")) if isinstance(s, dict)), None)
        rows.append([e["algorithm"], e.get("case") or "--", "--" if n is None else n,
                     *_consistency_cells(e.get("anees"), f"entries[{i}]['anees']"),
                     *_consistency_cells(e.get("anis"), f"entries[{i}]['anis']")])
    return markdown_table(["algorithm", "case", "valid runs", "ANEES ± s.e. [95 % band]", "ANEES inside its band",
                           "ANIS ± s.e. [95 % band]", "ANIS inside its band"], rows)


def sensitivity_table(mv: Multiverse | dict) -> str:
    """The sensitivity curves of a multiverse (``multiverse.sensitivity``; :meth:`Multiverse.sensitivity`): per
    sensitivity factor (an unstated tuning value swept over a range, never a reading of the paper), one row per
    swept value, the other factors at their headline: each claim's verdict (columns C1, C2, ... listed below the
    table) and, per published table, the cells reproduced, the root-mean-square relative distance and the joint
    test.  The headline value is marked.  A results file without the section is said to have none."""
    curves = _section(mv, "sensitivity")
    if curves is None:
        return "No sensitivity curves in these results."
    if isinstance(curves, (str, bytes, dict)) or not hasattr(curves, "__iter__"):
        raise ValueError(f"mv: 'sensitivity' must be a list of curves, one per sensitivity factor, got {curves!r}")
    curves = list(curves)
    if not curves:
        return "No sensitivity factor: every factor of the space is a reading of the text."
    claims, tables = [], []
    for i, c in enumerate(curves):
        if not isinstance(c, dict) or "factor" not in c or not isinstance(c.get("options"), list):
            raise ValueError(f"mv: sensitivity[{i}] must be {{factor, label, headline, options: [...]}}, got {c!r}")
        for o in c["options"]:
            if not isinstance(o, dict) or "option" not in o:
                raise ValueError(f"mv: sensitivity[{i}] has an option without its name: {o!r}")
            claims += [k for k in (o.get("claims") or {}) if k not in claims]
            tables += [k for k in (o.get("tables") or {}) if k not in tables]
    n_cells = {}
    if isinstance(mv, dict):
        n_cells = {t["table"]: t.get("n_cells") for t in mv.get("table_match") or [] if isinstance(t, dict)}
    rows = []
    for c in curves:
        for o in c["options"]:
            label = o.get("label") or o["option"]
            if o["option"] == c.get("headline"):
                label += " (headline)"
            cells = [f"{c['factor']}: {c.get('label', '')}".rstrip(": "), label]
            cells += [(o.get("claims") or {}).get(k, "--") for k in claims]
            for t in tables:
                m = (o.get("tables") or {}).get(t)
                if not m:
                    cells.append("--")
                    continue
                of = f" / {n_cells[t]}" if n_cells.get(t) is not None else ""
                rms = m.get("rms_relative")
                joint = m.get("joint_passes")
                cells.append(f"{m.get('n_reproduced', '--')}{of} reproduced; RMS "
                             + ("--" if rms is None else f"{100 * rms:.1f} %")
                             + ("" if joint is None else f"; joint test {'passes' if joint else 'fails'}"))
            rows.append(cells)
    header = ["sensitivity factor", "swept value"] + [f"C{k + 1}" for k in range(len(claims))] + \
        [f"{t}: cells reproduced, RMS relative distance" for t in tables]
    legend = "\n".join(f"- C{k + 1}: {claim}" for k, claim in enumerate(claims))
    return markdown_table(header, rows) + ("\n\n" + legend if legend else "")


def recovery_table(mv: Multiverse | dict) -> str:
    """Planted-reading recovery per published table (``multiverse.recovery["tables"]``): the recovery sentence
    (:func:`recovery_text`), and per factor the share of trials whose planted option the best match recovered, with
    the options the table cannot tell apart.  A results file without the section is said to have none."""
    rec = _section(mv, "recovery")
    if rec is None:
        return "No planted-reading recovery in these results."
    if not isinstance(rec, dict) or "planted" not in rec:
        raise ValueError(f"mv: 'recovery' must be {{planted, top1, top3, unidentifiable, tables}}, got {rec!r}")
    tables = rec.get("tables") or []
    if not tables:
        return recovery_text(rec) + "."
    rows = []
    for i, t in enumerate(tables):
        if not isinstance(t, dict) or "table" not in t:
            raise ValueError(f"mv: recovery['tables'][{i}] must be a table's recovery entry, got {t!r}")
        twins = t.get("indistinguishable") or {}
        by = t.get("by_factor") or {}
        unident = set(map(str, t.get("unidentifiable") or []))
        factors = "; ".join(
            f"{f} {_rate(r)}" + (" (unidentifiable)" if str(f) in unident else "")
            + ("" if not twins.get(f) else " — not told apart: "
               + ", ".join(" = ".join(map(str, pair)) for pair in twins[f]))
            for f, r in by.items()) or "--"
        rows.append([t["table"], recovery_text(t), factors])
    return markdown_table(["table", "planted readings recovered by the table match",
                           "planted option recovered, per factor"], rows)


def stability_text(mv: Multiverse | dict) -> str:
    """Whether the claims' verdicts are stable in the run count (``multiverse.stability``, written by the lead's
    :attr:`Multiverse.stability`): the statement the check wrote when it gives one, else ``"Run-count check: the
    verdicts of 6 universes at 40 runs (the universes' count) and at 200: 1 changes (claim C)"``.
    A results file without the section is said to have none."""
    st = _section(mv, "stability")
    if st is None:
        return "No run-count check in these results."
    if not isinstance(st, dict) or "n_changed" not in st:
        raise ValueError(f"mv: 'stability' must be {{n_runs_universe, n_runs_check, universes, n_changed, "
                         f"claims_changed, statement}}, got {st!r}")
    if st.get("statement"):
        return str(st["statement"])
    n_u = len(st.get("universes") or [])
    changed = [str(c) for c in st.get("claims_changed") or []]
    n = st["n_changed"]
    which = f" ({'; '.join(changed)})" if changed else ""
    return (f"Run-count check: the verdicts of {n_u} universe{'s' if n_u != 1 else ''} at "
            f"{st.get('n_runs_universe', '--')} runs (the universes' count) and at "
            f"{st.get('n_runs_check', '--')}: " + ("no verdict changes." if not n else
                                     f"{n} verdict{'s' if n != 1 else ''} change{'s' if n == 1 else ''}{which}."))


def _describe_stored(reading: dict, factors: list) -> str:
    """:meth:`ReadingSpace.describe` of a stored reading with the stored factors: 'headline' or the options that
    differ from the headline."""
    parts = []
    for f in factors:
        opt = reading.get(f["id"])
        if opt is not None and opt != f["headline"]:
            label = next((o["label"] for o in f.get("option_details", []) if o["name"] == opt), opt)
            parts.append(f"{f['id']}: {label}")
    return "; ".join(parts) or "headline"


def degenerate_list(mv: Multiverse | dict) -> list[dict] | None:
    """The degenerate universes of a multiverse, ``[{"universe", "describe", "reason"}]`` (every estimator no better
    than the no-information baseline; :func:`mmlib.experiment.evaluation.degenerate_reason`): the stored
    ``multiverse.degenerate`` list, else read off the universes' ``degenerate`` flags; None when the results predate
    the flag (no universe carries the key and there is no list)."""
    if isinstance(mv, dict):
        if isinstance(mv.get("degenerate"), list):
            return mv["degenerate"]
        universes = mv.get("universes")
        if not isinstance(universes, list):
            raise ValueError("mv: expected a Multiverse or its as_dict() form, got a dict without 'universes'")
        if "n_degenerate" not in mv and not any(isinstance(u, dict) and "degenerate" in u for u in universes):
            return None
        factors = mv.get("factors") or []
        return [{"universe": i, "describe": _describe_stored(u.get("reading") or {}, factors),
                 "reason": u["degenerate"]} for i, u in enumerate(universes) if u.get("degenerate")]
    m = _multiverse(mv)
    return [{"universe": i, "describe": m.space.describe(r), "reason": u.degenerate}
            for i, (r, u) in enumerate(zip(m.readings, m.universes)) if getattr(u, "degenerate", "")]


def degenerate_text(mv: Multiverse | dict, limit: int | None = None) -> str:
    """The degenerate universes named: ``"2 of 192 universes are degenerate (...): their comparisons are not counted
    in the shares of the reading space.\\n\\n- universe 5 (Z-2: drift): every estimator's error is at least ..."``;
    ``limit`` (an integer >= 1, or None for all) caps the list, saying how many more there are.  "No universe is
    degenerate." when none is; a results file written before the flag existed is said to carry none."""
    if limit is not None:
        check_positive_int(limit, "limit")
    found = degenerate_list(mv)
    if found is None:
        return "No degenerate-universe flag in these results."
    n_all = len(mv["universes"]) if isinstance(mv, dict) else len(_multiverse(mv).universes)
    if not found:
        return "No universe is degenerate (in every universe some estimator does better than the no-information " \
               "baseline)."
    for i, d in enumerate(found):
        if not isinstance(d, dict) or "reason" not in d:
            raise ValueError(f"mv: degenerate[{i}] must be {{universe, describe, reason}}, got {d!r}")
    shown = found if limit is None else found[:limit]
    lines = [f"{len(found)} of {n_all} universes {'is' if len(found) == 1 else 'are'} degenerate (every estimator "
             "no better than the no-information baseline: a comparison there measures only how the estimators "
             "fail); their comparisons are not counted in the shares of the reading space.", ""]
    lines += [f"- universe {d.get('universe', '--')} ({d.get('describe', '--')}): {d['reason']}" for d in shown]
    if len(found) > len(shown):
        lines.append(f"- and {len(found) - len(shown)} more")
    return "\n".join(lines)


def _count_pair(section: dict, key: str, where: str) -> str:
    n, total = section.get(key), section.get("n_cells")
    if n is None or total is None:
        raise ValueError(f"controls: '{where}' must give n_cells and {key}, got {section!r}")
    return f"{n}/{total}"


def controls_text(controls: dict) -> str:
    """The controls of the pipeline in one sentence, from the ``controls`` section of data/results/controls.json:
    ``"the machinery reproduces when the paper is right: positive control 12/12 cells reproduced, negative control
    12/12 rejected (each cell perturbed by +10 %), power 98 % [95, 99]"`` (the power of the rule at the paper's
    run count, with its interval when given), then what was searched for
    a published third control.  The positive control is a table known in closed form (the steady-state Kalman filter
    of the DWNA model: Kalata 1984; Bar-Shalom, Li & Kirubarajan 2001, Sec. 6.5) that the whole pipeline must
    reproduce; the negative control the same table perturbed, which it must reject."""
    if not isinstance(controls, dict) or not isinstance(controls.get("positive"), dict) \
            or not isinstance(controls.get("negative"), dict):
        raise ValueError(f"controls: expected {{positive: {{n_cells, n_reproduced}}, negative: {{n_cells, "
                         f"n_not_reproduced, perturbation, power}}, searched}}, got {controls!r}")
    pos, neg = controls["positive"], controls["negative"]
    text = (f"the machinery reproduces when the paper is right: positive control "
            f"{_count_pair(pos, 'n_reproduced', 'positive')} cells reproduced, negative control "
            f"{_count_pair(neg, 'n_not_reproduced', 'negative')} rejected")
    pert = neg.get("perturbation")
    if isinstance(pert, (int, float)) and not isinstance(pert, bool):
        text += f" (each cell perturbed by {100 * pert:+.3g} %)"
    elif pert:
        text += f" ({pert})"
    power = neg.get("power")
    if isinstance(power, dict):
        value, interval = power.get("value"), power.get("interval")
        text += f", power {_rate(value, interval)}" if value is not None else ""
    elif power is not None:
        text += f", power {_rate(power)}"
    searched = controls.get("searched")
    return text + (f". A published third control: {searched}" if searched else "")


# -- findings first (issue 26): the verdict box of a paper's page and the one-line findings ---------------------

def _is_control(doc: dict) -> bool:
    return doc.get("kind") == "control" or "controls" in doc


def _doc(doc, name: str = "doc") -> dict:
    if not isinstance(doc, dict) or not isinstance(doc.get("paper"), str) or not isinstance(doc.get("rows"), list):
        raise ValueError(f"{name}: expected a results document (read_results: paper, rows, claims, ...), got "
                         f"{type(doc).__name__}")
    return doc


def claim_class(verdict: str) -> str:
    """The CSS class of a claim verdict's chip, ``"claim-not-supported"``, from the claim vocabulary
    (:class:`mmlib.experiment.verdicts.ClaimVerdict`; a verdict text is reduced to its category first)."""
    return "claim-" + str(verdicts.claim_category(verdict)).replace(" ", "-")


def paper_verdicts(doc: dict) -> dict:
    """What a paper's replication found, from its results document (:func:`mmlib.experiment.results.read_results`):
    ``{"paper", "control", "tables": [...], "claims": [...]}``.

    Each table: ``table`` (its name), ``n_cells``, ``n_reproduced`` (under the headline reading; an isolated
    coincidence not counted) and ``joint`` (True/False: the whole-table joint test passes; None without one) with
    ``joint_dof``.  The tables are the items with a whole-table joint test, in their order (counted by the reading
    space's table match, ``multiverse.table_match``, when it has the table, else from the rows), then the table
    match's other tables; a control of the pipeline lists only its table match (its controls).  Each claim:
    ``claim`` (its text), ``verdict`` (the category of the claim vocabulary), ``words`` (the
    verdict as stated, :func:`claim_words`), ``decisive`` (the number that decided it), and across the reading space
    ``share`` of that verdict (a fraction, None without a sampled space), ``interval`` ((lo, hi) or None) and
    ``robust`` (bool or None)."""
    _doc(doc)
    mv = doc.get("multiverse") or {}
    matched = {t["table"]: t for t in mv.get("table_match") or []}

    def from_match(t):
        jt = t.get("joint_test")
        return {"table": t["table"], "n_cells": int(t["n_cells"]), "n_reproduced": int(t["headline_n_reproduced"]),
                "joint": None if jt is None else bool(jt["passes"]),
                "joint_dof": None if jt is None else int(jt["dof"])}

    tables, seen = [], set()
    for jt in [] if _is_control(doc) else doc.get("joint_tests") or []:
        if jt.get("algorithm") is not None or jt["item"] in seen:
            continue
        seen.add(jt["item"])
        if jt["item"] in matched:
            tables.append(from_match(matched[jt["item"]]))
            continue
        rows = [r for r in doc["rows"] if r["item"] == jt["item"]
                and verdicts.verdict_category(r["verdict"]) != verdicts.NOT_REPLICABLE]
        tables.append({"table": jt["item"], "n_cells": len(rows),
                       "n_reproduced": sum(verdicts.is_reproduced(r["verdict"]) for r in rows),
                       "joint": bool(jt["passes"]), "joint_dof": int(jt["dof"])})
    tables += [from_match(t) for name, t in matched.items() if name not in seen]
    across = {c["claim"]: c for c in mv.get("claims_summary") or []}
    claims = []
    for c in doc.get("claims") or []:
        category = str(verdicts.claim_category(c["verdict"]))
        a = across.get(c["claim"])
        share = interval = robust = None
        if a is not None and a.get("share") is not None and category in a["share"]:
            share = float(a["share"][category])
            iv = (a.get("interval") or {}).get(category)
            interval = None if iv is None else (float(iv[0]), float(iv[1]))
            robust = bool(a.get("robust"))
        claims.append({"key": c["key"], "claim": c["claim"], "verdict": category, "words": claim_words(c),
                       "decisive": c.get("decisive") or "", "share": share, "interval": interval, "robust": robust})
    return {"paper": doc["paper"], "control": _is_control(doc), "tables": tables, "claims": claims}


def _share_words(claim: dict) -> str:
    """``"92 % [85, 96] of the reading space"`` (robust or not said), "" without a share."""
    if claim["share"] is None:
        return ""
    lo, hi = claim["interval"] if claim["interval"] is not None else (claim["share"], claim["share"])
    band = "" if lo == hi == claim["share"] else f" [{percent(lo)}, {percent(hi)}]"
    robust = "robust" if claim["robust"] else "depends on the reading"
    return f"{percent(claim['share'])} %{band} of the reading space ({robust})"


def _table_words(t: dict) -> str:
    joint = "" if t["joint"] is None else f", joint test {'passes' if t['joint'] else 'fails'}"
    return f"{t['table']}: {t['n_reproduced']}/{t['n_cells']} cells reproduced{joint}"


def verdict_box_html(doc: dict) -> str:
    """The verdict box that opens a paper's page (HTML, styled by docs/_static/site.css): ``<div
    class="verdict-box">`` with the tables (cells reproduced x/y under the headline reading, the whole-table joint
    test) and each claim as a chip ``<span class="claim-chip claim-<verdict>">`` with its one-line verdict, the
    decisive number and its share of the reading space with the 95 % interval (:func:`paper_verdicts`)."""
    import html
    v = paper_verdicts(doc)
    out = ['<div class="verdict-box">']
    if v["tables"]:
        what = "Controls" if v["control"] else "Tables"
        out.append(f'<p class="verdict-tables"><strong>{what}</strong> (headline reading):</p>')
        out.append("<ul>")
        for t in v["tables"]:
            cls = "" if t["joint"] is None else (' class="joint-pass"' if t["joint"] else ' class="joint-fail"')
            out.append(f"<li{cls}>{html.escape(_table_words(t))}</li>")
        out.append("</ul>")
    if v["claims"]:
        out.append('<p class="verdict-claims"><strong>Claims</strong> (headline verdict — decisive number — share '
                   'of the reading space with that verdict):</p>')
        out.append('<ul class="claim-list">')
        for c in v["claims"]:
            share = _share_words(c)
            out.append(f'<li><span class="claim-chip {claim_class(c["verdict"])}">{html.escape(c["words"])}</span> '
                       f'{html.escape(c["claim"])}'
                       + (f' — <span class="claim-number">{html.escape(c["decisive"])}</span>' if c["decisive"] else "")
                       + (f' — <span class="claim-share">{html.escape(share)}</span>' if share else "") + "</li>")
        out.append("</ul>")
    out.append("</div>")
    return "\n".join(out)


def findings_line(doc: dict, link: str | None = None) -> str:
    """One Markdown line of what a paper's replication found (the README's "What we found" and the site's home
    page): its tables (cells reproduced x/y, joint test), its claim verdicts counted, its first claim's verdict with
    the decisive number and its share of the reading space, and how many claim verdicts are robust.  ``link`` the
    Markdown link to the paper's page or report (default: the paper's name in bold).  The arena's document
    (``kind == "arena"``) gives its cells and its first finding."""
    _doc(doc)
    name = link or f"**{doc['paper']}**"
    if doc.get("kind") == "arena":
        cells = doc.get("cells") or []
        first = next((f for f in doc.get("findings") or [] if "Kept out" not in f), "")
        first = re.sub(r"^[-*]\s*", "", first)
        return (f"{name}: {len(cells)} algorithm × scenario cells ({sum('reason' not in c for c in cells)} "
                f"applicable), {doc['provenance']['n_runs']} runs each" + (f"; {first}" if first else "."))
    v = paper_verdicts(doc)
    parts = [", ".join(f"{t['table']} {t['n_reproduced']}/{t['n_cells']} cells"
                       + ("" if t["joint"] is None else f" (joint test {'passes' if t['joint'] else 'fails'})")
                       for t in v["tables"])] if v["tables"] else []
    if v["claims"]:
        counts: dict = {}
        for c in v["claims"]:
            counts[c["verdict"]] = counts.get(c["verdict"], 0) + 1
        parts.append(f"claims: {', '.join(f'{n} {k}' for k, n in counts.items())}")
        first = v["claims"][0]
        share = _share_words(first)
        claim = re.split(r" \(|: ", first["claim"], maxsplit=1)[0]
        decisive = re.sub(r" \((\d+ parts|weakest of \d+)\)$", "", first["decisive"])
        parts.append(f"\"{claim}\" {first['words']}" + (f" ({decisive})" if decisive else "")
                     + (f" in {share}" if share else ""))
        with_share = [c for c in v["claims"] if c["robust"] is not None]
        if with_share:
            parts.append(f"{sum(c['robust'] for c in with_share)} of {len(with_share)} claim verdicts robust "
                         "across the reading space")
    return f"{name}: " + "; ".join(parts) + "."


def findings_lines(docs: Sequence[dict], link: Callable[[str], str] | None = None) -> list[str]:
    """:func:`findings_line` of each results document, the controls first, then the papers by name, the arena
    last; ``link(paper)`` the Markdown link to a paper's page (default: its name in bold)."""
    if isinstance(docs, (str, bytes, dict)) or not hasattr(docs, "__iter__"):
        raise ValueError(f"docs: expected a sequence of results documents, got {type(docs).__name__}")
    docs = [_doc(d, f"docs[{i}]") for i, d in enumerate(docs)]
    order = sorted(docs, key=lambda d: (0 if _is_control(d) else 2 if d.get("kind") == "arena" else 1, d["paper"]))
    return [findings_line(d, None if link is None else link(d["paper"])) for d in order]
