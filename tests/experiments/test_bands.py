"""The bands of the envelope's boundaries: the walk along the grid, a value the planner never
reads, the foot width's monotone effect on the flat boundary, and the command's refusals."""

from dataclasses import replace

import numpy as np
import pytest

from slopewalk.bench.cli import main
from slopewalk.bench.experiments.envelope.bands import NOMINAL, Job, axis, run_job, walk
from slopewalk.bench.experiments.envelope.config import envelope_from_dict
from slopewalk.planner.gait_search import GaitProblem, ga_params
from slopewalk.planner.spec import default_spec_path, load_spec
from slopewalk.planner.uncertainty import spec_at


@pytest.mark.parametrize("n", [1, 2, 5, 12])
def test_the_walk_finds_the_last_inside_cell_from_any_start(n):
    for k in range(-1, n):  # cells 0..k inside, the rest outside; -1: none inside
        for start in range(-2, n + 2):
            asked = []

            def inside(i, k=k, asked=asked):
                asked.append(i)
                return i <= k

            assert walk(inside, n, start) == k
            # it asks only the cells between its start and the boundary, and one beyond
            s = min(max(start, 0), n - 1)
            assert len(asked) <= abs(s - k) + 2
            assert len(set(asked)) == len(asked)


def _config(step_times=(1.0, 0.7, 0.6, 0.5), slopes=(-5.0, 0.0, 25.0)):
    data = {
        "steps": 2,
        "grid": {"step_time": list(step_times), "slope": list(slopes), "actuators": ["stiff"]},
        "search": {"population": 8, "generations": 3, "seed": 1},
    }
    return envelope_from_dict(data, base_dir=default_spec_path().parent, source="t.toml")


def test_the_axes_run_from_the_easy_end():
    config = _config(step_times=(0.6, 1.0, 0.5, 0.7), slopes=(25.0, -5.0, 0.0, -10.0))
    assert axis(config, "flat") == [(1.0, 0.0), (0.7, 0.0), (0.6, 0.0), (0.5, 0.0)]
    assert axis(config, "up") == [(1.0, 0.0), (1.0, 25.0)]
    assert axis(config, "down") == [(1.0, 0.0), (1.0, -5.0), (1.0, -10.0)]


def test_a_value_the_planner_never_reads_gives_a_zero_width_band():
    """The servo's joint friction acts only in the simulator's servo modes: the GA's problem
    is the same with either end of its range, so is every margin the walk meets."""
    config = _config()
    spec = load_spec()
    cells = tuple(axis(config, "flat"))
    base = replace(config.cells[0], threads=1)
    rows = []
    for key, value in ((NOMINAL, np.nan), ("servo.friction_loss", 0.0055),
                       ("servo.friction_loss", 0.022)):  # fmt: skip
        changed = spec if key == NOMINAL else spec_at(spec, key, value)
        job = Job("paper", "flat", key, "low", value, cells, 1, base, changed)
        rows.append(run_job(job))
    assert rows[0]["searched"]  # cells were searched
    # the nominal row reports the margin at its own boundary cell (the first cell if none)
    searched = dict(part.split(": ") for part in rows[0]["searched"].split("; "))
    at = rows[0]["at"] if rows[0]["at"] is not None else cells[0][0]
    assert searched[f"{at:g}"] == f"{rows[0]['nominal_cell_margin_mm']:+.1f} mm"
    for row in rows[1:]:
        assert (row["index"], row["at"], row["searched"]) == (
            rows[0]["index"],
            rows[0]["at"],
            rows[0]["searched"],
        )


def test_a_wider_foot_never_makes_the_flat_boundary_slower():
    """The sole rectangle of a wider foot holds the narrower one and nothing else the GA
    measures depends on the width, so for every gait the ZMP margin can only grow; the
    boundary found by the walk with the best of a fixed set of gaits can only get faster."""
    spec = load_spec()
    step_times = (2.0, 1.0, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3)

    def measured(s):
        out = []
        for i, t in enumerate(step_times):
            problem = GaitProblem(s, ga_params(s, t, 0.0, steps=2))
            b = problem.bounds  # the kinematics' box: the width plays no part
            assert b == GaitProblem(spec, ga_params(spec, t, 0.0, steps=2)).bounds
            X = b.xl + np.random.default_rng(i).random((60, 3)) * (b.xu - b.xl)
            out.append(problem.measure(X))
        return out

    widths = (0.05, 0.06, 0.07)
    runs = [measured(spec_at(spec, "geometry.foot_width", w)) for w in widths]
    for narrow, wide in zip(runs, runs[1:], strict=False):
        for a, b in zip(narrow, wide, strict=True):
            ok = a.admissible
            assert np.array_equal(ok, b.admissible)
            assert np.all(b.margin[ok] >= a.margin[ok] - 1e-12)
            assert np.any(b.margin[ok] > a.margin[ok] + 1e-4)  # the width does enter it
    boundaries = []
    for run in runs:
        best = [float(np.max(m.margin[m.admissible], initial=-np.inf)) for m in run]
        boundaries.append(walk(lambda i, best=best: best[i] >= 0, len(step_times), 3))
    assert boundaries == sorted(boundaries)
    print(boundaries)


def _refused(argv, capsys):
    try:
        code = main(argv)
    except SystemExit as exit_:
        code = exit_.code
    err = capsys.readouterr().err
    assert code not in (0, None), err
    assert err.endswith("\n") and err.count("\n") == 1 and "Traceback" not in err, err
    return err


def test_the_command_refuses_a_bad_range_or_no_table_in_one_line(tmp_path, capsys):
    text = default_spec_path().read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(
        text.replace("servo.stall_torque = [1.2, 1.6]", "servo.stall_torque = [1.6, 1.2]")
    )
    err = _refused(["bands", "--robot", str(bad), "--out", str(tmp_path / "o")], capsys)
    assert "uncertain.servo.stall_torque [1.6, 1.2] N m: low must be < high" in err
    plain = tmp_path / "plain.toml"
    plain.write_text(text[: text.index("[uncertain]")])
    err = _refused(["bands", "--robot", str(plain), "--out", str(tmp_path / "o")], capsys)
    assert "no [uncertain] table" in err
    err = _refused(["bands", "--walk", "contact.stiffness", "--out", str(tmp_path / "o")], capsys)
    assert "--walk contact.stiffness: not a value of the [uncertain] table of" in err
    assert "contact.timeconst" in err  # the known keys are named
    assert not (tmp_path / "o").exists()


def test_a_boundary_gaits_verdict_shows_the_strict_walk_where_it_differs():
    """bands.md's MuJoCo table: the balance verdict and, in brackets, the strict one ("stable
    (overload)", "stable (walked)"); the balance verdict alone where the walk fails with it
    (a tip is a tip) or the table is older than the walk columns."""
    from slopewalk.bench.experiments.envelope.bands import _verdicts

    row = {
        "maxmargin_stiff_verdict": "stable",
        "maxmargin_stiff_walk": "overload",
        "maxmargin_servo_verdict": "stable",
        "maxmargin_servo_walk": "walked",
        "maxmargin_servo_ff_verdict": "tip",
        "maxmargin_servo_ff_walk": "tip",
        "maxmargin_stiff_ff_verdict": "stable",
    }
    assert _verdicts(row, "stiff") == "stable (overload)"
    assert _verdicts(row, "servo") == "stable (walked)"
    assert _verdicts(row, "servo_ff") == "tip"
    assert _verdicts(row, "stiff_ff") == "stable"  # a table written before the walk columns
