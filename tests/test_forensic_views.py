"""The forensic sections of the reports and the site (issue 24), on constructed inputs with known answers:
mmlib.experiment.views (consistency, sensitivity, recovery, stability, degenerate universes, controls, qualified
claim words, the table-match sentence that never names an unidentifiable factor) and tools/make_report.py (the
pooled tallies that keep controls and qualified verdicts apart, the sections present only when the results carry
them).  Every input is built here; the committed results are read only to check that a file without the new keys
still renders."""
from __future__ import annotations

import copy
import importlib.util
import json
import re
from pathlib import Path

import pytest

from mmlib.experiment import views

REPO = Path(__file__).resolve().parents[1]


def load_tool(name: str):
    spec = importlib.util.spec_from_file_location(name, REPO / "tools" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# ---------------------------------------------------------------------------------------------- constructed inputs
def stat(value, stderr, band, inside, n_runs=100, dof=4.0, steps=0.95, runs=0.9) -> dict:
    return {"value": value, "stderr": stderr, "dof": dof, "band": band, "band_kind": "k", "inside": inside,
            "steps_inside": steps, "runs_inside": runs, "n_runs": n_runs}


FACTORS = [
    {"id": "A-1", "label": "onset", "options": ["100s", "150s"], "headline": "150s", "source": "Sec. 4",
     "influential": True, "metric_only": False, "kind": "reading",
     "option_details": [{"name": "100s", "label": "onset at 100 s", "source": "Fig. 2", "changes": {},
                         "motivated_by": ""},
                        {"name": "150s", "label": "onset at 150 s", "source": "Sec. 4", "changes": {},
                         "motivated_by": ""}]},
    {"id": "A-3", "label": "turn sense", "options": ["left", "right"], "headline": "left", "source": "Eq. 3",
     "influential": True, "metric_only": False, "kind": "reading",
     "option_details": [{"name": "left", "label": "left; then right", "source": "Eq. 3", "changes": {},
                         "motivated_by": ""},
                        {"name": "right", "label": "right turn", "source": "Fig. 1", "changes": {},
                         "motivated_by": ""}]},
    {"id": "A-9", "label": "filters' Q", "options": ["q", "q10"], "headline": "q", "source": "Sec. 5",
     "influential": True, "metric_only": False, "kind": "sensitivity",
     "option_details": [{"name": "q", "label": "Q = q", "source": "Sec. 5", "changes": {}, "motivated_by": ""},
                        {"name": "q10", "label": "Q = 10 q", "source": "unstated", "changes": {},
                         "motivated_by": ""}]},
]

RECOVERY_T1 = {"table": "Table 1", "planted": 50, "top1": 0.34, "top3": 0.61, "top1_interval": [0.25, 0.44],
               "top3_interval": [0.51, 0.70], "by_factor": {"A-1": 0.96, "A-3": 0.5},
               "unidentifiable": ["A-3"], "indistinguishable": {"A-3": [["left", "right"]]}}


def table_entry(passes: bool = False, recovery: dict | None = RECOVERY_T1) -> dict:
    test = {"item": "Table 1", "algorithm": None, "statistic": 3.1 if passes else 412.0, "dof": 4,
            "p_value": 0.54 if passes else 0.0, "passes": passes, "n_isolated": 0}
    t = {"table": "Table 1", "n_cells": 4, "precision": 0.1, "headline_sum": 412.0, "headline_rms_relative": 0.3,
         "headline_n_reproduced": 1, "joint_test": test, "isolated": 0, "n_passing": 1, "n_counted": 4,
         "weighting": "full factorial of 4", "n_excluded_imprecise": 0, "n_excluded_inconclusive": 0,
         "most_n_reproduced": 3, "most_universe": 3, "most_reading": {"A-1": "100s", "A-3": "right", "A-9": "q"},
         "most_describe": "A-1: onset at 100 s; A-3: right turn",
         "best_universe": 3, "best_reading": {"A-1": "100s", "A-3": "right", "A-9": "q"},
         "best_describe": "A-1: onset at 100 s; A-3: right turn", "best_sum": 3.1, "best_rms_relative": 0.041,
         "best_joint_test": test, "best_n_reproduced": 3, "n_candidates": 4}
    if recovery is not None:
        t["recovery"] = recovery
    return t


def claim_summary(motivated: dict | None = None) -> dict:
    c = {"claim": "A beats B", "headline_verdict": "contradicted", "headline_decisive": "A − B: +3 %",
         "verdict_counts": {"holds": 1, "contradicted": 3}, "n_counted": 4, "n_simulations": 4, "n_universes": 6,
         "weighting": "full factorial of 4",
         "share": {"holds": 0.25, "partly": 0.0, "contradicted": 0.75, "not supported": 0.0, "not assessable": 0.0},
         "interval": {"holds": [0.25, 0.25], "partly": [0.0, 0.0], "contradicted": [0.75, 0.75],
                      "not supported": [0.0, 0.0], "not assessable": [0.0, 0.0]},
         "robust": False, "robustness": "depends on the reading", "by_option": {}, "star_counts": {}, "n_star": 0}
    if motivated is not None:
        c["motivated"] = motivated
    return c


def universe(reading: dict, degenerate: str = "") -> dict:
    u = {"reading": reading, "values": [], "claims": [], "effects": [], "diverged": {}, "n_runs": 40}
    if degenerate:
        u["degenerate"] = degenerate
    return u


def stored_mv(new_keys: bool = True) -> dict:
    """A stored multiverse of 6 universes; with ``new_keys`` every section of issue 24."""
    readings = [{"A-1": a, "A-3": b, "A-9": "q"} for a in ("150s", "100s") for b in ("left", "right")]
    readings += [{"A-1": "150s", "A-3": "left", "A-9": "q10"}, {"A-1": "100s", "A-3": "left", "A-9": "q10"}]
    mv = {"factors": FACTORS, "design": "full", "design_description": "full factorial", "design_sample": [0, 1, 2, 3],
          "design_seed": None, "n_counted": 4, "weighting": "full factorial of 4", "n_universes": 6,
          "n_simulations": 6, "full_factorial_size": 8, "n_runs": 40,
          "universes": [universe(r) for r in readings],
          "claims_summary": [claim_summary({"holds": 2} if new_keys else None)],
          "numbers_summary": [], "table_match": [table_entry(recovery=RECOVERY_T1 if new_keys else None)],
          "diverged_total": {}}
    if not new_keys:
        del mv["table_match"][0]["n_candidates"]
        return mv
    mv["universes"][1] = universe(readings[1], degenerate="every estimator's error is at least the measurement-only "
                                                          "estimate's position RMSE (12.5; the smallest, B's, is 13)")
    mv.update({"n_degenerate": 1, "n_motivated": 2,
               "degenerate": [{"universe": 1, "describe": "A-3: right turn",
                               "reason": mv["universes"][1]["degenerate"]}],
               "recovery": {"planted": 50, "top1": 0.34, "top3": 0.61, "unidentifiable": ["A-3"],
                            "tables": [RECOVERY_T1]},
               "sensitivity": [{"factor": "A-9", "label": "filters' Q", "headline": "q", "options": [
                   {"option": "q", "label": "Q = q", "universe": 0, "claims": {"A beats B": "contradicted"},
                    "tables": {"Table 1": {"rms_relative": 0.3, "n_reproduced": 1, "joint_passes": False}}},
                   {"option": "q10", "label": "Q = 10 q", "universe": 4, "claims": {"A beats B": "holds"},
                    "tables": {"Table 1": {"rms_relative": 0.052, "n_reproduced": 4, "joint_passes": True}}}]}],
               "stability": {"n_runs_universe": 40, "n_runs_check": 200, "universes": [0, 2, 5], "n_changed": 1,
                             "claims_changed": ["A beats B"], "statement": ""}})
    return mv


CONTROLS = {"positive": {"n_cells": 12, "n_reproduced": 12}, "negative": {"n_cells": 12, "n_not_reproduced": 12,
                                                                          "perturbation": 0.1, "power": 0.98},
            "searched": "none found whose text is available"}


def paper_doc(name: str, verdicts: list[str], claims: list[str], *, qualifier: str = "", control: bool = False,
              new_keys: bool = True) -> dict:
    rows = [{"item": "Table 1", "algorithm": f"A{i}", "quantity": "RMSE (m)", "paper": "1.0", "replicated": 1.0,
             "stderr": 0.01, "verdict": v, "deviations": [], "distance": 0.0} for i, v in enumerate(verdicts)]
    cl = []
    for i, v in enumerate(claims):
        c = {"key": f"claim_{i}", "claim": f"claim {i}", "verdict": v, "decisive": f"A − B: {i + 1} %", "evidence": "e"}
        if qualifier:
            c["qualifier"] = qualifier
            c["stated"] = f"{v} by the {qualifier}" if v == "contradicted" else f"{v} in the {qualifier}"
        cl.append(c)
    doc = {"paper": name, "provenance": {"git_commit": "0" * 40, "root_seed": 1, "n_runs": 100, "profile": "full"},
           "rows": rows, "claims": cl}
    if control:
        doc["controls"] = CONTROLS
    if new_keys:
        doc["consistency"] = [{"algorithm": "A0", "case": "", "anees": stat(4.02, 0.05, [3.6, 4.5], True),
                               "anis": stat(2.3, 0.04, [1.9, 2.1], False, dof=2.0)}]
    return doc


# ------------------------------------------------------------------------------------------------ consistency
def test_consistency_table_rows_bands_and_absent_statistics():
    entries = [{"algorithm": "IMM", "case": "case 1", "anees": stat(4.02, 0.05, [3.61, 4.43], True),
                "anis": stat(2.3, 0.041, [1.9, 2.1], False, dof=2.0)},
               {"algorithm": "KF", "anees": stat(None, None, None, None, n_runs=1)},          # no anis at all
               {"algorithm": "UKF", "case": "", "anees": None, "anis": stat(1.5, None, [1.0, 2.0], True)}]
    text = views.consistency_table(entries)
    lines = text.splitlines()
    assert len(lines) == 2 + 3
    assert "| IMM | case 1 | 100 | 4.020 ± 0.050 [3.61, 4.43] (dof 4) | yes (95 % of steps, 90 % of runs) | " \
           "2.300 ± 0.041 [1.9, 2.1] (dof 2) | no (95 % of steps, 90 % of runs) |" == lines[2]
    assert lines[3].startswith("| KF | -- | 1 | -- (fewer than 2 valid runs: 1) | -- | -- | -- |")
    assert lines[4].startswith("| UKF | -- | 100 | -- | -- | 1.5 [1, 2] (dof 4) | yes")
    assert views.consistency_table([]) == "No NEES or NIS was recorded."


@pytest.mark.parametrize("bad, arg", [("IMM", "entries"), ({"algorithm": "x"}, "entries"),
                                      ([{"algorithm": "a"}, {"case": "no algorithm"}], r"entries\[1\]"),
                                      ([{"algorithm": "a", "anees": 3.0}], r"entries\[0\]\['anees'\]")])
def test_consistency_table_refuses_bad_input(bad, arg):
    with pytest.raises(ValueError, match=f"^{arg}"):
        views.consistency_table(bad)


# ------------------------------------------------------------------------------------------------ sensitivity
def test_sensitivity_table_verdict_against_the_swept_value():
    text = views.sensitivity_table(stored_mv())
    assert "| A-9: filters' Q | Q = q (headline) | contradicted | 1 / 4 reproduced; RMS 30.0 %; joint test fails |" \
        in text
    assert "| A-9: filters' Q | Q = 10 q | holds | 4 / 4 reproduced; RMS 5.2 %; joint test passes |" in text
    assert text.endswith("- C1: A beats B")
    assert views.sensitivity_table(stored_mv(new_keys=False)) == "No sensitivity curves in these results."
    assert views.sensitivity_table({**stored_mv(), "sensitivity": []}).startswith("No sensitivity factor")
    with pytest.raises(ValueError, match="^mv: sensitivity\\[0\\]"):
        views.sensitivity_table({**stored_mv(), "sensitivity": [{"factor": "A-9"}]})
    with pytest.raises(ValueError, match="^mv"):
        views.sensitivity_table("mv")


# ------------------------------------------------------------------------------------------------ recovery
def test_recovery_text_says_the_rate_its_interval_and_the_unidentifiable_factors():
    entry = {"table": "Table 1", "planted": 50, "top1": 0.34, "top3": 0.61, "top1_interval": [0.25, 0.44],
             "unidentifiable": ["H-9", "H-10"]}
    assert views.recovery_text(entry) == ("planted readings recovered first in 34 % [25, 44] of 50 trials, in the "
                                          "top three 61 %; unidentifiable from the table: H-9, H-10")
    assert views.recovery_text({"planted": 20, "top1": 1.0, "top3": 1.0, "unidentifiable": []}).endswith(
        "first in 100 % of 20 trials, in the top three 100 %; every factor identifiable from the table")
    assert views.recovery_text({"planted": 0, "top1": None}).startswith("no planted reading was tried")
    for bad in ("x", {"top1": 0.3}, {"planted": -1, "top1": 0.3}, {"planted": True, "top1": 0.3}):
        with pytest.raises(ValueError, match="^entry"):
            views.recovery_text(bad)


def test_recovery_table_per_factor():
    text = views.recovery_table(stored_mv())
    assert "A-1 96 %; A-3 50 % (unidentifiable) — not told apart: left = right" in text
    assert views.recovery_table(stored_mv(new_keys=False)) == "No planted-reading recovery in these results."


def test_the_table_match_never_names_an_unidentifiable_factor():
    """A-3's options give the same table within noise: the best reading differs from the headline in A-1 and A-3,
    and the sentence names A-1's option, says A-3 is unidentifiable and carries the recovery rate."""
    t = table_entry(passes=True)
    assert views.reading_text(t) == "A-1: onset at 100 s (A-3 unidentifiable from the table)"
    sentence = views.table_match_sentence(t)
    assert sentence.startswith("Table 1 is consistent with reading A-1: onset at 100 s (A-3 unidentifiable from the "
                               "table) (RMS relative distance 4.1 %, Σz² 3.1 (4 cells, p 0.54): passes; 4 readings "
                               "searched); planted readings recovered first in 34 % [25, 44] of 50 trials")
    assert "right turn" not in sentence
    assert "right turn" not in views.most_reading(t)
    assert "right turn" not in views.table_match_table({"table_match": [t]})
    # a failing joint test: the closest reading, never "consistent with"
    failing = views.table_match_sentence(table_entry(passes=False))
    assert "consistent" not in failing and "fails its joint test under every reading searched; the closest is " \
                                           "reading A-1: onset at 100 s" in failing
    # only A-3's options twin: a reading differing in A-1 only is named whole
    t2 = table_entry(recovery={**RECOVERY_T1, "unidentifiable": [], "indistinguishable": {"A-1": [["100s", "150s"]]}})
    assert views.reading_text(t2) == "A-1: onset at 100 s (not told apart from 150s); A-3: right turn"
    # a label holding "; " stays whole (the split is on the factor ids)
    t3 = table_entry(recovery={**RECOVERY_T1, "unidentifiable": ["A-1"]})
    t3.update(best_reading={"A-1": "100s", "A-3": "left", "A-9": "q"}, best_describe="A-1: onset at 100 s; A-3: x; y")
    assert views.reading_text(t3) == "A-3: x; y (not told apart from right) (A-1 unidentifiable from the table)"
    # every differing factor unidentifiable
    t4 = table_entry(recovery={**RECOVERY_T1, "unidentifiable": ["A-1", "A-3"]})
    assert views.reading_text(t4).startswith("headline in every identifiable factor (A-1, A-3 unidentifiable")
    with pytest.raises(ValueError, match="^which"):
        views.reading_text(t, "worst")


def test_results_without_recovery_keep_the_old_wording():
    t = table_entry(recovery=None)
    del t["n_candidates"]
    assert views.reading_text(t) == t["best_describe"] and views.most_reading(t) == t["most_describe"]
    assert views.table_match_sentence(t).endswith("the table match's recovery of planted readings is not in these "
                                                  "results")
    row = views.table_match_table({"table_match": [t]}).splitlines()[2]
    assert "| 1 / 4 | -- | A-1: onset at 100 s; A-3: right turn |" in row and row.endswith("| not in these results |")


def test_summary_line_carries_searched_readings_recovery_and_the_universes_apart():
    line = views.summary_line(stored_mv())
    assert line.startswith("Table 1: no reading of 4 searched reproduces all 4 cells (at most 3, by A-1: onset at "
                           "100 s (A-3 unidentifiable from the table); headline universe 1; the table match ranks a "
                           "planted reading first in 34 % [25, 44])")
    assert line.endswith("universes not counted: 1 degenerate, 2 with an option motivated by the results or another "
                         "paper")
    old = views.summary_line(stored_mv(new_keys=False))
    assert "searched" not in old and "planted" not in old and "not counted" not in old


# ------------------------------------------------------------------------------------------------ stability
def test_stability_text():
    mv = stored_mv()
    assert views.stability_text(mv) == ("Run-count check: the verdicts of 3 universes at 40 runs (the universes' "
                                        "count) and at 200: 1 verdict changes (A beats B).")
    mv["stability"].update(n_changed=0, claims_changed=[])
    assert views.stability_text(mv).endswith("no verdict changes.")
    mv["stability"]["statement"] = "No verdict changes between 40 and 200 runs."
    assert views.stability_text(mv) == "No verdict changes between 40 and 200 runs."
    assert views.stability_text(stored_mv(new_keys=False)) == "No run-count check in these results."
    with pytest.raises(ValueError, match="^mv: 'stability'"):
        views.stability_text({**mv, "stability": {"statement": "x"}})


# ------------------------------------------------------------------------------------------------ degenerate
def test_degenerate_text_names_every_degenerate_universe():
    mv = stored_mv()
    text = views.degenerate_text(mv)
    assert text.startswith("1 of 6 universes is degenerate")
    assert "- universe 1 (A-3: right turn): every estimator's error is at least the measurement-only" in text
    # the list absent, the universes' flags read instead (describe from the stored factors)
    del mv["degenerate"], mv["n_degenerate"]
    mv["universes"][5]["degenerate"] = "all diverged"
    text = views.degenerate_text(mv)
    assert text.startswith("2 of 6 universes are degenerate")
    assert "- universe 5 (A-1: onset at 100 s; A-9: Q = 10 q): all diverged" in text
    assert views.degenerate_text(mv, limit=1).endswith("- and 1 more")
    assert views.degenerate_text(stored_mv(new_keys=False)) == "No degenerate-universe flag in these results."
    clean = {**stored_mv(), "degenerate": [], "n_degenerate": 0}
    assert views.degenerate_text(clean).startswith("No universe is degenerate")
    with pytest.raises(ValueError, match="^limit"):
        views.degenerate_text(mv, limit=0)


# ------------------------------------------------------------------------------------------------ claims
def test_qualified_claim_words_and_the_motivated_split():
    claim = {"claim": "A beats B", "verdict": "contradicted", "decisive": "A − B: +3 %"}
    across = claim_summary({"holds": 2})
    assert views.claim_cell(claim, across) == "contradicted — A − B: +3 % — contradicted 75 % of the space"
    q = {**claim, "qualifier": "reconstruction"}
    assert views.claim_cell(q, across) == ("contradicted by the reconstruction — A − B: +3 % — contradicted 75 % of "
                                           "the space")
    assert views.claim_words({**q, "stated": "contradicted by our reconstruction"}) == \
        "contradicted by our reconstruction"
    with pytest.raises(ValueError, match="^qualifier"):
        views.claim_words({**claim, "qualifier": "guess"})
    assert views.robustness_text(across).endswith("(full factorial of 4); apart, universes with an option motivated "
                                                  "by the results or another paper (not counted): holds 2")
    assert "apart" not in views.robustness_text(claim_summary())
    table = views.claims_table({"claims_summary": [across]}, "reconstruction").splitlines()
    assert table[0].endswith("| an option motivated by the results or another paper (not counted) |")
    assert table[2].startswith("| A beats B | contradicted by the reconstruction |") and table[2].endswith(
        "| -- | holds 2 |")
    assert views.claims_table({"claims_summary": [claim_summary()]}).splitlines()[2].endswith("| -- | -- |")
    with pytest.raises(ValueError, match="^qualifier"):
        views.claims_table({"claims_summary": [across]}, "guess")


def test_controls_text():
    assert views.controls_text(CONTROLS) == (
        "the machinery reproduces when the paper is right: positive control 12/12 cells reproduced, negative control "
        "12/12 rejected (each cell perturbed by +10 %), power 98 %. A published third control: none found whose text "
        "is available")
    interval = {**CONTROLS, "negative": {**CONTROLS["negative"], "perturbation": "+1 s.e. per cell",
                                         "power": {"value": 0.9, "interval": [0.8, 0.95]}}}
    assert "(+1 s.e. per cell), power 90 % [80, 95]" in views.controls_text(interval)
    for bad in ({}, {"positive": {"n_cells": 3}, "negative": {"n_cells": 3, "n_not_reproduced": 3}}):
        with pytest.raises(ValueError, match="^controls"):
            views.controls_text(bad)


# ------------------------------------------------------------------------------------------------ make_report
def test_pooled_tallies_keep_controls_and_qualified_verdicts_apart():
    """Two papers pooled; a reconstruction's rows and claims and a control's are shown apart, never pooled."""
    make_report = load_tool("make_report")
    docs = [paper_doc("alpha2001", ["reproduced", "not reproduced"], ["holds", "contradicted"]),
            paper_doc("beta2002", ["not reproduced: far"], ["contradicted"]),
            paper_doc("gamma2003", ["not reproduced"] * 5, ["contradicted"] * 4, qualifier="reconstruction"),
            paper_doc("ctrl", ["reproduced"] * 12, ["holds"] * 3, control=True),
            {"paper": "arena", "kind": "arena", "provenance": {"n_runs": 10, "git_commit": "0" * 40}, "rows": [],
             "cells": [], "findings": []}]
    pooled = make_report.pooled_tallies(docs)
    assert pooled["papers"] == ["alpha2001", "beta2002"]
    assert pooled["rows"]["reproduced"] == 1 and pooled["rows"]["not reproduced"] == 2
    assert pooled["claims"]["holds"] == 1 and pooled["claims"]["contradicted"] == 2
    assert pooled["apart"] == {"controls": ["ctrl"], "qualified_papers": ["gamma2003"],
                               "qualified_rows": {**{k: 0 for k in pooled["rows"]}, "not reproduced": 5},
                               "qualified_claims": {"contradicted by the reconstruction": 4},
                               "degenerate_headlines": []}
    text = make_report.render_index(docs)
    assert text.index("## Controls: the machinery reproduces") < text.index("| paper | runs |")
    assert ("- [ctrl.md](ctrl.md): the machinery reproduces when the paper is right: positive control 12/12 cells "
            "reproduced, negative control 12/12 rejected") in text
    assert "| pooled over the 2 papers whose set-up is given | -- | 1 | 0 | 0 | 0 | 0 | 2 | 0 | 0 | -- |" in text
    assert "| apart: verdicts on a reconstruction (gamma2003) | -- | 0 | 0 | 0 | 0 | 0 | 5 | 0 | 0 | -- |" in text
    assert ("Pooled over the 2 papers whose set-up is given (3 claims, headline verdicts): holds 1, contradicted 2; "
            "apart, 4 claims on a reconstruction or a degenerate headline (gamma2003): contradicted by the "
            "reconstruction 4.") in text
    assert "| gamma2003 *[reconstruction]* | 100 |" in text and "| ctrl |" not in text
    # a paper whose headline universe is degenerate: its rows pooled, its claims apart
    delta = paper_doc("delta2004", ["not reproduced"], ["holds", "contradicted"])
    delta["multiverse"] = {"universes": [{"degenerate": "no estimator is detectably better than the raw data"}]}
    more = make_report.pooled_tallies(docs + [delta])
    assert more["papers"][-1] == "delta2004" and more["rows"]["not reproduced"] == 3
    assert more["claims"] == pooled["claims"] and more["apart"]["degenerate_headlines"] == ["delta2004"]
    assert more["apart"]["qualified_claims"]["holds (degenerate headline)"] == 1
    # the site's chip
    site = load_tool("build_site")
    assert site.chip("reconstruction") in make_report.render_index(docs, chip=site.chip)


def test_a_paper_report_gains_the_forensic_sections_only_when_its_results_carry_them(tmp_path):
    make_report = load_tool("make_report")
    new = paper_doc("alpha2001", ["reproduced"], ["contradicted"], qualifier="reconstruction")
    new["multiverse"] = stored_mv()
    page = make_report.render(new, tmp_path, tmp_path / "reports")
    for heading in ("## Consistency: NEES and NIS", "### Sensitivity curves", "### Can the table match find a "
                    "reading? Planted-reading recovery", "### Run-count stability", "### Degenerate universes"):
        assert page.count(heading) == 1, heading
    assert "*Qualifier:* the set-up is a reconstruction" in page
    assert "Paper-wide: planted readings recovered first in 34 % of 50 trials" in page
    assert "- Table 1 fails its joint test under every reading searched; the closest is reading A-1" in page
    old = paper_doc("alpha2001", ["reproduced"], ["contradicted"], new_keys=False)
    old["multiverse"] = stored_mv(new_keys=False)
    page = make_report.render(old, tmp_path, tmp_path / "reports")
    for heading in ("Consistency", "Sensitivity", "Planted", "Run-count", "Degenerate", "Qualifier", "controls"):
        assert heading not in page, heading
    ctrl = paper_doc("ctrl", ["reproduced"], ["holds"], control=True)
    page = make_report.render(ctrl, tmp_path, tmp_path / "reports")
    assert page.index("## The controls of the pipeline") < page.index("## Comparison")


def test_every_committed_results_file_still_renders(tmp_path):
    """The committed results (which may predate the new keys) render with the new code, and with the new keys
    grafted on (a constructed multiverse section) they gain the sections."""
    make_report = load_tool("make_report")
    docs = make_report.load_results(REPO)
    assert docs
    index = make_report.render_index(docs)
    assert "pooled over the" in index
    for doc in docs:
        make_report.render(doc, REPO, tmp_path)
        if doc.get("kind") == "arena" or not doc.get("multiverse"):
            continue
        grafted = copy.deepcopy(doc)
        extra = {k: v for k, v in stored_mv().items() if k in ("sensitivity", "recovery", "stability")}
        grafted["multiverse"].update(extra)
        page = make_report.render(grafted, REPO, tmp_path)
        assert "### Run-count stability" in page and "### Sensitivity curves" in page


def test_site_paper_page_gains_the_chip_and_the_forensic_sections(tmp_path):
    site = load_tool("build_site")
    nb = {"cells": [{"cell_type": "markdown", "metadata": {}, "source": "# Paper"},
                    {"cell_type": "code", "metadata": {}, "source": "x = 1", "outputs": [], "execution_count": 1}],
          "metadata": {}, "nbformat": 4, "nbformat_minor": 5}
    src, dst = tmp_path / "p.ipynb", tmp_path / "out" / "p.ipynb"
    src.write_text(json.dumps(nb))
    doc = paper_doc("alpha2001", ["reproduced"], ["contradicted"], qualifier="reconstruction")
    doc["multiverse"] = stored_mv()
    site.fold_notebook(src, dst, doc)
    cells = json.loads(dst.read_text())["cells"]
    assert cells[1]["source"].startswith(site.chip("reconstruction"))
    last = cells[-1]["source"]
    assert last.startswith("## Forensic checks (from `data/results/alpha2001.json`)")
    for heading in ("### Consistency: NEES and NIS against their chi-square bands (results file)",
                    "### Sensitivity curves (tuning swept, not readings) (results file)",
                    "### Run-count stability (results file)", "### Degenerate universes (results file)"):
        assert heading in last.splitlines(), heading
    # after the chip, the verdict box (tests/test_findings.py checks its content), then the folded code cell
    assert '<div class="verdict-box">' in cells[2]["source"]
    assert cells[3]["metadata"]["tags"] == ["hide-input"]
    old = paper_doc("alpha2001", ["reproduced"], ["contradicted"], new_keys=False)
    site.fold_notebook(src, dst, old)
    cells = json.loads(dst.read_text())["cells"]
    assert len(cells) == 3 and '<div class="verdict-box">' in cells[1]["source"]     # no chip, no forensic sections


def test_site_home_page_lists_the_controls_first(tmp_path):
    site = load_tool("build_site")
    docs = [paper_doc("alpha2001", ["reproduced"], ["holds"]), paper_doc("ctrl", ["reproduced"], ["holds"],
                                                                          control=True)]
    notebooks = {"alpha2001": tmp_path / "alpha2001_x.ipynb", "ctrl": tmp_path / "ctrl_dwna.ipynb"}
    page = site.index_page(docs, notebooks)
    assert page.index(":caption: Controls") < page.index(":caption: Papers")
    assert re.search(r":caption: Controls\n\ncontrols/ctrl_dwna\n```", page)
    assert "papers/ctrl_dwna" not in page and "[ctrl](controls/ctrl_dwna.ipynb)" in page
    assert page.index("## Controls: the machinery reproduces") < page.index("| paper | runs |")
