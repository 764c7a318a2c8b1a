"""The strict walk verdict against evidence of its own: MuJoCo stepped by hand, and a
hand-built recording whose landing errors are known by construction.

* overload: the trial's torque ratio is MuJoCo's ``data.actuator_force`` (read after each
  ``mj_step`` of an independent loop, not the rollout's sensors) over the spec's stall
  torque, and the verdict is ``overload`` exactly when that force reaches SATURATION of it.
* shuffle: a gait whose swing lift (0.5 mm) is below the floor's give (TOUCH_HEIGHT, 1 mm)
  drags its swing foot: MuJoCo's own contact list (``data.contact``, ``mj_contactForce``)
  has the swing foot pushed by the plane for longer than TOUCH_ALLOWANCE in a single
  support, and the verdict is ``shuffle``; the nominal lift (66.6 mm) is not.
* off_footprint: a recording whose soles stand exactly on the plan's footprints, one
  landing moved by a known distance or turned by a known angle.
"""

import mujoco
import numpy as np
import pytest

from slopewalk.bench.sim.model import servo_settings
from slopewalk.bench.sim.playback import (
    HOLD_TIME,
    SETTLE_TIME,
    Recording,
    build_model,
    control_sequence,
    initial_state,
)
from slopewalk.bench.sim.trial import run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.bench.sim.walk_check import (
    LANDING_TOLERANCE,
    WalkMeasures,
    heading_tolerance,
    landing_errors,
    walk_verdict,
)
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import LEFT
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.walk_prediction import SATURATION, TOUCH_ALLOWANCE, TOUCH_HEIGHT

DT = 0.001  # [s]


def _stepped(plan):
    """Play ``plan`` stiff with ``mj_step`` (no rollout, no sensors): row times [s], the
    actuator forces [N m] (m, 8) and whether each foot is pushed by the plane (m, 2)."""
    model = build_model(plan, friction=1.0, actuators="stiff", timestep=DT)
    data = mujoco.MjData(model)
    state = initial_state(model, plan)
    mujoco.mj_setState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    t, q_ref = control_sequence(
        plan, DT, SETTLE_TIME, HOLD_TIME, servo_settings(plan.spec, "stiff")
    )
    feet = [model.geom(f"{p}foot").id for p in ("l_", "r_")]
    force = np.empty((t.size, model.nu))
    pushed = np.zeros((t.size, 2), bool)
    wrench = np.zeros(6)
    for k in range(t.size):
        data.ctrl[:] = q_ref[k]
        mujoco.mj_step(model, data)  # its forward pass is row k's state
        force[k] = data.actuator_force
        for c in range(data.ncon):
            contact = data.contact[c]
            for side, geom in enumerate(feet):
                if geom in (contact.geom1, contact.geom2):
                    mujoco.mj_contactForce(model, data, c, wrench)
                    pushed[k, side] |= wrench[0] > 0
    return t, force, pushed


def _swing_touch(plan, t, pushed) -> float:
    """Longest time [s] a swing foot is pushed in one step's planned single support."""
    g = plan.params
    dsp = (1 - g.ssp_fraction) * g.step_time
    longest = 0.0
    for k in range(g.steps):
        rows = (t >= k * g.step_time + dsp) & (t < (k + 1) * g.step_time)
        mid = np.searchsorted(plan.t, (k + 0.5 * (1 + dsp / g.step_time)) * g.step_time)
        swing = 1 if plan.stance[mid] == LEFT else 0
        longest = max(longest, pushed[rows, swing].sum() * DT)
    return longest


@pytest.mark.parametrize("step_time", [1.0, 2.0])
def test_overload_is_mujocos_actuator_force_over_the_stall_torque(spec, step_time):
    """Stiff actuators (limit far above the servo's): at 1 s the swing knee, accelerating its
    own rotor (armature) with the leg, passes the AX-12A's 1.5 N m (measured 2.19 N m; the
    links' Newton–Euler torque alone 0.45 N m); at 2 s every joint stays under it."""
    gait = GaitParams.nominal(spec, step_time, steps=2)
    plan = plan_walk(spec, gait)
    t, force, _ = _stepped(plan)
    walk = (t >= plan.t[0]) & (t <= plan.t[-1])
    peak = np.abs(force[walk]).max()
    result = run_trial(spec, TrialSpec(gait), plan=plan, predict=False)
    assert result.simulated_verdict == "stable"
    assert servo_settings(spec, "stiff").force_limit > 2 * spec.stall_torque
    assert result.torque_ratio == pytest.approx(peak / spec.stall_torque, rel=1e-6)
    over = peak >= SATURATION * spec.stall_torque
    assert over == (step_time == 1.0)  # the case each parameter stands for
    assert (result.walk_verdict == "overload") == over
    # the links alone ask for under a third of the servo; the rotor's inertia × q̈ is what
    # passes it, and the plan predicts it (planned 1.35 × stall at 1 s, 0.39 × at 2 s)
    assert np.abs(plan.tau).max() < spec.stall_torque / 3
    assert (result.predicted_torque_ratio >= SATURATION) == over
    assert result.predicted_torque_ratio == pytest.approx(result.torque_ratio, rel=0.15)


