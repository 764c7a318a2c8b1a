"""The ``slopewalk`` command: the only place that reads flags and files.

One builder per subcommand (``_plan_parser``, ..., listed in ``COMMANDS``) says
what it does, with examples; ``build_parser`` puts them together. The flags, the
groups several commands share (gait, simulation, batch) and their range checks
are in ``bench.flags``, what the commands do in ``bench.commands``.
Every refusal is one line on stderr with exit status 2 and no traceback; output
files appear only whole. Ctrl-C ends any command with ``slopewalk: interrupted``
and status 130; a closed output pipe (``slopewalk ... | head -3``) stops it
quietly with status 141, as SIGPIPE stops a Unix filter (``_output_closed``).
"""

from __future__ import annotations

import argparse
import gc
import os
import select
import signal
import sys
import textwrap

from slopewalk.bench import commands
from slopewalk.bench.flags import (
    COMMAND_NOISE_DEG,
    DOCS,
    GENERATIONS,
    POPULATION,
    RECORD_RATE,
    SEED,
    VIDEO_FPS,
    WORKERS,
    Formatter,
    Parser,
    add_batch_flags,
    add_gait_flags,
    add_robot_flag,
    add_sim_flags,
    add_slope_flag,
    add_step_time_flag,
    integer,
    number,
    video_size,
)
from slopewalk.bench.regenerate import add_regenerate_parser
from slopewalk.planner import ranges
from slopewalk.planner.errors import SlopewalkError


def _command(sub, name: str, summary: str, description: str, *examples: str):
    """A subcommand whose help says what it does, with examples and where the formats are."""
    epilog = "examples:\n" + "\n".join(f"  {e}" for e in examples) + "\n\n" + DOCS
    return sub.add_parser(
        name,
        help=summary,
        description=textwrap.fill(description, 79),
        epilog=epilog,
        formatter_class=Formatter,
    )


def _plan_parser(sub) -> None:
    p = _command(
        sub,
        "plan",
        "plan a walk analytically and write its time series",
        "Plan a walk on the analytic side only (no simulation): cubic-spline task "
        "trajectories, inverse kinematics, Newton-Euler torques, the multibody and LIPM "
        "ZMP and the support polygon; print the verdict and write every series to .npz.",
        "slopewalk plan --step-time 1 --slope 10 --out plan.npz",
        "slopewalk plan --step-time 0.5 --hip-height 0.19 --tilt 8 --robot my.toml --out p.npz",
    )
    add_gait_flags(p)
    p.add_argument(
        "--out", required=True, metavar="FILE", help="output .npz (the name must end in .npz)"
    )
    p.set_defaults(run=commands.plan)


def _mjcf_parser(sub) -> None:
    p = _command(
        sub,
        "mjcf",
        "write a self-contained MuJoCo scene of the robot",
        "Write the MJCF scene built from the robot spec: the biped with its position "
        "actuators standing on the tilted plane. Open it with "
        "`python -m mujoco.viewer --mjcf scene.xml`.",
        "slopewalk mjcf --slope 12 --friction 0.6 --out scene.xml",
        "slopewalk mjcf --actuators servo --robot my.toml --out servo.xml",
    )
    add_slope_flag(p)
    add_sim_flags(p)
    add_robot_flag(p)
    p.add_argument("--out", required=True, metavar="FILE", help="output scene .xml")
    p.set_defaults(run=commands.mjcf)


