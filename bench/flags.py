"""The ``slopewalk`` command's flags: types that check ranges while parsing, shared groups.

A number flag is parsed by ``number(range)``/``integer(range)``, which refuse a
value outside the range (NaN and ±inf included) with argparse's one line,
``argument --step-time: inf: must lie in (0, 60] s``. The ranges are
``planner.ranges``'s, the same the dataclasses check through the API.
"""

from __future__ import annotations

import argparse
import math

from slopewalk.bench.actuators import ACTUATOR_MODES, DEFAULT_MODE, MODES
from slopewalk.planner import ranges
from slopewalk.planner.gait import NOMINAL_TILT
from slopewalk.planner.ranges import Range


class Parser(argparse.ArgumentParser):
    """argparse that reports a usage error in one line."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message}\n")


class Formatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the examples' layout and appends each option's default to its help."""

    def _get_help_string(self, action):
        text = action.help or ""
        if (
            "%(default)" in text
            or not action.option_strings
            or action.default in (None, False, argparse.SUPPRESS)
        ):
            return text
        return f"{text} (default: %(default)s)"


DOCS = (
    "Formats: robot spec TOML in docs/robot-spec.md, sweep TOML in docs/sweep-format.md,\n"
    "envelope TOML in docs/envelope-format.md; every flag in the README's 'Command line'\n"
    "section."
)
FINITE = Range(-math.inf, math.inf)
# GaSettings asks >= 2; a generation is evaluated in one batch of about 1.8 MB per
# individual (measured: 130 -> 0.23 GB, 1000 -> 1.8 GB), so 1000 is the most one
# machine should be asked for.
POPULATION = Range(2, 1000, integer=True, low_open=False)
GENERATIONS = Range(1, 100_000, integer=True, low_open=False)
SEED = Range(0, 2**32 - 1, integer=True, low_open=False)
WORKERS = Range(1, 1024, integer=True, low_open=False)
# --cluster: trials submitted at a time, and the longest wait for a worker (docs/cluster.md)
IN_FLIGHT = Range(1, 100_000, integer=True, low_open=False)
JOIN_TIMEOUT = Range(0.0, 86_400.0, "s")
JOIN_TIMEOUT_S = 60.0  # [s] the default: a worker started by hand has joined long before
# slopewalk.bench.sim.trial's MAX_COMMAND_NOISE_DEG (a test keeps them equal)
COMMAND_NOISE_DEG = Range(0.0, 0.5, "deg", low_open=False)
# the plots of `trial --record`: at most every sample of the 1 ms simulation step
RECORD_RATE = Range(0.0, 1000.0, "Hz")
VIDEO_FPS = Range(1.0, 120.0, "fps", low_open=False)
VIDEO_SIDE = Range(16, 4096, integer=True, low_open=False)  # [px], even (yuv420p's halves)


def number(allowed: Range = FINITE):
    """An argparse type: a float inside ``allowed`` (NaN and ±inf never are)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not allowed.contains(value):
            raise argparse.ArgumentTypeError(f"{text}: {allowed.requirement}")
        return value

    return parse


def integer(allowed: Range):
    """An argparse type: an integer inside ``allowed``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if not allowed.contains(value):
            raise argparse.ArgumentTypeError(f"{text}: {allowed.requirement}")
        return value

    return parse


def video_size(text: str) -> tuple[int, int]:
    """An argparse type: ``WIDTHxHEIGHT`` in pixels, each even and inside ``VIDEO_SIDE``."""
    try:
        width, height = (int(side) for side in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not WIDTHxHEIGHT in pixels, e.g. 640x480"
        ) from None
    for side in (width, height):
        if not VIDEO_SIDE.contains(side) or side % 2:
            raise argparse.ArgumentTypeError(
                f"{text}: each side must be an even number of pixels in {VIDEO_SIDE}"
            )
    return width, height


def add_step_time_flag(
    p: argparse.ArgumentParser, *, required: bool = True, default: float | None = None
) -> None:
    p.add_argument(
        "--step-time",
        type=number(ranges.STEP_TIME),
        required=required,
        default=default,
        metavar="S",
        help=f"step completion time t_c [s], in {ranges.STEP_TIME}",
    )


def add_slope_flag(p: argparse.ArgumentParser, *, required: bool = False) -> None:
    p.add_argument(
        "--slope",
        type=number(ranges.SLOPE_DEG),
        required=required,
        default=None if required else 0.0,
        metavar="DEG",
        help=f"plane inclination [deg], in {ranges.SLOPE_DEG}; positive walks uphill",
    )


