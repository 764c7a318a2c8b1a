"""Predicted events of a planned walk and the analytic verdict they imply.

Beside the paper's binary test (ZMP inside the support polygon at every sample,
``Plan.stable``), each way the simulator can find a walk failing is predicted from
the analytic series, with the simulator's own thresholds (defined here, used by
``bench/sim/events.py``, so both sides judge by one number):

* ``joint_limit``: a planned joint angle outside the spec's limits (the MJCF's
  joint range stops it there, so the walk played is not the walk planned).
* ``tip``: the support's tilt (``tipping.foot_rotation``: the robot rocking on
  its support's edges, the rocking carried from one excursion to the next, on
  the simulator's soft floor) passes ``TIP_ANGLE``.
  Or the servos' walk lands a swing sole tilted past ``TIP_ANGLE`` (``landing_events``:
  the sole's tilt off the plane at the sample before each touch-down): the foot meets the
  plane on an edge and is loaded there, the simulator's ``tip`` of that foot. The plan
  lands every sole flat; servos that lag behind it (their output clipped at the torque
  limit on fast steps) bring the sole down toe- or edge-first. Measured in MuJoCo on
  fast (0.2–0.3 s) saturated ``servo_ff`` GA gaits: the landing foot is tilted 1.6–10°
  at the planned touch-down, loaded past 5° within the first double support, and that
  is the first ``tip``; the servos' walk lands it 0.4–6° tilted (about 1–4° less, so
  this catches the larger tilts only). The walk re-roots at the new stance sole held
  flat, so the rocking never sees that tilt. Designed on the design GA sets: ga-dev3
  ``servo_ff`` 329 → 343 of 486 (14 verdicts from ``stable``, all failing in MuJoCo),
  ga-dev2 ``servo_ff`` 663 → 662 of 684 (one walker landing 5.4° tilted); ``servo``,
  ga-dev, the dense and paper grids and random-dev unchanged.
  Or, through a double support, the servos' joints turn the two soles past ``TIP_ANGLE``
  apart (``double_support_events``): after the touch-down the lagging joints go on
  towards their commands, and the walk that holds the second sole flat (bilateral,
  ``servo_loop``) turns that into ground moments a sole carrying a few newtons cannot
  give; one sole stands on its edge. The tilt is the second sole's off the plane on the
  same loop with no sole held (``servo_walk``'s ``open_chain_too``, the chain rooted at
  the stance sole, flat), in double support only. Measured in MuJoCo
  (``tests/sim/test_double_support_tilt.py``, a ga-dev3 ``servo_ff`` gait at 0.22 s):
  its loaded soles tilt 6.8°, 9.9°, 10.1° in the double supports after the first three
  landings, where the open chain turns them 4.5°, 6.2°, 7.3° apart (the landing tilt
  itself stays under 2°). Designed on the design sets with the simulator's tip angle:
  ga-dev3 ``servo_ff`` 379 → 398 of 486 (19 verdicts from ``stable``, all failing in
  MuJoCo), ga-dev4 ``servo`` 137 → 140 of 167, ga-dev2 ``servo`` 584 → 581 and
  ``servo_ff`` 662 → 661 of 684 (walkers whose soles the open chain turns 5.2–6.4°
  apart); ga-dev, random-dev and the development grids unchanged.
  Or the whole-body walk (``whole_body``: the servo loop on a floating base over two
  unilateral soft soles, through its landings) turns a sole carrying ``LOADED_FRACTION``
  of the weight past ``TIP_ANGLE`` (``body_tip``, the simulator's ``tip`` read on that
  walk). The rocking turns a rigid robot on the bolted loop's walk; this turns the
  servos' give and the soles' lift-off, late landing and the load thrown back onto the
  old foot together. Designed on the design sets and frozen there (results/README.md,
  stop 49): ``servo_ff`` 1417 → 1496 of their 1540 trials, ``servo`` 1384 → 1383,
  ``stiff`` and ``stiff_ff`` unchanged; evaluated once on the reported sets before it
  was added here (``ga`` ``servo_ff`` 96.2 → 98.7 %).
* ``strike``: the swing sole of the walk actually made (compliance-aware) would
  go into the plane in single support; the plane props the robot up and turns
  the stance foot about its far edge (``strike.strike_roll``) past ``TIP_ANGLE``.
* ``swing_drag``: the swing sole props the support's rocking (``tipping.rocking``:
  the robot turns towards the swing sole until it meets the plane) while the plan
  carries it along the plane. Propping, it holds the robot up, so it is loaded; the
  plan moves it on at the swing's speed, so it is dragged loaded over the plane, which
  is the simulator's ``slip`` of that foot past ``SLIP_DISTANCE``, and the friction
  that catches it trips the robot. Predicted where the planned swing sole travels more
  than ``SLIP_DISTANCE`` within one run of propped samples (its distance from where
  the run began, as the simulator measures a loaded sole's slide). Designed on the
  design GA set (``bench/experiments/envelopes/ga-dev.toml``: GA gaits with a swing
  lift of 7–14 mm at 0.35–0.75 s, whose low soles prop the rocking and catch; the
  predicted verdict there 75.2 → 88.3 %), random-dev and the development grids
  (unchanged there, but for one random-dev trial). A swing sole the servos' sag presses
  into the plane past the leg's give props the robot the same way (``strike``: the
  stance foot's roll about its far edge above zero, ``strike.strike_roll``, though short
  of ``TIP_ANGLE``); where the servos' walk carries it past ``SLIP_DISTANCE`` within one
  run of such samples, that is ``swing_drag`` too. Designed on the design GA sets: their
  saturated ``servo_ff`` gaits at 0.35–0.45 s, whose swing sole the lagging knee lowers
  into the plane (MuJoCo's robot stands on its swing foot and falls): ga-dev ``servo_ff``
  102 → 104 of 107, ga-dev2 (its spec ends included) 659 → 663 of 684; ``servo``,
  ga-dev3 (0.22–0.37 s), dense and random-dev unchanged.
* ``slip``: where the required friction |F_t|/F_n exceeds μ the ground holds only
  μ F_n; the rest, |F_t| − μ F_n, slides the robot (mass m) along the plane. The
  slide is integrated like the tip rotation and ``slip`` predicted past
  ``SLIP_DISTANCE``, the simulator's slip threshold.
* ``foot_slide``: the plan itself moves a loaded foot along the plane (the rear
  foot in double support drifts sideways by hip width × (1/cos λ − 1) as the lean
  changes, with no hip roll to absorb it) by more than ``SLIP_DISTANCE`` within one
  loaded stretch of that foot as the simulator counts it. On a rigid floor
  (``contact_time`` None) the foot stays loaded through the drag: the stretch is the
  whole loaded run (``planned_slide``). On MuJoCo's soft floor it does not: dragged
  at the friction limit by the position-stiff legs (the frontal chain has no roll
  joint to give), the sole chatters, touching in contacts that carry the load for at
  most about the contact's time constant τ (``solref``) and leave it in the air
  between them (measured, ``tests/sim/test_double_support_drag.py``: contacts of
  1–13 ms at τ = 20 ms, each sliding ≤ 0.35 mm). A loaded stretch then slides at most
  as far as the plan moves the foot in τ (``stretch_slide``): 5 mm needs a drag of
  250 mm/s at τ = 20 ms, ~10× the fastest planned drift. Not modelled: the foot's
  stretches where it sticks (|F_t| < μ F_n) at the run's ends, where it creeps with
  the contact's and the legs' give (measured ≤ 1.5 mm).

* ``ring``: a loop without feed-forward (``servo``) takes each double support's load
  transfer on its spring and rings; where the walk lands again with more of that ring
  left than ``RING_RESIDUAL`` of what a sudden load step would leave (the transfer's
  cubic over the double support exciting the loaded chain's slowest mode, which decays
  through the single support), the next landing comes on a ringing robot, which the
  loop's walk, bolted to the plane, cannot follow (``servo_ring``; MuJoCo's robot bounces
  back onto its old stance foot and falls). Designed on the design GA sets (``ga-dev``,
  ``ga-dev2``, ``ga-dev-spec-ends``) and their gaits re-timed at four armatures, three
  joint dampings and three stiffnesses (results/README.md, stops 37, 38 and 57).

* ``saturation``: the loop asks a servo for more torque than its limit (the stall
  torque for ``servo``), the analytic twin of the simulator's ``torque_limit``.
  Like that event it is reported and does not decide the verdict: the limit is
  physical, and what it does is in the walk judged (``servo_loop``: the clipped
  loop, the joint falling behind). Measured: ``servo_ff`` at 1 s steps on 0–10°
  asks the swing knee for about 2.1 N m of 1.5, and MuJoCo's robot walks with
  ``torque_limit`` events; the clipped loop lags there by 5.5° at most and walks.
  At 0.75 s the knee lags by 24°, the sole strikes the plane and the robot tips,
  as MuJoCo's falls.

Verdict: the most severe predicted event of ``VERDICT_KINDS``, in the order
joint_limit, tip, strike, swing_drag, slip, foot_slide, ring (a mechanism the models
follow decides before the ring, which says only that the walk outruns them);
``stable`` when none.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.joints import JOINT_KINDS, JOINT_NAMES
from slopewalk.planner.kinematics import GRAVITY, Chain
from slopewalk.planner.servo_ring import RING_RESIDUAL, landing_rows, unsettled_landing
from slopewalk.planner.strike import strike_roll
from slopewalk.planner.tipping import excursion_integral, foot_rotation

# ---- Thresholds shared with the simulator (bench/sim/events.py states their basis). ----
SLIP_DISTANCE = 0.005  # [m]
LOADED_FRACTION = 0.10  # of the robot's weight
TIP_ANGLE = np.deg2rad(5.0)  # [rad]

BODY_TIP = (
    "a loaded sole turned past the tip angle on the whole-body walk (the servo loop on a "
    "floating base over two unilateral soft soles, whole_body)"
)
STRUCK = "the robot up, struck into the plane"  # what a striking swing sole props (``swing_drag``)

# The paper's verdict: its ZMP test on the planned walk (``Plan.stable``).
PAPER_VERDICTS = ("stable", "zmp_outside")
PREDICTED_KINDS = (
    "joint_limit", "saturation", "tip", "strike", "swing_drag", "slip", "foot_slide", "ring"
)  # fmt: skip
VERDICT_KINDS = tuple(k for k in PREDICTED_KINDS if k != "saturation")
SEVERITY = {kind: len(VERDICT_KINDS) - i for i, kind in enumerate(VERDICT_KINDS)}


@dataclass(frozen=True)
class PredictedEvent:
    """Something the analytic model says will happen.

    Attributes:
        time: When [s], walk start = 0.
        kind: One of ``PREDICTED_KINDS``.
        cause: One line saying what and how much.
    """

    time: float
    kind: str
    cause: str


def verdict(events: list[PredictedEvent]) -> str:
    """The most severe predicted event kind of ``VERDICT_KINDS``, or ``stable``."""
    deciding = [e for e in events if e.kind in SEVERITY]
    worst = max(deciding, key=lambda e: SEVERITY[e.kind], default=None)
    return "stable" if worst is None else worst.kind


def joint_limit_events(plan) -> list[PredictedEvent]:
    """First sample where each joint of ``plan`` leaves the spec's limits."""
    events = []
    for j, (name, kind) in enumerate(zip(JOINT_NAMES, JOINT_KINDS, strict=True)):
        lower, upper = plan.spec.joint_limits[kind]
        q = plan.q[:, j]
        out = np.flatnonzero((q < lower) | (q > upper))
        if out.size:
            k = out[0]
            worst = q[np.argmax(np.maximum(lower - q, q - upper))]
            events.append(
                PredictedEvent(
                    float(plan.t[k]),
                    "joint_limit",
                    f"{name} leaves its limits [{lower:g}, {upper:g}] rad ({kind}), "
                    f"up to {worst:.3f} rad",
                )
            )
    return events


