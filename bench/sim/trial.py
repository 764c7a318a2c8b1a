"""One trial: plan a walk, play it in MuJoCo, compare prediction and physics.

``TrialResult.series`` (all on the walk's time base ``t``, vectors in S unless
said): ``zmp_analytic``, ``zmp_lipm``, ``cop`` (simulated, NaN when no foot is
loaded), ``foot_cop`` (n, 2, 2) and ``foot_force`` (n, 2, 3) per foot (left,
right), ``q_planned`` / ``q_simulated`` (MJCF joint order), ``standing``,
``margin_analytic``, ``actuator_force``, ``sole`` (n, 2, 3), ``pelvis_height``,
and ``qpos`` (n, 15): the simulated MuJoCo ``qpos`` (world frame) for replaying
the motion, e.g. with ``mj_kinematics``. The settling before the walk (the robot held
at the first pose, t < 0) has its own rows: ``settling_t`` and ``settling_<name>`` for
``qpos``, ``q_simulated``, ``actuator_force``, ``cop``, ``foot_cop`` and ``foot_force``.
A trial on an imported model (``scene``) also has ``model_qpos`` and
``settling_model_qpos`` (n, nq): the model's own ``qpos``, which a recording redraws.

``run_trial(spec, trial)`` returns a ``TrialResult``: both ZMP series on the
walk's time base, their RMS and max distance over the samples where the robot
stands (before any tip or fall, both values finite), the margin of each to the
planned support polygon, both verdicts, the events, the required friction ratio
against μ, and planned vs simulated joint angles. Joint tracking is measured from
the angles the playback aims at (``Recording.aim_offset``): the planned ones, plus what
a feedforward mode adds against the floor's give and sink (ankle turns, shorter legs).

Analytic verdicts (``prediction.py``): the paper's, ``analytic_verdict``: ``stable``
when the planned ZMP stays inside the support polygon at every sample, else
``zmp_outside``; ``compliant_verdict``, the same test on the walk the trial's servo
reaches under the planned torques (series ``zmp_compliant``); ``predicted_verdict``,
the most severe predicted event (joint_limit, saturation, tip, strike, swing_drag, slip,
foot_slide, ring) or
``stable``, with ``predicted_events``. ``slip_predicted`` when the required friction
|F_t|/F_n of the planned ground force exceeds μ somewhere. ``unplanned_support_s``
(``support.py``): foot-time the simulated contacts differed from the plan's.
"""

from __future__ import annotations

import io
import json
import time
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from slopewalk.bench.actuators import actuator_mode
from slopewalk.bench.sim.closed_loop import play_controller
from slopewalk.bench.sim.events import Event, detect, loaded_tilt, verdict
from slopewalk.bench.sim.playback import Recording, on_rows, play
from slopewalk.bench.sim.prediction import PredictionBeside, TrialPrediction, predict_trial
from slopewalk.bench.sim.support import support_difference
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.bench.sim.walk_check import measure as measure_walk
from slopewalk.bench.sim.walk_check import walk_verdict
from slopewalk.planner.joints import stance_swing_to_left_right
from slopewalk.planner.kinematics import GRAVITY, rotation_slope_to_world
from slopewalk.planner.plan import (
    LARGE_WALK_SAMPLES,
    Plan,
    measure_cost,
    plan_walk,
    refuse_pull,
    say_on_stderr,
)
from slopewalk.planner.spec import RobotSpec
from slopewalk.planner.verdict import TIP_ANGLE
from slopewalk.planner.walk_prediction import predict_walk, predicted_walk_verdict
from slopewalk.planner.zmp import signed_margin


