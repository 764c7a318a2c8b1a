"""The analytic prediction of one trial: the paper's test, the compliance-aware walk, events.

Three predictions sit side by side (``TrialPrediction``):

* the paper's verdict: the planned ZMP inside the support polygon at every sample
  (``Plan.stable``), ``stable`` or ``zmp_outside``;
* the compliance-aware verdict: the same test on the walk the trial's servo
  actually makes under the planned torques (``planner.compliance``), with its own
  ZMP trace and margin;
* the predicted verdict: the most severe event ``slopewalk.planner.verdict.predict`` finds on
  the walk the servo loop makes through time (``planner.servo_loop``: its sway, the
  closed chain of double support, the output clipped at the torque limit):
  joint_limit, tip, strike, swing_drag, slip, foot_slide, ring, or ``stable``;
  ``saturation`` (the loop asking for more than its limit, on the static walk) is
  reported beside them.

The servo is the trial's actuator mode (``model.servo_settings``), and in a
feedforward mode the loop is fed the same clipped torque as in the simulation
(``playback.feedforward_torque``), so the prediction models the loop that is played.
The floor is the scene's: its soft contact's corner stiffness (``floor.py``) gives
the tipping predictor the floor's give, and its time constant (``solref``) how long a
dragged sole stays loaded (``foot_slide``).
"""

from __future__ import annotations

import threading
from concurrent.futures import Future
from dataclasses import dataclass
from functools import lru_cache
from typing import TypedDict

import mujoco
import numpy as np

from slopewalk.bench.sim.floor import SoftFloor, scene_corner_stiffness
from slopewalk.bench.sim.model import Servo, scene_xml, servo_settings
from slopewalk.bench.sim.playback import feedforward_stance_swing
from slopewalk.planner import whole_body
from slopewalk.planner.compliance import CompliantWalk, compliant_walk
from slopewalk.planner.per_plan import once_per_plan
from slopewalk.planner.plan import Plan
from slopewalk.planner.servo_loop import friction_decides, linearised_at, servo_walk
from slopewalk.planner.servo_ring import RingLoop, landing_residuals, landing_rows
from slopewalk.planner.verdict import (
    PredictedEvent,
    Prediction,
    events_but_slip,
    slip_events,
    with_slips,
)
from slopewalk.planner.whole_body import Walk, tip_time


@dataclass(frozen=True)
class TrialPrediction:
    """Analytic predictions of one trial (see module doc).

    Attributes:
        paper_verdict: "stable" or "zmp_outside" (the planned ZMP).
        compliant_verdict: "stable" or "zmp_outside" (the ZMP of the walk the servo makes).
        walk: The compliance-aware walk; ``walk.plan.zmp`` its ZMP trace [m], (n, 2).
        prediction: Predicted events and the verdict they imply.
        loop_walk: The walk the servo loop makes (``servo_loop.servo_walk``), which
            ``prediction`` judges.
    """

    paper_verdict: str
    compliant_verdict: str
    walk: CompliantWalk
    prediction: Prediction
    loop_walk: CompliantWalk

    @property
    def verdict(self) -> str:
        return self.prediction.verdict


class _Loop(TypedDict):
    """The servo loop's settings, as ``compliant_walk`` and ``servo_walk`` take them."""

    stiffness: float
    velocity_gain: float
    damping: float
    armature: float
    feedforward: np.ndarray | None


def predict_trial(plan: Plan, *, friction: float, actuators: str) -> TrialPrediction:
    """All analytic predictions of ``plan`` played with ``actuators`` on a plane of μ.

    Once per plan object, μ and mode (``planner/per_plan.py``): the trials that play one
    plan alike but for their command noise (a sweep's noise replicas, its seeds) share it;
    the noise is the simulation's alone."""
    return _prediction_of(plan, float(friction), actuators)


