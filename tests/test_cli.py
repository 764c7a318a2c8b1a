"""The command line as a user meets it: one-line refusals, whole output files."""

import fcntl
import json
import os
import pty
import select
import signal
import struct
import subprocess
import sys
import termios
import time

import numpy as np
import pytest

REQUIRED = (
    "t",
    "q",
    "qd",
    "qdd",
    "tau",
    "zmp",
    "zmp_lipm",
    "cop_ne",
    "com",
    "stance",
    "margin",
    "meta",
)


def _run(*args):
    return subprocess.run(
        [sys.executable, "-m", "slopewalk.bench.cli", *args],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_plan_writes_the_series(tmp_path):
    out = tmp_path / "plan.npz"
    result = _run("plan", "--step-time", "1", "--slope", "10", "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert "verdict:" in result.stdout
    data = np.load(out)
    for key in REQUIRED:
        assert key in data.files, key
    n = data["t"].size
    assert data["q"].shape == (n, 8) and data["tau"].shape == (n, 8)
    assert data["zmp"].shape == (n, 2) and data["com"].shape == (n, 3)
    meta = json.loads(str(data["meta"]))
    assert meta["params"]["slope"] == pytest.approx(np.deg2rad(10))
    assert meta["spec"]["thigh"] == 0.111
    # the values are those of the plan the flags describe (degrees at the edge only)
    from slopewalk.planner.gait import GaitParams
    from slopewalk.planner.plan import plan_walk
    from slopewalk.planner.spec import load_spec

    spec = load_spec()
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, slope=np.deg2rad(10.0)))
    for key in ("t", "q", "qd", "tau", "zmp", "zmp_lipm", "cop_ne", "com", "stance", "margin"):
        np.testing.assert_allclose(data[key], getattr(plan, key), rtol=0, atol=1e-12, err_msg=key)
    np.testing.assert_array_equal(data["q_left_right"], plan.q_left_right)
    assert meta["summary"]["min_margin_m"] == pytest.approx(plan.margin.min(), abs=1e-12)
    assert f"verdict: {'stable' if plan.stable else 'zmp_outside'} " in result.stdout
    assert f"min ZMP margin {plan.margin.min() * 1e3:.2f} mm" in result.stdout


def test_planner_never_imports_mujoco():
    code = (
        "import sys; sys.modules['mujoco'] = None; import slopewalk, slopewalk.planner.plan, "
        "slopewalk.planner.spec, slopewalk.planner.zmp, slopewalk.planner.ik, "
        "slopewalk.planner.trajectory, slopewalk.planner.newton_euler; slopewalk.plan_walk"
    )
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


def test_plan_reports_a_knee_beyond_its_limit(tmp_path):
    """The paper's ZMP test alone would say 'stable'; the predicted verdict names the joint."""
    from slopewalk.planner.spec import default_spec_path

    robot = tmp_path / "low_knee.toml"
    text = default_spec_path().read_text()
    assert "knee = [-0.10, 2.60]" in text
    robot.write_text(text.replace("knee = [-0.10, 2.60]", "knee = [-0.10, 1.20]"))
    run = _run("plan", "--step-time", "1", "--robot", str(robot), "--out", str(tmp_path / "p.npz"))
    assert run.returncode == 0, run.stderr
    assert "verdict: stable" in run.stdout
    assert "predicted: joint_limit" in run.stdout
    assert "swing_knee leaves its limits [-0.1, 1.2] rad (knee), up to" in run.stdout
    default = _run("plan", "--step-time", "1", "--out", str(tmp_path / "q.npz"))
    assert "predicted: stable" in default.stdout


def _until(fd: int, marker: bytes | None, timeout: float) -> bytes:
    """What a pty's reader gets until ``marker`` (None: until every writer is gone)."""
    seen, deadline = b"", time.monotonic() + timeout
    while marker is None or marker not in seen:
        left = deadline - time.monotonic()
        if left <= 0 or not select.select([fd], [], [], left)[0]:
            raise AssertionError(f"no {marker!r} within {timeout} s: {seen[-2000:]!r}")
        try:
            chunk = os.read(fd, 4096)
        except OSError:  # EIO: every writer closed (Linux)
            chunk = b""
        if not chunk:
            if marker is None:
                return seen
            raise AssertionError(f"ended before {marker!r}: {seen[-2000:]!r}")
        seen += chunk
    return seen