def tip_events(
    plan, zmp=None, *, clearance=None, floor_stiffness=None, props=None
) -> tuple[list[PredictedEvent], np.ndarray]:
    """``tip`` where the support's tilt passes TIP_ANGLE; and the tilt [rad], (n,).

    Args:
        plan: The walk to judge.
        zmp: Its ZMP series, (n, 2) [m]; default the plan's.
        clearance: Swing sole height [m], (n,), for the swing sole's prop; default the plan's.
        floor_stiffness: Sole-corner stiffness of the soft floor [N/m]; None: rigid.
        props: Boolean (n,) or None: where given, marks the samples at which the swing
            sole props the rocking (``tipping.foot_rotation``).
    """
    theta = foot_rotation(plan, zmp, clearance, floor_stiffness, props)
    return _first_past(
        plan.t,
        theta,
        TIP_ANGLE,
        "tip",
        lambda: (
            f"support tilts {np.rad2deg(theta.max()):.1f} deg rocking on its edges "
            f"(tip angle {np.rad2deg(TIP_ANGLE):g} deg)"
        ),
    ), theta


def swing_drag_events(plan, props: np.ndarray, what: str = "the rocking") -> list[PredictedEvent]:
    """``swing_drag`` where the swing sole travels past SLIP_DISTANCE while it props.

    Args:
        plan: The walk whose swing sole's path on the plane (``swing_sole``) is judged:
            the plan where the rocking is propped, the servos' walk where a strike is.
        props: Boolean (n,): the samples at which the swing sole props the robot
            (``tip_events``' ``props``, or ``strike.strike_roll`` > 0).
        what: What the sole props, for the cause line.
    """
    for start, moved in slide_runs(props, plan.swing_sole[:, :2]):
        past = np.flatnonzero(moved > SLIP_DISTANCE)
        if past.size:
            k = start + int(past[0])
            return [
                PredictedEvent(
                    float(plan.t[k]),
                    "swing_drag",
                    f"the swing sole props {what} from {plan.t[start]:.3f} s and the "
                    f"walk carries it {moved.max() * 1e3:.1f} mm along the plane meanwhile",
                )
            ]
    return []


