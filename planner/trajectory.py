"""The walk's timeline and its cubic-spline task trajectories (sec. IV), from ``GaitParams``.

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

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy.interpolate import CubicSpline

from slopewalk.planner.gait import SWAY_SHARES, GaitParams
from slopewalk.planner.joints import LEFT, RIGHT


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
