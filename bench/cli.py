"""The ``slopewalk`` command: the only place that reads flags and files.

Degrees at the command line, radians inside. Every refusal is one line on
stderr with a non-zero exit and no traceback; output files appear only whole.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from planner.errors import SlopewalkError


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error in one line."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message}\n")


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None


def _add_gait_flags(p: argparse.ArgumentParser, *, step_time_required: bool = True) -> None:
    p.add_argument(
        "--step-time",
        type=_number,
        required=step_time_required,
        metavar="S",
        help="step completion time t_c [s], > 0",
    )
    p.add_argument(
        "--slope",
        type=_number,
        default=0.0,
        metavar="DEG",
        help="plane inclination [deg], in (-60, 60); positive walks uphill",
    )
    p.add_argument("--robot", metavar="FILE", help="robot spec TOML (default: the paper's biped)")
    p.add_argument(
        "--hip-height",
        type=_number,
        metavar="M",
        help="pelvis-centre height above the plane Hz [m] "
        "(default ankle height + 0.757 x (thigh + shank): 0.20 for the paper's biped)",
    )
    p.add_argument(
        "--swing-lift",
        type=_number,
        metavar="M",
        help="peak swing-foot lift Szmax [m] (default 0.6 x thigh)",
    )
    p.add_argument(
        "--tilt",
        type=_number,
        metavar="DEG",
        help="peak frontal lean towards the stance foot [deg]",
    )
    p.add_argument(
        "--tilt-profile",
        choices=("hold", "sway"),
        default="hold",
        help="lean shape: cubic transfer in DSP and hold (default), or sway",
    )
    p.add_argument("--steps", type=int, default=4, metavar="N", help="number of steps (4)")


def _add_sim_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--friction",
        type=_number,
        default=1.0,
        metavar="MU",
        help="Coulomb friction of feet on the plane, > 0 (1.0)",
    )
    p.add_argument(
        "--actuators",
        default="stiff",
        metavar="MODE",
        help="stiff (tracks the plan closely) or servo (AX-12A-like)",
    )


def gait_from_args(args, spec):
    """GaitParams from parsed flags (degrees → radians here)."""
    from planner.trajectory import GaitParams

    overrides = {
        "slope": np.deg2rad(args.slope),
        "steps": args.steps,
        "tilt_profile": args.tilt_profile,
    }
    if args.hip_height is not None:
        overrides["hip_height"] = args.hip_height
    if args.swing_lift is not None:
        overrides["swing_lift"] = args.swing_lift
    if args.tilt is not None:
        overrides["tilt"] = np.deg2rad(args.tilt)
    return GaitParams.nominal(spec, args.step_time, **overrides)


def _cmd_plan(args) -> None:
    from bench.files import atomic_path
    from planner.plan import plan_walk
    from planner.spec import load_spec

    spec = load_spec(args.robot)
    plan = plan_walk(spec, gait_from_args(args, spec))
    with atomic_path(args.out) as tmp, open(tmp, "wb") as f:
        plan.save_npz(f)
    summary = plan.summary()
    p = plan.params
    print(
        f"plan: {spec.name}, {p.steps} steps of {p.step_time:g} s on "
        f"{np.rad2deg(p.slope):g} deg, Hz {p.hip_height:.4f} m, lift {p.swing_lift:.4f} m, "
        f"tilt {np.rad2deg(p.tilt):.2f} deg ({p.tilt_profile}), {plan.t.size} samples"
    )
    print(
        f"verdict: {summary['verdict']}  (min ZMP margin {summary['min_margin_m'] * 1e3:.2f} mm"
        f" at t = {summary['time_of_min_margin_s']:.3f} s)"
    )
    print(
        f"work: {summary['work_J']:.4f} J   max friction ratio: "
        f"{summary['max_friction_ratio']:.3f}   max |ZMP - LIPM|: "
        f"{summary['max_lipm_distance_m'] * 1e3:.2f} mm"
    )
    print(
        "peak torque [N m]: "
        + ", ".join(f"{k} {v:.3f}" for k, v in summary["peak_torque_Nm"].items())
    )
    print(f"wrote {args.out}")


def _cmd_mjcf(args) -> None:
    from bench.files import atomic_path
    from bench.sim.model import scene_xml
    from planner.spec import load_spec

    spec = load_spec(args.robot)
    xml = scene_xml(
        spec, slope=np.deg2rad(args.slope), friction=args.friction, actuators=args.actuators
    )
    with atomic_path(args.out) as tmp:
        tmp.write_text(xml)
    print(
        f"wrote {args.out}: {spec.name} on {args.slope:g} deg, mu {args.friction:g}, "
        f"{args.actuators} actuators"
    )


def _cmd_trial(args) -> None:
    from bench.files import atomic_path
    from bench.sim.trial import TrialSpec, run_trial
    from planner.spec import load_spec

    spec = load_spec(args.robot)
    trial = TrialSpec(gait_from_args(args, spec), friction=args.friction, actuators=args.actuators)
    result = run_trial(spec, trial)
    with atomic_path(args.out) as tmp:
        tmp.write_text(json.dumps(result.scalars(), indent=2))
    if args.series:
        with atomic_path(args.series) as tmp, open(tmp, "wb") as f:
            np.savez_compressed(f, **result.series)
    print("\n".join(result.summary_lines()))
    print(f"wrote {args.out}" + (f" and {args.series}" if args.series else ""))


def _cmd_optimize(args) -> None:
    from bench.experiments.ga import GaSettings, pareto_figure
    from bench.experiments.ga_case import (
        optimize_case,
        pareto_csv,
        pareto_paths,
        pareto_title,
        summary_lines,
    )
    from bench.files import atomic_path
    from planner.spec import load_spec

    settings = GaSettings(
        population=args.population,
        generations=args.generations,
        seed=args.seed,
        constraint=args.constraint,
    )
    spec = load_spec(args.robot)
    if args.foot_length is not None:
        if not args.foot_length > 0:
            raise SlopewalkError(f"foot length {args.foot_length!r} m: must be > 0")
        spec = spec.with_foot_length(args.foot_length, extend=args.foot_extend)
    case = optimize_case(
        spec,
        slope=np.deg2rad(args.slope),
        step_time=args.step_time,
        settings=settings,
        friction=args.friction,
        pareto=args.pareto,
        progress=sys.stderr.isatty(),
    )
    written = [str(args.out)]
    if case.front is not None:
        csv_path, png_path = pareto_paths(args.out)
        with atomic_path(csv_path) as tmp:
            tmp.write_text(pareto_csv(case.front))
        with atomic_path(png_path) as tmp:
            pareto_figure(case.front, pareto_title(case.report)).savefig(tmp, format="png", dpi=120)
        case.report["pareto"].update(csv=csv_path.name, png=png_path.name)
        written += [str(csv_path), str(png_path)]
    with atomic_path(args.out) as tmp:
        tmp.write_text(json.dumps(case.report, indent=2) + "\n")
    print("\n".join(summary_lines(case.report)))
    print("wrote " + ", ".join(written))


def _cmd_compare(args) -> None:
    from bench.experiments import compare
    from bench.files import atomic_path
    from planner.spec import load_spec

    rows = compare.run_comparison(load_spec())
    baseline = None if args.write_baseline else compare.load_baseline(args.baseline)
    problems = compare.check(rows, baseline)
    text = compare.report(rows, baseline, problems)
    with atomic_path(args.out) as tmp:
        tmp.write_text(text)
    if args.write_baseline:
        with atomic_path(args.baseline) as tmp:
            tmp.write_text(json.dumps(rows, indent=2) + "\n")
    print(text, end="")
    if baseline is None and not args.write_baseline:
        print(f"(no baseline at {args.baseline}: nothing to compare against)")
    if problems:
        raise SystemExit(1)


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value}: must be >= 1")
    return value


def _cmd_sweep(args) -> None:
    from pathlib import Path

    from bench.experiments.sweep import open_executor, run_sweep
    from bench.experiments.sweep_config import SweepError, load_sweep

    config = load_sweep(args.config)  # the whole file is checked before anything runs
    if args.record:
        try:
            import bench.report.recording  # noqa: F401
        except ImportError as err:
            raise SweepError(f"--record: recordings are unavailable ({err})") from None
    out = Path(args.out) if args.out is not None else Path.cwd() / "results"
    with open_executor(workers=args.workers, cluster=args.cluster) as executor:
        summary = run_sweep(
            config, out, executor=executor, record=args.record, progress=sys.stderr.isatty()
        )
    print("\n".join(summary.lines()))
    if summary.lost:
        raise SweepError(f"{len(summary.lost)} trials lost with their workers; re-run to resume")
    if args.config is None or args.report:
        from bench.experiments.sweep_table import read_table
        from bench.report.claims import ga_claims, write_report
        from planner.spec import load_spec

        spec = load_spec()
        written = write_report(
            out, read_table(summary.table), spec, ga_claims(out / "optimize", spec)
        )
        print("wrote " + ", ".join(str(p.name) for p in written))


def _cmd_benchmark(args) -> None:
    from bench.experiments import benchmark

    for name, value in benchmark.run(args.what).items():
        print(f"{name}: {value:.6g}" if isinstance(value, float) else f"{name}: {value}")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="slopewalk", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("plan", help="plan a walk analytically and write its time series")
    _add_gait_flags(p)
    p.add_argument("--out", required=True, metavar="FILE", help="output .npz")
    p.set_defaults(run=_cmd_plan)

    p = sub.add_parser("mjcf", help="write a self-contained MuJoCo scene of the robot")
    p.add_argument(
        "--slope",
        type=_number,
        default=0.0,
        metavar="DEG",
        help="plane inclination [deg], in (-60, 60)",
    )
    _add_sim_flags(p)
    p.add_argument("--robot", metavar="FILE", help="robot spec TOML (default: the paper's biped)")
    p.add_argument("--out", required=True, metavar="FILE", help="output scene .xml")
    p.set_defaults(run=_cmd_mjcf)

    p = sub.add_parser("trial", help="plan a walk, play it in MuJoCo, compare the ZMPs")
    _add_gait_flags(p)
    _add_sim_flags(p)
    p.add_argument("--out", required=True, metavar="FILE", help="output .json (scalars, events)")
    p.add_argument("--series", metavar="FILE", help="also write the time series (.npz)")
    p.set_defaults(run=_cmd_trial)

    p = sub.add_parser("optimize", help="GA-optimise Hz, swing lift and tilt on a slope (sec. VI)")
    p.add_argument(
        "--slope",
        type=_number,
        required=True,
        metavar="DEG",
        help="plane inclination [deg], in (-60, 60); positive walks uphill",
    )
    p.add_argument(
        "--step-time",
        type=_number,
        default=1.0,
        metavar="S",
        help="step completion time t_c [s], > 0 (1.0)",
    )
    p.add_argument(
        "--friction",
        type=_number,
        metavar="MU",
        help="friction coefficient of the plane, > 0: report whether the best gait needs more",
    )
    p.add_argument(
        "--population",
        type=int,
        default=130,
        metavar="N",
        help="individuals per generation, >= 2 (130)",
    )
    p.add_argument(
        "--generations", type=int, default=500, metavar="N", help="generations, >= 1 (500)"
    )
    p.add_argument("--seed", type=int, default=0, metavar="N", help="random seed, >= 0 (0)")
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
    p.add_argument("--robot", metavar="FILE", help="robot spec TOML (default: the paper's biped)")
    p.add_argument(
        "--foot-length",
        type=_number,
        metavar="M",
        help="toe-to-heel foot length [m] (default: the spec's)",
    )
    p.add_argument(
        "--foot-extend",
        choices=("toe", "heel", "both"),
        default="toe",
        help="where --foot-length adds or removes length (toe)",
    )
    p.add_argument("--out", required=True, metavar="FILE", help="output best-gait .json")
    p.set_defaults(run=_cmd_optimize)

    p = sub.add_parser("compare", help="analytic vs simulated ZMP on fixed cases, vs a baseline")
    p.add_argument(
        "--baseline",
        default="results/compare_baseline.json",
        metavar="FILE",
        help="baseline JSON (default results/compare_baseline.json)",
    )
    p.add_argument("--out", default="compare.md", metavar="FILE", help="markdown report")
    p.add_argument(
        "--write-baseline",
        action="store_true",
        help="store this run as the new baseline instead of checking",
    )
    p.set_defaults(run=_cmd_compare)

    p = sub.add_parser(
        "sweep",
        help="run a sweep file's trials in parallel into DIR/sweep.csv (resumable)",
        description="Run every trial of a sweep file (bench/experiments/sweep_config.py has "
        "the format), "
        "one CSV row per finished trial; re-running skips the finished ones.",
    )
    p.add_argument(
        "config",
        nargs="?",
        metavar="CONFIG",
        help="sweep TOML (default: bench/experiments/sweeps/paper.toml, the paper's sweep)",
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        help="output directory: sweep.csv, recordings/ (default: ./results, the "
        "repository's results/ when run from its root)",
    )
    p.add_argument(
        "--workers",
        type=_positive_int,
        metavar="N",
        help="local worker processes (default: all cores); ignored with --cluster",
    )
    p.add_argument(
        "--cluster",
        metavar="ADDRESS",
        help="run on a Dask distributed scheduler, e.g. tcp://host:8786 (workers need "
        "slopewalk installed)",
    )
    p.add_argument(
        "--record",
        action="store_true",
        help="also write DIR/recordings/<trial_id>.rrd per trial (rerun)",
    )
    p.add_argument(
        "--report",
        action="store_true",
        help="write claims.md, confusion.md and the figures for a custom CONFIG too (always "
        "for the default sweep)",
    )
    p.set_defaults(run=_cmd_sweep)

    p = sub.add_parser("benchmark", help="print speed figures as name: value lines")
    p.add_argument("what", choices=("planner", "sim", "ga", "sweep"), help="what to measure")
    p.set_defaults(run=_cmd_benchmark)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        args.run(args)
    except SlopewalkError as err:
        print(f"slopewalk: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("slopewalk: interrupted", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