def _robot_parser(sub) -> None:
    p = _command(
        sub,
        "robot",
        "import an MJCF or URDF humanoid as a robot spec; compare it with its twin",
        "Bring your own robot (docs/importing-robots.md). `robot import MODEL` compiles "
        "the MJCF or URDF with MuJoCo, finds both legs' hip pitch, knee, ankle pitch and "
        "ankle roll, checks that they fit the planner (or refuses in one line naming the "
        "joint and the misfit) and writes a robot spec with a report of every approximation. "
        "`robot compare MODEL` plays one plan on the spec's twin and on the unmodified model "
        "(held joints as actuated and welded, its own contact options and the twin's), side "
        "by side.",
        "slopewalk robot import humanoid.xml --out humanoid.toml",
        "slopewalk robot import robot.urdf --map robot-map.toml --out robot.toml",
        "slopewalk robot compare robot.urdf --map robot-map.toml --step-time 3 --tilt 9 "
        "--steps 2 --out compare.md",
    )
    actions = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    imp = actions.add_parser("import", help="write the robot spec of an MJCF or URDF model")
    imp.add_argument("model", metavar="MODEL", help="the robot's MJCF (.xml) or URDF (.urdf)")
    imp.add_argument("--map", metavar="MAP.toml", help="names what detection cannot decide")
    imp.add_argument("--out", metavar="SPEC.toml", help="output spec (default: stdout)")
    imp.set_defaults(run=commands.robot_import)
    cmp = actions.add_parser(
        "compare",
        help="play one plan on the twin and on the unmodified model, side by side",
        description="Plan on the imported spec (--robot's, default: imported now) and play "
        "the plan open loop on the twin, on the unmodified model, on the model with its held "
        "joints welded, with the twin's contact options, and with both: a markdown table "
        "of CoP-ZMP RMS, pelvis RMS, footprints and verdicts (docs/importing-robots.md).",
    )
    cmp.add_argument("model", metavar="MODEL", help="the robot's MJCF (.xml) or URDF (.urdf)")
    cmp.add_argument("--map", metavar="MAP.toml", help="names what detection cannot decide")
    add_gait_flags(cmp)
    add_sim_flags(cmp)
    cmp.set_defaults(actuators="servo_ff")  # a model plays on its own servos
    cmp.add_argument("--out", metavar="REPORT.md", help="also write the report here")
    cmp.set_defaults(run=commands.robot_compare)


def _model_flags(p, batch: str = "") -> None:
    """``--model`` and ``--map``: of ``trial``, or of a batch command (``batch``: what it
    plays, "trial" or "gait"), whose file's ``robot`` key then names the spec."""
    spec = (
        "--robot: its spec from `slopewalk robot import`, default: imported now"
        if not batch
        else "the file's robot key: its spec from `slopewalk robot import`, default: imported "
        "now; replaces the file's model and map keys"
    )
    p.add_argument(
        "--model",
        metavar="MODEL",
        help=f"play {'every ' + batch if batch else 'the plan'} on this unmodified MJCF/URDF "
        f"robot instead of the spec's twin (open loop, servo or servo_ff; {spec}; "
        "docs/importing-robots.md)",
    )
    p.add_argument("--map", metavar="MAP.toml", help="--model's map file (only with --model)")