@once_per_plan
def _prediction_of(plan: Plan, friction: float, actuators: str) -> TrialPrediction:
    """``predict_trial``'s work."""
    servo = servo_settings(plan.spec, actuators)
    walk = _compliant_of(plan, servo)
    made, loop_walk = _loop_walk(plan, servo, friction)
    floor = trial_floor(plan, friction=friction, actuators=actuators)
    events, rotation = _events_of(plan, servo, made, *floor)
    prediction = with_slips(events, rotation, *slip_events(loop_walk.plan, friction))
    from slopewalk.planner.kernel import cache

    # the entry's last kernel call made (``predict``'s rocking): marked warm only now, so a
    # process stopped before it leaves the entry cold and the next run says so
    cache.compiled("predictors")
    return TrialPrediction(
        paper_verdict="stable" if plan.stable else "zmp_outside",
        compliant_verdict="stable" if walk.converged and walk.plan.stable else "zmp_outside",
        walk=walk,
        prediction=prediction,
        loop_walk=loop_walk,
    )


def body_walk(plan: Plan, *, friction: float, actuators: str) -> Walk:
    """The whole-body walk (``planner/whole_body.py``) of ``plan`` played with ``actuators``
    on the trial's floor (its scene's corner stiffness and contact time), as the
    prediction makes it."""
    floor = trial_floor(plan, friction=friction, actuators=actuators)
    return _body_walk(plan, servo_settings(plan.spec, actuators), *floor)


def trial_floor(plan: Plan, *, friction: float, actuators: str) -> tuple[float, float, float]:
    """The floor of the trial's scene: its corner stiffness [N/m], contact time [s] and
    damping ratio [-] (``_floor_of``)."""
    return _floor_of(
        scene_xml(plan.spec, slope=plan.params.slope, friction=friction, actuators=actuators)
    )


@once_per_plan
def _body_walk(
    plan: Plan, servo: Servo, corner_stiffness: float, contact_time: float, dampratio: float
) -> Walk:
    """``whole_body.walk`` of ``plan`` under ``servo``'s loop on a floor of that corner
    stiffness [N/m], contact time [s] and damping ratio [-]; once per plan object, servo and
    floor (a sweep's trials of one plan at several frictions share it: the model has no
    friction)."""
    return whole_body.walk(
        plan,
        force_limit=servo.force_limit,
        corner_stiffness=corner_stiffness,
        contact_time=contact_time,
        contact_dampratio=dampratio,
        **_loop_of(plan, servo),
    )


@once_per_plan
def _events_of(
    plan: Plan,
    servo: Servo,
    made: int,
    floor_stiffness: float,
    contact_time: float,
    dampratio: float,
) -> tuple[list[PredictedEvent], np.ndarray]:
    """``verdict.events_but_slip`` of ``plan`` judged on its ``made``-th loop walk under
    ``servo`` (``_loop_walk``) on a floor of that corner stiffness [N/m], contact time [s]
    and damping ratio [-]: every predicted event but ``slip``, the one μ decides beside the
    loop walk, and the support's rotation. Once per plan object, servo, walk and floor: the
    trials that share a loop walk share these (``verdict.predict`` is ``with_slips`` of the
    two, the same events in the same order)."""
    loop_walk = _loop_walks(plan, servo)[made]
    body = _body_walk(plan, servo, floor_stiffness, contact_time, dampratio)
    return events_but_slip(
        plan,
        walk=loop_walk,
        stiffness=servo.kp,
        force_limit=servo.force_limit,
        floor_stiffness=floor_stiffness,
        contact_time=contact_time,
        ring_residual=_ring_residual(plan, servo),
        body_tip=tip_time(plan, body),
    )


def _loop_walk(plan: Plan, servo: Servo, friction: float) -> tuple[int, CompliantWalk]:
    """``servo_walk`` of ``plan`` under ``servo``'s loop on a plane of μ ``friction``, its
    open chain too. μ decides only whether a lifting sole stays held, so the trials of one
    plan at several frictions mostly make one walk: the walks made so far for this plan
    object and servo are kept (``_loop_walks``), and one whose every friction check comes
    out the same at this μ is that walk to the bit (``servo_loop.friction_decides``) and
    is returned as it is, with its index in ``_loop_walks`` (issue 24)."""
    made = _loop_walks(plan, servo)
    for index, walk in enumerate(list(made)):
        if not friction_decides(walk, friction):
            return index, walk
    walk = servo_walk(
        plan,
        force_limit=servo.force_limit,
        friction=friction,
        open_chain_too=True,
        **_loop_of(plan, servo),
    )
    with _APPENDING:  # a trial's prediction runs on a thread beside its playback
        made.append(walk)
        return len(made) - 1, walk


