"""``slopewalk regenerate``: every command that writes ``results/``, in the order their
inputs need, each recording what it wrote in ``results/PROVENANCE.json``
(``bench.provenance``).

``STEPS`` is the one list: results/README.md and results/optimize/README.md point at
it, and tests/test_provenance.py checks that the manifest's commands are its commands.
The order: the GA's files first (the claims table reads ``optimize/``), then the
envelopes, then the default sweep (its claims table reads ``envelope/envelope.csv``),
the controllers (they walk the envelope's gaits), the fidelity sweeps and their report,
the single-run reports and the trials. Run from the repository root.
"""

from __future__ import annotations

import fnmatch
import shlex
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from slopewalk.bench import digest, provenance
from slopewalk.planner.errors import SlopewalkError


class RegenerateError(SlopewalkError):
    """Not run from the repository root, or a pattern that selects nothing."""


@dataclass(frozen=True)
class Step:
    """One command of the regeneration, the files it writes, and about how long it takes.

    ``stdout``: the output file its printed summary goes to (the trials' ``.txt``).
    ``manual``: a file written by hand from a command's output; listed, never run.
    ``code``: globs of the source its outputs depend on; its digest is recorded with them
    (``digest.code_digest``) and a test fails when that source changes.
    """

    args: tuple[str, ...]
    outputs: tuple[str, ...]
    minutes: float
    stdout: str | None = None
    manual: bool = False
    code: tuple[str, ...] = ()

    @property
    def command(self) -> str:
        if self.manual:  # args: the words of what is done by hand
            return " ".join(self.args)
        text = " ".join(shlex.quote(a) for a in ("slopewalk", *self.args))
        return f"{text} > {self.stdout}" if self.stdout else text


def _step(command: str, outputs, minutes: float, **kw) -> Step:
    """A step from its command line as the READMEs give it (``slopewalk ...``)."""
    words = shlex.split(command)
    assert words[0] == "slopewalk", command
    return Step(tuple(words[1:]), tuple(outputs), minutes, **kw)


def _optimize_steps() -> list[Step]:
    """results/optimize/README.md's commands, one per file (foot search, penalty vs margin)."""
    opt = "results/optimize"
    steps = []
    for slope in ("22.5", "30"):
        out = f"{opt}/slope{slope}"
        steps += [
            _step(f"slopewalk optimize --slope {slope} --friction 0.5 --pareto --out {out}.json",
                  (f"{out}.json", f"{out}_pareto.csv", f"{out}_pareto.png"), 0.5),
            _step(f"slopewalk optimize --slope {slope} --constraint margin --friction 0.5 "
                  f"--out {out}_margin.json", (f"{out}_margin.json",), 0.2),
        ]  # fmt: skip
    for side in ("toe", "heel"):
        foot, out = f"--foot-length 0.110 --foot-extend {side}", f"{opt}/slope30_foot0.110_{side}"
        steps += [
            _step(f"slopewalk optimize --slope 30 {foot} --out {out}.json", (f"{out}.json",), 0.2),
            _step(f"slopewalk optimize --slope 30 --constraint margin {foot} "
                  f"--out {out}_margin.json", (f"{out}_margin.json",), 0.2),
        ]  # fmt: skip
    for length in ("0.102", "0.104", "0.106", "0.108", "0.109"):
        out = f"{opt}/foot_search/slope30_foot{length}_heel_margin_g150.json"
        command = (f"slopewalk optimize --slope 30 --constraint margin --generations 150 "
                   f"--foot-length {length} --foot-extend heel --out {out}")  # fmt: skip
        steps.append(_step(command, (out,), 0.1))
    out = f"{opt}/foot_search/slope30_foot0.108_heel_margin.json"
    steps.append(_step("slopewalk optimize --slope 30 --constraint margin --foot-length 0.108 "
                       f"--foot-extend heel --out {out}", (out,), 0.2))  # fmt: skip
    for seed in range(5):
        for constraint in ("penalty", "margin"):
            out = f"{opt}/compare/slope22.5_g100_{constraint}_seed{seed}.json"
            steps.append(_step(f"slopewalk optimize --slope 22.5 --generations 100 --seed {seed} "
                               f"--constraint {constraint} --out {out}", (out,), 0.1))  # fmt: skip
    return steps


_REPORT = ("claims.md", "claims.json", "confusion.md", "stability_map.png", "zmp_traces.png",
           "joint_torques.png", "joint_angles.png", "lipm_vs_step_time.png")  # fmt: skip