def _sigint_default() -> None:
    """In the child, before exec: Ctrl-C's default action, as a terminal's shell gives it.
    A test run started in the background of a non-interactive shell inherits SIGINT
    ignored, and Python keeps an inherited ignore: the command would never see it."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.parametrize("delay", [0.3, 0.9, 1.7])
def test_ctrl_c_during_optimize_is_one_line_and_130(delay, tmp_path):
    """Ctrl-C (SIGINT to the process group, as a terminal sends it) while the GA runs.

    About 80 % of a generation is spent in the compiled kernel; a SIGINT there used to
    surface inside numba's ``_numba_unpickle`` as a SystemError traceback, exit 1. The
    GA has started when its progress bar (stderr is a terminal here) appears; the
    signal comes ``delay`` s later. The default population keeps the kernel's share."""
    controller, terminal = pty.openpty()
    # a new pty is 0 columns wide, and tqdm draws nothing in 0 columns
    fcntl.ioctl(terminal, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    out = tmp_path / "o.json"
    proc = subprocess.Popen(
        [sys.executable, "-m", "slopewalk.bench.cli", "optimize", "--slope", "10",
         "--generations", "100000", "--out", str(out)],
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=terminal,
        start_new_session=True, cwd=tmp_path, preexec_fn=_sigint_default,
    )  # fmt: skip
    os.close(terminal)
    try:
        seen = _until(controller, b"GA:", timeout=120)
        time.sleep(delay)
        os.killpg(proc.pid, signal.SIGINT)
        seen += _until(controller, None, timeout=60)
        assert proc.wait(timeout=60) == 130, seen.decode(errors="replace")
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        os.close(controller)
    err = seen.decode(errors="replace").replace("\r\n", "\n")
    assert "Traceback" not in err and "SystemError" not in err, err
    assert err.endswith("\nslopewalk: interrupted\n"), repr(err)
    assert proc.stdout is not None and proc.stdout.read() == b""
    assert not out.exists()


def _user_env() -> dict:
    """The environment of a user's shell: stdout to a pipe block-buffered, as Python has it."""
    return {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}


SMALL_SWEEP = "steps = 1\n[grid]\nstep_time = [0.3, 0.35, 0.4]\n"


# two cells: the reader's one line is read before the first ends, so the run stops after it
SMALL_ENVELOPE = (
    'steps = 1\n[grid]\nstep_time = [1.0]\nslope = [0, 15]\nactuators = ["stiff"]\n'
    "[search]\npopulation = 6\ngenerations = 2\n"
)


@pytest.mark.parametrize(  # the envelope's case is the same batch code: .ci/run runs it
    "command, config, rows",
    [
        ("sweep", SMALL_SWEEP, 3),
        pytest.param("envelope", SMALL_ENVELOPE, 2, marks=pytest.mark.slow),
    ],
)
def test_a_run_whose_output_pipe_closes_stops_with_141_and_resumes(
    command, config, rows, tmp_path, capsys
):
    """``slopewalk sweep|envelope FILE --out r 2>&1 | head -1``: the reader goes after one
    line.

    The run used to end silently with exit 1 (the progress line's BrokenPipeError, then
    the error message's own). Now it stops as a filter stops on SIGPIPE: exit 141, the
    finished rows kept in the partial table, and ``--resume`` finishes it."""
    path, out = tmp_path / "run.toml", tmp_path / "r"
    path.write_text(config)
    argv = [sys.executable, "-m", "slopewalk.bench.cli", command, str(path), "--out", str(out)]
    proc = subprocess.Popen(
        [*argv, "--workers", "1"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        env=_user_env(), cwd=tmp_path,
    )  # fmt: skip
    assert proc.stdout is not None
    first = proc.stdout.readline()  # head -1
    proc.stdout.close()
    assert proc.wait(timeout=300) == 141
    noun = "trials" if command == "sweep" else "cells"
    assert first.startswith(f"{command}: {rows} {noun}, 0 already done".encode())
    assert not (out / f"{command}.csv").exists()
    kept = (out / f"{command}.partial.csv").read_bytes().count(b"\n") - 1  # the header's
    assert 1 <= kept < rows  # stopped mid-run
    from slopewalk.bench.cli import main

    # resumed in this process: the same command line, no second interpreter to start
    again = main([command, str(path), "--out", str(out), "--resume", "--workers", "1"])
    said = capsys.readouterr()
    assert again == 0, said.err
    assert f"{kept} already done" in said.out
    assert (out / f"{command}.csv").read_bytes().count(b"\n") == rows + 1


@pytest.mark.parametrize("command", ["plan", "sweep"])
def test_a_closed_stdout_ends_quietly_with_141_after_the_work(command, tmp_path):
    """``slopewalk plan ... | true``: stdout's reader is gone before the first line. The
    command does its work (stdout is written at its end), then stops quietly with 141:
    no ``Exception ignored ... BrokenPipeError`` on stderr, no exit 120."""
    (tmp_path / "s.toml").write_text(SMALL_SWEEP)
    args = {
        "plan": ["plan", "--step-time", "1", "--steps", "1", "--out", "p.npz"],
        "sweep": ["sweep", "s.toml", "--out", "r", "--workers", "1"],
    }[command]
    proc = subprocess.Popen(
        [sys.executable, "-m", "slopewalk.bench.cli", *args], stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, env=_user_env(), cwd=tmp_path,
    )  # fmt: skip
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=300) == 141, err
    assert "Traceback" not in err and "Exception ignored" not in err and "error" not in err, err
    if command == "plan":
        assert err == ""
        assert np.load(tmp_path / "p.npz")["t"].size > 0
    else:  # the sweep finished: only its summary was lost, so no word of --resume
        assert "--resume" not in err
        assert (tmp_path / "r" / "sweep.csv").read_bytes().count(b"\n") == 4


ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def _options(command: str) -> list[str]:
    from slopewalk.bench.cli import build_parser

    parser = build_parser()._subparsers._group_actions[0].choices[command]
    return [o for a in parser._actions for o in a.option_strings if o not in ("-h", "--help")]


def test_the_readme_synopsis_and_flag_table_name_every_gait_flag():
    """``plan``'s synopsis line lists every flag of ``plan``, and the flag table has a row
    for each (``trial`` takes them as "gait flags as for plan"); --sway-share,
    --pelvis-offset and --step-length were missing from both."""
    text = (ROOT / "README.md").read_text()
    section = text[text.index("## Command line") :]
    synopsis = section[
        section.index("```bash") : section.index("```", section.index("```bash") + 3)
    ]
    plan = synopsis[synopsis.index("slopewalk plan") : synopsis.index("slopewalk trial")]
    table = [line for line in section.splitlines() if line.startswith("| `--")]
    for flag in _options("plan"):
        assert f"[{flag} " in plan or f"{flag} " in plan, f"{flag} not in plan's synopsis"
        assert any(f"`{flag} " in row or f"`{flag}`" in row for row in table), flag
    trial = synopsis[synopsis.index("slopewalk trial") : synopsis.index("slopewalk mjcf")]
    assert "[gait flags as for plan]" in trial
    for flag in set(_options("trial")) - set(_options("plan")):
        assert flag in trial, f"{flag} not in trial's synopsis"


def _printed_names() -> dict[str, set[str]]:
    """The names each ``slopewalk benchmark WHAT`` prints: the keys of the dicts its
    functions return (read from the source, so nothing is run)."""
    import ast

    functions = {}
    for path in (
        ROOT / "bench" / "experiments" / "benchmark.py",
        ROOT / "bench" / "experiments" / "envelope" / "benchmark.py",
    ):
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.FunctionDef) and node.name.endswith("_figures"):
                keys = {
                    k.value
                    for ret in ast.walk(node)
                    if isinstance(ret, ast.Return) and isinstance(ret.value, ast.Dict)
                    for k in ret.value.keys
                    if isinstance(k, ast.Constant)
                }
                functions[node.name] = keys
    f = functions
    return {
        "planner": f["planner_figures"],
        "sim": f["sim_figures"],
        "ga": f["ga_figures"],
        "sweep": f["grid_figures"]
        | f["trial_part_figures"]
        | f["sweep_figures"]
        | f["ceiling_figures"],
        "controller": f["controller_figures"],
        "envelope": f["envelope_figures"],
    }