def slip_events(plan, friction: float) -> tuple[list[PredictedEvent], np.ndarray]:
    """``slip`` where the friction the walk needs beyond μ slides it past SLIP_DISTANCE."""
    force = plan.ground_force
    tangential = np.hypot(force[:, 0], force[:, 1])
    normal = np.maximum(force[:, 2], 0.0)
    # μ F_n, the most the ground holds; 0 where no foot is loaded, for any μ (inf too:
    # μ = inf means "no slip judged", and inf * 0 would be NaN and a RuntimeWarning)
    held = np.multiply(friction, normal, out=np.zeros_like(normal), where=normal > 0)
    excess = tangential - held
    slide = excursion_integral(plan.t, excess, plan.spec.total_mass)
    return _first_past(
        plan.t,
        slide,
        SLIP_DISTANCE,
        "slip",
        lambda: (
            f"friction ratio {np.nanmax(plan.friction_ratio):.3f} > mu {friction:g} "
            f"slides the feet {slide.max() * 1e3:.1f} mm (threshold {SLIP_DISTANCE * 1e3:g} mm)"
        ),
    ), slide


def _first_past(t, series, threshold: float, kind: str, describe) -> list[PredictedEvent]:
    """One ``kind`` event at the first sample where ``series`` exceeds ``threshold``
    (none if it never does); ``describe()`` gives its cause line."""
    over = np.flatnonzero(series > threshold)
    return [PredictedEvent(float(t[over[0]]), kind, describe())] if over.size else []