_ENVELOPE = ("envelope.csv", "envelope.png", "boundaries.md", "convergence.csv", "convergence.md")
_FIDELITY = {"paper": 0.3, "dense": 1, "paper-noise": 1, "dense-noise": 3}  # minutes
# the held-out sets (issue 22), reported apart: random gaits, other robots, every committed
# envelope gait in every mode (629 gaits x 4 modes), CI's set, and the random and GA gaits
# in the servo modes at the ends of the servo's estimated values (8 ends each), and in
# every mode at the ends of the floor contact's (4 ends each), and in the servo modes at the
# ends of the joint damping (2 ends each)
_HELD_OUT = {"random": 1.5, "robots": 1.5, "ga": 6, "ci": 0.2, "random-spec-ends": 5,
             "ga-spec-ends": 17, "ga-noise": 5, "random-contact-ends": 4.5,
             "ga-contact-ends": 16, "random-damping-ends": 1,
             "ga-damping-ends": 5}  # fmt: skip  # minutes on 2 cores
_TRIALS = (("2", "0", "1.0"), ("0.5", "0", "1.0"), ("0.4", "0", "1.0"), ("1", "15", "0.5"),
           ("1", "15", "1.0"), ("1", "30", "0.5"), ("1", "30", "1.0"))  # fmt: skip


# The source a `slopewalk trial` runs (the modules it imports: the planner and the robot
# spec, the simulation, the command and its flags; not the experiments, tables or reports).
TRIAL_CODE = (
    "planner/**/*.py",
    "planner/**/*.toml",
    "bench/__init__.py",
    "bench/actuators.py",
    "bench/cli.py",
    "bench/commands.py",
    "bench/files.py",
    "bench/flags.py",
    "bench/controllers/**/*.py",
    "bench/sim/**/*.py",
)


def _trial(step_time: str, slope: str, friction: str) -> Step:
    stem = f"results/trials/T{step_time}_slope{slope}_mu{friction}"
    command = f"slopewalk trial --step-time {step_time} --slope {slope} --friction {friction}"
    outputs = (f"{stem}.json", f"{stem}.txt")
    return _step(
        f"{command} --out {stem}.json", outputs, 0.1, stdout=f"{stem}.txt", code=TRIAL_CODE
    )


STEPS: tuple[Step, ...] = (
    *_optimize_steps(),
    # the bands before the envelope: its boundaries.md quotes results/envelope/bands.csv
    _step(
        "slopewalk bands --workers 2 --walk contact.timeconst --walk contact.dampratio "
        "--walk servo.damping",
        ("results/envelope/bands.csv", "results/envelope/bands.md"),
        15,
    ),  # fmt: skip
    # the default envelope also rewrites the claims table from the old sweep.csv: the
    # sweep below writes it again, with this envelope
    _step("slopewalk envelope --convergence", (f"results/envelope/{n}" for n in _ENVELOPE), 7),
    _step(
        "slopewalk envelope bench/experiments/envelopes/extended-small.toml "
        "--out results/envelope/extended-small --workers 2 --convergence",
        (f"results/envelope/extended-small/{n}" for n in _ENVELOPE),
        4,
    ),  # fmt: skip
    _step("slopewalk sweep", ("results/sweep.csv", *(f"results/{n}" for n in _REPORT)), 1),
    _step(
        "slopewalk controllers --workers 2 --envelope results/envelope/envelope.csv "
        "--out results/controllers.md",
        ("results/controllers.md",),
        20,  # both families of the default envelope
    ),  # fmt: skip
    *(
        _step(
            f"slopewalk sweep bench/experiments/sweeps/{name}.toml "
            f"--out results/fidelity/{name} --workers 2",
            (f"results/fidelity/{name}/sweep.csv",),
            minutes,
        )  # fmt: skip
        for name, minutes in (_FIDELITY | _HELD_OUT).items()
    ),
    _step(
        "slopewalk fidelity "
        + " ".join(f"results/fidelity/{n}/sweep.csv" for n in _FIDELITY)
        + "".join(f" --held-out results/fidelity/{n}/sweep.csv" for n in _HELD_OUT)
        + " --out results/fidelity.md",
        ("results/fidelity.md",),
        0.2,
    ),  # fmt: skip
    _step("slopewalk cop-error --out results/cop_error.md", ("results/cop_error.md",), 1),
    # an imported model (issue 23): walker.xml's files name it and its map themselves
    _step(
        "slopewalk sweep tests/robots/walker-sweep.toml --out results/robots/walker --workers 2",
        ("results/robots/walker/sweep.csv",),
        0.5,
    ),
    _step(
        "slopewalk envelope tests/robots/walker-envelope.toml --out results/robots/walker/envelope "
        "--workers 2",
        (f"results/robots/walker/envelope/{n}" for n in _ENVELOPE[:3]),
        0.5,
    ),
    _step(
        "slopewalk compare --write-baseline --out results/compare.md",
        ("results/compare_baseline.json", "results/compare.md"),
        0.5,
    ),  # fmt: skip
    *(_trial(*t) for t in _TRIALS),
    Step(
        ("mutmut run --max-children 2, then mutmut results (by hand into the report)",),
        ("results/mutation.md",),
        60,
        manual=True,
    ),  # fmt: skip
)
# Written by hand; the manifest says so and records no content for them.
BY_HAND = ("results/README.md", "results/optimize/README.md")