def _trial_parser(sub) -> None:
    p = _command(
        sub,
        "trial",
        "plan a walk, play it in MuJoCo, compare the ZMPs",
        "Plan a walk, play its joint angles open loop through position actuators on the "
        "tilted plane (or let --controller command them, closed loop), and compare the "
        "analytic ZMP with the simulated contact CoP: both verdicts, RMS and max distance, "
        "slip/tip/fall/torque-limit events. Writes the scalars as JSON (null where a value "
        "does not exist; the summary says why).",
        "slopewalk trial --step-time 1 --slope 15 --out trial.json",
        "slopewalk trial --step-time 0.5 --friction 0.4 --actuators servo --out t.json \\\n"
        "      --series t.npz --record t.rrd",
        "slopewalk trial --step-time 1 --slope 10 --out t.json --record t.rrd --video t.mp4",
        "slopewalk trial --step-time 0.6 --controller "
        "slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback --out t.json",
        "slopewalk trial --step-time 1 --slope 20 --command-noise 1e-4 --noise-seed 3 --out t.json",
    )
    add_gait_flags(p)
    add_sim_flags(p)
    _model_flags(p)
    p.add_argument(
        "--command-noise",
        type=number(COMMAND_NOISE_DEG),
        default=0.0,
        metavar="DEG",
        help=f"σ of white noise on every command row [deg], in {COMMAND_NOISE_DEG}: does the "
        "verdict hang on the simulation's last bits? (open loop only; docs/sweep-format.md)",
    )
    p.add_argument(
        "--noise-seed",
        type=integer(SEED),
        metavar="N",
        help=f"the seed of --command-noise (only with it), in {SEED} (default: 0)",
    )
    p.add_argument("--out", required=True, metavar="FILE", help="output .json (scalars, events)")
    p.add_argument(
        "--series", metavar="FILE", help="also write the time series (a name ending in .npz)"
    )
    p.add_argument(
        "--record",
        metavar="FILE",
        help="also write a rerun recording (.rrd; open it with `rerun FILE`): the robot on its "
        "slope, support polygon, ZMP and CoP, contact forces, joint angles and torques, "
        "margins, events, laid out by its own blueprint (docs/recordings.md)",
    )
    p.add_argument(
        "--record-rate",
        type=number(RECORD_RATE),
        metavar="HZ",
        help=f"sample rate of the recording's plots, in {RECORD_RATE} (only with --record; "
        "default: every 1 ms sample, about 1 MB per simulated second; 100 Hz: a third of it)",
    )
    p.add_argument(
        "--video",
        metavar="FILE",
        help="also render an .mp4 of the trial offscreen (a camera following the pelvis, ZMP "
        "and CoP markers; needs PyAV, pip install 'slopewalk[video]', and an OpenGL backend: "
        "MUJOCO_GL=egl by default; about 0.2 s a frame at 640x480); embedded in --record's file",
    )
    p.add_argument(
        "--video-fps",
        type=number(VIDEO_FPS),
        metavar="FPS",
        help=f"frames per second of --video, in {VIDEO_FPS} (default: 30)",
    )
    p.add_argument(
        "--video-size",
        type=video_size,
        metavar="WxH",
        help="frame size of --video in pixels, even sides in [16, 4096] (default: 640x480)",
    )
    p.add_argument(
        "--controller",
        metavar="MODULE:CALLABLE",
        help="close the loop: call this function (observation dict, see bench/sim/observation.py, "
        "-> actuator command) once per simulation step instead of playing the plan open loop, "
        "e.g. slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback (default: open loop)",
    )
    p.set_defaults(run=commands.trial)


def _optimize_parser(sub) -> None:
    p = _command(
        sub,
        "optimize",
        "GA-optimise Hz, swing lift and tilt on a slope (sec. VI)",
        "Run the paper's genetic algorithm (sec. VI): tune the hip height, the swing lift "
        "and the peak tilt to minimise the joint work with the ZMP inside the support "
        "polygon, for one slope and step time. Same seed, same result.",
        "slopewalk optimize --slope 22.5 --out best.json",
        "slopewalk optimize --slope 30 --generations 50 --pareto --out best30.json",
        "slopewalk optimize --slope 15 --foot-length 0.12 --foot-extend toe --out long.json",
    )
    add_slope_flag(p, required=True)
    add_step_time_flag(p, required=False, default=1.0)
    p.add_argument(
        "--friction",
        type=number(ranges.FRICTION),
        metavar="MU",
        help=f"friction coefficient of the plane, in {ranges.FRICTION}: report whether the "
        "best gait needs more (default: not checked)",
    )
    p.add_argument(
        "--population",
        type=integer(POPULATION),
        default=130,
        metavar="N",
        help=f"individuals per generation, in {POPULATION}",
    )
    p.add_argument(
        "--generations",
        type=integer(GENERATIONS),
        default=500,
        metavar="N",
        help=f"generations, in {GENERATIONS}",
    )
    p.add_argument(
        "--seed", type=integer(SEED), default=0, metavar="N", help=f"random seed, in {SEED}"
    )
    p.add_argument(
        "--constraint",
        choices=("penalty", "margin"),
        default="penalty",
        help="penalty: O = work + 1e4 if the ZMP leaves the polygon (paper); "
        "margin: -min margin <= 0 as a constraint",
    )
    p.add_argument(
        "--pareto",
        action="store_true",
        help="also run NSGA-II over (work, -margin); writes <out>_pareto.csv/.png",
    )
    add_robot_flag(p)
    p.add_argument(
        "--foot-length",
        type=number(),
        metavar="M",
        help="toe-to-heel foot length [m]; the ankle must stay over the foot (default: the spec's)",
    )
    p.add_argument(
        "--foot-extend",
        choices=("toe", "heel", "both"),
        default="toe",
        help="where --foot-length adds or removes length",
    )
    p.add_argument("--out", required=True, metavar="FILE", help="output best-gait .json")
    p.set_defaults(run=commands.optimize)