def foot_slide_events(plan, contact_time: float | None = None) -> list[PredictedEvent]:
    """``foot_slide`` where a loaded stretch of the second foot in DSP slides past SLIP_DISTANCE.

    Args:
        plan: The planned walk.
        contact_time: The floor contact's time constant τ [s] (MuJoCo's ``solref``): a
            foot dragged at the friction limit stays loaded at most that long per
            stretch (module doc). None: a rigid floor, loaded through the whole run.
    """
    if contact_time is not None and not contact_time > 0:
        raise SlopewalkError(f"foot_slide_events: contact_time {contact_time!r} s must be > 0")
    worst, when = 0.0, None
    for start, moved in _loaded_runs(plan):
        if contact_time is not None:
            end = start + moved.size
            moved = stretch_slide(plan.t[start:end], plan.swing_sole[start:end, :2], contact_time)
        over = np.flatnonzero(moved > SLIP_DISTANCE)
        if over.size and moved.max() > worst:
            worst, when = float(moved.max()), float(plan.t[start + over[0]])
    if when is None:
        return []
    stretch = (
        "in double support"
        if contact_time is None
        else (f"within one contact time ({contact_time * 1e3:g} ms) in double support")
    )
    return [
        PredictedEvent(
            when,
            "foot_slide",
            f"the plan slides a loaded foot {worst * 1e3:.1f} mm along the plane {stretch} "
            f"(threshold {SLIP_DISTANCE * 1e3:g} mm)",
        )
    ]