@dataclass(frozen=True)
class TrialResult:
    """Analytic vs simulated balance of one trial (series on the walk's time base)."""

    trial: TrialSpec
    analytic_verdict: str
    simulated_verdict: str
    slip_predicted: bool
    events: list[Event]
    zmp_rms: float  # [m]
    zmp_max: float  # [m]
    lipm_rms: float  # [m], analytic multibody ZMP vs LIPM ZMP over the walk
    cop_lipm_rms: float  # [m], simulated CoP vs LIPM ZMP while standing
    standing_fraction: float  # share of walk samples compared
    analytic_min_margin: float  # [m]
    simulated_min_margin: float  # [m], simulated CoP to the planned support polygon
    max_friction_ratio: float  # analytic |F_t|/F_n
    simulated_max_friction_ratio: float  # measured, while standing
    tracking_rms: float  # [rad], all joints, while standing, from the angles aimed at
    peak_torque_planned: float  # [N m]
    peak_torque_simulated: float  # [N m]
    wall_s: float
    sim_steps: int
    series: dict = field(repr=False, compare=False)
    compliant_verdict: str = "stable"  # the paper's test on the walk the servo reaches
    compliant_min_margin: float = float("nan")  # [m]
    predicted_verdict: str = "stable"  # the most severe predicted event
    predicted_events: list = field(default_factory=list)  # slopewalk.planner.verdict.PredictedEvent
    predicted_rotation: float = 0.0  # [rad] largest predicted turn of the support
    unplanned_contact_s: float = 0.0  # [s] foot-time touching where the plan has it lifted
    missed_contact_s: float = 0.0  # [s] foot-time lifted where the plan has it down
    simulated_max_tilt: float = 0.0  # [rad] largest tilt of a loaded foot off the plane, walk
    # the strict walk verdict (walk_check.py) and its measures
    walk_verdict: str = "walked"  # walked, overload, off_footprint, shuffle, pelvis_off, or
    # the balance verdict when not stable
    landing_error: float = float("nan")  # [m] largest landing distance off its footprint
    landing_heading_error: float = float("nan")  # [rad] largest landing heading error
    swing_touch: float = float("nan")  # [s] longest swing-foot touch in one single support
    pelvis_end_error: float = float("nan")  # [m] pelvis at the end vs the plan's end pose
    torque_ratio: float = float("nan")  # largest |actuator torque| / spec stall torque, walk
    predicted_walk_verdict: str = "walked"  # walk_prediction.py: overload / shuffle from plan
    predicted_torque_ratio: float = float("nan")  # largest planned |τ| / spec stall torque
    predicted_swing_touch: float = float("nan")  # [s] planned swing sole within touch height

    def scalars(self) -> dict:
        """Everything but the series, strict JSON (angles in degrees at this edge).

        A value that does not exist (NaN: no walk sample to compare) is ``null``, and
        ``null_because`` says why for each such key; each event carries its ``phase``
        (``settling`` before the walk starts at t = 0, ``walk``, or ``hold`` after it).
        """
        gait = asdict(self.trial.gait)  # the lean as resolved (both fields agree)
        gait |= {
            "tilt_profile": self.trial.gait.lean_profile,
            "sway_share": self.trial.gait.lean_share,
        }
        gait["slope_deg"] = float(np.rad2deg(gait.pop("slope")))
        gait["tilt_deg"] = float(np.rad2deg(gait.pop("tilt")))
        skip = ("trial", "series", "events", "predicted_events")
        out = {k: v for k, v in asdict(self).items() if k not in skip}
        out["trial"] = {
            "gait": gait,
            **{k: v for k, v in asdict(self.trial).items() if k != "gait"},
        }
        if self.trial.controller is None:  # open loop: the output as before controllers
            del out["trial"]["controller"]
        if not self.trial.command_noise:  # no noise: the output as before it existed
            del out["trial"]["command_noise"], out["trial"]["noise_seed"]
        out["events"] = [{**asdict(e), "phase": self.phase(e.time)} for e in self.events]
        out["predicted_events"] = [asdict(e) for e in self.predicted_events]
        out["unplanned_support_s"] = self.unplanned_support_s
        out = json.loads(json.dumps(out, default=float), parse_constant=lambda _: None)
        missing = [k for k, v in out.items() if v is None]
        if missing:
            out["null_because"] = {
                k: "not predicted: compared with predict=False"
                if self.predicted_verdict == NOT_PREDICTED and k in _PREDICTED_FIELDS
                else self.why_missing()
                for k in missing
            }
        return out

    @property
    def unplanned_support_s(self) -> float:
        """Foot-time [s] the simulated support differed from the plan's, both ways."""
        return self.unplanned_contact_s + self.missed_contact_s

    def phase(self, time: float) -> str:
        """ "settling" before the walk starts (t < 0), "walk", or "hold" after its end."""
        g = self.trial.gait
        if time < 0:
            return "settling"
        return "walk" if time <= (g.steps + 1 - g.ssp_fraction) * g.step_time else "hold"

    def why_missing(self) -> str:
        """Why the simulated comparison has no value (NaN), in one sentence."""
        lost = [e for e in self.events if e.kind in ("tip", "fall", "diverged")]
        first = min(lost, key=lambda e: e.time, default=None)
        if first is not None and first.time <= 0:
            return (
                f"the robot was lost before the walk began ({first.kind} at "
                f"t = {first.time:.3f} s, {self.phase(first.time)}): no walk sample to compare"
            )
        return "no walk sample where the robot stood with a loaded foot"

    def summary_lines(self) -> list[str]:
        g = self.trial.gait
        lines = [
            f"trial: {g.steps} steps of {g.step_time:g} s on {np.rad2deg(g.slope):g} deg, "
            f"mu {self.trial.friction:g}, {self.trial.actuators} actuators"
            + (f", controller {self.trial.controller}" if self.trial.controller else "")
            + (
                f", command noise {np.rad2deg(self.trial.command_noise):g} deg "
                f"(seed {self.trial.noise_seed})"
                if self.trial.command_noise
                else ""
            ),
            f"analytic:  {self.analytic_verdict:<12} min ZMP margin "
            f"{self.analytic_min_margin * 1e3:7.2f} mm, max friction ratio "
            f"{self.max_friction_ratio:.3f} ({'>' if self.slip_predicted else '<='} mu)",
            f"compliant: {self.compliant_verdict:<12} min ZMP margin "
            f"{_mm(self.compliant_min_margin):>7} mm (the walk the servos reach)",
            f"predicted: {self.predicted_verdict:<12}"
            + "; ".join(
                f"{e.kind} at {e.time:.3f} s: {e.cause}" for e in self.predicted_events[:2]
            ),
            f"simulated: {self.simulated_verdict:<12} min CoP margin "
            f"{_mm(self.simulated_min_margin):>7} mm (to the planned support polygon), max "
            f"friction ratio {_num(self.simulated_max_friction_ratio, '.3f')}, loaded foot "
            f"tilted up to {_num(np.rad2deg(self.simulated_max_tilt), '.2f')} deg (tip angle "
            f"{np.rad2deg(TIP_ANGLE):g} deg)",
            f"walk:      {self.walk_verdict:<12} landing off its footprint up to "
            f"{_mm(self.landing_error)} mm / {_num(np.rad2deg(self.landing_heading_error), '.2f')}"
            f" deg, swing foot on the plane up to {_num(self.swing_touch, '.3f')} s of a single "
            f"support, pelvis {_mm(self.pelvis_end_error)} mm off the end pose, peak torque "
            f"{_num(self.torque_ratio, '.2f')} x stall (predicted {self.predicted_walk_verdict}: "
            f"{_num(self.predicted_torque_ratio, '.2f')} x stall, planned swing sole on the "
            f"plane {_num(self.predicted_swing_touch, '.3f')} s)",
            f"ZMP analytic vs simulated: RMS {_mm(self.zmp_rms)} mm, max "
            f"{_mm(self.zmp_max)} mm over {self.standing_fraction:.0%} of the walk",
            f"unplanned support {self.unplanned_support_s:.3f} s (foot-time touching while "
            f"planned lifted {self.unplanned_contact_s:.3f} s, lifted while planned down "
            f"{self.missed_contact_s:.3f} s)",
            f"joint tracking RMS {_num(np.rad2deg(self.tracking_rms), '.2f')} deg; peak torque "
            f"planned {self.peak_torque_planned:.3f} / simulated "
            f"{self.peak_torque_simulated:.3f} N m",
        ]
        if not np.isfinite(self.zmp_rms):
            lines.append(f"n/a: {self.why_missing()}")
        lines += [
            f"event {e.time:7.3f} s  {e.kind:<12} {e.cause}"
            + (f"  ({self.phase(e.time)})" if self.phase(e.time) != "walk" else "")
            for e in self.events[:8]
        ]
        if len(self.events) > 8:
            lines.append(f"... and {len(self.events) - 8} more events")
        return lines