def test_every_benchmark_figure_is_documented_in_its_section():
    """``benchmark`` printed names such as ``ratio`` with no word of what they are:
    docs/benchmark.md has a row per name, in the section of its benchmark, and the
    command's help points there."""
    from slopewalk.bench.cli import build_parser

    doc = (ROOT / "docs" / "benchmark.md").read_text()
    names = _printed_names()
    choices = build_parser()._subparsers._group_actions[0].choices
    what = [a for a in choices["benchmark"]._actions if a.dest == "what"][0]
    assert set(names) == set(what.choices)
    for benchmark, keys in names.items():
        assert keys, benchmark
        start = doc.index(f"## `{benchmark}`")
        end = doc.find("\n## ", start + 1)
        section = doc[start : end if end > 0 else None]
        rows = {line.split("|")[1].strip().strip("`") for line in section.splitlines()[1:]
                if line.startswith("| `")}  # fmt: skip
        assert rows == keys, (benchmark, keys ^ rows)
    assert "docs/benchmark.md" in choices["benchmark"].format_help()
    assert "docs/envelope-format.md" in choices["envelope"].format_help()
    assert "envelope_config.py" not in choices["envelope"].format_help()
    assert "](docs/benchmark.md)" in (ROOT / "README.md").read_text()


def test_the_tilt_help_gives_the_nominal_number():
    from slopewalk.bench.cli import build_parser

    text = build_parser()._subparsers._group_actions[0].choices["plan"].format_help()
    assert "(default 12, every robot's nominal gait)" in " ".join(text.split())


def test_the_console_script_freezes_the_collector_then_exits_with_mains_status(monkeypatch):
    """``command`` (the console script, ``python -m slopewalk``) freezes the cyclic
    collector before the exit, whose last collection would walk the compiled kernel
    (~0.5 s of every command, ``cli.command``), and exits with ``main``'s status."""
    import gc
    import tomllib

    from slopewalk.bench import cli

    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["slopewalk"] == "slopewalk.bench.cli:command"
    monkeypatch.setattr(cli, "main", lambda: 3)
    frozen = gc.get_freeze_count()
    gc.collect()
    try:
        with pytest.raises(SystemExit) as exit_:
            cli.command()
        assert exit_.value.code == 3
        assert gc.get_freeze_count() > frozen
    finally:
        gc.unfreeze()