def stretch_slide(t, xy, contact_time: float) -> np.ndarray:
    """Farthest the path ``xy`` [m], (n, 2), at times ``t`` [s], (n,), moves within
    ``contact_time`` [s] ending at each sample [m], (n,): the slide of a loaded stretch
    that lasts at most ``contact_time`` (``foot_slide``'s chattering sole)."""
    xy = np.asarray(xy, dtype=float)
    t = np.asarray(t, dtype=float)
    moved = np.zeros(t.size)
    for k in range(1, t.size):  # lag in samples; the span t[i] - t[i-k] grows with k
        within = t[k:] - t[:-k] <= contact_time * (1 + 1e-9)
        if not within.any():
            break
        step = np.hypot(*(xy[k:] - xy[:-k]).T)
        moved[k:] = np.where(within, np.maximum(moved[k:], step), moved[k:])
    return moved


def planned_slide(plan) -> float:
    """Largest planned slide of a loaded foot in double support [m] (see ``foot_slide``)."""
    return max((float(moved.max()) for _, moved in _loaded_runs(plan)), default=0.0)


def _loaded_runs(plan):
    """(first sample, distance moved since it) of each DSP run where the second foot is loaded."""
    weight = plan.spec.total_mass * GRAVITY
    loaded = plan.double_support & (plan.swing_force[:, 2] > LOADED_FRACTION * weight)
    return slide_runs(loaded, plan.swing_sole[:, :2])


def slide_runs(mask, xy):
    """(first sample, distance [m] moved since it, per sample of the run) of each run of
    True in ``mask`` (n,), for the path ``xy`` [m], (n, 2): how the simulator measures a
    loaded sole's slide (``bench/sim/events.py``) and how the predictions do."""
    edges = np.diff(np.concatenate([[0], np.asarray(mask).astype(np.int8), [0]]))
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
        yield int(a), np.hypot(*(xy[a:b] - xy[a]).T)


def ring_events(plan, residual: np.ndarray | None) -> list[PredictedEvent]:
    """``ring`` at the first landing that finds more than ``RING_RESIDUAL`` of a load
    step's ring left from the last load transfer (``servo_ring``); ``residual``: that
    share at each touch-down (``servo_ring.landing_residuals``), None for a loop that takes
    no load transfer on its spring (feed-forward, ``servo_ring`` module doc)."""
    if residual is None:
        return []
    found = unsettled_landing(plan, residual)
    if found is None:
        return []
    k, left = found
    return [
        PredictedEvent(
            float(plan.t[k]),
            "ring",
            f"lands {plan.params.step_time:g} s after the last landing with {100 * left:.0f} % "
            "of a load step's ring left on the loaded joints' slowest mode (more than "
            f"the {100 * RING_RESIDUAL:g} % a landing takes, servo_ring)",
        )
    ]


def landing_tilt(walk_plan, rows: np.ndarray) -> np.ndarray:
    """Tilt of the swing sole off the plane [rad] at samples ``rows`` of a walk, (k,): the
    angle between its normal and the plane's (the chain's frame 9, ``Chain.poses``)."""
    rows = np.asarray(rows, dtype=np.int64)
    return _sole_tilt(walk_plan, walk_plan.q[rows], rows)


def double_support_tilt(plan, open_deflection: np.ndarray) -> np.ndarray:
    """Angle between the two soles [rad], (n,), in double support (0 elsewhere), of the
    walk the servo loop makes with the second sole never held (module doc, ``tip``).

    Args:
        plan: The planned walk (its ``q`` is the command).
        open_deflection: q_ref − q of that loop [rad], (n, 8)
            (``CompliantWalk.open_deflection``).

    The chain is rooted at the stance sole, flat on the plane, so the second sole's tilt
    off the plane (frame 9) is the angle between the two.
    """
    rows = np.flatnonzero(plan.double_support)
    tilt = np.zeros(plan.t.size)
    if rows.size:
        tilt[rows] = _sole_tilt(plan, plan.q[rows] - open_deflection[rows], rows)
    return tilt