def _compare_parser(sub) -> None:
    p = _command(
        sub,
        "compare",
        "analytic vs simulated ZMP on fixed cases, vs a baseline",
        "Play five fixed cases (flat at 2, 0.5 and 0.4 s; 15 and 22.5 deg at 1 s) and fail "
        "(exit 1) if a verdict flips or the analytic-vs-simulated ZMP RMS grows beyond "
        "1 mm + 10 % of the committed baseline. A missing or empty baseline is an error; "
        "make one with --write-baseline.",
        "slopewalk compare",
        "slopewalk compare --write-baseline --baseline results/compare_baseline.json",
    )
    p.add_argument(
        "--baseline",
        default="results/compare_baseline.json",
        metavar="FILE",
        help="baseline JSON to check against (or to write with --write-baseline)",
    )
    p.add_argument("--out", default="compare.md", metavar="FILE", help="markdown report")
    p.add_argument(
        "--write-baseline",
        action="store_true",
        help="store this run as the new baseline instead of checking",
    )
    p.set_defaults(run=commands.compare)


def _sweep_parser(sub) -> None:
    p = _command(
        sub,
        "sweep",
        "run a sweep file's trials in parallel into DIR/sweep.csv (resumable)",
        "Run every trial of a sweep file (format: docs/sweep-format.md), on the local cores "
        "or a Dask cluster, one CSV row per finished trial, appended to DIR/sweep.partial.csv "
        "as it ends; when all are done the rows go to DIR/sweep.csv in the file's order. A "
        "plain run plays every trial. If a run is stopped (Ctrl-C, kill), the same command "
        "with --resume plays only the trials not yet done; with --out DIR naming a directory "
        "that holds an unfinished run, it resumes without the flag. Without CONFIG, the "
        "paper's sweep, then the claims table and figures.",
        "slopewalk sweep",
        "slopewalk sweep --resume          # finish a killed 'slopewalk sweep'",
        "slopewalk sweep my_sweep.toml --out runs/slopes --workers 4 --record",
        "slopewalk sweep my_sweep.toml --cluster tcp://scheduler:8786 --report",
        "slopewalk sweep walker.toml --model walker.xml --map walker-map.toml --out runs/walker",
    )
    p.add_argument(
        "config",
        nargs="?",
        metavar="CONFIG",
        help="sweep TOML (default: bench/experiments/sweeps/paper.toml, the paper's sweep)",
    )
    add_batch_flags(
        p,
        out_help="output directory: sweep.csv, recordings/ (default: ./results, the "
        "repository's results/ when run from its root)",
        resume_help="count the trials already in DIR (an unfinished run, or a finished "
        "sweep.csv) as done and play the rest",
        record_help="also write DIR/recordings/<trial_id>.rrd per trial (rerun)",
    )
    _model_flags(p, "trial")
    p.add_argument(
        "--report",
        action="store_true",
        help="write claims.md, confusion.md and the figures for a custom CONFIG too (always "
        "for the default sweep)",
    )
    p.set_defaults(run=commands.sweep)


