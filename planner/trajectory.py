"""Gait parameters, the walk's timeline and its cubic-spline task trajectories (sec. IV).

A walk of N steps, each of duration T (the paper's step completion time t_c):

    step k:  [ DSP (1 − f)·T | SSP f·T ]          f = ssp_fraction = 0.6
    then one closing DSP of (1 − f)·T to come to rest.

* Footprints: step k's stance sole is at x = k·L/2 (L = step length); the
  first stance is the right foot, the left foot starts L/2 behind it. The swing
  foot advances L (from L/2 behind its stance foot to L/2 ahead), the hip L/2 per
  step, as in the paper.
* Hip: x is one clamped cubic spline through the step boundaries (zero velocity
  at start and end, continuous velocity in between); its height Hz is constant.
* Swing foot (SSP only): x and z are clamped cubic splines through lift-off,
  mid-swing and touch-down; z rises to the lift Szmax at mid-swing; the foot
  stays parallel to the plane.
* Frontal tilt λ(t): the lean of legs and pelvis about x_S (positive leans to the
  right, −y), ±tilt towards the stance foot, shaped by the sway share w ∈ [0, 1]
  (``Timeline.tilt_shape``): λ/tilt = (1 − w)·hold + w·sway, a blend of the lean
  held through the SSP (w = 0, "hold", the paper's) and a continuous sway peaking at
  mid-SSP (w = 1, "sway"). Both ankle rolls equal −λ.
* Pelvis offset δ: the hip's x in S is the hip spline + δ at every instant (a
  constant sagittal lean of the pelvis ahead of the feet, positive forward, i.e.
  uphill on a positive slope); feet and footprints do not move.

Every shape is linear in its parameter - Szmax, tilt, the step length L (hip x,
swing x, stance x) and w (the blend) - so a GA population only rescales and blends
basis curves computed once (see ``Timeline``): the extended gait family
(``planner.gait_search``) searches δ, L and w per individual as well.

Hip height Hz is the height of the pelvis centre (midway between the hip
joints) above the plane, along its normal; the lift is the swing sole's height.
Both are converted to each leg's tilted plane in ``ik.tilted_plane_height``.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy.interpolate import CubicSpline

from slopewalk.planner import ranges
from slopewalk.planner.errors import GaitError
from slopewalk.planner.joints import LEFT, RIGHT

MAX_SLOPE = np.deg2rad(60.0)
TILT_PROFILES = ("sway", "hold")
# The named profiles are the two ends of the sway share w; any other w is a "blend".
SWAY_SHARES = {"hold": 0.0, "sway": 1.0}
BLEND = "blend"

# The nominal gait of any robot, as fractions of its own lengths, fixed so that the
# paper's robot (sec. VII-A: ankle 0.032 m above the sole, L1 = L2 = 0.111 m) walks
# at its nominal Hz = 0.20 m, L = L1, Szmax = 0.6·L1 (exactly: the products below
# give 0.2 back in floating point for that robot).
#
# Hip height: the hip-ankle distance Hz − Lan is this share of the leg reach L1 + L2,
# so a robot scaled in all lengths stands with the same knee bend (about 0.757 of the
# reach; 0.20 m fixed would put a twice-as-large robot in a deep crouch).
NOMINAL_REACH_FRACTION = (0.20 - 0.032) / (0.111 + 0.111)
# Swing lift Szmax and step length L, as shares of the thigh L1.
NOMINAL_LIFT_PER_THIGH = 0.6
NOMINAL_STEP_PER_THIGH = 1.0
# The tilt is an angle and stays 12°: it needs no scaling for a robot scaled in all
# lengths (every joint angle of the walk is then the same).
NOMINAL_TILT = np.deg2rad(12.0)


@dataclass(frozen=True)
class GaitParams:
    """What to walk: step time, slope and the GA variables.

    The defaults of the length fields are the paper's robot's; for any other robot
    use ``GaitParams.nominal(spec, ...)``, which derives them from the spec.

    The lean's shape is given by ``tilt_profile`` ("hold" or "sway"), by
    ``sway_share`` (w in [0, 1]), or by both when they agree (w = 0 is "hold",
    w = 1 "sway", anything between "blend"); neither given is "hold". The fields
    keep what was given (so ``replace(params, tilt_profile="sway")`` changes the
    lean), ``lean_profile`` and ``lean_share`` what it resolves to.

    Attributes:
        step_time: Duration T of one step (DSP + SSP) [s], > 0.
        slope: Plane inclination θs [rad], in (−60°, 60°); positive walks uphill.
        hip_height: Hz, pelvis-centre height above the plane [m].
        swing_lift: Szmax, peak sole height of the swing foot [m], ≥ 0.
        tilt: Peak frontal lean towards the stance foot [rad].
        steps: Number of steps N, ≥ 1.
        step_length: Swing-foot advance per step L [m], > 0.
        ssp_fraction: Single-support share of a step, in (0, 1).
        dt: Sample period of the plan [s].
        tilt_profile: "sway", "hold" or "blend", the shape of λ(t) (``Timeline.tilt_shape``);
            None (default): from ``sway_share``, else "hold" (``lean_profile``).
        pelvis_offset: δ, the hip's constant x offset ahead of the hip spline in S [m],
            finite, |δ| < thigh + shank (``check_fits``); positive forward (uphill on a
            positive slope).
        sway_share: w, the share of "sway" in the lean's shape [-], in [0, 1]; None
            (default): from ``tilt_profile`` (``lean_share``).
    """

    step_time: float
    slope: float = 0.0
    hip_height: float = 0.20
    swing_lift: float = 0.0666
    tilt: float = NOMINAL_TILT
    steps: int = 4
    step_length: float = 0.111
    ssp_fraction: float = 0.6
    dt: float = 1e-3
    tilt_profile: str | None = None
    pelvis_offset: float = 0.0
    sway_share: float | None = None

    def __post_init__(self) -> None:
        # Types and finiteness first: every later comparison may then trust a real number.
        ranges.DT.check("dt", self.dt, GaitError)
        ranges.STEP_TIME.check("step time", self.step_time, GaitError)
        _check(
            self.step_time >= 10 * self.dt,
            f"step time {ranges.show(self.step_time)} s: must lie in [{10 * self.dt:g}, "
            f"{ranges.STEP_TIME.high:g}] s (at least 10 samples of dt = {self.dt:g} s)",
        )
        ranges.SLOPE_DEG.check("slope", _degrees(self.slope), GaitError)
        _positive_length("hip height", self.hip_height)
        _check(
            _finite(self.swing_lift) and self.swing_lift >= 0,
            f"swing lift {ranges.show(self.swing_lift)} m: must be a finite length >= 0 m",
        )
        ranges.TILT_DEG.check("tilt", _degrees(self.tilt), GaitError)
        ranges.STEPS.check("steps", self.steps, GaitError)
        _positive_length("step length", self.step_length)
        ranges.Range(0.0, 1.0, high_open=True).check("ssp fraction", self.ssp_fraction, GaitError)
        _check(
            _finite(self.pelvis_offset),
            f"pelvis offset {ranges.show(self.pelvis_offset)} m: must be a finite length "
            "(the robot's reach bounds it, ``check_fits``)",
        )
        lean_shape(self.tilt_profile, self.sway_share)
        samples = self.samples
        _check(
            samples <= ranges.MAX_SAMPLES,
            f"a walk of {self.steps} steps of {self.step_time:g} s at dt {self.dt:g} s has "
            f"{samples:.3g} samples: must be <= {ranges.MAX_SAMPLES:.0e} (fewer steps, "
            "shorter steps or a longer dt)",
        )

    @property
    def lean_profile(self) -> str:
        """The lean's shape by name: "hold" (w = 0), "sway" (w = 1) or "blend"."""
        return lean_shape(self.tilt_profile, self.sway_share)[0]

    @property
    def lean_share(self) -> float:
        """The sway share w [-] of the lean's shape (``Timeline.tilt_shape``)."""
        return lean_shape(self.tilt_profile, self.sway_share)[1]

    @property
    def samples(self) -> int:
        """Number of plan samples, the closing DSP included (as ``Timeline`` makes them)."""
        duration = (self.steps + 1 - self.ssp_fraction) * self.step_time
        return int(round(duration / self.dt)) + 1

    def check_fits(self, spec) -> None:
        """Refuse lengths that no pose of ``spec`` can reach, before any computing.

        Necessary conditions only, each a vertical distance no leg can span: Hz
        cannot exceed the straight stance leg on its ankle (ankle height + thigh +
        shank), the swing ankle (Szmax + ankle height) cannot be farther than a leg
        from the hip, and a step cannot be longer than both legs. Targets that
        pass and are still out of reach are found by the IK, at their time.

        Raises:
            GaitError: naming the value and the range the robot allows.
        """
        reach = spec.leg_reach
        top = spec.ankle_height + reach
        _check(
            self.hip_height <= top,
            f"hip height {self.hip_height:g} m: must lie in (0, {top:.4g}] m for "
            f"{spec.name} (ankle height + thigh + shank)",
        )
        lift = self.hip_height - spec.ankle_height + reach
        _check(
            self.swing_lift < lift,
            f"swing lift {self.swing_lift:g} m: must lie in [0, {lift:.4g}) m for {spec.name} "
            f"at hip height {self.hip_height:g} m (hip height - ankle height + thigh + shank)",
        )
        _check(
            self.step_length <= 2 * reach,
            f"step length {self.step_length:g} m: must lie in (0, {2 * reach:.4g}] m "
            f"for {spec.name} (two legs)",
        )
        _check(
            abs(self.pelvis_offset) < reach,
            f"pelvis offset {self.pelvis_offset:g} m: must lie in ({-reach:.4g}, {reach:.4g}) m "
            f"for {spec.name} (thigh + shank)",
        )

    @classmethod
    def nominal(cls, spec, step_time: float, **overrides) -> GaitParams:
        """The nominal gait for ``spec``, scaled from the paper's (Hz 0.20 m, L = L1).

        Hz = Lan + 0.757·(L1 + L2) (``NOMINAL_REACH_FRACTION``), Szmax = 0.6·L1,
        L = L1, tilt 12°, all in [m] and [rad]; for the paper's robot Hz = 0.20 m,
        Szmax = 0.0666 m, L = 0.111 m. ``overrides`` replace any field.
        """
        base = {
            "hip_height": spec.ankle_height + NOMINAL_REACH_FRACTION * spec.leg_reach,
            "step_length": NOMINAL_STEP_PER_THIGH * spec.thigh,
            "swing_lift": NOMINAL_LIFT_PER_THIGH * spec.thigh,
        }
        base.update(overrides)
        return cls(step_time=step_time, **base)


