"""Re-predicting a finished sweep's trials (bench/experiments/repredict.py).

What it guarantees: with the predictor that wrote a table, each trial's prediction worked
out again is the table's, verdict, event kinds and support turn (to the table's 1e-5°),
on this machine; so a predictor change moves only what it changes. The sweep below plays
a spec end, a mass scaling, two frictions and two modes, each a different input of the
prediction a wrong reconstruction of the trial would get wrong.
"""

from __future__ import annotations

import csv

import pytest

from slopewalk.bench.cli import main
from slopewalk.bench.experiments import repredict as rp
from slopewalk.bench.experiments.repredict import Repredicted, report, repredict
from slopewalk.planner.errors import SlopewalkError

SWEEP = """steps = 1
spec_ends = ["nominal", "servo.stiffness:low"]
[grid]
step_time = [1.0, 0.4]
friction = [0.3, 1.0]
actuators = ["servo", "stiff_ff"]
[[trial]]
step_time = 1.0
mass_scale = { legs = 2 }
"""


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """The sweep above, run once on one worker: (sweep file, its table)."""
    out = tmp_path_factory.mktemp("repredict")
    (out / "s.toml").write_text(SWEEP)
    assert main(["sweep", str(out / "s.toml"), "--workers", "1", "--out", str(out)]) == 0
    return out / "s.toml", out / "sweep.csv"


def test_the_predictor_that_wrote_a_table_predicts_each_of_its_trials_as_it_did(swept):
    found = repredict(*swept)
    with open(swept[1], newline="") as f:
        assert len(found) == sum(1 for _ in csv.DictReader(f)) == 18
    for r in found:
        assert r.now == r.before and r.events_now == r.events_before, r.label
        assert abs(r.rotation_now_deg - r.rotation_before_deg) <= 5e-6, r.label
    assert "moved: 0" in report(found)


def test_two_worker_processes_predict_what_one_does_in_the_same_order(swept):
    one, two = repredict(*swept), repredict(*swept, workers=2)
    assert [(r.trial_id, r.now, r.events_now) for r in two] == [
        (r.trial_id, r.now, r.events_now) for r in one
    ]
    assert [r.rotation_now_deg for r in two] == [r.rotation_now_deg for r in one]


def test_the_sweep_exercises_what_a_wrong_reconstruction_would_miss(swept):
    # the spec end and the friction each change some prediction in the table, so a
    # re-prediction on the nominal spec or at another μ would not match it (test above)
    with open(swept[1], newline="") as f:
        rows = list(csv.DictReader(f))

    def turn(**where):
        return {
            r["predicted_rotation_deg"]
            for r in rows
            if all(r[k] == v for k, v in where.items()) and r["mass_scale"] == "none"
        }

    servo = {"step_time": "1.0", "friction": "1.0", "actuators": "servo"}
    assert turn(**servo, spec_end="nominal") != turn(**servo, spec_end="servo.stiffness:low")
    assert any(
        turn(step_time=t, actuators=m, friction="0.3")
        != turn(step_time=t, actuators=m, friction="1.0")
        for t in ("1.0", "0.4")
        for m in ("servo", "stiff_ff")
    )


def test_only_the_mode_asked_for(swept):
    found = repredict(*swept, mode="stiff_ff")
    assert found and {r.actuators for r in found} == {"stiff_ff"}


def test_a_moved_verdict_is_counted_and_listed():
    def row(before, now, simulated):
        return Repredicted("id", "servo", "T=1 s", simulated, before, now, "", "", 0.0, 0.0)

    text = report([row("stable", "tip", "fall"), row("stable", "stable", "stable")])
    assert "servo: 2, 1 -> 2" in text and "moved: 1" in text
    assert "T=1 s: stable -> tip (MuJoCo fall)" in text


def test_a_file_that_is_not_a_sweep_table_is_one_error_line(swept, tmp_path, capsys):
    bad = tmp_path / "other.csv"
    bad.write_text("a,b\n1,2\n")
    with pytest.raises(SlopewalkError, match="not a sweep table"):
        repredict(swept[0], bad)
    assert rp.main([str(swept[0]), str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "predicted_verdict" in err
    assert rp.main([str(swept[0]), str(tmp_path / "missing.csv")]) == 2
