"""What each ``slopewalk`` subcommand does, given its parsed flags.

Every command checks all of its output paths first, then reads its inputs, then
computes, and writes its outputs together at the end (``bench.files``), so bad
input costs no time and leaves nothing behind. Degrees at the command line,
radians inside.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shlex
import stat
import sys
from typing import TYPE_CHECKING

import numpy as np

from slopewalk.bench.files import atomic_paths, check_output, check_output_dir, in_package
from slopewalk.planner.errors import SlopewalkError

if TYPE_CHECKING:
    from slopewalk.planner.gait import GaitParams
    from slopewalk.planner.spec import RobotSpec


def gait_from_args(args: argparse.Namespace, spec: RobotSpec) -> GaitParams:
    """GaitParams from parsed flags (degrees → radians here)."""
    from slopewalk.planner.gait import GaitParams

    overrides = {
        "slope": np.deg2rad(args.slope),
        "steps": args.steps,
        "tilt_profile": args.tilt_profile,
        "sway_share": args.sway_share,
        "pelvis_offset": args.pelvis_offset,
    }
    if args.step_length is not None:
        overrides["step_length"] = args.step_length
    if args.hip_height is not None:
        overrides["hip_height"] = args.hip_height
    if args.swing_lift is not None:
        overrides["swing_lift"] = args.swing_lift
    if args.tilt is not None:
        overrides["tilt"] = np.deg2rad(args.tilt)
    return GaitParams.nominal(spec, args.step_time, **overrides)


def plan(args: argparse.Namespace) -> None:
    from slopewalk.planner.plan import plan_checked
    from slopewalk.planner.spec import load_spec
    from slopewalk.planner.verdict import predict
    from slopewalk.planner.walk_prediction import (
        TOUCH_ALLOWANCE,
        TOUCH_HEIGHT,
        predict_walk,
        predicted_walk_verdict,
    )

    check_output(args.out)
    _named_npz(args.out, "--out")
    spec = load_spec(args.robot)
    plan, beyond = plan_checked(spec, gait_from_args(args, spec))  # its size, the ground
    with atomic_paths(args.out) as (tmp,), open(tmp, "wb") as f:
        plan.save_npz(f)
    summary = plan.summary()
    p = plan.params
    print(
        f"plan: {spec.name}, {p.steps} steps of {p.step_time:g} s on "
        f"{np.rad2deg(p.slope):g} deg, Hz {p.hip_height:.4f} m, lift {p.swing_lift:.4f} m, "
        f"tilt {np.rad2deg(p.tilt):.2f} deg ({p.lean_profile}, sway share {p.lean_share:g}), "
        f"pelvis offset {p.pelvis_offset:.4f} m, step length {p.step_length:.4f} m, "
        f"{plan.t.size} samples"
    )
    print(
        f"verdict: {summary['verdict']}  (min ZMP margin {summary['min_margin_m'] * 1e3:.2f} mm"
        f" at t = {summary['time_of_min_margin_s']:.3f} s)"
    )
    predicted = predict(plan, friction=np.inf)  # no μ here: slip is judged by `trial`
    print(
        f"predicted: {predicted.verdict}  "
        "(joint limits, foot slide, tip; rigid servos on a rigid floor)"
    )
    for event in predicted.events[:8]:
        print(f"  {event.time:7.3f} s  {event.kind:<12} {event.cause}")
    walk = predict_walk(plan)
    print(
        f"predicted walk: {predicted_walk_verdict(predicted.verdict, walk)}  (servo torque "
        f"peak {walk.torque_ratio:.2f} x stall, Newton-Euler + rotor; swing sole within "
        f"{TOUCH_HEIGHT * 1e3:g} mm of the plane up to {walk.swing_touch:.3f} s of a single "
        f"support, allowance {TOUCH_ALLOWANCE:g} s; docs/verdicts.md)"
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
    print("".join(f"beyond the robot: {note}\n" for note in beyond), end="")
    print(f"wrote {args.out}")


def mjcf(args: argparse.Namespace) -> None:
    from slopewalk.bench.sim.model import scene_xml
    from slopewalk.planner.spec import load_spec

    check_output(args.out)
    spec = load_spec(args.robot)
    xml = scene_xml(
        spec, slope=np.deg2rad(args.slope), friction=args.friction, actuators=args.actuators
    )
    with atomic_paths(args.out) as (tmp,):
        tmp.write_text(xml)
    print(
        f"wrote {args.out}: {spec.name} on {args.slope:g} deg, mu {args.friction:g}, "
        f"{args.actuators} actuators"
    )


def robot_import(args: argparse.Namespace) -> None:
    from slopewalk.bench.robot_import.write import import_robot

    if args.out:
        check_output(args.out)
    text, notes = import_robot(args.model, args.map)
    if not args.out:
        sys.stdout.write(text)
        return
    with atomic_paths(args.out) as (tmp,):
        tmp.write_text(text)
    print(f"wrote {args.out}: the robot spec of {args.model}; approximations:")
    for note in notes:
        print(f"  {note}")


def robot_compare(args: argparse.Namespace) -> None:
    from slopewalk.bench.experiments.model_compare import compare_model, report
    from slopewalk.bench.robot_import.scene import model_scene
    from slopewalk.bench.sim.trial import trial_checked
    from slopewalk.bench.sim.trial_spec import TrialSpec
    from slopewalk.planner.spec import load_spec

    if args.out:
        check_output(args.out)
    spec = load_spec(args.robot) if args.robot is not None else None
    scene = model_scene(args.model, args.map, spec)
    trial = TrialSpec(
        gait_from_args(args, scene.spec), friction=args.friction, actuators=args.actuators
    )
    plan = trial_checked(scene.spec, trial)
    # a mode the model cannot play (its own servos) is refused before any trial runs
    scene.build(plan, friction=trial.friction, actuators=trial.actuators, timestep=trial.timestep)
    rows = compare_model(scene, trial, plan)
    command = "slopewalk " + shlex.join(sys.argv[1:])
    text = report(rows, scene=scene, trial=trial, plan=plan, command=command)
    print(text, end="")
    if args.out:
        with atomic_paths(args.out) as (tmp,):
            tmp.write_text(text)
        print(f"wrote {args.out}")


def trial(args: argparse.Namespace) -> None:
    if args.video is not None:  # offscreen OpenGL, no display needed; read as MuJoCo is imported
        os.environ.setdefault("MUJOCO_GL", "egl")
    from slopewalk.bench.sim.trial import run_trial, trial_checked
    from slopewalk.bench.sim.trial_spec import TrialSpec
    from slopewalk.planner.spec import load_spec

    outputs = {"--out": args.out, "--series": args.series, "--record": args.record}
    outputs |= {"--video": args.video}
    outputs = {flag: path for flag, path in outputs.items() if path is not None}
    _distinct(outputs)
    for flag, path in outputs.items():
        check_output(path, name=flag)
    if args.series is not None:
        _named_npz(args.series, "--series")
    _check_noise_flags(args)
    _check_media_flags(args)
    _check_model_flags(args)
    if args.video is not None:
        render_video = _video_renderer(args)
    if args.record is not None:
        record_trial = _recorder("--record")
    if args.controller is not None:
        from slopewalk.bench.controllers import load_controller

        load_controller(args.controller)  # a bad name is refused before any work
    spec, scene = _trial_robot(args, load_spec)
    trial = TrialSpec(
        gait_from_args(args, spec),
        friction=args.friction,
        actuators=args.actuators,
        controller=args.controller,
        command_noise=float(np.deg2rad(args.command_noise)),
        noise_seed=args.noise_seed or 0,
    )
    plan = trial_checked(spec, trial)  # its size said first; a walk the ground must pull refused
    result = run_trial(spec, trial, plan=plan, scene=scene)
    scalars = result.scalars()
    if scene is not None:  # marked with the model it was played on
        from slopewalk.bench.robot_import.model_file import contents_digest

        scalars["model"] = {"name": scene.name, "path": str(args.model), "map": args.map,
                            "sha256": contents_digest(args.model, args.map)}  # fmt: skip
    with atomic_paths(*outputs.values()) as tmps:
        tmp = dict(zip(outputs, tmps, strict=True))
        tmp["--out"].write_text(json.dumps(scalars, indent=2, allow_nan=False) + "\n")
        if "--series" in tmp:
            with open(tmp["--series"], "wb") as f:
                np.savez_compressed(f, **result.series)
        if "--video" in tmp:
            render_video(tmp["--video"], plan, result, scene=scene)
        if "--record" in tmp:
            record_trial(
                tmp["--record"], plan, result, plot_rate=args.record_rate,
                video=tmp.get("--video"), scene=scene,
            )  # fmt: skip
    print("\n".join(result.summary_lines()))
    print("wrote " + ", ".join(str(p) for p in outputs.values()))


def _trial_robot(args: argparse.Namespace, load_spec):
    """(spec, scene) of ``trial``: the twin of ``--robot`` (scene None), or ``--model``'s
    scene (``robot_import.scene.model_scene``; the spec ``--robot``'s or imported now)."""
    if args.model is None:
        return load_spec(args.robot), None
    from slopewalk.bench.robot_import.scene import model_scene

    spec = load_spec(args.robot) if args.robot is not None else None
    scene = model_scene(args.model, args.map, spec)
    return scene.spec, scene


def _check_model_flags(args: argparse.Namespace) -> None:
    """``--map`` needs ``--model``; what a trial on a model cannot do yet, refused before any
    work (a model plays the plan open loop, its own bodies recorded by ``--record``)."""
    if args.model is None:
        if args.map is not None:
            raise SlopewalkError(f"--map {args.map!r}: only with --model, which is not given")
        return
    if args.controller is not None:
        raise SlopewalkError(
            "--controller with --model: not yet (the closed loop steps the twin's scene "
            "only); a model plays the plan open loop, written as --out, --series, --record "
            "and --video"
        )


def _check_media_flags(args: argparse.Namespace) -> None:
    """``--record-rate`` needs ``--record``; ``--video-fps``/``--video-size`` need ``--video``,
    a file (an mp4 is written, then seeks back: no device) named ``.mp4``."""
    from pathlib import Path

    for flag, value, needs, given in (
        ("--record-rate", args.record_rate, "--record", args.record),
        ("--video-fps", args.video_fps, "--video", args.video),
        ("--video-size", args.video_size, "--video", args.video),
    ):
        if value is not None and given is None:
            shown = "x".join(map(str, value)) if isinstance(value, tuple) else f"{value:g}"
            raise SlopewalkError(f"{flag} {shown}: only with {needs}, which is not given")
    if args.video is None:
        return
    video = Path(args.video)
    if video.exists() and not video.is_file():
        raise SlopewalkError(f"--video {args.video!r}: must be a regular file (an mp4 seeks back)")
    if video.suffix.lower() != ".mp4":
        raise SlopewalkError(
            f"--video {args.video!r}: is written as an MP4 video; give a name ending in .mp4"
        )


def _video_renderer(args: argparse.Namespace):
    """``render_trial_video`` at the flags' rate and size, once PyAV and an OpenGL backend
    are known to work here; else one line saying what to install or set."""
    import functools

    from slopewalk.bench.sim.video import VIDEO_FPS, VIDEO_SIZE, check_video, render_trial_video

    size = args.video_size or VIDEO_SIZE
    try:
        check_video(size)
    except SlopewalkError as err:
        raise SlopewalkError(f"--video: {err}") from None
    return functools.partial(render_trial_video, fps=args.video_fps or VIDEO_FPS, size=size)


def _named_npz(path, flag: str) -> None:
    """A NumPy archive is written only under a name that says so (or to a device such as
    /dev/null): ``plan --out p.json`` would leave an .npz that no JSON reader opens."""
    from pathlib import Path

    name = Path(path)
    if name.suffix.lower() == ".npz" or (name.exists() and stat.S_ISCHR(name.stat().st_mode)):
        return
    raise SlopewalkError(
        f"{flag} {str(path)!r}: is written as a NumPy .npz archive; give a name ending in .npz"
    )


def _check_noise_flags(args: argparse.Namespace) -> None:
    """``--noise-seed`` seeds ``--command-noise``, which only an open-loop trial plays;
    refused in the user's words (flags, degrees) before any work."""
    if args.command_noise and args.controller is not None:
        raise SlopewalkError(
            f"--command-noise {args.command_noise:g} deg with --controller {args.controller}: "
            "the noise is for the plan played open loop; a controller makes its own commands"
        )
    if args.noise_seed is not None and not args.command_noise:
        raise SlopewalkError(
            f"--noise-seed {args.noise_seed}: seeds --command-noise, which is not given (or 0): "
            "there is no noise to seed"
        )


def _recorder(flag: str):
    """``record_trial``, or one line saying why recordings are unavailable."""
    try:
        from slopewalk.bench.sim.recording import record_trial
    except ImportError as err:
        raise SlopewalkError(f"{flag}: recordings are unavailable ({err})") from None
    return record_trial


def _distinct(outputs: dict) -> None:
    """Two outputs may not be the same file (the second would overwrite the first)."""
    seen: dict[str, str] = {}
    for flag, path in outputs.items():
        key = os.path.realpath(path)
        if key in seen:
            raise SlopewalkError(f"{flag} {str(path)!r}: is the same file as {seen[key]}")
        seen[key] = flag


def optimize(args: argparse.Namespace) -> None:
    from slopewalk.bench.experiments.ga.case import (
        optimize_case,
        pareto_csv,
        pareto_paths,
        pareto_title,
        summary_lines,
    )
    from slopewalk.bench.experiments.ga.search import GaSettings, pareto_figure
    from slopewalk.planner.spec import load_spec

    outputs = [args.out, *(pareto_paths(args.out) if args.pareto else ())]
    check_output(args.out)
    for path in outputs[1:]:
        check_output(path, name="--pareto output")
    settings = GaSettings(
        population=args.population,
        generations=args.generations,
        seed=args.seed,
        constraint=args.constraint,
    )
    spec = load_spec(args.robot)
    if args.foot_length is not None:
        allowed = spec.foot_length_range(args.foot_extend)
        if not allowed.contains(args.foot_length):
            raise SlopewalkError(
                f"--foot-length {args.foot_length:g} m: {allowed.requirement} with "
                f"--foot-extend {args.foot_extend} (the ankle must stay over the foot)"
            )
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
    with atomic_paths(*outputs) as tmps:
        if case.front is not None:
            csv_path, png_path = outputs[1:]
            tmps[1].write_text(pareto_csv(case.front))
            figure = pareto_figure(case.front, pareto_title(case.report))
            figure.savefig(tmps[2], format="png", dpi=120)
            case.report["pareto"].update(csv=csv_path.name, png=png_path.name)
        tmps[0].write_text(json.dumps(case.report, indent=2) + "\n")
    print("\n".join(summary_lines(case.report)))
    print("wrote " + ", ".join(str(p) for p in outputs))


def fidelity(args: argparse.Namespace) -> None:
    from slopewalk.bench.report.fidelity import fidelity_report, read_tables

    check_output(args.out)
    held_out = args.held_out or []
    command = (
        "slopewalk fidelity "
        + " ".join(args.tables)
        + "".join(f" --held-out {t}" for t in held_out)
        + f" --out {args.out}"
    )
    text = fidelity_report(
        read_tables(args.tables), command=command, held_out=read_tables(held_out)
    )
    with atomic_paths(args.out) as (tmp,):
        tmp.write_text(text)
    print(f"wrote {args.out}")


def cop_error(args: argparse.Namespace) -> None:
    from slopewalk.bench.experiments.cop_error.report import cop_error_report
    from slopewalk.planner.spec import load_spec

    check_output(args.out)
    text = cop_error_report(load_spec(), command=f"slopewalk cop-error --out {args.out}")
    with atomic_paths(args.out) as (tmp,):
        tmp.write_text(text)
    print(f"wrote {args.out}")


def compare(args: argparse.Namespace) -> None:
    from slopewalk.bench.experiments import compare as comparison
    from slopewalk.planner.spec import load_spec

    outputs = {"--out": args.out}
    if args.write_baseline:
        outputs["--baseline"] = args.baseline
    _distinct(outputs)
    for flag, path in outputs.items():
        check_output(path, name=flag)
    # A missing, empty or malformed baseline is refused before the five trials run.
    baseline = None if args.write_baseline else comparison.load_baseline(args.baseline)
    rows = comparison.run_comparison(load_spec())
    problems = comparison.check(rows, baseline)
    text = comparison.report(rows, baseline, problems)
    with atomic_paths(*outputs.values()) as tmps:
        tmps[0].write_text(text)
        if args.write_baseline:
            tmps[1].write_text(json.dumps(rows, indent=2) + "\n")
    print(text, end="")
    if args.write_baseline:
        print(f"wrote the new baseline {args.baseline}")
    if problems:
        raise SystemExit(1)


# a local batch's workers are forked from a server that imports the job's module and a
# trial's kernel entries (``executor.KERNEL_PRELOAD``) once; started first, it imports
# beside this process
_SWEEP_SERVER = "slopewalk.bench.experiments.sweep.run"
_ENVELOPE_SERVER = "slopewalk.bench.experiments.envelope.run"


def _start_workers_server(args: argparse.Namespace, module: str) -> None:
    """Start the fork server of a local batch's workers now (``executor.start_server``)."""
    if args.cluster is None:
        from slopewalk.bench.batch.executor import KERNEL_PRELOAD, start_server

        start_server((module, KERNEL_PRELOAD))


def sweep(args: argparse.Namespace) -> None:
    _start_workers_server(args, _SWEEP_SERVER)
    from pathlib import Path

    from slopewalk.bench.experiments.sweep.config import SweepError, load_sweep
    from slopewalk.bench.experiments.sweep.run import run_sweep

    model = _batch_model(args, SweepError)
    config = load_sweep(args.config, model=model)  # the whole file is checked before anything runs
    _batch_on_model(args, config.model, SweepError)
    out, resume = _batch_start(args, Path.cwd() / "results", SweepError)
    report = args.config is None or args.report  # the claims and figures after the trials
    with _batch_executor(args) as executor:
        summary = run_sweep(
            config,
            out,
            workers=args.workers,
            executor=executor,
            resume=resume,
            record=args.record,
            progress=sys.stderr.isatty(),
            report_robots=len(config.robots) if report else 0,
        )
    print("\n".join(summary.lines()))
    if summary.lost:
        raise SweepError(f"{len(summary.lost)} trials lost with their workers; add --resume")
    if report:
        envelope = out / "envelope" / "envelope.csv"
        _write_claims(out, summary.table, envelope if envelope.exists() else None, config)


def _batch_model(args: argparse.Namespace, error: type[SlopewalkError]):
    """``--model`` (with ``--map``) of ``sweep`` and ``envelope`` as a ``ModelFile``: its
    paths made absolute and its files' digest taken, for every job and worker; None."""
    from slopewalk.bench.robot_import.mapfile import RobotImportError
    from slopewalk.bench.robot_import.model_file import ModelFile

    if args.model is None:
        if args.map is not None:
            raise error(f"--map {args.map!r}: only with --model, which is not given")
        return None
    try:
        return ModelFile.of(args.model, args.map)
    except RobotImportError as err:
        raise error(f"--model: {err}") from None


def _batch_on_model(args: argparse.Namespace, model, error: type[SlopewalkError]) -> None:
    """Refuse what a run on a model (``--model`` or the file's ``model`` key) cannot do."""
    if model is None:
        return
    if args.report:
        raise error(f"--report with a model ({model.name}): the claims and figures are the "
                    "paper's biped's")  # fmt: skip


def _batch_start(args: argparse.Namespace, default_out, error: type[SlopewalkError]):
    """What ``sweep`` and ``envelope`` check before any job runs: ``--record`` can
    record, the output folder can be written. Returns (out, resume): ``resume`` is
    True with ``--resume``, None (resume an unfinished run found there) when ``--out``
    names the folder, False (a fresh run) for the default folder."""
    from pathlib import Path

    if args.cluster is None:
        for flag, value in (("--in-flight", args.in_flight), ("--join-timeout", args.join_timeout)):
            if value is not None:
                raise error(f"{flag} {value:g}: only with --cluster")
    if args.record:
        try:
            import slopewalk.bench.sim.recording  # noqa: F401
        except ImportError as err:
            raise error(f"--record: recordings are unavailable ({err})") from None
    out = Path(args.out) if args.out is not None else default_out
    check_output_dir(out)
    return out, True if args.resume else None if args.out is not None else False


@contextlib.contextmanager
def _batch_executor(args: argparse.Namespace):
    """The Dask cluster of ``--cluster`` (None: local workers) for a resumable run;
    SIGINT or SIGTERM of the run exits with 128 + the signal, its message on stderr."""
    from slopewalk.bench.batch.cluster import open_cluster
    from slopewalk.bench.batch.run import Stopped
    from slopewalk.bench.flags import JOIN_TIMEOUT_S

    cluster = (
        open_cluster(
            args.cluster,
            in_flight=args.in_flight,
            join_timeout=JOIN_TIMEOUT_S if args.join_timeout is None else args.join_timeout,
        )
        if args.cluster
        else contextlib.nullcontext()
    )
    try:
        with cluster as executor:
            yield executor
    except Stopped as stop:
        print(f"slopewalk: {stop.message}", file=sys.stderr)
        raise SystemExit(128 + stop.signum) from None


def _write_claims(results, sweep_table, envelope_table, config=None) -> None:
    """Write the claims table, confusion table and figures into ``results`` from the
    sweep's table, with the envelope's claims when ``envelope_table`` is not None.

    ``config``: the sweep file the table came from (its robots' specs; the report's
    header names it unless it is the default sweep); None: the default sweep. The
    GA's results are read from ``results/optimize/`` and the envelope from
    ``results/envelope/``, beside the report, never from elsewhere: a report of a run
    outside the repository says which of them it did not find there."""
    from pathlib import Path

    from slopewalk.bench.experiments.claim_trials import claim_trials, play_ga_best
    from slopewalk.bench.experiments.sweep.config import DEFAULT_SWEEP, load_sweep
    from slopewalk.bench.report.claims import DEFAULT_ROBOT, ga_claims, robots, write_report
    from slopewalk.bench.tables.table import read_table
    from slopewalk.planner.spec import load_spec

    rows = read_table(sweep_table)
    if config is None and robots(rows) != [DEFAULT_ROBOT]:
        print(f"claims not rewritten: {sweep_table} holds robots of a sweep file not named "
              "here; run 'slopewalk sweep FILE --report' again")  # fmt: skip
        return
    config = config or load_sweep()
    specs, trials = {}, {}
    for name in robots(rows):
        path = None if name == DEFAULT_ROBOT else Path(config.source).parent / name
        specs[name] = load_spec(path)
        played = [r for r in rows if r["robot"] == name and r["simulated_verdict"] != "error"]
        trials[name] = claim_trials(specs[name], played)
    envelope = envelope_table and (read_table(envelope_table), envelope_table.relative_to(results))
    ga = ga_claims(results / "optimize", specs[DEFAULT_ROBOT], play_ga_best) if (
        DEFAULT_ROBOT in specs) else []  # fmt: skip
    written = write_report(
        results, rows, specs, trials, ga, envelope=envelope,
        source=None if Path(config.source).resolve() == DEFAULT_SWEEP.resolve() else config.source,
    )  # fmt: skip
    print("wrote " + ", ".join(str(p.name) for p in written))


def controllers(args: argparse.Namespace) -> None:
    from slopewalk.bench.controllers import SHIPPED, ControllerError, load_controller
    from slopewalk.bench.experiments.controller_comparison import compare_controllers, report
    from slopewalk.bench.experiments.sweep.config import DEFAULT_SWEEP, load_sweep

    check_output(args.out)
    names = tuple(args.controller or SHIPPED)
    for name in names:
        load_controller(name)  # a bad name is refused before any trial runs
    if args.min_step_time is not None and args.envelope is None:
        raise ControllerError("--min-step-time: only with --envelope")
    envelope = _envelope_gaits(args) if args.envelope else None  # checked before any trial
    config = load_sweep(args.config)
    if config.model is not None:
        raise ControllerError(
            f"{config.source}: names the model {config.model.name}: the controllers step the "
            "twin's scene only (a model plays the plan open loop); give a sweep file without model"
        )
    if config.noisy:
        raise ControllerError(
            f"{config.source}: command_noise = {config.command_noise_deg:g} deg: the "
            "controllers make their own commands; give a sweep file without command_noise"
        )
    if config.spec_ends:
        raise ControllerError(
            f"{config.source}: spec_ends = {list(config.spec_ends)!r}: the controllers' table "
            "has no spec_end column; give a sweep file without spec_ends"
        )
    table = compare_controllers(config, names, workers=args.workers)
    source = args.config or in_package(DEFAULT_SWEEP)
    command = " ".join(
        ["slopewalk controllers", *([args.config] if args.config else [])]
        + [f"--controller {name}" for name in args.controller or ()]
        + ([f"--envelope {args.envelope}"] if args.envelope else [])
        + ([f"--min-step-time {args.min_step_time:g}"] if args.min_step_time else [])
        + [f"--out {args.out}"]
    )
    text = report(table, source=source, command=command)
    if envelope is not None:
        from slopewalk.bench.experiments.envelope.controllers import (
            compare_envelope,
            envelope_report,
        )

        jobs = envelope()
        verdicts = compare_envelope(jobs, names, workers=args.workers)
        subset = f" of step time >= {args.min_step_time:g} s" if args.min_step_time else ""
        text += "\n" + envelope_report(jobs, verdicts, names, source=args.envelope, subset=subset)
    with atomic_paths(args.out) as (tmp,):
        tmp.write_text(text)
    print(text, end="")
    print(f"wrote {args.out}")


def _envelope_gaits(args: argparse.Namespace):
    """The ``--envelope`` file checked now; a callable that returns its gait jobs."""
    from pathlib import Path

    from slopewalk.bench.experiments.envelope import controllers as ec

    path, low = Path(args.envelope), args.min_step_time or 0.0
    if path.suffix == ".toml":
        from slopewalk.bench.experiments.envelope.config import load_envelope

        config = load_envelope(path)
        if config.model is not None:
            raise ec.EnvelopeTableError(
                f"--envelope {args.envelope}: names the model {config.model.name}: the "
                "controllers step the twin's scene only (a model plays the plan open loop)"
            )
        return lambda: ec.config_jobs(config, workers=args.workers, min_step_time=low)
    jobs = ec.table_jobs(path, min_step_time=low)
    if not jobs:
        raise ec.EnvelopeTableError(f"{path}: no played gait at step time >= {low:g} s")
    return lambda: jobs


def envelope(args: argparse.Namespace) -> None:
    _start_workers_server(args, _ENVELOPE_SERVER)
    from pathlib import Path

    from slopewalk.bench.experiments.envelope.config import EnvelopeError, load_envelope
    from slopewalk.bench.experiments.envelope.run import (
        run_convergence,
        run_envelope,
        write_convergence,
    )
    from slopewalk.bench.report.envelope_claims import write_envelope_documents

    model = _batch_model(args, EnvelopeError)
    config = load_envelope(args.config, model=model)  # checked whole before anything runs
    _batch_on_model(args, config.model, EnvelopeError)
    out, resume = _batch_start(args, Path.cwd() / "results" / "envelope", EnvelopeError)
    progress = sys.stderr.isatty()
    with _batch_executor(args) as executor:
        summary = run_envelope(
            config,
            out,
            workers=args.workers,
            executor=executor,
            resume=resume,
            record=args.record,
            progress=progress,
        )
        print("\n".join(summary.lines()))
        if summary.lost:
            raise EnvelopeError(f"{len(summary.lost)} cells lost with their workers; add --resume")
        write_envelope_documents(summary.table, out, config.source)
        if args.convergence:
            check = run_convergence(
                config, summary.table, out, workers=args.workers, executor=executor,
                resume=resume, progress=progress,
            )  # fmt: skip
            print("\n".join(check.lines()))
            print(f"wrote {write_convergence(check, config, out)}")
    if args.config is None or args.report:
        _envelope_report(out, summary.table)


def bands(args: argparse.Namespace) -> None:
    """``slopewalk bands``: the envelope's boundaries under the spec's unknowns."""
    import time
    from pathlib import Path

    from slopewalk.bench.experiments.envelope.bands import (
        CONVERGENCE_FACTOR,
        converge_boundaries,
        play_boundaries,
        run_bands,
    )
    from slopewalk.bench.experiments.envelope.config import EnvelopeError, load_envelope
    from slopewalk.bench.files import check_output_dir
    from slopewalk.bench.report import bands as report
    from slopewalk.planner.spec import default_spec_path, load_spec
    from slopewalk.planner.uncertainty import load_uncertainty

    config = load_envelope(args.config)
    spec = load_spec(args.robot)
    uncertain = load_uncertainty(args.robot)
    robot = args.robot or "planner/robots/bioloid.toml"
    if not uncertain:
        path = args.robot or default_spec_path()
        raise EnvelopeError(f"robot spec {str(path)!r}: no [uncertain] table to take bands over")
    walk = tuple(args.walk or ())
    known = [u.key for u in uncertain]
    for key in walk:
        if key not in known:
            raise EnvelopeError(
                f"--walk {key}: not a value of the [uncertain] table of {robot} "
                f"(known: {', '.join(known)})"
            )
    out = check_output_dir(args.out or Path.cwd() / "results" / "envelope")
    out.mkdir(parents=True, exist_ok=True)
    rows, wall_s = run_bands(config, spec, uncertain, workers=args.workers)
    start = time.perf_counter()
    played = play_boundaries(config, spec, report.picks(rows, walk), workers=args.workers)
    checked = converge_boundaries(config, spec, report.picks(rows), workers=args.workers)
    wall_s += time.perf_counter() - start
    workers = args.workers or os.cpu_count() or 1
    report.write_csv(rows, out / report.CSV_NAME)
    text = report.markdown(rows, source=config.source, robot=robot, spec=spec,
                           search=config.search, wall_s=wall_s, workers=workers,
                           played=played, checked=checked,
                           factor=CONVERGENCE_FACTOR)  # fmt: skip
    report.write_markdown(text, out / report.MD_NAME)
    print("\n".join(report.band_lines(rows)))
    print(f"wrote {out / report.CSV_NAME} and {out / report.MD_NAME} in {wall_s:.0f} s")


def _envelope_report(out, table) -> None:
    """Rewrite the claims table of the sweep beside ``out`` with the envelope's claims."""
    results = out.parent
    if not (results / "sweep.csv").exists():
        print(f"claims not rewritten: no {results / 'sweep.csv'} (run 'slopewalk sweep' first)")
        return
    _write_claims(results, results / "sweep.csv", table)


def benchmark(args: argparse.Namespace) -> None:
    from slopewalk.bench.experiments import benchmark as benchmarks

    for name, value in benchmarks.run(args.what).items():
        print(f"{name}: {value:.6g}" if isinstance(value, float) else f"{name}: {value}")