def _num(value: float, spec: str) -> str:
    return format(value, spec) if np.isfinite(value) else "n/a"


def _mm(value: float) -> str:
    return _num(value * 1e3, ".2f")


def run_trial(
    spec: RobotSpec,
    trial: TrialSpec,
    *,
    plan: Plan | None = None,
    recording: Recording | None = None,
    predict: bool = True,
    scene=None,
) -> TrialResult:
    """Plan (unless given), simulate (unless given) and compare one trial.

    Open loop (``trial.controller`` None) the plan is one ``mujoco.rollout``; with a
    controller, ``closed_loop.play_controller`` steps ``env.TrialEnv`` through the
    whole trial; either way the same ``Recording`` goes through the same comparison.
    ``predict`` False leaves out the analytic predictions beyond the paper's verdict
    (``compare``), which cost most of a trial's time (the servo loop's walk).
    ``scene``: ``playback.play``'s (an imported model's, open loop only).
    """
    start = time.perf_counter()
    plan = plan or plan_walk(spec, trial.gait)
    beside = (  # worked out while the walk is played (``PredictionBeside``)
        PredictionBeside(plan, friction=trial.friction, actuators=trial.actuators)
        if predict and recording is None
        else None
    )
    if recording is None and trial.controller is not None:
        recording = play_controller(spec, trial, plan)
    recording = recording or play(
        plan,
        friction=trial.friction,
        actuators=trial.actuators,
        timestep=trial.timestep,
        command_noise=trial.command_noise,
        noise_seed=trial.noise_seed,
        scene=scene,
    )
    wall_s = time.perf_counter() - start
    prediction = None if beside is None else beside.result()
    return compare(plan, trial, recording, wall_s=wall_s, predict=predict, prediction=prediction)