def _controllers_parser(sub) -> None:
    p = _command(
        sub,
        "controllers",
        "open loop vs the shipped controllers over a sweep: which trials walk",
        "Play every trial of a sweep file open loop and with each shipped closed-loop "
        "controller (bench/controllers/), and write the markdown table of how many walk "
        "(simulated verdict stable), which each controller gains and loses, and every verdict. "
        "With --envelope, a second table does the same over a stability envelope's gaits: "
        "those of a finished envelope.csv (re-planned from its parameters, no GA run again) "
        "or of an envelope TOML (every cell's GA run again).",
        "slopewalk controllers --workers 2 --envelope results/envelope/envelope.csv "
        "--out results/controllers.md",
        "slopewalk controllers my_sweep.toml --out controllers.md",
    )
    p.add_argument(
        "config",
        nargs="?",
        metavar="CONFIG",
        help="sweep TOML (default: bench/experiments/sweeps/paper.toml)",
    )
    p.add_argument(
        "--controller",
        action="append",
        metavar="MODULE:CALLABLE",
        help="compare this controller (repeatable; default: the shipped ones)",
    )
    p.add_argument(
        "--workers",
        type=integer(WORKERS),
        default=1,
        metavar="N",
        help=f"local worker processes, in {WORKERS}",
    )
    p.add_argument(
        "--envelope",
        metavar="TABLE_OR_TOML",
        help="also compare over an envelope's gaits: its envelope.csv, or an envelope TOML "
        "(docs/envelope-format.md)",
    )
    p.add_argument(
        "--min-step-time",
        type=number(ranges.STEP_TIME),
        metavar="S",
        help="with --envelope: only the cells of step time >= S [s] (default: every cell)",
    )
    p.add_argument("--out", required=True, metavar="FILE", help="output markdown table")
    p.set_defaults(run=commands.controllers)


def _fidelity_parser(sub) -> None:
    p = _command(
        sub,
        "fidelity",
        "agreement of each analytic verdict with the simulated one, from sweep tables",
        "Read sweep tables (DIR/sweep.csv of `slopewalk sweep`) and write a markdown report: "
        "how often the paper's verdict, the compliance-aware one and the predicted one (the "
        "most severe predicted event) agree with the simulated verdict, both confusion "
        "tables, and every disagreement of the predicted verdict with its measured causes; "
        "per set and actuator mode with a 95% Wilson interval. Tables given with --held-out "
        "(gaits or robots the predictor was never designed on) are reported apart.",
        "slopewalk fidelity runs/paper/sweep.csv runs/dense/sweep.csv --out results/fidelity.md",
        "slopewalk fidelity runs/dense/sweep.csv --held-out runs/random/sweep.csv --out f.md",
    )
    p.add_argument("tables", nargs="+", metavar="TABLE", help="development sweep.csv files")
    p.add_argument(
        "--held-out",
        action="append",
        metavar="TABLE",
        help="a held-out sweep.csv (repeatable), reported apart from the development tables",
    )
    p.add_argument("--out", required=True, metavar="FILE", help="markdown report")
    p.set_defaults(run=commands.fidelity)


def _cop_error_parser(sub) -> None:
    p = _command(
        sub,
        "cop-error",
        "the flat slow walk's simulated CoP vs analytic ZMP, taken apart by phase and cause",
        "Play flat ground at 2 s steps (the default robot, mu 1) in the stiff modes, with and "
        "without the floor's give and sink fed forward, and with stiffer contacts and finer "
        "time steps, and write a markdown report of the CoP - ZMP distance by phase window, "
        "the touch-down timing and speed, the unplanned support, the servo's sag, the plan's "
        "ZMP jumps at phase changes and the double support's foot slide.",
        "slopewalk cop-error --out results/cop_error.md",
    )
    p.add_argument("--out", required=True, metavar="FILE", help="markdown report")
    p.set_defaults(run=commands.cop_error)


