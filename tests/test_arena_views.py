"""The arena's figures and table (mmlib.arena.views) on a small synthetic set of cells: an algorithm that does not
apply, a cell with some diverged runs and one whose every run diverged."""
import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.image import AxesImage  # noqa: E402

from mmlib.arena import views  # noqa: E402
from mmlib.experiment.views import markdown_table  # noqa: E402

ALGORITHMS = ("EKF", "UKF", "IMMUKF")
SCENARIOS = ("paper", "ladder-nl1", "ladder-nl3", "ladder-turn1", "ladder-turn2")
N = 20
REASON = "needs an IMM mode set: the paper defines none"
# position RMSE (m); None: no cell metrics of that kind (see _cell)
RMSE = {("paper", "EKF"): 4.0, ("paper", "UKF"): 5.0,
        ("ladder-nl1", "EKF"): 8.0, ("ladder-nl1", "UKF"): 8.0, ("ladder-nl1", "IMMUKF"): 7.0,
        ("ladder-nl3", "EKF"): 60.0, ("ladder-nl3", "UKF"): 120.0, ("ladder-nl3", "IMMUKF"): 40.0,
        ("ladder-turn1", "EKF"): 50.0, ("ladder-turn1", "UKF"): 52.0, ("ladder-turn1", "IMMUKF"): 45.0,
        ("ladder-turn2", "UKF"): 110.0, ("ladder-turn2", "IMMUKF"): 44.0}
PARTLY = ("ladder-nl3", "UKF")          # 3 of 20 runs diverged
ALL_DIVERGED = ("ladder-turn2", "EKF")  # 20 of 20
NOT_APPLICABLE = ("paper", "IMMUKF")


def _stat(value, dof, inside):
    if value is None:
        return {"value": None, "stderr": None, "dof": dof, "band": None, "steps_inside": None, "runs_inside": None,
                "n_runs": 0}
    return {"value": value, "stderr": 0.05 * value, "dof": dof, "band": [0.8 * dof, 1.25 * dof],
            "steps_inside": 0.9, "runs_inside": 0.8, "n_runs": N, "inside": inside}


def _cell(scenario, algorithm):
    doc = {"algorithm": algorithm, "scenario": scenario, "n_runs": N}
    if (scenario, algorithm) == NOT_APPLICABLE:
        doc["reason"] = REASON
        return doc
    if (scenario, algorithm) == ALL_DIVERGED:
        doc.update(diverged=N, divergence=f"{N} of {N} runs diverged (step 9 x{N}; covariance not PD)",
                   cost_us_per_run_step=10.0, rmse_position=None, rmse_velocity=None,
                   anees=_stat(None, 4.0, False), anis=_stat(None, 2.0, False), rank=None, versus_best=None)
        return doc
    rmse = RMSE[(scenario, algorithm)]
    nd = 3 if (scenario, algorithm) == PARTLY else 0
    k = ALGORITHMS.index(algorithm)
    anees = 4.0 * (1.0 + k)             # EKF consistent (1), UKF 2, IMMUKF 3 (x dof)
    doc.update(diverged=nd, divergence=f"{nd} of {N} runs diverged (steps 12 x3; covariance not PD)" if nd else "",
               cost_us_per_run_step=10.0 + k,
               rmse_position={"value": rmse, "stderr": 0.02 * rmse, "n_runs": N - nd},
               rmse_velocity={"value": rmse / 4, "stderr": 0.01 * rmse, "n_runs": N - nd},
               anees=_stat(anees, 4.0, k == 0), anis=_stat(2.0 * (1.0 + 0.5 * k), 2.0, k <= 1),
               rank=1, versus_best={"algorithm": "EKF", "difference_m2": 0.0, "stderr_m2": 0.0, "verdict": "best"})
    return doc


def cells():
    return [_cell(s, a) for s in SCENARIOS for a in ALGORITHMS]