def trial_checked(spec: RobotSpec, trial: TrialSpec, *, say=say_on_stderr) -> Plan:
    """The plan of ``trial`` for the ``trial`` command: a large walk
    (``plan.LARGE_WALK_SAMPLES``) has its size and time said through ``say`` first, measured
    on a one-step trial of the same gait (series file included), and is refused when it
    cannot fit in memory; a walk the ground would have to pull is refused
    (``Plan.ground_pull``: its analytic ZMP, margin and friction ratio do not exist).

    Raises:
        GaitError: too large for the memory available, or the ground would have to pull.
    """
    if trial.gait.samples > LARGE_WALK_SAMPLES:
        trial.gait.check_fits(spec)

        def one(gait):
            result = run_trial(spec, replace(trial, gait=gait))
            np.savez_compressed(io.BytesIO(), **result.series)

        cost = measure_cost(one, trial.gait)
        cost.check("trial")
        say(cost.line("trial"))
    plan = plan_walk(spec, trial.gait)
    refuse_pull(plan)
    return plan


NOT_PREDICTED = "not_predicted"  # the verdict columns of a trial compared with predict=False


def compare(
    plan: Plan,
    trial: TrialSpec,
    recording: Recording,
    *,
    wall_s: float,
    predict: bool = True,
    prediction: TrialPrediction | None = None,
) -> TrialResult:
    """Put prediction and simulation side by side (see module doc).

    With ``predict`` False the compliant and predicted verdicts read ``NOT_PREDICTED``,
    their margin and rotation NaN, and the series have no ``*_compliant`` entries.
    ``prediction``: ``predict_trial``'s for this plan and trial, if already worked out
    (``run_trial``: beside the simulation); None: worked out here.
    """
    weight = plan.spec.total_mass * GRAVITY
    events = detect(recording, weight=weight, hip_height=plan.params.hip_height)
    s, t = recording.sensors, recording.t
    walk = (t >= plan.t[0]) & (t <= plan.t[-1])
    tw = t[walk]

    def on_walk(x):
        return on_rows(tw, plan, x)

    zmp = on_walk(plan.zmp)
    lipm = on_walk(plan.zmp_lipm)
    cop = s.cop[walk]
    lost = [e.time for e in events if e.kind in ("tip", "fall", "diverged")]
    standing = (tw < min(lost, default=np.inf)) & np.isfinite(cop).all(axis=1)
    distance = np.hypot(*(cop - zmp).T)[standing]
    idx = np.clip(np.searchsorted(plan.t, tw), 0, plan.t.size - 1)
    polygon = plan.polygon[idx]
    sim_margin = signed_margin(np.nan_to_num(cop), polygon)[standing]
    if prediction is None and predict:
        prediction = predict_trial(plan, friction=trial.friction, actuators=trial.actuators)
    rows = walk & (t < min(lost, default=np.inf))
    down = [e.time for e in events if e.kind in ("fall", "diverged")]  # a tip's turn counts
    rocking = walk & (t < min(down, default=np.inf))
    support = support_difference(plan, recording, rows)
    q_plan = stance_swing_to_left_right(on_walk(plan.q), plan.stance[idx])
    q_aim = q_plan if recording.aim_offset is None else q_plan + recording.aim_offset[walk]
    tracking = (s.q[walk] - q_aim)[standing]
    force = s.foot_force[walk].sum(axis=1)[standing]
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.hypot(force[:, 0], force[:, 1]) / force[:, 2]
    planned_ratio = float(plan.friction_ratio.max())

    def worst(x, f=np.max):
        return float(f(x)) if np.size(x) else float("nan")

    return TrialResult(
        trial=trial,
        analytic_verdict="stable" if plan.stable else "zmp_outside",
        simulated_verdict=verdict(events),
        slip_predicted=planned_ratio > trial.friction,
        events=events,
        zmp_rms=worst(np.sqrt(np.mean(distance**2))) if distance.size else float("nan"),
        zmp_max=worst(distance),
        lipm_rms=float(np.sqrt(np.mean(np.sum((plan.zmp - plan.zmp_lipm) ** 2, axis=1)))),
        cop_lipm_rms=_rms(np.hypot(*(cop - lipm).T)[standing]),
        standing_fraction=float(standing.mean()) if standing.size else 0.0,
        analytic_min_margin=float(plan.margin.min()),
        simulated_min_margin=worst(sim_margin, np.min),
        max_friction_ratio=planned_ratio,
        simulated_max_friction_ratio=worst(ratio[np.isfinite(ratio)]),
        tracking_rms=worst(np.sqrt(np.mean(tracking**2))) if tracking.size else float("nan"),
        peak_torque_planned=float(np.abs(plan.tau).max()),
        peak_torque_simulated=float(np.abs(s.actuator_force[walk]).max()),
        wall_s=wall_s,
        sim_steps=int(t.size),
        **_predicted_columns(prediction),
        unplanned_contact_s=support.unplanned_contact_s,
        missed_contact_s=support.missed_contact_s,
        simulated_max_tilt=worst(loaded_tilt(recording, weight=weight)[rocking]),
        **_walk_columns(plan, trial, recording, verdict(events), prediction),
        series=_series(plan, s, walk, on_walk, prediction, tw, zmp, lipm, cop, q_plan, standing)
        | _settling_series(s, t, t < plan.t[0])
        | _model_series(recording, walk, t < plan.t[0]),
    )