def _envelope_parser(sub) -> None:
    p = _command(
        sub,
        "envelope",
        "the best gait of every step time x slope cell, by the GA, walked in MuJoCo (resumable)",
        "For every cell of an envelope file (step time x slope x friction x robot; format in "
        "docs/envelope-format.md), the GA finds the gait of largest minimum ZMP "
        "margin and the least-work gait whose margin is at least the required margin; each "
        "is re-planned at 1 ms and played in MuJoCo in every actuator mode. One row per cell "
        "and gait family goes to DIR/envelope.partial.csv as it ends, DIR/envelope.csv and "
        "DIR/envelope.png when all are done. Stopped runs resume as for 'slopewalk sweep'. "
        "Without CONFIG, the paper's envelope into ./results/envelope, then the claims table "
        "(with results/sweep.csv).",
        "slopewalk envelope",
        "slopewalk envelope --resume            # finish a killed 'slopewalk envelope'",
        "slopewalk envelope my.toml --out runs/env --workers 4 --record",
        "slopewalk envelope --convergence       # also re-search 10 % of the cells at 4x budget",
        "slopewalk envelope w.toml --model walker.xml --map walker-map.toml --out runs/walker",
    )
    p.add_argument(
        "config",
        nargs="?",
        metavar="CONFIG",
        help="envelope TOML, format in docs/envelope-format.md (default: "
        "bench/experiments/envelopes/paper.toml)",
    )
    add_batch_flags(
        p,
        out_help="output directory: envelope.csv, envelope.png, recordings/ (default: "
        "./results/envelope)",
        resume_help="count the cells already in DIR as done and run the rest",
        record_help="also write DIR/recordings/<cell_id>.rrd per cell (the max-margin gait, "
        "first mode)",
    )
    _model_flags(p, "gait")
    p.add_argument(
        "--convergence",
        action="store_true",
        help="then re-search a seeded 10 %% of the cells with 4x the generations; "
        "DIR/convergence.md says how many verdicts and how much margin change",
    )
    p.add_argument(
        "--report",
        action="store_true",
        help="rewrite the claims table beside DIR (needs DIR/../sweep.csv) for a custom CONFIG "
        "too (always for the default envelope)",
    )
    p.set_defaults(run=commands.envelope)


def _bands_parser(sub) -> None:
    p = _command(
        sub,
        "bands",
        "the envelope's boundaries with each estimated robot value at either end of its range",
        "For each boundary of the envelope (per gait family: the fastest flat step time with "
        "a gait inside, the steepest uphill and downhill slope inside at 1 s steps), search it "
        "again with the envelope's GA, once with the robot spec as it is and then with one "
        "value of its [uncertain] table (docs/robot-spec.md) at a time set to the low and "
        "the high end of its range; write DIR/bands.csv and DIR/bands.md: the boundary at "
        "low / nominal / high per value, the band (min-max) per boundary and the value that "
        "moves it most (analytic boundaries); then MuJoCo walks the boundary gaits of the "
        "nominal spec and of the value that moves each boundary most, and of each value "
        "--walk names, at both ends, in every actuator mode.",
        "slopewalk bands --workers 2",
        "slopewalk bands --walk contact.timeconst --walk contact.dampratio",
        "slopewalk bands my_envelope.toml --robot my.toml --out runs/bands",
    )
    p.add_argument(
        "config",
        nargs="?",
        metavar="CONFIG",
        help="envelope TOML whose grid and GA settings are used (default: "
        "bench/experiments/envelopes/paper.toml)",
    )
    p.add_argument("--out", metavar="DIR", help="output directory (default: ./results/envelope)")
    p.add_argument(
        "--workers",
        type=integer(WORKERS),
        metavar="N",
        help=f"local worker processes, in {WORKERS} (default: all cores)",
    )
    p.add_argument(
        "--walk",
        action="append",
        metavar="KEY",
        help="also walk each boundary's gait in MuJoCo with this [uncertain] value at either "
        "end (repeatable): for a value the analytic boundaries do not see, like the floor's "
        "contact.timeconst",
    )
    add_robot_flag(p)
    p.set_defaults(run=commands.bands)