def scenario_rows():
    props = {"paper": ({}, 0.002),
             "ladder-nl1": ({"axis": "nonlinearity", "sigma_theta_mrad": 1.0, "omega_deg_s": 3.0}, 0.002),
             "ladder-nl3": ({"axis": "nonlinearity", "sigma_theta_mrad": 10.0, "omega_deg_s": 3.0}, 0.04),
             "ladder-turn1": ({"axis": "manoeuvre", "sigma_theta_mrad": 10.0, "omega_deg_s": 1.0}, 0.04),
             "ladder-turn2": ({"axis": "manoeuvre", "sigma_theta_mrad": 10.0, "omega_deg_s": 6.0}, 0.04)}
    return [{"scenario": s, "title": s, "nonlinearity_index": {"median": eta, "p90": 1.1 * eta},
             "properties": {**p, "cross_range_spread": None}} for s, (p, eta) in props.items()]


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _image(fig):
    ims = [a for ax in fig.axes for a in ax.get_children() if isinstance(a, AxesImage)]
    assert len(ims) == 1
    return ims[0].get_array()


def _texts(fig):
    return [t.get_text() for t in fig.axes[0].texts]


def test_rmse_heatmap_colours_are_the_ratio_to_the_best_of_each_row():
    fig = views.rmse_heatmap(cells(), scenario_rows())
    assert isinstance(fig, matplotlib.figure.Figure)
    assert len(fig.axes) == 2                                   # the map and its colour bar
    data = _image(fig)
    assert data.shape == (len(SCENARIOS), len(ALGORITHMS))
    for i, s in enumerate(SCENARIOS):
        best = min(v for (ss, _), v in RMSE.items() if ss == s)
        for j, a in enumerate(ALGORITHMS):
            if (s, a) in RMSE:
                assert not data.mask[i, j]
                assert data[i, j] == pytest.approx(RMSE[(s, a)] / best)
            else:
                assert data.mask[i, j]                              # n/a and all-diverged: no colour value
    assert data[SCENARIOS.index("ladder-nl3"), ALGORITHMS.index("UKF")] == pytest.approx(3.0)
    assert np.nanmin(data.filled(np.nan), axis=1) == pytest.approx(np.ones(len(SCENARIOS)))
    texts = _texts(fig)
    assert texts.count("n/a") == 1 and texts.count("div.") == 1
    assert "† 3" in texts                                           # the partly diverged cell's count
    assert "3.0" in texts and "1.0" in texts and "1.2" in texts     # ratios to two significant digits
    assert fig.axes[1].get_ylabel().startswith("position RMSE / best in scenario")
    assert [t.get_text() for t in fig.axes[0].get_xticklabels()] == list(ALGORITHMS)
    assert fig.axes[0].get_yticklabels()[2].get_text().startswith("ladder-nl3")
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert any(t.startswith("n/a") for t in legend) and any(t.startswith("div.") for t in legend)
    assert any(t.startswith("† n") for t in legend)


def test_rmse_heatmap_draws_into_a_given_axes_and_needs_no_scenario_table():
    fig, ax = plt.subplots()
    assert views.rmse_heatmap(cells(), ax=ax) is fig
    assert [t.get_text() for t in ax.get_yticklabels()] == list(SCENARIOS)


@pytest.mark.parametrize("which, dof, values", [("anees", 4.0, (4.0, 8.0, 12.0)), ("anis", 2.0, (2.0, 3.0, 4.0))])
def test_consistency_heatmap_colours_are_value_over_dof(which, dof, values):
    fig = views.consistency_heatmap(cells(), which, scenarios=scenario_rows())
    assert len(fig.axes) == 2
    data = _image(fig)
    for i, s in enumerate(SCENARIOS):
        for j, a in enumerate(ALGORITHMS):
            if (s, a) in (NOT_APPLICABLE, ALL_DIVERGED):
                assert data.mask[i, j]
            else:
                assert data[i, j] == pytest.approx(values[j] / dof)
    texts = fig.axes[0].texts
    assert [t.get_text() for t in texts].count("n/a") == 1
    assert [t.get_text() for t in texts].count("div.") == 1
    assert "† 3" in [t.get_text() for t in texts]
    # the cells inside their band are bold, the others not
    bold = {t.get_text() for t in texts if t.get_fontweight() == "bold" and t.get_text() not in ("div.",)}
    plain = {t.get_text() for t in texts if t.get_fontweight() != "bold" and t.get_text() not in ("n/a", "† 3")}
    if which == "anees":
        assert bold == {"1.0"} and plain == {"2.0", "3.0"}
    else:
        assert bold == {"1.0", "1.5"} and plain == {"2.0"}
    name = which.upper()
    assert fig.axes[1].get_ylabel().startswith(f"{name} / dof")
    assert name in fig.axes[0].get_title()


