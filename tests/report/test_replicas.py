"""Replicas: per-seed agreement and the trials whose simulated verdict the seed decides."""

from slopewalk.bench.report.replicas import flipping, replica_section


def _row(step_time, seed, simulated, predicted, paper="stable"):
    return {
        "step_time": step_time,
        "slope_deg": 0.0,
        "friction": 1.0,
        "actuators": "stiff",
        "robot": "default",
        "mass_scale": "",
        "seed": seed,
        "command_noise_deg": 1e-4,
        "simulated_verdict": simulated,
        "predicted_verdict": predicted,
        "analytic_verdict": paper,
    }


def _label(r):
    return f"T {r['step_time']:g}"


ROWS = [
    _row(1.0, 0, "stable", "stable"),
    _row(1.0, 1, "stable", "stable"),
    _row(1.0, 2, "tip", "stable"),  # this trial's verdict is the seed's
    _row(0.5, 0, "fall", "tip", paper="zmp_outside"),
    _row(0.5, 1, "fall", "tip", paper="zmp_outside"),
    _row(0.5, 2, "fall", "tip", paper="zmp_outside"),
]


def test_a_trial_flips_when_it_walks_under_some_seeds_only():
    flips = flipping(ROWS)
    assert list(flips) == [(1.0, 0.0, 1.0, "stiff", "default", "")]
    assert flipping([r for r in ROWS if r["seed"] != 2]) == {}


def test_the_section_counts_each_seed_and_names_the_flipping_trials():
    text = "\n".join(replica_section(ROWS, _label))
    assert "### Replicas: 3 seeds of command noise 0.0001°" in text
    assert "| 0 | 2 | 2/2 (100.0%) | 2/2 (100.0%) |" in text
    assert "| 2 | 2 | 1/2 (50.0%) | 1/2 (50.0%) |" in text
    assert "agrees in 1/2 (50.0%) to 2/2 (100.0%)" in text
    assert "1 of 2 trials walk under some seeds" in text
    assert "1 of the predicted verdict's 1 disagreements" in text
    assert "- T 1: walks under 2/3 seeds (else tip); predicted stable" in text


def test_one_seed_has_no_section():
    assert replica_section([r for r in ROWS if r["seed"] == 0], _label) == []


def test_a_disagreement_in_a_one_seed_table_says_when_the_noise_decides_its_trial():
    from slopewalk.bench.report.fidelity import fidelity_report
    from slopewalk.bench.report.replicas import undecided

    assert undecided({"noise": ROWS}) == {
        (1.0, 0.0, 1.0, "stiff", "default", ""): "walks under 2/3 seeds of command noise (noise)"
    }
    assert undecided({"one seed": ROWS[:1]}) == {}
    extra = dict.fromkeys(
        ("predicted_events", "events", "predicted_rotation_deg", "compliant_min_margin_mm"), 0.0
    ) | {"compliant_verdict": "stable", "unplanned_support_s": 0.0, "tracking_rms_deg": 0.1}
    extra |= {"analytic_min_margin_mm": 1.0, "first_event_time_s": 1.0}
    extra |= {"simulated_max_tilt_deg": 0.0}
    single = [ROWS[2] | extra | {"seed": 0}]  # the flipping trial, one seed, disagreeing
    text = fidelity_report({"single": single, "noise": [r | extra for r in ROWS]})
    assert "MuJoCo does not decide it: walks under 2/3 seeds of command noise (noise)" in text
    assert "1 of them on trials whose simulated verdict command noise decides" in text