def add_gait_flags(p: argparse.ArgumentParser, *, step_time_required: bool = True) -> None:
    """The walk's flags (``commands.gait_from_args`` reads them): timing, slope, robot,
    the gait's shape."""
    add_step_time_flag(p, required=step_time_required)
    add_slope_flag(p)
    add_robot_flag(p)
    p.add_argument(
        "--hip-height",
        type=number(),
        metavar="M",
        help="pelvis-centre height above the plane Hz [m], in (0, ankle height + leg] "
        "(default ankle height + 0.757 x (thigh + shank): 0.20 for the paper's biped)",
    )
    p.add_argument(
        "--swing-lift",
        type=number(),
        metavar="M",
        help="peak swing-foot lift Szmax [m], in [0, Hz - ankle height + leg) "
        "(default 0.6 x thigh)",
    )
    p.add_argument(
        "--tilt",
        type=number(ranges.TILT_DEG),
        metavar="DEG",
        help=f"peak frontal lean towards the stance foot [deg], in {ranges.TILT_DEG} "
        f"(default {math.degrees(NOMINAL_TILT):g}, every robot's nominal gait)",
    )
    p.add_argument(
        "--tilt-profile",
        choices=("hold", "sway"),
        default=None,
        help="lean shape: cubic transfer in DSP and hold (default), or sway; the two ends "
        "of --sway-share (hold 0, sway 1)",
    )
    p.add_argument(
        "--sway-share",
        type=number(ranges.SWAY_SHARE),
        metavar="W",
        help=f"lateral-sway timing w, in {ranges.SWAY_SHARE}: the lean's shape is (1 - w) x "
        "hold + w x sway (default: --tilt-profile's, 0 for hold)",
    )
    p.add_argument(
        "--pelvis-offset",
        type=number(),
        default=0.0,
        metavar="M",
        help="sagittal pelvis offset delta [m]: the hip held this far ahead of its spline "
        "(positive forward, uphill on a positive slope), |delta| < thigh + shank (default 0)",
    )
    p.add_argument(
        "--step-length",
        type=number(),
        metavar="M",
        help="swing-foot advance per step L [m], in (0, 2 x (thigh + shank)] (default: the "
        "thigh length)",
    )
    p.add_argument(
        "--steps",
        type=integer(ranges.STEPS),
        default=4,
        metavar="N",
        help=f"number of steps, an integer in {ranges.STEPS}; the walk may have at most "
        f"{ranges.MAX_SAMPLES:.0e} plan samples (steps x step time / 1 ms)",
    )


def add_robot_flag(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--robot",
        metavar="FILE",
        help="robot spec TOML, see docs/robot-spec.md (default: the paper's biped)",
    )


def add_sim_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--friction",
        type=number(ranges.FRICTION),
        default=1.0,
        metavar="MU",
        help=f"Coulomb friction of feet on the plane, in {ranges.FRICTION}",
    )
    p.add_argument(
        "--actuators",
        choices=ACTUATOR_MODES,
        default=DEFAULT_MODE,
        help="; ".join(f"{m.name}: {m.description}" for m in MODES.values()),
    )


def add_batch_flags(
    p: argparse.ArgumentParser, *, out_help: str, resume_help: str, record_help: str
) -> None:
    """The flags of a resumable parallel run (``sweep``, ``envelope``): where it writes,
    on what it runs, whether it resumes, whether it records."""
    p.add_argument("--out", metavar="DIR", help=out_help)
    p.add_argument(
        "--workers",
        type=integer(WORKERS),
        metavar="N",
        help=f"local worker processes, in {WORKERS} (default: all cores); with --cluster "
        "unused: the cluster's workers run the jobs (see --in-flight)",
    )
    p.add_argument(
        "--cluster",
        metavar="ADDRESS",
        help="run on the workers of a Dask scheduler, e.g. tcp://host:8786; every node needs "
        "this slopewalk installed and, for --record, DIR on a shared file system "
        "(docs/cluster.md)",
    )
    p.add_argument(
        "--in-flight",
        type=integer(IN_FLIGHT),
        metavar="N",
        help=f"with --cluster: jobs submitted at a time, in {IN_FLIGHT} (default: 2 per "
        "worker thread connected, followed as workers come and go)",
    )
    p.add_argument(
        "--join-timeout",
        type=number(JOIN_TIMEOUT),
        metavar="S",
        help=f"with --cluster: the longest wait [s] for a worker, at the start or when all "
        f"have left, in {JOIN_TIMEOUT} (default: {JOIN_TIMEOUT_S:g})",
    )
    p.add_argument("--resume", action="store_true", help=resume_help)
    p.add_argument("--record", action="store_true", help=record_help)
