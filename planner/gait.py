"""What to walk: ``GaitParams`` (step time, slope and the GA's variables), checked whole.

The nominal gait of any robot is derived from its own lengths
(``GaitParams.nominal``); ``lean_shape`` resolves the frontal lean's profile.
Radians and SI units: ``slope`` and ``tilt`` are radians, lengths metres, times seconds.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from slopewalk.planner import ranges
from slopewalk.planner.errors import GaitError

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
            f"{spec.name} (ankle height + {_reach_words(spec)})",
        )
        lift = self.hip_height - spec.ankle_height + reach
        _check(
            self.swing_lift < lift,
            f"swing lift {self.swing_lift:g} m: must lie in [0, {lift:.4g}) m for {spec.name} "
            f"at hip height {self.hip_height:g} m (hip height - ankle height + "
            f"{_reach_words(spec)})",
        )
        _check(
            self.step_length <= 2 * reach,
            f"step length {self.step_length:g} m: must lie in (0, {2 * reach:.4g}] m "
            f"for {spec.name} (two legs)",
        )
        _check(
            abs(self.pelvis_offset) < reach,
            f"pelvis offset {self.pelvis_offset:g} m: must lie in ({-reach:.4g}, {reach:.4g}) m "
            f"for {spec.name} ({_reach_words(spec)})",
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


def _reach_words(spec) -> str:
    """How the error lines name ``spec.leg_reach``: the two links in line."""
    if spec.knee_offset:
        return "the legs' reach, √(thigh² + k²) + √(shank² + k²) with the knee offset k"
    return "thigh + shank"