def _benchmark_parser(sub) -> None:
    p = _command(
        sub,
        "benchmark",
        "print speed figures as name: value lines",
        "Measure how fast a part of the bench runs and print one 'name: value' line per "
        "figure (no thresholds: speed goals are read, never asserted). docs/benchmark.md "
        "says what each name is and its unit (e.g. sim's and controller's 'ratio': the share "
        "of the faster way's steps per second that the slower one keeps).",
        "slopewalk benchmark planner",
        "slopewalk benchmark sim",
        "slopewalk benchmark controller   # closed-loop vs rollout steps/s, same trial",
    )
    p.add_argument(
        "what",
        choices=("planner", "sim", "ga", "sweep", "controller", "envelope"),
        help="what to measure: the compiled planner, one MuJoCo trial, the paper's GA, "
        "the default sweep, closed vs open loop, the default envelope (docs/benchmark.md)",
    )
    p.set_defaults(run=commands.benchmark)


COMMANDS = (  # one builder per subcommand, in the order `slopewalk --help` lists them
    _plan_parser,
    _mjcf_parser,
    _trial_parser,
    _optimize_parser,
    _compare_parser,
    _sweep_parser,
    _controllers_parser,
    _robot_parser,
    _fidelity_parser,
    _cop_error_parser,
    _envelope_parser,
    _bands_parser,
    _benchmark_parser,
    lambda sub: add_regenerate_parser(sub, _command),
)


def build_parser() -> argparse.ArgumentParser:
    """The `slopewalk` parser: its own help, then one subparser per ``COMMANDS`` entry."""
    parser = Parser(
        prog="slopewalk",
        description=textwrap.fill(
            "Does the analytic balance prediction of a biped walking on a slope "
            "(ZMP, Newton-Euler) hold up in MuJoCo? Plan walks, play them, compare, sweep.",
            79,
        ),
        epilog="examples:\n"
        "  slopewalk plan --step-time 1 --slope 10 --out plan.npz\n"
        "  slopewalk trial --step-time 1 --slope 15 --out trial.json --record trial.rrd\n"
        "  slopewalk sweep                 # the paper's sweep into ./results\n"
        "  slopewalk COMMAND --help        # a command's flags, ranges and defaults\n\n" + DOCS,
        formatter_class=Formatter,
    )
    sub = parser.add_subparsers(
        dest="command", required=True, parser_class=Parser, metavar="COMMAND"
    )
    for add in COMMANDS:
        add(sub)
    return parser


# The kernel entries (planner/kernel/cache.py) each command compiles on first use.
_TRIAL = ("plan", "predictors")
COMPILES = {
    "plan": ("plan",),
    "trial": _TRIAL,
    "sweep": _TRIAL,
    "controllers": _TRIAL,
    "compare": _TRIAL,
    "cop_error": _TRIAL,
    "optimize": ("scores", "plan"),
    "envelope": ("scores", *_TRIAL),
    "bands": ("scores", "plan"),
}


def command() -> None:
    """The ``slopewalk`` console script (and ``python -m slopewalk``): ``main``, then exit.

    The interpreter's last garbage collection at exit walks every object the command
    made, numba's and LLVM's compiled kernel included: measured on the 2-core
    development VM, a warm ``slopewalk plan`` ends 0.52–0.57 s after ``main`` returns,
    0.05–0.06 s with them frozen first (``gc.freeze``: the cyclic collector ignores
    them from then on; atexit handlers and stream flushes run as before). Only for the
    process's own command: ``main`` called in-process (the tests) leaves the collector
    as it is.
    """
    code = main()
    gc.freeze()
    sys.exit(code)


