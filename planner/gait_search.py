"""The gait optimisation problem of sec. VI: variables, bounds, objective, constraint.

The GA tunes x = (Hz [m], Szmax [m], θ1max [rad]) - pelvis height, swing lift and
peak frontal tilt - to minimise the joint work w (``plan.evaluate``) under the ZMP
condition min margin ≥ 0. The paper's objective (eq. 6) is O = w + p with
p = 10⁴ when the ZMP leaves the support polygon.

Two gait families (``FAMILIES``): the paper's three variables, and the *extended*
family x = (Hz, Szmax, θ1max, δ [m], L [m], w [-]) that also searches what real
slope walkers change (``trajectory`` module doc): a sagittal pelvis offset δ
(leaning into the slope), the step length L and the lateral-sway timing w (the
share of the continuous sway in the lean's shape; 0 is the paper's hold). The
paper family is the extended one at x[3:] = (0, the walk's L, its profile's w).

Why two modules: ``planner`` imports numpy, scipy and numba only (DESIGN.md), so the problem
*definition* lives here - the variables, their bounds derived from the spec's
kinematics, the objective and constraint arrays and the paper's penalty - while
the pymoo *driver* (GA, NSGA-II, progress bar) lives in ``bench/experiments/ga/search.py``.
Any other optimiser can solve a ``GaitProblem`` through ``measure`` and
``objectives`` without pymoo.

Kinematic admissibility: ``plan.score`` marks unreachable targets (work = inf,
margin = −inf); in addition an individual that would drive a hip pitch, knee or
ankle pitch joint past its limit at any sample is inadmissible (the gap ``plan.score``
returns from the compiled kernel's IK; ``joint_gap`` is its readable numpy twin, held
equal by a test; the ankle rolls are kept within their limits by the tilt bounds).
Both count as infeasible for every constraint treatment.

What a real robot needs besides the ZMP (issue 21), each with its physical basis:

* **A bent knee** (``min_knee_flexion``): the knee stays at least the servo's
  compliance band, stall torque / kp (0.162 rad for the AX-12A), away from straight at
  every sample. The proportional servo holds a joint only to within τ/kp of its
  command, up to that band at full torque, so a knee planned nearer to straight can be
  pushed straight by its load, where the leg loses its vertical degree of freedom; and
  near the straight knee the IK's joint rates and accelerations grow as 1/sin κ, so the
  planned ZMP is not a continuous function of the gait there (at 1 s, −10° 1e-7 m of
  hip height moved the margin between −97 and −540 mm). The band is the search's lower
  knee limit (``search_limits``), checked per individual through the joint gap, and it
  caps the hip height (``hip_height_bounds``).
* **Swing clearance** (``swing_clearance``): the peak lift is at least
  hip_width · sin(TIP_ANGLE) (7.4 mm for the Bioloid). The simulator does not call a
  rock of the stance foot on its inner edge a tip below ``verdict.TIP_ANGLE``; such a
  rock lowers the swing sole's far edge, one hip width from that edge, by
  Lh sin φ, so a lift below it lets a tolerated rock put the swing foot on the plane.
* **No planned foot slide**: the largest slide of a loaded foot in double support
  (``verdict.planned_slide``, at the GA's samples) is at most ``verdict.SLIP_DISTANCE``,
  the simulator's own slip threshold, so the plan never asks for what the simulator
  would call a slip.
* **Friction**: the largest |F_t| / F_n of the total ground force is at most the cell's
  μ (``GaitProblem.friction``): beyond it the plane cannot hold the planned walk.

The slide and friction are constraints (``Measurement``), like the joint gap: an
individual past either is inadmissible for every treatment.

The bounds below come from the same geometry as ``plan._solve`` (hip and
swing-ankle targets in each leg's tilted plane, see ``ik.tilted_plane_height``):
for a hip-to-ankle vector (u, w) in the leg plane, w is affine in the pelvis
height h = Hz − Lan with slope 1/cos λ and in the lift with slope −ℓ(t)/cos λ
(ℓ the unit lift shape), so every bound is a closed form per sample, then a
min/max over the samples of one walk and over a grid of tilts.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.ik import leg_ik, tilted_plane_height
from slopewalk.planner.joints import JOINT_KINDS, RIGHT, principal_angle
from slopewalk.planner.kinematics import GRAVITY
from slopewalk.planner.plan import score
from slopewalk.planner.spec import RobotSpec
from slopewalk.planner.trajectory import Curve, Timeline, blend
from slopewalk.planner.verdict import LOADED_FRACTION, SLIP_DISTANCE, TIP_ANGLE

VARIABLES = ("hip_height", "swing_lift", "tilt")
EXTENDED = (*VARIABLES, "pelvis_offset", "step_length", "sway_share")
FAMILIES = {"paper": VARIABLES, "extended": EXTENDED}
STEP_PER_THIGH = (0.5, 1.0)  # the extended family's step length L, as shares of the thigh
CONSTRAINTS = ("penalty", "margin", "stability")
PENALTY = 1e4  # p of eq. (6), added to the work [J] of an infeasible gait
SAMPLES_PER_STEP = 100  # GA grid: dt = step_time / 100, plus phase-change limits and refinement
INADMISSIBLE_GAP = 1.0  # constraint value [m or rad] given to an unreachable individual
_TILT_GRID = 61  # tilts tried when a bound is the best over all tilts
_UNMEASURED = np.zeros(0)  # a ``Measurement`` gap not given: 0 for every individual


@dataclass(frozen=True)
class Bounds:
    """Box of the search: lower and upper value of each variable of ``names``.

    (Hz [m], Szmax [m], tilt [rad]) for the paper family, then (δ [m], L [m], w [-])
    for the extended one.
    """

    lower: tuple[float, ...]
    upper: tuple[float, ...]
    names: tuple[str, ...] = VARIABLES

    def __post_init__(self) -> None:
        for name, lo, hi in zip(self.names, self.lower, self.upper, strict=True):
            if not lo < hi:
                raise SlopewalkError(
                    f"{name} bounds [{lo:.4g}, {hi:.4g}]: empty; the robot's kinematics "
                    "leave no room for this variable"
                )

    @property
    def xl(self) -> np.ndarray:
        return np.asarray(self.lower, dtype=float)

    @property
    def xu(self) -> np.ndarray:
        return np.asarray(self.upper, dtype=float)


@dataclass(frozen=True)
class Measurement:
    """What the planner says of a population, each shape (P,).

    Attributes:
        work: Joint work Σ∫|τθ̇|dt [J]; inf where unreachable.
        margin: Minimum signed ZMP margin [m], positive inside; −inf where unreachable.
        joint_gap: Worst excursion of a pitch joint past its search limit [rad]
            (``joint_gap``, ``search_limits``); ≤ 0 when admissible, inf where unreachable.
        friction_gap: Largest friction ratio |F_t|/F_n less the floor's μ [-]; ≤ 0 when
            the plane holds the walk. Not given: not measured (0).
        slide_gap: Largest planned slide of a loaded foot in double support less
            ``SLIP_DISTANCE`` [m]; ≤ 0 when no foot slides. Not given: not measured (0).
    """

    work: np.ndarray
    margin: np.ndarray
    joint_gap: np.ndarray
    friction_gap: np.ndarray = field(default_factory=lambda: _UNMEASURED)
    slide_gap: np.ndarray = field(default_factory=lambda: _UNMEASURED)

    def __post_init__(self) -> None:
        for name in ("friction_gap", "slide_gap"):
            if getattr(self, name) is _UNMEASURED:
                object.__setattr__(self, name, np.zeros(np.shape(self.work)))

    @property
    def admissible(self) -> np.ndarray:
        """Reachable, every pitch joint inside its search limits, no slide, friction held."""
        finite = np.isfinite(self.work) & np.isfinite(self.margin)
        return finite & (self.joint_gap <= 0) & (self.friction_gap <= 0) & (self.slide_gap <= 0)

    @property
    def feasible(self) -> np.ndarray:
        """Admissible and the ZMP inside the support polygon at every sample."""
        return self.admissible & (self.margin >= 0)


def min_knee_flexion(spec: RobotSpec) -> float:
    """Least knee flexion the search admits [rad]: the servo's compliance band, stall / kp.

    A proportional servo of gain kp with torque limit τ_max sits τ/kp off its command,
    up to τ_max / kp at full torque (0.162 rad for the AX-12A); a knee planned nearer
    to straight than that can be pushed straight by its load (module doc).
    """
    if spec.stiffness <= 0:
        raise SlopewalkError(
            f"servo stiffness {spec.stiffness:g} N m/rad: must be > 0 for the search's "
            "least knee flexion (stall torque / stiffness)"
        )
    return float(spec.stall_torque / spec.stiffness)


def search_limits(spec: RobotSpec) -> np.ndarray:
    """Joint limits of the search per Table-I joint [rad], (8, 2): the spec's, with the knee's
    lower limit raised to ``min_knee_flexion`` (never below the spec's own)."""
    limits = np.array([spec.joint_limits[kind] for kind in JOINT_KINDS], dtype=float)
    knee = np.array([kind == "knee" for kind in JOINT_KINDS])
    limits[knee, 0] = np.maximum(limits[knee, 0], min_knee_flexion(spec))
    return limits


def swing_clearance(spec: RobotSpec) -> float:
    """Smallest peak swing lift Szmax searched [m]: hip_width · sin(TIP_ANGLE) (module doc)."""
    return float(spec.hip_width * np.sin(TIP_ANGLE))


def knee_distance_range(spec: RobotSpec) -> tuple[float, float]:
    """Hip-to-ankle distances [m] the search's knee limits allow.

    With knee flexion κ (0 = straight) the law of cosines gives
    d² = L1² + L2² + 2 L1 L2 cos(κ + γ) over the effective links L1, L2 and the angle
    γ = γ_s + γ_t a knee offset puts between them at κ = 0 (``ik.leg_ik``; 0 without
    one); the upper knee limit sets the shortest d, the search's lower one
    (``search_limits``: at least ``min_knee_flexion`` bent) the longest.
    """
    lo = max(spec.joint_limits["knee"][0], min_knee_flexion(spec))
    hi = spec.joint_limits["knee"][1]
    L1, L2 = spec.shank_link, spec.thigh_link
    gamma = spec.shank_tilt + spec.thigh_tilt

    def d(kappa):
        return float(np.sqrt(L1**2 + L2**2 + 2 * L1 * L2 * np.cos(kappa)))

    return d(min(hi + gamma, np.pi)), d(max(lo + gamma, 0.0))


def tilt_bounds(spec: RobotSpec) -> tuple[float, float]:
    """Range of the peak tilt [rad] the ankle-roll limits allow.

    Both ankle rolls equal −λ and the lean λ swings between +tilt and −tilt (it
    leans towards each stance foot in turn), so |tilt| ≤ min(upper, −lower) of the
    ankle_roll limit. Negative tilts (leaning away from the stance foot) are kept:
    the paper's optimum at 22.5° is θ1max = −9.18°.
    """
    lo, hi = spec.joint_limits["ankle_roll"]
    reach = min(hi, -lo)
    if not reach > 0:
        raise SlopewalkError(f"joint_limits.ankle_roll = [{lo}, {hi}]: must contain 0")
    return -reach, reach


def leg_vectors(
    spec: RobotSpec, timeline: Timeline, hip_height, lift, tilt, pelvis_offset=None,
    step_length=None, sway_share=None,
):  # fmt: skip
    """Hip-to-ankle vectors of both legs in their tilted planes, as ``plan._solve`` builds them.

    Args:
        hip_height, lift, tilt: Hz [m], Szmax [m], tilt [rad]; broadcastable, shape (P,).
        pelvis_offset, step_length, sway_share: δ [m], L [m], w [-], broadcastable with
            them; None: the timeline's.

    Returns:
        (u, w, cos_lean, lift_shape): u forward and w up in the leg plane [m], each
        shape (P, n, 2) with [..., 0] the stance leg and [..., 1] the swing leg;
        cos λ, shape (P, n, 1); the unit lift shape ℓ(t), shape (1, n, 2) (0 for
        the stance leg).
    """
    defaults = (timeline.pelvis_offset, timeline.step_length, timeline.sway_share)
    given = (pelvis_offset, step_length, sway_share)
    hz, lift, tilt, delta, length, share = np.broadcast_arrays(
        *(
            np.atleast_1d(np.asarray(a, float))
            for a in (
                hip_height,
                lift,
                tilt,
                *(d if g is None else g for g, d in zip(given, defaults, strict=True)),
            )
        )
    )
    n = timeline.t.size
    zeros = np.zeros((hz.size, n))
    unit = timeline.per_unit  # shapes per unit step length, δ = 0
    lean = blend(unit.hold_shape, unit.sway_shape, share[:, None]).scaled(tilt[:, None])
    towards_swing = np.where(timeline.stance == RIGHT, 1.0, -1.0)
    pelvis = Curve(hz[:, None] - spec.ankle_height + zeros, zeros, zeros)
    hip_w = tilted_plane_height(pelvis, towards_swing * spec.hip_width / 2, lean).p
    z_swing = tilted_plane_height(
        timeline.lift_shape.scaled(lift[:, None]), towards_swing * spec.hip_width, lean
    ).p
    hip_u = length[:, None] * unit.hip_x.p + delta[:, None]
    u = np.stack([hip_u, hip_u - length[:, None] * unit.swing_x.p], axis=-1)
    w = np.stack([hip_w, hip_w - z_swing], axis=-1)
    shape = np.stack([np.zeros(n), timeline.lift_shape.p], axis=-1)[None]
    return u, w, np.cos(lean.p)[..., None], shape


def joint_gap(spec: RobotSpec, timeline: Timeline, population) -> np.ndarray:
    """Worst excursion of a hip pitch, knee or ankle pitch past its joint limit [rad], shape (P,).

    The legs' joint angles come from ``ik.two_link_ik`` on the targets of
    ``leg_vectors`` (hip pitch = β_thigh, knee = β_shank − β_thigh, ankle pitch =
    −β_shank, both legs, every sample). Positive where some joint leaves its
    limits somewhere in the walk, ≤ 0 (minus the smallest distance to a limit)
    when every sample is admissible; inf where a target is out of reach.

    Each angle is the joint's configuration, its principal value in (−π, π]
    (``joints.principal_angle``), as in a plan; the compiled kernel gets its
    extremes from tan(q/2). The limits are the search's (``search_limits``: the knee
    at least ``min_knee_flexion`` bent).
    """
    X = np.atleast_2d(np.asarray(population, dtype=float))
    u, w, _, _ = leg_vectors(spec, timeline, *X.T)
    zero = np.zeros(u.shape)
    with np.errstate(invalid="ignore", divide="ignore"):
        shank, thigh = leg_ik(
            (Curve(u, zero, zero), Curve(w, zero, zero)), spec, timeline.t, strict=False
        )
    gaps = []
    limits = dict(zip(JOINT_KINDS, search_limits(spec), strict=True))
    for kind, q in (
        ("hip_pitch", thigh.p),
        ("knee", shank.p - thigh.p),
        ("ankle_pitch", -shank.p),
    ):
        lo, hi = limits[kind]
        q = principal_angle(q)
        gaps.append(np.maximum(lo - q, q - hi).max(axis=(1, 2)))
    gap = np.max(gaps, axis=0)
    return np.where(np.isnan(gap), np.inf, gap)


def hip_height_bounds(
    spec: RobotSpec, timeline: Timeline, tilt_range: tuple[float, float], lift: float, shapes=None
) -> tuple[float, float]:
    """Lowest and highest pelvis height Hz [m] any tilt in ``tilt_range`` admits.

    ``shapes``: (δ, L, w) columns of the extended family's corners, shape (k, 3), each
    tried with every tilt (``_shape_grid``), of which those count where the knee's
    limit binds and some height is left between both bounds (a pelvis leaning far
    enough out never bends a knee to its limit, and its own reach caps it); None: the
    timeline's own (the paper family).

    Lowest: the knees stay within their joint limits (d ≥ d_min of
    ``knee_distance_range``) at every sample, both legs, with the smallest lift.
    This is a necessary condition only: the hip- and ankle-pitch limits cut
    further into the box and are checked per individual (``joint_gap``).
    Highest: both legs reach every target with the knee bent by at least
    ``min_knee_flexion`` (d ≤ d_max of ``knee_distance_range``), which is decided in the
    double support where the lift plays no part. Each is a closed form per
    sample (w is affine in h = Hz − Lan with slope 1/cos λ):
    h ≥ cos λ (√(d_min² − u²) − w₀) and h ≤ cos λ (√(d_max² − u²) − w₀),
    with w₀ the value of w at h = 0.
    """
    d_min, d_max = knee_distance_range(spec)
    tilts, extra = _shape_grid(tilt_range, shapes)
    u, w0, c, _ = leg_vectors(spec, timeline, spec.ankle_height, lift, tilts, *extra)
    with np.errstate(invalid="ignore"):
        need = np.where(u**2 < d_min**2, c * (np.sqrt(d_min**2 - u**2) - w0), -np.inf)
        room = np.where(u**2 < d_max**2, c * (np.sqrt(d_max**2 - u**2) - w0), -np.inf)
    lows, highs = need.max(axis=(1, 2)), room.min(axis=(1, 2))
    if shapes is not None:  # the corners where the knee decides and some Hz is left
        viable = np.isfinite(lows) & np.isfinite(highs) & (lows < highs)
        lows, highs = lows[viable], highs[viable]
    low, high = lows.min(), highs.max()
    return spec.ankle_height + low, spec.ankle_height + high - 1e-6


def swing_lift_bounds(
    spec: RobotSpec, timeline: Timeline, tilt_range: tuple[float, float], shapes=None
) -> tuple[float, float]:
    """Smallest and largest swing lift Szmax [m] worth searching.

    Smallest: ``swing_clearance``. Largest: at the highest pelvis each tilt admits,
    the swing knee stays within its limit at mid-swing: w₀ + h/cos λ − ℓ Szmax/cos λ
    ≥ √(d_min² − u²) for every SSP sample (ℓ > 0), best over the tilts.
    """
    d_min, d_max = knee_distance_range(spec)
    tilts, extra = _shape_grid(tilt_range, shapes)
    u, w0, c, shape = leg_vectors(spec, timeline, spec.ankle_height, 0.0, tilts, *extra)
    with np.errstate(invalid="ignore", divide="ignore"):
        room = np.where(u**2 < d_max**2, c * (np.sqrt(d_max**2 - u**2) - w0), -np.inf)
        h = room.min(axis=(1, 2))[:, None, None]  # highest pelvis per tilt
        lift = np.where(
            (shape > 1e-9) & (u**2 < d_min**2),
            (c * w0 + h - c * np.sqrt(d_min**2 - u**2)) / shape,
            np.inf,
        )
    highest = lift.min(axis=(1, 2))
    if shapes is not None:  # the corners where the knee decides and some pelvis height is left
        highest = highest[np.isfinite(highest) & np.isfinite(h[:, 0, 0])]
    return swing_clearance(spec), float(highest.max())


def _shape_grid(tilt_range, shapes):
    """Every tilt of the grid with every (δ, L, w) row of ``shapes``: (tilts, (δ, L, w)),
    each flat of the same length; (tilts, ()) when ``shapes`` is None."""
    low, high = tilt_range
    tilts = np.linspace(low, high, _TILT_GRID)
    if shapes is None:
        return tilts, ()
    shapes = np.atleast_2d(np.asarray(shapes, dtype=float))
    t = np.repeat(tilts, len(shapes))
    rows = np.tile(shapes, (tilts.size, 1))
    return t, tuple(rows.T)


def pelvis_offset_bounds(spec: RobotSpec, slope: float = 0.0) -> tuple[float, float]:
    """Range of the pelvis offset δ [m] of the extended family on a slope θs [rad].

    δ moves the hip, and with it most of the mass, ahead of the feet. Held still,
    the ZMP of eq. (4) is p_x = c_x − c_z tan θs (gravity in S has g_x/g_z = tan θs),
    so a gait with the ZMP on the sole, x in [−heel offset, ankle-to-toe] about the
    stance ankle, holds its CoM over [−heel, toe] + c_z tan θs at the instant the hip
    spline passes over that ankle: leaning into the slope, forward uphill, back
    downhill. No CoM is higher than the straight leg on its ankle, H = ankle height +
    thigh + shank, so the box is the sole's extent widened on the slope's side by
    H |tan θs| (a pelvis beyond it puts a slow walk's ZMP off the sole), and kept
    inside the legs' reach (|δ| < thigh + shank, ``GaitParams.check_fits``); the
    reach at a given Hz, L and tilt is each individual's own check (``plan.score``).
    """
    reach = spec.leg_reach
    lean = (spec.ankle_height + reach) * np.tan(slope)
    low, high = -spec.heel_offset + min(lean, 0.0), spec.ankle_to_toe + max(lean, 0.0)
    return float(max(low, -reach + 1e-6)), float(min(high, reach - 1e-6))


def step_length_bounds(spec: RobotSpec) -> tuple[float, float]:
    """Range of the step length L [m] of the extended family: 0.5 … 1.0 × thigh.

    The paper's L is the thigh length (``trajectory.NOMINAL_STEP_PER_THIGH``); real
    slope walkers shorten their steps, so the search goes down to half of it and
    not beyond the paper's (issue 10).
    """
    return STEP_PER_THIGH[0] * spec.thigh, STEP_PER_THIGH[1] * spec.thigh


def extended_corners(spec: RobotSpec, slope: float = 0.0) -> np.ndarray:
    """(δ, L, w) of the corners and centre lines of the extended box on a slope θs [rad],
    shape (18, 3): δ at both ends and 0, L at both ends and the middle, w 0 and 1 (the
    lean's two shapes; a blend lies between them sample by sample)."""
    d_lo, d_hi = pelvis_offset_bounds(spec, slope)
    l_lo, l_hi = step_length_bounds(spec)
    grid = np.meshgrid([d_lo, 0.0, d_hi], [l_lo, 0.5 * (l_lo + l_hi), l_hi], [0.0, 1.0])
    return np.column_stack([g.ravel() for g in grid])


def gait_bounds(spec: RobotSpec, params: GaitParams, family: str = "paper") -> Bounds:
    """The search box of a family, from the spec's kinematics (see each bound).

    Paper: (Hz, Szmax, tilt) at the walk's own L, δ and w. Extended: also (δ, L, w),
    with the Hz and Szmax bounds widened to what any corner of the flat-ground (δ, L,
    w) box admits with any tilt (``extended_corners``).
    """
    check_family(family)
    timeline = Timeline.of(params)
    tilts = tilt_bounds(spec)
    # Hz and Szmax: what the legs admit at the corners of the flat-ground box (δ on the
    # sole); a pelvis leaning further into a slope is searched at those heights (leant far
    # enough out, no knee reaches its limit and the knee bound would not be finite)
    shapes = extended_corners(spec) if family == "extended" else None
    lift = swing_lift_bounds(spec, timeline, tilts, shapes)
    hz = hip_height_bounds(spec, timeline, tilts, lift[0], shapes)
    lower, upper = [hz[0], lift[0], tilts[0]], [hz[1], lift[1], tilts[1]]
    if family == "extended":
        for lo, hi in (
            pelvis_offset_bounds(spec, params.slope),
            step_length_bounds(spec),
            (0.0, 1.0),
        ):
            lower.append(lo)
            upper.append(hi)
    return Bounds(lower=tuple(lower), upper=tuple(upper), names=FAMILIES[family])


def check_family(family: str) -> None:
    if family not in FAMILIES:
        raise SlopewalkError(f"gait family {family!r}: must be one of {', '.join(FAMILIES)}")


def ga_params(spec: RobotSpec, step_time: float, slope: float, **overrides) -> GaitParams:
    """The walk every individual is planned on: the nominal gait at 100 samples per step."""
    overrides.setdefault("dt", step_time / SAMPLES_PER_STEP)
    return GaitParams.nominal(spec, step_time, slope=slope, **overrides)


@dataclass(frozen=True)
class GaitProblem:
    """Minimise the joint work over a family's variables with the ZMP inside the polygon.

    Attributes:
        spec: The robot.
        params: Step time, slope, steps and sampling; its Hz, lift and tilt are ignored,
            and in the extended family its δ, L and w too.
        bounds: The search box (default: ``gait_bounds`` of the family).
        family: "paper" (Hz, Szmax, tilt) or "extended" (and δ, L, w).
        friction: The floor's Coulomb μ: a gait whose friction ratio exceeds it is
            inadmissible (module doc). 1.0 is the bench's default floor.
    """

    spec: RobotSpec
    params: GaitParams
    bounds: Bounds | None = None
    family: str = "paper"
    friction: float = 1.0

    def __post_init__(self) -> None:
        check_family(self.family)
        if not self.friction > 0:
            raise SlopewalkError(f"friction {self.friction!r}: must be > 0 (Coulomb μ)")
        if self.bounds is None:
            object.__setattr__(self, "bounds", gait_bounds(self.spec, self.params, self.family))

    def measure(self, population) -> Measurement:
        """Plan every individual and check the joint limits (one compiled ``plan.score`` call).

        Args:
            population: Rows of the family's variables: (Hz [m], Szmax [m], tilt [rad])
                and, in the extended family, (δ [m], L [m], w [-]); shape (P, 3) or (P, 6).
        """
        X = np.atleast_2d(np.asarray(population, dtype=float))
        width = len(FAMILIES[self.family])
        if X.ndim != 2 or X.shape[1] != width:
            raise SlopewalkError(
                f"population of shape {X.shape}: the {self.family} family has {width} "
                f"variables ({', '.join(FAMILIES[self.family])})"
            )
        loaded = LOADED_FRACTION * self.spec.total_mass * GRAVITY
        work, margin, gap, friction, slide = score(
            self.spec, self.params, X, contact=True, limits=search_limits(self.spec),
            loaded=loaded,
        )  # fmt: skip
        return Measurement(work, margin, gap, friction - self.friction, slide - SLIP_DISTANCE)


def objectives(m: Measurement, constraint: str) -> tuple[np.ndarray, np.ndarray | None]:
    """Objective and constraint arrays of one treatment, all finite.

    "penalty" (the paper, eq. 6): F = w + 10⁴ when the gait is infeasible (ZMP
    outside, or a joint past its limit), G = None; an unreachable individual gets
    F = 2·10⁴ and w is capped at 10⁴ so that no feasible gait scores worse than
    an infeasible one.
    Every treatment with constraints also has G columns friction gap [-] and slide
    gap [m] ≤ 0 (``Measurement``); the penalty counts either past 0 as infeasible.
    "margin": F = w, G = (−min margin [m], joint gap [rad], …) ≤ 0, so the search
    sees how far from feasible an individual is (pymoo sums the positive parts
    into one violation; both are 0 for a feasible gait, so the units only weigh
    infeasible ones against each other); unreachable individuals get w = 2·10⁴
    and G = 1.
    "stability" (the stability envelope's first question): the most stable gait,
    F = −min margin [m], G = (joint gap [rad], …) ≤ 0; unreachable individuals get
    F = 1 m (farther outside than any foot) and G = 1. The work plays no part.

    Returns:
        (F, G): shapes (P,) and (P, 4), (P, 3) or None.
    """
    reachable = np.isfinite(m.work) & np.isfinite(m.margin)
    work = np.where(reachable, np.minimum(m.work, PENALTY), 2 * PENALTY)
    if constraint == "penalty":
        return np.where(reachable, work + PENALTY * ~m.feasible, 2 * PENALTY), None
    if constraint == "margin":
        G = np.column_stack([-m.margin, _admissibility(m)])
        return work, np.where(reachable[:, None], G, INADMISSIBLE_GAP)
    if constraint == "stability":
        F = np.where(reachable, -m.margin, INADMISSIBLE_GAP)
        return F, np.where(reachable[:, None], _admissibility(m), INADMISSIBLE_GAP)
    raise SlopewalkError(f"constraint {constraint!r}: must be one of {', '.join(CONSTRAINTS)}")


def pareto_objectives(m: Measurement) -> tuple[np.ndarray, np.ndarray]:
    """Objectives (work [J], −min margin [m]) and the admissibility constraint of NSGA-II.

    Returns:
        (F, G): shapes (P, 2) and (P, 3); G = (joint gap [rad], friction gap [-], slide
        gap [m]) ≤ 0, 1 if unreachable.
    """
    reachable = np.isfinite(m.work) & np.isfinite(m.margin)
    F = np.column_stack(
        [
            np.where(reachable, np.minimum(m.work, PENALTY), 2 * PENALTY),
            np.where(reachable, -m.margin, INADMISSIBLE_GAP),
        ]
    )
    return F, np.where(reachable[:, None], _admissibility(m), INADMISSIBLE_GAP)


def _admissibility(m: Measurement) -> np.ndarray:
    """(joint gap [rad], friction gap [-], slide gap [m]), shape (P, 3): each ≤ 0 admissible."""
    return np.column_stack([m.joint_gap, m.friction_gap, m.slide_gap])


def joint_limit_excess(spec: RobotSpec, q) -> dict[str, float]:
    """Largest excursion of each joint kind beyond its limit [rad] (0 when within).

    Args:
        q: Joint angles in Table-I order [rad], shape (n, 8).
    """
    q = np.asarray(q, dtype=float)
    out: dict[str, float] = {}
    for i, kind in enumerate(JOINT_KINDS):
        lo, hi = spec.joint_limits[kind]
        excess = float(np.maximum(lo - q[:, i], q[:, i] - hi).max())
        out[kind] = max(out.get(kind, 0.0), excess, 0.0)
    return out