def lean_shape(tilt_profile: str | None, sway_share) -> tuple[str, float]:
    """(profile name, sway share w) of a lean given by either or both (``GaitParams``).

    Raises:
        GaitError: an unknown profile, w outside [0, 1], or the two disagreeing.
    """
    if tilt_profile is not None and tilt_profile not in (*TILT_PROFILES, BLEND):
        raise GaitError(
            f"tilt profile {tilt_profile!r}: must be one of {', '.join(TILT_PROFILES)} "
            f"(or {BLEND} with a sway share in (0, 1))"
        )
    if sway_share is None:
        if tilt_profile == BLEND:
            raise GaitError("tilt profile 'blend': give its sway share in (0, 1)")
        profile = tilt_profile or "hold"
        return profile, SWAY_SHARES[profile]
    ranges.SWAY_SHARE.check("sway share", sway_share, GaitError)
    share = float(sway_share)
    named = {v: k for k, v in SWAY_SHARES.items()}.get(share, BLEND)
    if tilt_profile is not None and tilt_profile != named:
        raise GaitError(
            f"tilt profile {tilt_profile!r} and sway share {share:g}: disagree ("
            + ", ".join(f"{k} is sway share {v:g}" for k, v in SWAY_SHARES.items())
            + f", {BLEND} lies between)"
        )
    return named, share