@pytest.mark.parametrize("lift", [0.0005, 0.0666])
def test_a_swing_lift_below_the_floors_give_shuffles(spec, lift):
    gait = GaitParams.nominal(spec, 1.0, steps=2, swing_lift=lift)
    plan = plan_walk(spec, gait)
    t, _, pushed = _stepped(plan)
    touch = _swing_touch(plan, t, pushed)
    result = run_trial(spec, TrialSpec(gait), plan=plan)
    print("\n".join(result.summary_lines()))
    assert result.simulated_verdict == "stable"
    # the contact sensor's "pushed" and MuJoCo's contact list agree to a row at each end
    assert result.swing_touch == pytest.approx(touch, abs=2 * DT)
    shuffles = lift < TOUCH_HEIGHT
    assert (touch > TOUCH_ALLOWANCE) == shuffles
    assert (result.walk_verdict == "shuffle") == shuffles
    assert (result.predicted_walk_verdict == "shuffle") == shuffles


def _on_footprints(plan, moved=(0.0, 0.0), turned=0.0, step=1) -> Recording:
    """A recording (1 ms rows from t = -0.5 s) whose soles stand where the plan has them at
    every row, and whose foot of landing ``step`` is moved by ``moved`` [m] in the plane and
    turned by ``turned`` [rad] from its landing on."""
    t = np.arange(-0.5, plan.t[-1] + 0.5, DT)
    i = np.clip(np.searchsorted(plan.t, t), 0, plan.t.size - 1)
    sole = np.empty((t.size, 2, 3))
    for side in (0, 1):
        mine = (plan.stance[i] == side)[:, None]
        sole[:, side] = np.where(mine, plan.stance_sole[i], plan.swing_sole[i])
    axis = np.tile([1.0, 0.0, 0.0], (t.size, 2, 1))
    g = plan.params
    lands = (step + 1) * g.step_time
    mid = np.searchsorted(plan.t, lands - g.ssp_fraction * g.step_time / 2)
    foot = 1 if plan.stance[mid] == LEFT else 0
    after = t >= lands
    sole[after, foot, :2] += moved
    axis[after, foot] = [np.cos(turned), np.sin(turned), 0.0]

    class Sensors:
        pass

    sensors = Sensors()
    sensors.sole, sensors.foot_axis_x = sole, axis
    return Recording(t=t, q_ref=np.zeros((t.size, 8)), sensors=sensors, force_limit=1.5,
                     diverged_at=None)  # fmt: skip


def test_a_landing_off_its_footprint_is_measured_by_its_distance_and_turn(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=3))
    distance, heading = landing_errors(plan, _on_footprints(plan))
    assert np.abs(distance).max() < 1e-12 and np.abs(heading).max() < 1e-12
    distance, heading = landing_errors(plan, _on_footprints(plan, moved=(0.003, -0.004)))
    assert distance == pytest.approx([0.0, 0.005, 0.0], abs=1e-12)  # 3-4-5 mm
    turn = np.deg2rad(12.0)
    distance, heading = landing_errors(plan, _on_footprints(plan, turned=turn, step=2))
    assert heading == pytest.approx([0.0, 0.0, turn], abs=1e-12)


def test_the_verdict_names_the_first_failed_check_after_the_balance():
    def measures(**changes):
        ok = dict(landing_error=0.0, landing_heading_error=0.0, swing_touch=0.0,
                  pelvis_end_error=0.0, torque_ratio=0.5, heading_tolerance=0.1,
                  pelvis_tolerance=0.01)  # fmt: skip
        return WalkMeasures(**(ok | changes))

    assert walk_verdict("stable", measures()) == "walked"
    assert walk_verdict("tip", measures(torque_ratio=2.0)) == "tip"
    assert walk_verdict("stable", measures(landing_error=LANDING_TOLERANCE * 1.01)) == (
        "off_footprint"
    )
    assert walk_verdict("stable", measures(landing_heading_error=0.11)) == "off_footprint"
    assert walk_verdict("stable", measures(swing_touch=0.2, landing_error=1.0)) == "shuffle"
    assert walk_verdict("stable", measures(torque_ratio=SATURATION, swing_touch=1)) == "overload"
    assert walk_verdict("stable", measures(pelvis_end_error=0.02)) == "pelvis_off"
    # the Bioloid's 60 mm foot: 5 mm at its toe is a turn of 1/6 rad (9.5 deg)
    assert heading_tolerance(0.06) == pytest.approx(1 / 6)


@pytest.mark.parametrize("mode", ["stiff", "stiff_ff"])
def test_the_floors_give_makes_a_low_swing_shuffle_unless_fed_forward(spec, mode):
    """A 7.4 mm lift (the GA's typical one) at 1.5 s steps: played stiff, the stance sole's
    give tilts the robot onto the swing foot (MuJoCo's contact list has it on the plane
    longer than TOUCH_ALLOWANCE; the plan, counting its sole within TOUCH_HEIGHT, predicts
    it); fed forward ("_ff", the give cancelled) the swing foot clears the plane."""
    gait = GaitParams.nominal(spec, 1.5, steps=2, swing_lift=0.0074)
    plan = plan_walk(spec, gait)
    result = run_trial(spec, TrialSpec(gait, actuators=mode), plan=plan)
    assert result.simulated_verdict == "stable"
    fed = mode.endswith("_ff")
    if not fed:  # the independent loop plays the stiff mode's commands (no feedforward)
        t, _, pushed = _stepped(plan)
        assert result.swing_touch == pytest.approx(_swing_touch(plan, t, pushed), abs=2 * DT)
    assert (result.swing_touch > TOUCH_ALLOWANCE) == (not fed)
    assert result.walk_verdict == ("walked" if fed else "shuffle")
    assert result.predicted_walk_verdict == result.walk_verdict