_APPENDING = threading.Lock()


@once_per_plan
def _loop_walks(plan: Plan, servo: Servo) -> list[CompliantWalk]:
    """The loop walks of ``plan`` under ``servo`` made so far (``_loop_walk``), once per plan
    object and servo (``planner/per_plan.py``); appended to, never changed."""
    return []


@once_per_plan
def _loop_of(plan: Plan, servo: Servo) -> _Loop:
    """The loop's settings for ``plan`` played by ``servo``, its feed-forward included;
    once per plan object and servo (``planner/per_plan.py``: a sweep's trials of one plan
    at several frictions share it)."""
    return _Loop(
        stiffness=servo.kp,
        velocity_gain=servo.kv,
        damping=servo.damping,
        armature=servo.armature,
        feedforward=feedforward_stance_swing(plan, servo) if servo.feedforward else None,
    )


@once_per_plan
def _compliant_of(plan: Plan, servo: Servo) -> CompliantWalk:
    """``compliant_walk`` of ``plan`` under ``servo``'s loop, once per plan object and servo."""
    return compliant_walk(plan, **_loop_of(plan, servo))


class PredictionBeside:
    """``predict_trial`` on a thread of its own, started at once: a trial's predictions are
    worked out while MuJoCo plays the walk (``mujoco.rollout`` steps with the GIL released),
    so a trial takes about the longer of the two, not their sum, where a second core is
    free (``slopewalk trial``; in a sweep every worker already has one). The same calls on
    the same inputs: the prediction is the one ``predict_trial`` returns in line. A daemon
    thread, so a stopped command does not wait for it; ``result`` re-raises its error.
    """

    def __init__(self, plan: Plan, *, friction: float, actuators: str):
        self._future: Future[TrialPrediction] = Future()
        threading.Thread(
            target=self._run, args=(plan, friction, actuators), daemon=True, name="prediction"
        ).start()

    def _run(self, plan: Plan, friction: float, actuators: str) -> None:
        try:
            self._future.set_result(predict_trial(plan, friction=friction, actuators=actuators))
        except BaseException as err:  # handed to the caller's thread by ``result``
            self._future.set_exception(err)

    def result(self) -> TrialPrediction:
        """The prediction, once its thread is done (waits for it)."""
        return self._future.result()


@once_per_plan
def _ring_residual(plan: Plan, servo: Servo) -> np.ndarray | None:
    """The share of a load step's ring the loop has left at each touch-down of ``plan``
    where it takes the load's transfer on its spring (no feed-forward;
    ``planner/servo_ring.py``), from the spec's A, d + kv and kp on the chain's M and K_g
    before each landing; else None: no ``ring`` check. Once per plan object and servo."""
    if servo.feedforward:
        return None
    loop = RingLoop(servo.armature, servo.damping + servo.kv, servo.kp)
    mass, gravity_k = linearised_at(plan, landing_rows(plan))
    return landing_residuals(plan, mass, gravity_k, loop)


@lru_cache(maxsize=16)
def _floor_of(xml: str) -> tuple[float, float, float]:
    """The floor of the scene ``xml``: its corner stiffness [N/m] and its contact's time
    constant [s] and damping ratio [-], compiled once per scene text (a sweep's trials share
    a few scenes; the compile cost ~2.5 ms a trial)."""
    scene = mujoco.MjModel.from_xml_string(xml)
    floor = SoftFloor.of_scene(scene)
    return scene_corner_stiffness(scene), floor.timeconst, floor.dampratio
