"""The predicted strict walk verdict: what the plan alone says of ``overload`` and ``shuffle``.

The simulator's strict walk verdict (``slopewalk.bench.sim.walk_check``) asks whether the
robot walked the plan: landings on their footprints, the swing foot off the plane, the
pelvis at the end pose, every actuator within the spec's servo. Two of its checks the
plan can answer before any simulation, with the simulator's own thresholds (defined
here, used by ``walk_check``, so both sides judge by one number):

* ``overload``: the torque the servo must give to make the planned motion reaches
  ``SATURATION`` of the spec's servo stall torque (``RobotSpec.stall_torque``, the most the
  servo gives: the AX-12A's 1.5 N m for the Bioloid). A walk that needs more is not that
  robot's walk. That torque (``servo_torque``) is the planned Newton–Euler joint torque
  (``Plan.tau``, the links' dynamics) plus the servo's own rotor: its reflected inertia
  (``RobotSpec.armature``, the MJCF joint's armature) times the planned joint acceleration,
  which the paper's Newton–Euler leaves out. For the nominal gait the rotor term is most of
  it at 1 s steps (peak 2.03 N m with it, 0.45 N m without; MuJoCo's stiff actuators
  measure 2.19 N m).
* ``shuffle``: the planned swing sole stays within ``TOUCH_HEIGHT`` of the plane for more
  than ``TOUCH_ALLOWANCE`` of a step's single support. ``TOUCH_HEIGHT`` is the soft
  floor's give: the stance sole's give tilts the robot towards the swing foot, whose sole
  meets the plane ~1 mm early (``bench/sim/floor.py``), so a sole planned within 1 mm of
  the plane is expected on it. ``TOUCH_ALLOWANCE`` is the time a swing may spend there:
  one ``TOUCH_WINDOW`` (the ~50 ms that 1 mm early touch-down takes, ``floor.py``) at each
  end of the swing, lift-off and touch-down. Where the actuators feed the floor's give
  forward (the "_ff" modes turn the ankles against it and shorten the legs by the sink,
  so the swing sole meets the plane at the planned touch-down) that band is gone: only a
  sole planned on the plane (height ≤ 0) is expected on it.

The plan puts every landing on its footprint and the pelvis at its end pose by
construction; ``off_footprint`` and ``pelvis_off`` are the simulation's alone.

Predicted walk verdict (``predicted_walk_verdict``): the predicted balance verdict
(``verdict.predict``) when it is not ``stable``; else ``overload``, then ``shuffle``, when
predicted; else ``walked``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SATURATION = 0.99  # of the actuator's torque limit (also the simulator's torque_limit event)
TOUCH_HEIGHT = 0.001  # [m] the floor's give: a swing sole this near the plane touches it
TOUCH_WINDOW = 0.05  # [s] the early touch-down that give makes, per end of a swing
TOUCH_ALLOWANCE = 2 * TOUCH_WINDOW  # [s] swing sole on the plane per planned single support


@dataclass(frozen=True)
class WalkPrediction:
    """The plan's answer to the strict checks it can judge (module doc).

    Attributes:
        torque_ratio: Largest planned servo torque (``servo_torque``) / the spec's stall
            torque [-].
        swing_touch: Longest planned time a swing sole is within ``TOUCH_HEIGHT`` of the
            plane in one step's single support [s].
    """

    torque_ratio: float
    swing_touch: float

    def failed(self) -> list[str]:
        """Predicted failed checks, overload then shuffle."""
        return [
            kind
            for kind, over in (
                ("overload", self.torque_ratio >= SATURATION),
                ("shuffle", self.swing_touch > TOUCH_ALLOWANCE),
            )
            if over
        ]


def planned_swing_touch(plan, *, give_fed_forward: bool = False) -> np.ndarray:
    """Each step's planned time [s] with the swing sole within ``TOUCH_HEIGHT`` of the
    plane during its single support (on it, with ``give_fed_forward``: module doc),
    (steps,)."""
    g = plan.params
    dsp = (1 - g.ssp_fraction) * g.step_time
    dt = float(np.median(np.diff(plan.t))) if plan.t.size > 1 else 0.0
    height = plan.swing_sole[:, 2]
    low = height <= 0.0 if give_fed_forward else height < TOUCH_HEIGHT
    out = np.zeros(g.steps)
    for k in range(g.steps):
        rows = (plan.t >= k * g.step_time + dsp) & (plan.t < (k + 1) * g.step_time)
        out[k] = float((rows & low & ~plan.double_support).sum() * dt)
    return out


def servo_torque(plan) -> np.ndarray:
    """The torque each servo must give to make ``plan``'s motion [N m], (n, 8), Table-I
    order: the Newton–Euler torque plus the rotor's reflected inertia × q̈ (module doc)."""
    return plan.tau + plan.spec.armature * plan.qdd


def predict_walk(plan, *, give_fed_forward: bool = False) -> WalkPrediction:
    """``WalkPrediction`` of a ``Plan``; ``give_fed_forward``: played by actuators that feed
    the floor's give forward (the "_ff" modes, module doc)."""
    touch = planned_swing_touch(plan, give_fed_forward=give_fed_forward)
    return WalkPrediction(
        torque_ratio=float(np.abs(servo_torque(plan)).max() / plan.spec.stall_torque),
        swing_touch=float(np.max(touch, initial=0.0)),
    )


def predicted_walk_verdict(balance: str, prediction: WalkPrediction) -> str:
    """The predicted strict verdict (module doc) from the predicted balance verdict."""
    if balance != "stable":
        return balance
    failed = prediction.failed()
    return failed[0] if failed else "walked"