def test_ladder_curves_leave_gaps_where_there_is_no_value():
    fig = views.ladder_curves(cells(), scenario_rows())
    assert len(fig.axes) == 2
    ax_nl, ax_w = fig.axes
    assert ax_nl.get_xscale() == "log" and "nonlinearity index" in ax_nl.get_xlabel()
    assert "(°/s)" in ax_w.get_xlabel() and ax_nl.get_ylabel() == "position RMSE (m)"

    def curve(ax, label):
        (c,) = [c for c in ax.containers if c.get_label() == label]
        line = c.lines[0]
        return np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)

    x, y = curve(ax_nl, "UKF")                       # the nonlinearity rungs, sorted by the index
    assert x == pytest.approx([0.002, 0.04]) and y == pytest.approx([8.0, 120.0])
    # the manoeuvre axis: turn1 (1 deg/s), ladder-nl3 (3 deg/s, same 10 mrad: the crossing) and turn2 (6 deg/s)
    x, y = curve(ax_w, "EKF")
    assert x == pytest.approx([1.0, 3.0, 6.0])
    assert y[:2] == pytest.approx([50.0, 60.0]) and np.isnan(y[2])      # every run diverged at turn2: a gap
    x, y = curve(ax_w, "IMMUKF")
    assert y == pytest.approx([45.0, 40.0, 44.0])
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels[:3] == ["EKF", "UKF", "IMMUKF"] and any("diverged" in t for t in labels)
    # the IMM shares its base rule's colour, dashed
    styles = {c.get_label(): c.lines[0] for c in ax_w.containers}
    assert styles["IMMUKF"].get_color() == styles["UKF"].get_color() and styles["IMMUKF"].get_linestyle() == "--"


def test_ladder_curves_selected_algorithms_only():
    fig = views.ladder_curves(cells(), scenario_rows(), algorithms=["IMMUKF"])
    assert [c.get_label() for c in fig.axes[0].containers] == ["IMMUKF"]


def test_cell_table_rows():
    rows = views.cell_table(cells(), "paper")
    assert [r["algorithm"] for r in rows] == list(ALGORITHMS)
    assert all(list(r) == list(views.CELL_TABLE_KEYS) for r in rows)
    na = rows[2]
    assert any(REASON in str(v) for v in na.values())
    assert rows[0]["RMSE position (m)"] == "4.000 ± 0.080"  # the s.e. to two significant figures (format_pm)
    assert "inside" in rows[0]["ANEES (95 % band)"] and "outside" in rows[1]["ANEES (95 % band)"]
    assert rows[0]["rank"] == "1" and rows[0]["versus best, or why it does not apply"] == "best"
    text = markdown_table(list(rows[0]), [list(r.values()) for r in rows])
    assert REASON in text and text.count("\n") == 1 + len(rows)
    div = views.cell_table(cells(), "ladder-turn2")[0]
    assert div["RMSE position (m)"] == "--" and div["diverged"].startswith("20 of 20")
    part = views.cell_table(cells(), "ladder-nl3")[1]
    assert part["diverged"].startswith("3 of 20")


def test_bad_input_names_the_argument():
    good = cells()
    with pytest.raises(ValueError, match=r"^which: "):
        views.consistency_heatmap(good, which="nees")
    for f in (views.rmse_heatmap, views.consistency_heatmap, lambda c: views.ladder_curves(c, scenario_rows())):
        with pytest.raises(ValueError, match=r"^cells: "):
            f([])
        with pytest.raises(ValueError, match=r"^cells: "):
            f([{"scenario": "x"}])
    with pytest.raises(ValueError, match=r"^cells: "):
        views.rmse_heatmap(good + [good[0]])                  # a duplicate cell
    with pytest.raises(ValueError, match=r"^scenario: "):
        views.cell_table(good, "nowhere")
    with pytest.raises(ValueError, match=r"^scenarios: "):
        views.ladder_curves(good, None)
    with pytest.raises(ValueError, match=r"^scenarios: "):
        views.rmse_heatmap(good, scenarios=[{"title": "no name"}])
    with pytest.raises(ValueError, match=r"^scenarios: "):
        views.ladder_curves(good, [r for r in scenario_rows() if r["scenario"] == "paper"])
    with pytest.raises(ValueError, match=r"^algorithms: "):
        views.ladder_curves(good, scenario_rows(), algorithms=["EKF", "NOPE"])


