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


# --- spec ends ----------------------------------------------------------------------------------

LOW, HIGH = "servo.armature:low", "servo.armature:high"


def _at(step_time, end, simulated, predicted):
    r = _row(step_time, 0, simulated, predicted) | {"actuators": "servo", "command_noise_deg": 0.0}
    return r | {"compliant_verdict": "stable"} | ({"spec_end": end} if end else {})


NOMINAL_ROWS = [  # a table without the column: every row nominal
    _at(1.0, None, "stable", "stable"),  # A: tips at the high end; predicted agrees
    _at(0.5, None, "fall", "stable"),  # B: walks at the high end; predicted misses, moves itself
    _at(0.4, None, "fall", "tip"),  # C: decided; agrees
    _at(0.3, None, "tip", "stable"),  # D: decided; missed
    _at(0.2, None, "stable", "stable"),  # E: no ends: not counted
]
END_ROWS = [
    _at(1.0, LOW, "stable", "stable"), _at(1.0, HIGH, "tip", "stable"),
    _at(0.5, LOW, "fall", "tip"), _at(0.5, HIGH, "stable", "stable"),
    _at(0.4, LOW, "fall", "tip"), _at(0.4, HIGH, "fall", "tip"),
    _at(0.3, LOW, "tip", "stable"), _at(0.3, HIGH, "tip", "stable"),
    _at(0.3, HIGH, "error", "error") | {"seed": 1},  # errors are no replica
]  # fmt: skip


def test_spec_ends_pair_with_the_nominal_rows_of_any_table():
    from slopewalk.bench.report.replicas import spec_decides, spec_groups

    tables = {"nom": NOMINAL_ROWS, "ends": END_ROWS}
    groups = spec_groups(tables)
    assert sorted(k[0] for k in groups) == [0.3, 0.4, 0.5, 1.0]  # E has no ends
    assert all(set(g) == {"nominal", LOW, HIGH} for g in groups.values())
    decides = spec_decides(tables)
    assert sorted(k[0] for k in decides) == [0.5, 1.0]
    assert decides[next(k for k in decides if k[0] == 1.0)] == (
        f"the spec's estimates decide it (walks at nominal, {LOW}; not at {HIGH})"
    )
    assert spec_decides({"ends": END_ROWS}) == {}  # no nominal row: nothing to pair


def test_the_spec_end_section_counts_by_hand():
    from slopewalk.bench.report.replicas import spec_end_section

    lines = spec_end_section({"nom": NOMINAL_ROWS, "ends": END_ROWS}, lambda k, n: f"{k}/{n}")
    # 4 trials with ends, 2 ends; A and B move; of the misses (B, D) B is on them; decided
    # C, D: the paper (stable everywhere) 0/2, the predicted 1/2; the predicted verdict moves
    # on B only: of A, C, D it agrees on A and C
    row = "| nom | servo | 4 | 2 | 2/4 50.0% | 1/2 | 0/2 | 0/2 | 1/2 | 2/3; uncertain 1/4 25.0% |"
    assert row in lines
    # end by end: A alone walks at the nominal spec, the predicted verdict right on A and C;
    # at the high end A tips and B walks (both moved), the predicted verdict right on B, C
    # (the low end moves the predicted verdict of B alone, to tip; the high end none)
    assert "| nom | servo | nominal | 1/4 | 0 | 0 | 0 | 2/4 |" in lines
    assert f"| nom | servo | {LOW} | 1/4 | 0 | 1 | 0 | 3/4 |" in lines
    assert f"| nom | servo | {HIGH} | 1/4 | 2 | 0 | 0 | 2/4 |" in lines
    # as a probability: p (share of the 3 specs predicted stable) is 1, 2/3, 0, 1 for A-D,
    # MuJoCo's nominal walk 1, 0, 0, 0: Brier (0 + 4/9 + 0 + 1) / 4 = 13/36; the 0/1
    # predicted verdict misses B, D (0.5), the paper's (stable everywhere) B, C, D (0.75);
    # MuJoCo's own shares 2/3, 1/3, 0, 0: (1/9 + 1/9) / 4 = 1/18. Bins: C; -; B; A and D
    assert (
        "| nom | servo | 0.361 | 0.500 | 0.750 | 0.056 | 0/1 walk | - | 0/1 walk | 1/2 walk |"
        in lines
    )
    assert spec_end_section({"nom": NOMINAL_ROWS}, str) == []  # no ends anywhere


def test_an_end_moves_the_prediction_alike_only_where_it_moves_mujoco_the_same_way():
    from slopewalk.bench.report.replicas import spec_end_section

    nominal = [_at(1.0, None, "stable", "stable"), _at(0.5, None, "fall", "tip"),
               _at(0.4, None, "stable", "tip"), _at(0.3, None, "tip", "tip")]  # fmt: skip
    # P stops walking in both, Q starts walking in both, R the opposite ways, S stays
    ends = [_at(1.0, HIGH, "tip", "tip"), _at(0.5, HIGH, "stable", "stable"),
            _at(0.4, HIGH, "fall", "stable"), _at(0.3, HIGH, "tip", "tip")]  # fmt: skip
    lines = spec_end_section({"nom": nominal, "ends": ends}, lambda k, n: f"{k}/{n}")
    assert f"| nom | servo | {HIGH} | 1/4 | 3 | 3 | 2 | 3/4 |" in lines


def test_a_disagreement_says_when_the_spec_decides_its_trial():
    from slopewalk.bench.report.fidelity import fidelity_report

    extra = dict.fromkeys(
        ("predicted_events", "events", "predicted_rotation_deg", "compliant_min_margin_mm"), 0.0
    ) | {"unplanned_support_s": 0.0, "tracking_rms_deg": 0.1, "analytic_min_margin_mm": 1.0}
    extra |= {"first_event_time_s": 1.0, "simulated_max_tilt_deg": 0.0}
    text = fidelity_report(
        {"nom": [r | extra for r in NOMINAL_ROWS]},
        held_out={"ends": [r | extra for r in END_ROWS]},
    )
    assert "## Where the spec's estimates decide the simulated verdict" in text
    assert "1 of them on trials whose simulated verdict moves within the spec's" in text
    assert f"; the spec's estimates decide it (walks at {HIGH}; not at nominal, {LOW})" in text
    assert "Not listed one by one in a table of spec ends" in text  # the replicas' misses
    assert "- t_c 1 s, 0°, μ 1, servo:" not in text  # A walks on the nominal spec
