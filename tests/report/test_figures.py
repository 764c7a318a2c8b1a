"""The figures say what they show: outcomes told apart, cases and steps named, gaps explained."""

import numpy as np
import pytest
from matplotlib.colors import to_rgba

from slopewalk.bench.report import figures
from slopewalk.bench.sim.trial import run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk


@pytest.fixture
def drawn(monkeypatch):
    """The figures a call draws, kept open instead of written."""
    kept = []
    monkeypatch.setattr(figures, "_save", lambda fig, path: kept.append(fig) or path)
    return kept


def _trial(spec, step_time, slope_deg):
    plan = plan_walk(spec, GaitParams.nominal(spec, step_time, slope=np.deg2rad(slope_deg)))
    return plan, run_trial(spec, TrialSpec(plan.params), plan=plan)


def _row(step_time, analytic, simulated):
    return {
        "step_time": step_time,
        "slope_deg": 0.0,
        "friction": 1.0,
        "mass_scale": "",
        "actuators": "stiff",
        "analytic_verdict": analytic,
        "simulated_verdict": simulated,
    }


def _marker(collection):
    return collection.get_paths()[0].vertices.round(6).tobytes()


def test_stability_map_gives_each_outcome_its_own_colour_and_marker(drawn, tmp_path):
    """One point per outcome; the drawn colours and marker shapes are pairwise distinct."""
    simulated = ("stable", "slip", "tip", "fall", "diverged")
    rows = [_row(0.4 + 0.1 * i, "zmp_outside", v) for i, v in enumerate(simulated)]
    rows.append(_row(2.0, "stable", "stable"))
    figures.stability_map(rows, tmp_path / "map.png")
    (ax,) = drawn[0].axes[:1]
    outer, inner = ax.collections[0::2], ax.collections[1::2]  # ring then dot, per row
    style = {}
    for row, ring, dot in zip(rows, outer, inner, strict=True):
        style[row["simulated_verdict"]] = (tuple(ring.get_edgecolor()[0]), _marker(ring))
        style[row["analytic_verdict"]] = (tuple(dot.get_facecolor()[0]), _marker(dot))
    assert set(style) == {*simulated, "zmp_outside"}
    colours = [c for c, _ in style.values()]
    markers = [m for _, m in style.values()]
    assert len(set(colours)) == len(style), style
    assert len(set(markers)) == len(style), style
    assert to_rgba(style["fall"][0]) != to_rgba(style["zmp_outside"][0])
    legend_labels = [t.get_text() for lg in drawn[0].legends for t in lg.get_texts()]
    assert sorted(legend_labels) == sorted(["stable", "zmp_outside", *simulated])


def test_joint_figures_name_their_case_and_step(spec, drawn, tmp_path):
    plan, result = _trial(spec, 1.0, 0.0)
    figures.joint_angles(plan, result, tmp_path / "a.png")
    figures.joint_torques(plan, result, tmp_path / "t.png")
    for fig in drawn:
        title = fig._suptitle.get_text()
        for words in ("flat", "t_c = 1 s", "μ = 1", "stiff", "step 2 of 4", "t = 1 … 2 s"):
            assert words in title, title


def test_zmp_traces_say_why_a_panel_has_no_simulated_cop(spec, drawn, tmp_path):
    """22.5° at 1 s: the robot tips in step 1 and falls before step 2's single support."""
    cases = [("22.5°", *_trial(spec, 1.0, 22.5)), ("flat 2 s", *_trial(spec, 2.0, 0.0))]
    figures.zmp_traces(cases, tmp_path / "zmp.png")
    steep, flat = drawn[0].axes

    def simulated_cop(ax):
        (line,) = [ln for ln in ax.get_lines() if ln.get_label().startswith("simulated")]
        return line.get_xydata()

    assert simulated_cop(steep).size == 0 and simulated_cop(flat).size > 0
    (note,) = [t.get_text() for t in steep.texts]
    lost = next(e for e in cases[0][2].events if e.kind in ("tip", "fall"))
    assert note.startswith("no simulated CoP") and f"{lost.kind} at {lost.time:.2f} s" in note
    assert lost.cause in note
    assert len(flat.texts) == 0 and "step 2 of 4" in flat.get_title()


def _legend_boxes(fig):
    fig.canvas.draw()
    return [leg.get_window_extent() for leg in fig.legends], fig.bbox


@pytest.mark.parametrize("frictions", [(1.0,), (0.6, 1.0), (0.4, 0.6, 1.0)])
@pytest.mark.parametrize("robots", [("default",), ("big.toml", "default")])
def test_stability_map_legends_neither_overlap_nor_clip(drawn, tmp_path, frictions, robots):
    """One panel (a small sweep) or three: both legends inside the figure, apart, above
    the panels; one row of panels per robot, each panel only its robot's points."""
    rows = [
        {**_row(t, "stable", "tip" if robot == "default" else "stable"), "friction": mu,
         "robot": robot}
        for robot in robots for mu in frictions for t in (0.5, 1.0)
    ]  # fmt: skip
    figures.stability_map(rows, tmp_path / "map.png")
    fig = drawn[0]
    (analytic, simulated), box = _legend_boxes(fig)
    for legend in (analytic, simulated):
        assert box.x0 <= legend.x0 and legend.x1 <= box.x1, (legend, box)
        assert box.y0 <= legend.y0 and legend.y1 <= box.y1, (legend, box)
        for ax in fig.axes:
            assert not legend.overlaps(ax.get_tightbbox()), "a legend over a panel"
    assert not analytic.overlaps(simulated)
    assert len(fig.axes) == len(frictions) * len(robots)
    for ax in fig.axes:
        robot = next((r for r in robots if f"robot {r}," in ax.get_title()), robots[0])
        assert len(robots) == 1 or robot in ax.get_title()
        rings = ax.collections[0::2]
        tip = {tuple(ring.get_edgecolor()[0]) for ring in rings}
        want = to_rgba(figures._style("tip" if robot == "default" else "stable")[0])
        assert tip == {want}, (ax.get_title(), tip)


def test_lipm_figure_draws_each_robot_apart(drawn, tmp_path):
    """Two robots at the same step times: one line pair each, none joining two robots."""
    series = {
        "big.toml": ([0.5, 1.0], [43.4, 7.8], [90.0, 26.5]),
        "default": ([0.5, 1.0], [16.1, 3.6], [27.9, 11.7]),
    }
    figures.lipm_vs_step_time(series, tmp_path / "lipm.png")
    (ax,) = drawn[0].axes
    lines = ax.get_lines()
    assert len(lines) == 4
    for name, (times, analytic, simulated) in series.items():
        mine = [ln for ln in lines if ln.get_label().startswith(f"{name}: ")]
        assert [list(ln.get_ydata()) for ln in mine] == [analytic, simulated]
        assert all(list(ln.get_xdata()) == times for ln in mine)
    unnamed = {None: series["default"]}
    figures.lipm_vs_step_time(unnamed, tmp_path / "one.png")
    labels = [ln.get_label() for ln in drawn[1].axes[0].get_lines()]
    assert labels == [
        "multibody ZMP (eq. 4) vs LIPM (eq. 5)",
        "simulated CoP vs LIPM (while standing)",
    ]