def main(argv: list[str] | None = None) -> int:
    """Run the ``slopewalk`` command; returns the exit status (2 for refused input, 130
    for Ctrl-C, 141 when its output pipe was closed: ``_output_closed``)."""
    argv = sys.argv[1:] if argv is None else argv
    finished = False
    try:
        try:
            code = _main(argv)
            finished = True
            return code
        finally:  # output to a pipe is buffered: meet a closed one here, not at the exit
            sys.stdout.flush()
            sys.stderr.flush()
    except BrokenPipeError:  # the last lines, a refusal's or the help's found no reader
        if not _output_gone():
            raise
        return _output_closed(argv, stopped=not finished)


def _main(argv: list[str]) -> int:
    parser = build_parser()
    if not argv:
        parser.print_help(sys.stderr)
        return 2
    args = parser.parse_args(argv)
    entries = COMPILES.get(args.run.__name__)
    if entries:  # the kernel's first-use line sums what the command compiles
        from slopewalk.planner.kernel import cache

        cache.expect(*entries)
    try:
        args.run(args)
    except SlopewalkError as err:
        print(f"slopewalk: error: {' '.join(str(err).split())}", file=sys.stderr)
        return 2
    except OSError as err:  # a file that vanished or a device that refused, mid-way
        if isinstance(err, BrokenPipeError) and _output_gone():  # not a pipe of our own
            return _output_closed(argv, stopped=True)
        where = f"{err.filename!r}: " if err.filename else ""
        print(f"slopewalk: error: {where}{err.strerror or err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("slopewalk: interrupted", file=sys.stderr)
        return 130
    except SystemError as err:
        if not _interrupted(err):
            raise
        print("slopewalk: interrupted", file=sys.stderr)
        return 130
    return 0


OUTPUT_CLOSED = 128 + signal.SIGPIPE  # 141: what a shell reports for a writer that SIGPIPE ended


def _output_gone() -> bool:
    """Whether the reader of stdout or stderr has gone (``slopewalk ... | head -3``)."""
    return any(_reader_gone(stream) for stream in (sys.stdout, sys.stderr))


def _reader_gone(stream) -> bool:
    try:
        poll = select.poll()
        poll.register(stream.fileno(), select.POLLOUT)
        return any(event & (select.POLLERR | select.POLLHUP) for _, event in poll.poll(0))
    except (OSError, ValueError, AttributeError):  # closed, replaced or no descriptor
        return False


def _output_closed(argv: list[str], *, stopped: bool) -> int:
    """Stop quietly when the reader of our output has gone, as SIGPIPE stops a Unix filter,
    with the status a shell gives such a filter (141), never a traceback or exit 1.

    The command stops where the write failed (``stopped``; False: it had finished and only
    its last lines were lost); its output files are whole or absent (``bench.files``),
    and a stopped sweep or envelope keeps its finished rows for ``--resume``, as after
    Ctrl-C. A stream without a reader is pointed at /dev/null, so nothing more is
    written to it (nor complained of at exit); while stderr still has a reader (only
    stdout was piped), a stopped sweep or envelope says how to finish in one line.
    """
    devnull = os.open(os.devnull, os.O_WRONLY)
    gone = [stream for stream in (sys.stdout, sys.stderr) if _reader_gone(stream)]
    for stream in gone:
        os.dup2(devnull, stream.fileno())
    os.close(devnull)
    if stopped and sys.stderr not in gone and argv and argv[0] in ("sweep", "envelope"):
        print(
            f"slopewalk: stopped: stdout was closed (broken pipe); the finished rows are kept: "
            f"'slopewalk {argv[0]} ... --resume' finishes the run",
            file=sys.stderr,
        )
    return OUTPUT_CLOSED


def _interrupted(err: BaseException) -> bool:
    """A Ctrl-C that compiled code turned into another error: numba's ``SystemError``
    ("returned a result with an exception set") raised from the ``KeyboardInterrupt``
    that struck inside its callback (``batch.executor.held_interrupts`` says where)."""
    seen: set[int] = set()
    cause: BaseException | None = err
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return True
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return False


if __name__ == "__main__":
    sys.exit(main())