def _check(ok: bool, message: str) -> None:
    if not ok:
        raise GaitError(message)


def _finite(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


def _degrees(radians):
    """Radians to degrees for the message, leaving a non-number as it is."""
    return float(np.rad2deg(radians)) if _finite(radians) or isinstance(radians, float) else radians


def _positive_length(name: str, value) -> None:
    _check(
        _finite(value) and value > 0,
        f"{name} {ranges.show(value)} m: must be a finite length > 0 m",
    )


@dataclass(frozen=True)
class Curve:
    """A time series with its first two derivatives, each shape (..., n)."""

    p: np.ndarray
    v: np.ndarray
    a: np.ndarray

    def scaled(self, factor) -> Curve:
        """This curve times ``factor`` (a scalar or a column of shape (P, 1))."""
        return Curve(self.p * factor, self.v * factor, self.a * factor)


@dataclass(frozen=True)
class Timeline:
    """Sample times, phases and the parameter-free shapes of a walk.

    Built from the timing part of ``GaitParams`` (T, N, L, f, dt) and the shape of
    its lean (w) and hip (δ); the lift and tilt enter later as scale factors of
    ``lift_shape`` and ``tilt_shape``. The sample times depend on T, N, f and dt
    only, so every individual of a population (its own L, δ, w) shares them; the
    shapes for one individual are those of ``per_unit`` (L = 1, δ = 0) scaled by L
    plus δ, and the blend ``(1 − w)·hold_shape + w·sway_shape``.

    Attributes:
        pelvis_offset: δ [m], added to ``hip_x``.
        sway_share: w [-] of ``tilt_shape``; None: from ``tilt_profile`` (0 "hold", 1 "sway").
    """

    step_time: float
    steps: int
    step_length: float
    ssp_fraction: float
    dt: float
    tilt_profile: str = "hold"
    pelvis_offset: float = 0.0
    sway_share: float | None = None
    t: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        if self.sway_share is None:
            object.__setattr__(self, "sway_share", SWAY_SHARES.get(self.tilt_profile, 0.0))
        duration = (self.steps + 1 - self.ssp_fraction) * self.step_time
        n = int(round(duration / self.dt)) + 1
        object.__setattr__(self, "t", np.linspace(0.0, duration, n))

    @classmethod
    def of(cls, params: GaitParams) -> Timeline:
        return cls(
            params.step_time,
            params.steps,
            params.step_length,
            params.ssp_fraction,
            params.dt,
            params.lean_profile,
            params.pelvis_offset,
            params.lean_share,
        )

    @cached_property
    def per_unit(self) -> Timeline:
        """The same timing with L = 1 m and δ = 0: the shapes per unit step length."""
        return Timeline(
            self.step_time, self.steps, 1.0, self.ssp_fraction, self.dt, self.tilt_profile,
            0.0, self.sway_share,
        )  # fmt: skip

    @property
    def dsp_time(self) -> float:
        return (1 - self.ssp_fraction) * self.step_time

    @cached_property
    def step(self) -> np.ndarray:
        """Step index per sample, shape (n,); N marks the closing DSP."""
        k = np.floor(self.t / self.step_time + 1e-9).astype(int)
        return np.minimum(k, self.steps)

    @cached_property
    def in_ssp(self) -> np.ndarray:
        """True where the robot stands on one foot, shape (n,)."""
        tau = self.t - self.step * self.step_time
        return (self.step < self.steps) & (tau > self.dsp_time + 1e-12)

    @cached_property
    def stance(self) -> np.ndarray:
        """Stance leg per sample (0 left / 1 right), shape (n,); the closing DSP keeps the last."""
        k = np.minimum(self.step, self.steps - 1)
        return np.where(k % 2 == 0, RIGHT, LEFT)

    @cached_property
    def stance_x(self) -> np.ndarray:
        """x of the stance sole point in S [m], shape (n,)."""
        return np.minimum(self.step, self.steps - 1) * self.step_length / 2

    @cached_property
    def hip_x(self) -> Curve:
        """Hip x relative to the stance ankle [m] (and its rates), shape (n,).

        The spline through the step boundaries (the hip advances L/2 per step) plus
        the pelvis offset δ, which moves the hip and not the feet.
        """
        L, T, N = self.step_length, self.step_time, self.steps
        knots = np.append(np.arange(N) * T, self.t[-1])
        values = np.append((2 * np.arange(N) - 1) * L / 4, (2 * N - 1) * L / 4)
        curve = _spline(knots, values, self.t)
        return Curve(curve.p - self.stance_x + self.pelvis_offset, curve.v, curve.a)

    @cached_property
    def swing_x(self) -> Curve:
        """Swing ankle x relative to the stance ankle [m], shape (n,)."""
        x = np.where(self.step < self.steps, -self.step_length / 2, self.step_length / 2)
        ssp = _ssp_shape(self, [-self.step_length / 2, 0.0, self.step_length / 2])
        return Curve(np.where(self.in_ssp, ssp.p, x), ssp.v * self.in_ssp, ssp.a * self.in_ssp)

    @cached_property
    def lift_shape(self) -> Curve:
        """Swing sole height for a unit lift [-], shape (n,)."""
        ssp = _ssp_shape(self, [0.0, 1.0, 0.0])
        return Curve(ssp.p * self.in_ssp, ssp.v * self.in_ssp, ssp.a * self.in_ssp)

    @cached_property
    def tilt_shape(self) -> Curve:
        """Frontal lean λ for a unit tilt [-], shape (n,): +1 leans towards step 0's stance.

        The blend (1 − w)·``hold_shape`` + w·``sway_shape`` of the sway share w;
        w = 0 and w = 1 are the two shapes exactly.
        """
        return blend(self.hold_shape, self.sway_shape, self.sway_share)

    @cached_property
    def sway_shape(self) -> Curve:
        """λ per unit tilt of "sway" (w = 1) [-], shape (n,).

        One clamped cubic spline through 0 at start and end and ±1 at mid-SSP of each
        step; the weight moves across during the whole step, as in the natural
        lateral oscillation of a walking biped.
        """
        k = np.arange(self.steps)
        lean = np.where(k % 2 == 0, 1.0, -1.0)  # step 0 stands on the right foot: lean right
        knots = np.concatenate(
            [[0.0], (k + 1 - self.ssp_fraction / 2) * self.step_time, [self.t[-1]]]
        )
        return _spline(knots, np.concatenate([[0.0], lean, [0.0]]), self.t)

    @cached_property
    def hold_shape(self) -> Curve:
        """λ per unit tilt of "hold" (w = 0, the paper's) [-], shape (n,).

        ±1 held through each SSP; in each DSP the paper's cubic d0 + d1 t + d2 t² +
        d3 t³ with zero end rates carries λ from the previous value to the next
        (quasi-static: the whole transfer happens in the DSP). A sample on a phase
        change belongs to the phase ``in_ssp`` gives it and takes that phase's
        one-sided value (the last DSP sample keeps the cubic's λ̈).
        """
        k = np.arange(self.steps)
        lean = np.where(k % 2 == 0, 1.0, -1.0)
        before = np.concatenate([[0.0], lean])[self.step]
        after = np.append(lean, 0.0)[self.step]
        x = np.clip((self.t - self.step * self.step_time) / self.dsp_time, 0.0, 1.0)
        span = after - before
        return Curve(
            before + span * (3 * x**2 - 2 * x**3),
            span * 6 * x * (1 - x) / self.dsp_time,
            span * (6 - 12 * x) / self.dsp_time**2 * ~self.in_ssp,
        )

    @cached_property
    def touch_downs(self) -> np.ndarray:
        """Sample index of each touch-down k = 0..N-1, shape (N,)."""
        knots = (np.arange(self.steps) + 1) * self.step_time
        return np.minimum(np.searchsorted(self.t, knots - 1e-9), self.t.size - 1)

    @cached_property
    def landing_shape(self) -> np.ndarray:
        """λ (per unit tilt) at each touch-down k = 0..N-1, shape (N,)."""
        return self.tilt_shape.p[self.touch_downs]


def blend(hold: Curve, sway: Curve, share) -> Curve:
    """(1 − w)·hold + w·sway, w a scalar or a column (P, 1) [-]; exact at w = 0 and 1."""
    keep = 1.0 - np.asarray(share, dtype=float)
    return Curve(
        *(keep * h + share * s for h, s in ((hold.p, sway.p), (hold.v, sway.v), (hold.a, sway.a)))
    )


def _spline(knots, values, t) -> Curve:
    """Clamped cubic spline (zero end velocities) through (knots, values), sampled at t."""
    spline = CubicSpline(knots, values, bc_type="clamped")
    return Curve(spline(t), spline(t, 1), spline(t, 2))


def _ssp_shape(timeline: Timeline, values) -> Curve:
    """Clamped spline over a unit SSP through lift-off, mid-swing, touch-down, per sample."""
    ssp_time = timeline.ssp_fraction * timeline.step_time
    tau = timeline.t - timeline.step * timeline.step_time - timeline.dsp_time
    s = np.clip(tau / ssp_time, 0.0, 1.0)
    spline = CubicSpline([0.0, 0.5, 1.0], values, bc_type="clamped")
    return Curve(spline(s), spline(s, 1) / ssp_time, spline(s, 2) / ssp_time**2)


def footprint_y(timeline: Timeline, hip_width: float, tilt, sway_share=None) -> np.ndarray:
    """Lateral position of each step's stance sole in S [m].

    The first stance (right) foot is at −Lh/2. Each touch-down lands the swing
    sole at Lh / cos λ beside the stance sole (legs stay parallel in the frontal
    plane and there is no hip roll), towards the swing side; λ at touch-down is
    the tilt times the landing shape of the lean, the blend of the hold and sway
    shapes' by the sway share.

    Args:
        tilt: Peak tilt [rad], scalar or shape (P,).
        sway_share: w [-], scalar or shape (P,); None: the timeline's.

    Returns:
        y of step k's stance sole, shape (N,) or (P, N).
    """
    tilt = np.asarray(tilt, dtype=float)[..., None]
    if sway_share is None:
        landing = timeline.landing_shape
    else:
        w = np.asarray(sway_share, dtype=float)[..., None]
        idx = timeline.touch_downs
        landing = (1.0 - w) * timeline.hold_shape.p[idx] + w * timeline.sway_shape.p[idx]
    lean = tilt * landing  # (.., N)
    k = np.arange(timeline.steps)
    towards_swing = np.where(k % 2 == 0, 1.0, -1.0)  # step 0: stance right, swing left (+y)
    offsets = towards_swing * hip_width / np.cos(lean)
    first = np.full(tilt.shape[:-1] + (1,), -hip_width / 2)
    return np.concatenate([first, first + np.cumsum(offsets, axis=-1)[..., :-1]], axis=-1)