SIMULATED_ROWS = ("qpos", "q_simulated", "actuator_force", "cop", "foot_cop", "foot_force")


def simulated_rows(series: dict) -> dict:
    """The simulated series of ``TrialResult.series`` over the settling and the walk, in time
    order: ``t``, each of ``SIMULATED_ROWS`` and, for a trial on a model, ``model_qpos`` (a
    series without ``settling_*`` entries, as written before they existed, gives its walk
    rows alone)."""
    settling = "settling_t" in series
    names = ("t", *SIMULATED_ROWS, *(("model_qpos",) if "model_qpos" in series else ()))
    return {
        name: np.concatenate([series[f"settling_{name}"], series[name]])
        if settling
        else np.asarray(series[name])
        for name in names
    }


def _model_series(recording: Recording, walk: np.ndarray, settling: np.ndarray) -> dict:
    """``model_qpos`` and ``settling_model_qpos`` of a trial on an imported model; {}."""
    qpos = recording.model_qpos
    if qpos is None:
        return {}
    return {"model_qpos": qpos[walk], "settling_model_qpos": qpos[settling]}


def _settling_series(s, t: np.ndarray, settling: np.ndarray) -> dict:
    """``TrialResult.series``' ``settling_*`` entries: the simulation before the walk."""
    return {
        "settling_t": t[settling],
        "settling_qpos": np.column_stack([s.pelvis_qpos, s.q])[settling],
        "settling_q_simulated": s.q[settling],
        "settling_actuator_force": s.actuator_force[settling],
        "settling_cop": s.cop[settling],
        "settling_foot_cop": s.foot_cop[settling],
        "settling_foot_force": s.foot_force[settling],
    }