def command_of(path: str) -> str:
    """The command that writes ``path`` (``provenance.BY_HAND`` for the READMEs)."""
    if path in BY_HAND:
        return provenance.BY_HAND
    for step in STEPS:
        if path in step.outputs:
            return f"{provenance.BY_HAND}: {step.command}" if step.manual else step.command
    raise RegenerateError(f"{path}: no step of 'slopewalk regenerate' writes it")


def select(only: list[str] | None) -> list[Step]:
    """The steps that write a file matching one of ``only`` (glob patterns of paths from
    the repository root), in order; all steps without it."""
    if not only:
        return list(STEPS)
    chosen = [s for s in STEPS if any(fnmatch.fnmatch(o, p) for o in s.outputs for p in only)]
    if not chosen:
        raise RegenerateError(f"--only {' '.join(only)}: no step writes a matching file")
    return chosen


def listing(steps: list[Step]) -> list[str]:
    """One line per step: about how long it takes, its command, and (indented) its files."""
    lines = []
    for step in steps:
        when = "by hand" if step.manual else f"~{step.minutes:g} min"
        lines.append(f"{when:>10}  {step.command}")
        lines.extend(f"{'':>12}-> {o}" for o in step.outputs if o != step.stdout)
    auto = [s for s in steps if not s.manual]
    lines.append(f"{len(auto)} commands, about {sum(s.minutes for s in auto):.0f} min on 2 cores")
    return lines


def run_step(step: Step, root: Path = Path(".")) -> list[str]:
    """Run one step's command with this interpreter, from ``root``, and record its files;
    returns the paths whose manifest entry changed."""
    argv = [sys.executable, "-m", "slopewalk.bench.cli", *step.args]
    if step.stdout:
        with open(root / step.stdout, "w") as out:
            subprocess.run(argv, cwd=root, stdout=out, check=True)
    else:
        subprocess.run(argv, cwd=root, check=True)
    code = digest.code_digest(step.code, root) if step.code else None
    return provenance.record(list(step.outputs), step.command, root, code=code)


def regenerate(args) -> None:
    """The ``regenerate`` command: list, or run, the selected steps in order."""
    steps = select(args.only)
    if args.list:
        print("\n".join(listing(steps)))
        return
    root = Path.cwd()
    if not (root / "results" / "README.md").is_file() or not (root / "pyproject.toml").is_file():
        raise RegenerateError(f"{root}: not the repository root (no results/README.md)")
    for i, step in enumerate(steps, 1):
        if step.manual:
            print(f"[{i}/{len(steps)}] skipped, by hand: {step.command}")
            continue
        print(f"[{i}/{len(steps)}] {step.command}", flush=True)
        start = time.monotonic()
        try:
            changed = run_step(step, root)
        except subprocess.CalledProcessError as err:
            raise RegenerateError(f"'{step.command}' failed with status {err.returncode}") from None
        print(f"  {time.monotonic() - start:.0f} s; provenance updated for {len(changed)} files")


def add_regenerate_parser(sub, command) -> None:
    """The ``regenerate`` subcommand; ``command`` is the CLI's subcommand factory."""
    p = command(
        sub,
        "regenerate",
        "rewrite results/: every command that writes it, in order, with provenance",
        "Run, from the repository root, every command that writes a committed result under "
        "results/, in the order their inputs need (GA, envelopes, sweep, controllers, "
        "fidelity, reports, trials), and record for each file written the command and the "
        "versions of slopewalk, numpy, scipy, numba, mujoco and pymoo in "
        "results/PROVENANCE.json. The whole run takes about "
        f"{sum(s.minutes for s in STEPS if not s.manual) / 60:.1f} hours on 2 cores "
        "(--list: each step's time).",
        "slopewalk regenerate --list",
        "slopewalk regenerate --only 'results/trials/*'",
        "slopewalk regenerate",
    )
    p.add_argument(
        "--only",
        action="append",
        metavar="PATTERN",
        help="only the steps that write a file matching this glob (repeatable), e.g. "
        "'results/optimize/*'",
    )
    p.add_argument(
        "--list", action="store_true", help="print the steps, their files and times; run none"
    )
    p.set_defaults(run=regenerate)
