"""The servo loop's ring outlasting a step: a landing that finds the robot still ringing.

A position loop without feed-forward (the ``servo`` mode) holds every load on its
spring: where the load moves from leg to leg in one go (a touchdown, a lift-off) the
joint's deflection jumps by Δτ / kp, and the joint's own mode rings. The mode is a
mass-spring of rotor inertia A and damping d (+ the velocity gain kv, which acts the
same way), whose ring decays as exp(−t d / (2 A)) whatever kp is (underdamped, the
links' own inertia on the joint aside): time constant τ_ring = 2 A / (d + kv). The
ring is down to e^−3 ≈ 5 % after ``RING_DECAYS`` = 3 time constants, the settling time

    t_settle = 3 · 2 A / (d + kv)

(the AX-12A: A = 0.0232 kg m², d = 1.5 / 6.18 = 0.243 N m s/rad, t_settle = 0.57 s).
Where a walk lands again before its last landing's ring has settled (step time
T < t_settle), every landing comes on a robot still ringing from the one before.

``servo_loop`` integrates that ring at the joints, but with the stance sole bolted
to the plane and every landing plastic, so it does not see what the ring does to the
robot standing on its soles: measured in MuJoCo (results/README.md, stop 35), the
robot lands hard on the ringing leg, bounces back onto the old stance foot and falls.
Found on the design sets (``bench/experiments/sweeps/ga-dev.toml``, ``ga-dev2.toml``,
``ga-dev-spec-ends.toml``; results/README.md, stop 37): in ``servo`` MuJoCo's robot
walks 7 of the 72 nominal-spec GA gaits with T < t_settle and 67 of 111 of the others,
and the boundary moves with the spec's armature as t_settle does (A halved, t_settle
0.29 s: 20 of 35 walk at 0.45–0.55 s on ga-dev; A doubled, 1.15 s: 0 of 18 walk at 0.75 s).

With feed-forward (``servo_ff``) the loop is fed the planned torque, load jumps
included, and its spring takes only what the plan gets wrong: no ring of that size
(the same design sets: 38 of 72 ``servo_ff`` gaits with T < t_settle walk). A stiff
loop's t_settle is a few hundredths of a second. So the check is made for a loop
without feed-forward only (``bench/sim/prediction.py``).
"""

from __future__ import annotations

import numpy as np

from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.trajectory import Timeline

RING_DECAYS = 3.0  # time constants: the ring down to exp(-3), about 5 %


def settle_time(armature: float, damping: float) -> float:
    """t_settle [s] of a joint of rotor inertia ``armature`` [kg m²] on a loop of total
    damping ``damping`` (joint damping + velocity gain) [N m s/rad]: module doc. A loop
    without damping never settles (inf)."""
    if not (armature >= 0 and damping >= 0):
        raise SlopewalkError(
            f"armature {armature!r} kg m^2 and damping {damping!r} N m s/rad: must be >= 0"
        )
    if damping == 0:
        return np.inf if armature > 0 else 0.0
    return RING_DECAYS * 2.0 * armature / damping


def unsettled_landing(plan, settle: float) -> int | None:
    """The first touch-down of ``plan`` (``trajectory.Timeline.touch_downs``) that comes
    less than ``settle`` [s] after the one before it (a sample index), or None."""
    downs = Timeline.of(plan.params).touch_downs
    early = np.flatnonzero(np.diff(plan.t[downs]) < settle)
    return None if early.size == 0 else int(downs[early[0] + 1])