def test_two_significant_digits():
    assert [views._sig2(v) for v in (1.0, 1.04, 2.96, 10.6, 33.4, 177.0, 4720.0, 53300.0, 0.945, 0.0042)] == \
        ["1.0", "1.0", "3.0", "11", "33", "180", "4700", "5.3e4", "0.94", "0.0042"]


def test_an_arena_result_stands_for_its_cells():
    from typing import NamedTuple

    class Result(NamedTuple):          # the shape of study.ArenaResult
        cells: list
        per_run: dict
        n_runs: int

    data = _image(views.rmse_heatmap(Result(cells(), {}, N)))
    assert data.shape == (len(SCENARIOS), len(ALGORITHMS))
    assert len(views.cell_table(Result(cells(), {}, N), "paper")) == len(ALGORITHMS)


def test_cell_table_reads_round_off_as_an_identity_without_a_z_score():
    """A cell identical to the best to round-off says so and gives only the size of the round-off; a cell with no
    detectable difference gives its difference with the standard error (two distinct readings)."""
    good = cells()
    ukf = next(c for c in good if (c["scenario"], c["algorithm"]) == ("paper", "UKF"))
    ukf["versus_best"] = {"algorithm": "EKF", "difference_m2": -1.5e-13, "stderr_m2": 1.4e-13,
                          "verdict": "identical (to round-off)"}
    got = views.cell_table(good, "paper")[1]["versus best, or why it does not apply"]
    assert got == "identical (to round-off) (vs EKF: |Δ MSE| 1e-13 m²)"
    ukf["versus_best"] = {"algorithm": "EKF", "difference_m2": 0.3, "stderr_m2": 0.2,
                          "verdict": "no detectable difference"}
    got = views.cell_table(good, "paper")[1]["versus best, or why it does not apply"]
    assert got == "no detectable difference (vs EKF: Δ MSE +0.30 ± 0.20 m²)"     # format_pm: s.e. to 2 figures


def _part(a, b, scenario, verdict, difference, reference, quantity="position MSE"):
    return {"comparison": f"{a} − {b}", "quantity": f"{quantity}, {scenario}", "verdict": verdict,
            "difference": difference, "stderr": 0.1, "reference": reference, "unit": "m²", "kind": "difference",
            "margin": None, "number": "..."}


def test_claim_scenario_matrix_one_row_per_pair_one_column_per_scenario():
    pcs = [{"paper": "p1", "claim": "A beats B and C", "verdict": "partly", "decisive": "1 of 3 hold; ...",
            "parts": [_part("A", "B", "s1", "identical (to round-off)", 1e-13, 10.0),
                      _part("A", "B", "s2", "holds", -2.0, 10.0),
                      _part("A", "C", "s2", "contradicted", 20.0, 10.0, quantity="diverged runs")],
            "pairs": [{"a": "A", "b": "B", "verdicts": {"s1": "not supported", "s2": "holds"},
                       "part_verdicts": {"s1": "identical (to round-off)", "s2": "holds"}},
                      {"a": "A", "b": "C", "verdicts": {"s2": "contradicted"},
                       "part_verdicts": {"s2": "contradicted"}}]}]
    text = views.claim_scenario_matrix(pcs)
    lines = text.splitlines()
    assert lines[0] == "| paper | verdict | A − B | s1 | s2 |"
    assert lines[2] == "| p1 | partly | A − B | ≡ | ✓ -20 % |"           # the identity carries no effect size
    assert lines[3] == "| p1 | partly | A − C |  | ✗ div. |"              # not applicable on s1; a divergence
    assert "≡ identical to round-off" in text and "· no detectable difference" in text
    with pytest.raises(ValueError, match=r"^paper_claims: "):
        views.claim_scenario_matrix([{"paper": "p1", "pairs": []}])
    with pytest.raises(ValueError, match=r"^paper_claims: "):
        views.claim_scenario_matrix("p1")