def _series(plan, s, walk, on_walk, predicted, tw, zmp, lipm, cop, q_plan, standing) -> dict:
    """``TrialResult.series``: the plan's and the simulation's series over the walk."""
    return {
        "t": tw,
        "zmp_analytic": zmp,
        "zmp_lipm": lipm,
        "cop": cop,
        "foot_cop": s.foot_cop[walk],
        "foot_force": s.foot_force[walk],
        "q_planned": q_plan,
        "q_simulated": s.q[walk],
        "standing": standing,
        "margin_analytic": on_walk(plan.margin)[:, 0],
        **(
            {
                "zmp_compliant": on_walk(predicted.walk.plan.zmp),
                "margin_compliant": on_walk(predicted.walk.plan.margin)[:, 0],
            }
            if predicted
            else {}
        ),
        "actuator_force": s.actuator_force[walk],
        "sole": s.sole[walk],
        "pelvis_height": s.pelvis_height[walk],
        "qpos": np.column_stack([s.pelvis_qpos, s.q])[walk],
    }


_PREDICTED_FIELDS = ("compliant_min_margin", "predicted_rotation")  # NaN when not predicted


def _predicted_columns(predicted) -> dict:
    """``TrialResult``'s prediction fields of a ``TrialPrediction``, or of none."""
    if predicted is None:
        return {
            "compliant_verdict": NOT_PREDICTED,
            "compliant_min_margin": float("nan"),
            "predicted_verdict": NOT_PREDICTED,
            "predicted_rotation": float("nan"),
        }
    return {
        "compliant_verdict": predicted.compliant_verdict,
        "compliant_min_margin": float(np.min(predicted.walk.plan.margin)),
        "predicted_verdict": predicted.verdict,
        "predicted_events": predicted.prediction.events,
        "predicted_rotation": float(np.max(predicted.prediction.rotation, initial=0.0)),
    }


def _walk_columns(
    plan: Plan, trial: TrialSpec, recording: Recording, balance: str, predicted
) -> dict:
    """``TrialResult``'s strict walk fields (``walk_check``), and the plan's prediction of
    them (``walk_prediction``) beside the predicted balance verdict, when predicted."""
    measures = measure_walk(plan, recording, rotation_slope_to_world(plan.params.slope))
    give_fed_forward = actuator_mode(trial.actuators).feedforward  # the "_ff" modes
    walk = predict_walk(plan, give_fed_forward=give_fed_forward)
    return {
        "walk_verdict": walk_verdict(balance, measures),
        "landing_error": measures.landing_error,
        "landing_heading_error": measures.landing_heading_error,
        "swing_touch": measures.swing_touch,
        "pelvis_end_error": measures.pelvis_end_error,
        "torque_ratio": measures.torque_ratio,
        "predicted_walk_verdict": predicted_walk_verdict(predicted.verdict, walk)
        if predicted
        else NOT_PREDICTED,
        "predicted_torque_ratio": walk.torque_ratio,
        "predicted_swing_touch": walk.swing_touch,
    }


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2))) if x.size else float("nan")