def _sole_tilt(plan, q: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Frame 9's tilt off the plane [rad] at joint angles ``q`` (k, 8) on ``plan``'s
    stance soles at ``rows`` (k,)."""
    chain = Chain.from_spec(plan.spec)
    rotation, _ = chain.poses(q, plan.stance_sole[rows], plan.stance[rows])
    return np.arccos(np.clip(rotation[9, 2, 2], -1.0, 1.0))


def double_support_events(plan, open_deflection: np.ndarray) -> list[PredictedEvent]:
    """``tip`` at the first double-support sample where the servos' joints, the second
    sole left free, turn the two soles more than TIP_ANGLE apart (``double_support_tilt``):
    the plane cannot hold both flat, and one stands on its edge (module doc)."""
    tilt = double_support_tilt(plan, open_deflection)
    return _first_past(
        plan.t,
        tilt,
        TIP_ANGLE,
        "tip",
        lambda: (
            f"in double support the servos' joints turn the two soles "
            f"{np.rad2deg(tilt.max()):.1f} deg apart: one stands on its edge "
            f"(tip angle {np.rad2deg(TIP_ANGLE):g} deg)"
        ),
    )


def landing_events(walk_plan, rows: np.ndarray) -> list[PredictedEvent]:
    """``tip`` at the first landing of the servos' walk whose swing sole meets the plane
    tilted past TIP_ANGLE (module doc).

    Args:
        walk_plan: The walk the servos make (``servo_loop.servo_walk``'s ``plan``).
        rows: The sample before each of its touch-downs (``servo_ring.landing_rows``).
    """
    tilt = landing_tilt(walk_plan, rows)
    return _first_past(
        walk_plan.t[rows],
        tilt,
        TIP_ANGLE,
        "tip",
        lambda: (
            f"the lagging servos land the swing sole tilted "
            f"{np.rad2deg(tilt[tilt > TIP_ANGLE][0]):.1f} deg off the plane, loaded on its "
            f"edge (tip angle {np.rad2deg(TIP_ANGLE):g} deg)"
        ),
    )


def strike_events(walk, theta: np.ndarray) -> list[PredictedEvent]:
    """``strike`` where a swing-sole strike turns the stance foot past TIP_ANGLE (``strike``).

    Args:
        walk: The compliance-aware walk (``compliance.CompliantWalk``).
        theta: The stance foot's roll from the strike [rad], (n,) (``strike.strike_roll``).
    """
    plan = walk.plan
    return _first_past(
        plan.t,
        theta,
        TIP_ANGLE,
        "strike",
        lambda: (
            f"the sagging servos put the swing sole "
            f"{-plan.swing_sole[:, 2].min() * 1e3:.1f} mm into the plane in single support: it "
            f"props the robot up and turns the stance foot {np.rad2deg(theta.max()):.1f} deg "
            f"(tip angle {np.rad2deg(TIP_ANGLE):g} deg)"
        ),
    )


@dataclass(frozen=True)
class Prediction:
    """The analytic prediction of one trial.

    Attributes:
        verdict: The most severe of ``events`` or ``stable``.
        events: Predicted events, by time.
        rotation: Support rotation about its edge [rad], (n,).
        slide: Predicted slide from friction beyond μ [m], (n,).
    """

    verdict: str
    events: list[PredictedEvent]
    rotation: np.ndarray
    slide: np.ndarray


def saturation_events(walk, force_limit: float) -> list[PredictedEvent]:
    """``saturation`` where the loop asks a servo for more than its torque limit.

    ``CompliantWalk.loop_torque`` is what the loop asks for (the static walk: what
    the joint needs; the servo loop's walk: kp (−δ) − kv q̇ + τ_ff before clipping).
    Beyond the limit the servo delivers the limit and the joint falls behind, which
    ``servo_loop`` integrates; the event reports it and does not decide the verdict.
    """
    over = np.abs(walk.loop_torque) > force_limit
    if not over.any():
        return []
    k, j = np.unravel_index(np.argmax(over), over.shape)
    peak = np.abs(walk.loop_torque).max(axis=0)
    worst = int(np.argmax(peak))
    return [
        PredictedEvent(
            float(walk.plan.t[k]),
            "saturation",
            f"{JOINT_NAMES[worst]} asks for {peak[worst]:.2f} N m of a servo limited to "
            f"{force_limit:g} N m (first {JOINT_NAMES[j]})",
        )
    ]


def predict(
    plan,
    *,
    friction: float,
    walk=None,
    stiffness: float | None = None,
    force_limit: float = np.inf,
    floor_stiffness: float | None = None,
    contact_time: float | None = None,
    ring_residual: np.ndarray | None = None,
    body_tip: float | None = None,
) -> Prediction:
    """Every predicted event of ``plan`` on a plane of friction μ (see module doc).

    Args:
        plan: The planned walk (joint limits and foot slide are the plan's).
        friction: Coulomb μ of the feet on the plane.
        walk: The walk the servo makes (``compliance.CompliantWalk``: the static fixed
            point, or ``servo_loop.servo_walk``, the loop through time); tip, slip,
            strike and saturation are judged on it. None: on ``plan`` itself, neither
            strike nor saturation.
        stiffness: The servo's kp [N m/rad], with ``walk``.
        force_limit: The servo's torque limit [N m], with ``walk``.
        floor_stiffness: Sole-corner stiffness of the simulator's soft floor [N/m]
            (``bench/sim/floor.py``); None: a rigid floor, no give.
        contact_time: The floor contact's time constant τ [s] (``solref``), how long a
            dragged sole stays loaded per stretch (``foot_slide``); None: a rigid floor.
        ring_residual: The share of a load step's ring the loop has left at each
            touch-down where it takes the load's transfer on its spring (no feed-forward,
            ``servo_ring.landing_residuals``); None: no ``ring`` check.
        body_tip: When the whole-body walk turns a loaded sole past ``TIP_ANGLE`` [s]
            (``whole_body.tip_time``), a ``tip``; None: it does not, or not modelled.

    The rocking's prop uses the planned clearance and the planned sole's travel; where
    the servos' sag puts the reached walk's sole into the plane, that is ``strike``'s
    case, and the reached sole's travel while it holds the robot up (``strike_roll`` > 0)
    decides ``swing_drag`` too (the earlier of the two is the one reported).
    """
    events, rotation = events_but_slip(
        plan,
        walk=walk,
        stiffness=stiffness,
        force_limit=force_limit,
        floor_stiffness=floor_stiffness,
        contact_time=contact_time,
        ring_residual=ring_residual,
        body_tip=body_tip,
    )
    slips, slide = slip_events(plan if walk is None else walk.plan, friction)
    return with_slips(events, rotation, slips, slide)


def with_slips(
    events: list[PredictedEvent], rotation: np.ndarray, slips: list[PredictedEvent], slide
) -> Prediction:
    """``predict``'s prediction from ``events_but_slip``'s events and rotation and
    ``slip_events``' slips and slide: every event by time (then kind) and the verdict."""
    every = sorted(events + slips, key=lambda e: (e.time, e.kind))
    return Prediction(verdict(every), every, rotation, slide)


def events_but_slip(
    plan,
    *,
    walk=None,
    stiffness: float | None = None,
    force_limit: float = np.inf,
    floor_stiffness: float | None = None,
    contact_time: float | None = None,
    ring_residual: np.ndarray | None = None,
    body_tip: float | None = None,
) -> tuple[list[PredictedEvent], np.ndarray]:
    """``predict``'s events but ``slip`` (the only one μ decides), by time, and the
    support's rotation [rad], (n,); arguments as ``predict``'s. The trials of one walk at
    several frictions share them (``bench/sim/prediction.py``)."""
    made = plan if walk is None else walk.plan
    events = joint_limit_events(plan) + foot_slide_events(plan, contact_time)
    props = np.zeros(plan.t.size, dtype=bool)
    tips, rotation = tip_events(
        made, clearance=plan.swing_sole[:, 2], floor_stiffness=floor_stiffness, props=props
    )
    events += tips + ring_events(plan, ring_residual)
    drags = swing_drag_events(plan, props)
    if walk is not None:
        if stiffness is None:
            raise SlopewalkError(
                "predict: a walk needs the stiffness (kp [N m/rad]) it was made with"
            )
        if not walk.converged:
            events.append(
                PredictedEvent(
                    0.0,
                    "strike",
                    "the servos cannot hold the walk (the compliance fixed point does "
                    "not converge, or the loop's sway leaves the plan by pi)",
                )
            )
        else:
            theta = strike_roll(walk.plan, stiffness)
            events += strike_events(walk, theta) + saturation_events(walk, force_limit)
            events += landing_events(walk.plan, landing_rows(plan))
            if walk.open_deflection is not None:
                events += double_support_events(plan, walk.open_deflection)
            drags += swing_drag_events(walk.plan, theta > 0, STRUCK)
    events += sorted(drags, key=lambda e: e.time)[:1]
    if body_tip is not None:
        events.append(PredictedEvent(float(body_tip), "tip", BODY_TIP))
    events.sort(key=lambda e: (e.time, e.kind))
    return events, rotation
