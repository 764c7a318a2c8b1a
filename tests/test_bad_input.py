"""Bad input at the command line: one line naming the value and the range, nothing left behind.

Each row of ``CASES`` is (argv, fragment). ``{out}`` is an empty folder that must
stay empty, ``{in}`` a folder of prepared inputs that must stay as it was; the
command runs in-process (``slopewalk.bench.cli.main``) from a working directory that must
gain nothing (no ``MUJOCO_LOG.TXT`` either). A few end-to-end runs at the bottom
go through a real process.
"""

import argparse
import json
import math
import os
import re
import stat
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from slopewalk.bench.cli import main
from slopewalk.planner.spec import default_spec_path

SPEC = default_spec_path().read_text()
SWEEP_TABLE = (Path(__file__).resolve().parents[1] / "results" / "sweep.csv").read_bytes()
WALKER = Path(__file__).resolve().parent / "robots" / "walker.xml"


def _spec(old: str, new: str, count: int = 1) -> str:
    assert old in SPEC, old
    return SPEC.replace(old, new, count)


ENVELOPE = "[grid]\nstep_time = [1.0]\nslope = [0]\n"
THIGH_INERTIA = "inertia = [8.150e-5, 7.450e-5, 2.050e-5]"
INPUTS = {  # file name in {in} -> content
    "nan_com.toml": _spec("com = [0.0, 0.0, -0.070]", "com = [nan, 0.0, -0.070]"),
    "inf_com.toml": _spec("com = [0.0, 0.0, -0.070]", "com = [0.0, 0.0, -inf]"),
    "huge_com.toml": _spec("com = [0.0, 0.0, -0.070]", "com = [0.0, 0.0, -70.0]"),
    "nan_inertia.toml": _spec(THIGH_INERTIA, "inertia = [8.150e-5, nan, 2.050e-5]"),
    "inf_inertia.toml": _spec(THIGH_INERTIA, "inertia = [inf, 7.450e-5, 2.050e-5]"),
    "neg_inertia.toml": _spec(THIGH_INERTIA, "inertia = [8.150e-5, -7.450e-5, 2.050e-5]"),
    "triangle.toml": _spec(THIGH_INERTIA, "inertia = [1e-5, 1e-5, 1e-3]"),
    "short_inertia.toml": _spec(THIGH_INERTIA, "inertia = [1e-5, 1e-5]"),
    "nan_mass.toml": _spec("mass = 0.066", "mass = nan"),
    "neg_mass.toml": _spec("mass = 0.066", "mass = -0.066"),
    "huge_mass.toml": _spec("mass = 0.066", "mass = 1e9"),
    "string_mass.toml": _spec("mass = 0.066", 'mass = "66 g"'),
    "bool_mass.toml": _spec("mass = 0.066", "mass = true"),
    "nan_length.toml": _spec("thigh = 0.111", "thigh = nan"),
    "inf_length.toml": _spec("shank = 0.111", "shank = inf"),
    "neg_length.toml": _spec("hip_width = 0.085", "hip_width = -0.085"),
    "huge_length.toml": _spec("foot_width = 0.060", "foot_width = 1e9"),
    "string_length.toml": _spec("thigh = 0.111", 'thigh = "0.111"'),
    "nan_stall.toml": _spec("stall_torque = 1.5", "stall_torque = nan"),
    "inf_stall.toml": _spec("stall_torque = 1.5", "stall_torque = inf"),
    "neg_stall.toml": _spec("stall_torque = 1.5", "stall_torque = -1.5"),
    "nan_limit.toml": _spec("knee = [-0.10, 2.60]", "knee = [-0.10, nan]"),
    "unknown_key.toml": _spec("stall_torque = 1.5", "stall_toque = 1.5"),
    "unknown_table.toml": SPEC + "\n[arms]\nmass = 0.1\n",
    "unknown_link.toml": _spec("[links.ankle]", "[links.ankel]"),
    "not_toml.toml": "thigh = = 0.1\n",
    "binary.toml": bytes(range(256)) * 16,
    "latin1.toml": "name = 'caf\xe9'\n".encode("latin-1"),
    "empty.json": "",
    "empty_list.json": "[]",
    "broken.json": "[{",
    "a_file": "not a folder\n",
    "cut_sweep.csv": SWEEP_TABLE[:5000],  # head -c 5000 results/sweep.csv: a line cut short
    "empty.csv": "",
    "cut_header.csv": SWEEP_TABLE[:100],
    "header_only.csv": SWEEP_TABLE[: SWEEP_TABLE.index(b"\n") + 1],
    "narrow_line.csv": SWEEP_TABLE[: SWEEP_TABLE.index(b"\n") + 1] + b"0123456789ab,1.0\n",
    "noisy_sweep.toml": "command_noise = 1e-4\n" + ENVELOPE,
    "nan_noise_sweep.toml": "command_noise = nan\n" + ENVELOPE,
    "ends_sweep.toml": 'spec_ends = ["servo.armature:low"]\n' + ENVELOPE,
    "nan_ends_sweep.toml": "spec_ends = [nan]\n" + ENVELOPE,
    "envelope_module.toml": ENVELOPE + 'controller = ["no_such_module:f"]\n',
    "envelope_name.toml": ENVELOPE + 'controller = ["ankle_cop_feedback"]\n',
    "envelope_number.toml": ENVELOPE + "controller = [1]\n",
    "envelope_grids.toml": "[[grid]]\nstep_time = [1.0]\nslope = [0]\n"
    + "[[grid]]\nstep_time = [0.5]\nslope = [10]\n",
    "envelope_modes.toml": ENVELOPE + 'actuators = ["servo", "servo"]\n',
    "envelope_metres.toml": ENVELOPE + "[search]\nrequired_margin = 0.005\n",
    "plain_sweep.toml": ENVELOPE,  # a sweep file too
    "walker.xml": WALKER.read_bytes(),
    "model_sweep.toml": 'model = "no.xml"\n' + ENVELOPE,
    "map_sweep.toml": 'map = "walker-map.toml"\n' + ENVELOPE,
    "stiff_model_sweep.toml": 'model = "walker.xml"\n' + ENVELOPE + 'actuators = ["stiff"]\n',
    "walker_sweep.toml": 'model = "walker.xml"\n' + ENVELOPE,
    "envelope_clash.toml": ENVELOPE  # two callables of one name: their columns would clash
    + 'controller = ["slopewalk.bench.controllers:load_controller",'
    + ' "slopewalk.bench.sim.closed_loop:load_controller"]\n',
}

PLAN = ["plan", "--step-time", "1"]
TRIAL = ["trial", "--step-time", "0.4", "--steps", "1"]
ROBOT = [*PLAN, "--robot"]
DEFAULT_OUT = {  # an --out is added where a row has none
    "plan": "{out}/p.npz",
    "trial": "{out}/t.json",
    "mjcf": "{out}/s.xml",
    "optimize": "{out}/b.json",
    "compare": "{out}/c.md",
    "sweep": "{out}",
    "controllers": "{out}/c.md",
    "envelope": "{out}",
    "cop-error": "{out}/c.md",
    "fidelity": "{out}/f.md",
}
CASES = [
    # numbers at the command line
    (["plan", "--step-time", "inf"], "--step-time: inf: must lie in (0, 60] s"),
    (["plan", "--step-time=-inf"], "--step-time: -inf: must lie in"),
    (["plan", "--step-time", "nan"], "--step-time: nan: must lie in"),
    (["plan", "--step-time", "1e5"], "--step-time: 1e5: must lie in (0, 60] s"),
    (["plan", "--step-time", "0"], "--step-time: 0: must lie in (0, 60] s"),
    (["plan", "--step-time", "-1"], "--step-time: -1: must lie in"),
    (["plan", "--step-time", "0.005"], "step time 0.005 s: must lie in [0.01, 60] s"),
    (["plan", "--step-time", "abc"], "--step-time: 'abc' is not a number"),
    ([*PLAN, "--steps", "100000"], "--steps: 100000: must be an integer in [1, 1000]"),
    ([*PLAN, "--steps", "0"], "--steps: 0: must be an integer in [1, 1000]"),
    ([*PLAN, "--steps", "2.5"], "--steps: '2.5' is not an integer"),
    (["plan", "--step-time", "50", "--steps", "900"], "4.5e+07 samples: must be <= 1e+06"),
    # in range, but beyond what any robot on its feet does: the ground would have to pull
    (
        ["plan", "--step-time", "0.0105"],
        "the walk asks the ground to pull: from t = 0.000 s the planned force normal to the "
        "plane falls to -834.80 x the robot's weight",
    ),
    (["plan", "--step-time", "0.2"], "falls to -1.59 x the robot's weight (t = 0.140 s)"),
    (["trial", "--step-time", "0.02"], "ZMP, margin and friction ratio do not exist there"),
    ([*TRIAL, "--out", "{out}/t.json", "--map", "m.toml"], "--map 'm.toml': only with --model"),
    ([*TRIAL, "--out", "{out}/t.json", "--model", "{in}/no.xml"], "no.xml': no such file"),
    (
        [
            *TRIAL,
            "--out",
            "{out}/t.json",
            "--model",
            "tests/robots/walker.xml",
            "--controller",
            "slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback",
        ],
        "--controller with --model: not yet (the closed loop steps the twin's scene only)",
    ),
    # sweep and envelope on a model: every path checked (made absolute) before any trial
    (
        ["sweep", "{in}/plain_sweep.toml", "--model", "{in}/no.xml"],
        "--model: model '{in}/no.xml': no such file",
    ),
    (["sweep", "{in}/plain_sweep.toml", "--map", "m.toml"], "--map 'm.toml': only with --model"),
    (
        [
            "envelope",
            "{in}/plain_sweep.toml",
            "--model",
            "{in}/walker.xml",
            "--map",
            "{in}/no.toml",
        ],
        "--model: map file '{in}/no.toml': no such file",
    ),
    (
        ["envelope", "{in}/plain_sweep.toml", "--model", "{in}/a_file"],
        "--model: model '{in}/a_file': MuJoCo refused it",
    ),
    (["sweep", "{in}/model_sweep.toml"], "model_sweep.toml: model '{in}/no.xml': no such file"),
    (["sweep", "{in}/map_sweep.toml"], "map = 'walker-map.toml': only with a model key"),
    (
        ["sweep", "{in}/plain_sweep.toml", "--model", "{in}/walker.xml", "--report"],
        "--report with a model (walker): the claims and figures are the paper's biped's",
    ),
    (
        ["sweep", "{in}/stiff_model_sweep.toml"],
        "grid.actuators = 'stiff' with a model: it plays on its own actuators",
    ),
    (
        ["controllers", "{in}/walker_sweep.toml"],
        "walker_sweep.toml: names the model walker: the controllers step the twin's scene only",
    ),
    ([*PLAN, "--slope", "60"], "--slope: 60: must lie in (-60, 60) deg"),
    ([*PLAN, "--slope", "-75"], "--slope: -75: must lie in (-60, 60) deg"),
    ([*PLAN, "--slope", "nan"], "--slope: nan: must lie in"),
    ([*PLAN, "--hip-height", "nan"], "--hip-height: nan: must be a finite number"),
    ([*PLAN, "--hip-height", "0.5"], "hip height 0.5 m: must lie in (0, 0.254] m"),
    ([*PLAN, "--hip-height", "-0.1"], "hip height -0.1 m: must be a finite length > 0 m"),
    ([*PLAN, "--hip-height", "0.25"], "unreachable hip target at t ="),
    ([*PLAN, "--swing-lift", "inf"], "--swing-lift: inf: must be a finite number"),
    ([*PLAN, "--swing-lift", "0.5"], "swing lift 0.5 m: must lie in [0, 0.39) m"),
    ([*PLAN, "--swing-lift", "-0.01"], "swing lift -0.01 m: must be a finite length >= 0 m"),
    ([*PLAN, "--tilt", "50"], "--tilt: 50: must lie in (-45, 45) deg"),
    ([*PLAN, "--tilt-profile", "wobble"], "invalid choice: 'wobble'"),
    ([*PLAN, "--sway-share", "1.5"], "--sway-share: 1.5: must lie in [0, 1]"),
    ([*PLAN, "--sway-share", "nan"], "--sway-share: nan: must lie in [0, 1]"),
    (
        [*PLAN, "--tilt-profile", "sway", "--sway-share", "0.5"],
        "tilt profile 'sway' and sway share 0.5: disagree",
    ),
    ([*PLAN, "--pelvis-offset", "inf"], "--pelvis-offset: inf: must be a finite number"),
    ([*PLAN, "--pelvis-offset", "0.3"], "pelvis offset 0.3 m: must lie in (-0.222, 0.222) m"),
    ([*PLAN, "--step-length", "0"], "step length 0.0 m: must be a finite length > 0 m"),
    ([*PLAN, "--step-length", "1"], "step length 1 m: must lie in (0, 0.444] m"),
    ([*PLAN, "--step-length", "x"], "--step-length: 'x' is not a number"),
    (["trial", "--step-time", "1", "--sway-share", "-0.1"], "--sway-share: -0.1: must lie in"),
    (["trial", "--step-time", "1", "--friction", "inf"], "--friction: inf: must lie in (0, 10]"),
    (["trial", "--step-time", "1", "--friction", "1e6"], "--friction: 1e6: must lie in (0, 10]"),
    (["trial", "--step-time", "1", "--friction", "0"], "--friction: 0: must lie in (0, 10]"),
    (["trial", "--step-time", "1", "--friction", "-2"], "--friction: -2: must lie in (0, 10]"),
    (["trial", "--step-time", "1", "--friction", "nan"], "--friction: nan: must lie in (0, 10]"),
    (["trial", "--step-time", "1", "--friction", "grippy"], "--friction: 'grippy' is not a number"),
    (["trial", "--step-time", "1", "--slope", "61"], "--slope: 61: must lie in (-60, 60) deg"),
    (["trial", "--step-time", "1", "--actuators", "soft"], "--actuators: invalid choice: 'soft'"),
    ([*TRIAL, "--command-noise", "nan"], "--command-noise: nan: must lie in [0, 0.5] deg"),
    ([*TRIAL, "--command-noise=-1e-4"], "--command-noise: -1e-4: must lie in [0, 0.5] deg"),
    ([*TRIAL, "--command-noise", "1"], "--command-noise: 1: must lie in [0, 0.5] deg"),
    ([*TRIAL, "--command-noise", "x"], "--command-noise: 'x' is not a number"),
    ([*TRIAL, "--noise-seed", "-1"], "--noise-seed: -1: must be an integer in [0, 4294967295]"),
    (
        [
            *TRIAL,
            "--command-noise",
            "1e-4",
            "--controller",
            "slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback",
        ],
        "--command-noise 0.0001 deg with --controller slopewalk.bench.controllers.ankle_cop:"
        "ankle_cop_feedback: the noise is for the plan played open loop",
    ),
    ([*TRIAL, "--noise-seed", "5"], "--noise-seed 5: seeds --command-noise, which is not given"),
    (
        [*TRIAL, "--command-noise", "0", "--noise-seed", "0"],
        "--noise-seed 0: seeds --command-noise, which is not given (or 0): there is no noise",
    ),
    (
        [*PLAN, "--out", "{out}/p.json"],
        "--out '{out}/p.json': is written as a NumPy .npz archive; give a name ending in .npz",
    ),
    (
        [*TRIAL, "--series", "{out}/s.json"],
        "--series '{out}/s.json': is written as a NumPy .npz archive",
    ),
    # closed-loop controllers (tests/controller_faults.py holds the misbehaving ones)
    ([*TRIAL, "--controller", "ankle_cop_feedback"], "'ankle_cop_feedback': must read MODULE:CA"),
    ([*TRIAL, "--controller", "a b:c"], "controller 'a b:c': must read MODULE:CALLABLE"),
    ([*TRIAL, "--controller", "no_such_module:f"], "no module named 'no_such_module'"),
    (
        [*TRIAL, "--controller", "slopewalk.bench.controllers.ankle_cop:nothing"],
        "module 'slopewalk.bench.controllers.ankle_cop' has no 'nothing'",
    ),
    ([*TRIAL, "--controller", "controller_faults:NOT_CALLABLE"], "is a float, not callable"),
    (
        [*TRIAL, "--controller", "controller_faults:seven_numbers"],
        "at t = 0.000 s: returned an action of shape (7,): must be (8,)",
    ),
    ([*TRIAL, "--controller", "controller_faults:nan_command"], "[nan nan nan nan"),
    ([*TRIAL, "--controller", "controller_faults:words"], "'stand still': not an array of numbers"),
    (
        [*TRIAL, "--controller", "controller_faults:raises"],
        "raised ZeroDivisionError at t = 0.000 s: the user's bug",
    ),
    (["controllers", "--controller", "no_such_module:f"], "no module named 'no_such_module'"),
    (["controllers", "--workers", "0"], "--workers: 0: must be an integer in [1, 1024]"),
    (["controllers", "--out", "{out}"], "--out '{out}': is a directory"),
    (["cop-error", "--out", "{out}"], "--out '{out}': is a directory"),
    (
        ["envelope", "{in}/envelope_module.toml"],
        "envelope_module.toml: grid.controller: controller 'no_such_module:f': no module named",
    ),
    (
        ["envelope", "{in}/envelope_name.toml"],
        "grid.controller: controller 'ankle_cop_feedback': must read MODULE:CALLABLE",
    ),
    (
        ["envelope", "{in}/envelope_number.toml"],
        'grid.controller = 1: must be "none" or MODULE:CALLABLE',
    ),
    (
        ["envelope", "{in}/envelope_clash.toml"],
        "grid.controller: controllers slopewalk.bench.controllers:load_controller, "
        "slopewalk.bench.sim.closed_loop:load_controller: their callables' names",
    ),
    (["envelope", "{in}/envelope_grids.toml"], "an envelope takes one [grid] table, whose"),
    (
        ["envelope", "{in}/envelope_modes.toml"],
        "grid.actuators = ['servo', 'servo']: names servo more than once",
    ),
    (
        ["envelope", "{in}/envelope_metres.toml"],
        "search.required_margin = 0.005 mm: looks like metres",
    ),
    (
        ["controllers", "--envelope", "{in}/a_file"],
        "a_file: not an envelope table (no column cell_id)",
    ),
    (
        ["controllers", "--envelope", "{in}/missing.csv"],
        "missing.csv: cannot read (No such file or directory)",
    ),
    (["controllers", "--envelope", "{in}"], "in: is a directory, not an envelope table"),
    (
        ["controllers", "--envelope", "{in}/envelope_name.toml"],
        "grid.controller: controller 'ankle_cop_feedback': must read MODULE:CALLABLE",
    ),
    (["controllers", "--min-step-time", "0.5"], "--min-step-time: only with --envelope"),
    (
        ["controllers", "{in}/noisy_sweep.toml"],
        "command_noise = 0.0001 deg: the controllers make their own commands",
    ),
    (["sweep", "{in}/nan_noise_sweep.toml"], "command_noise = nan: must be a finite number"),
    (
        ["controllers", "{in}/ends_sweep.toml"],
        "spec_ends = ['servo.armature:low']: the controllers' table has no spec_end column",
    ),
    (["sweep", "{in}/nan_ends_sweep.toml"], "spec_ends entry nan: must be a non-empty list"),
    (
        ["controllers", "--envelope", "{in}/a_file", "--min-step-time", "0"],
        "--min-step-time: 0: must lie in (0, 60] s",
    ),
    (["mjcf", "--friction", "inf"], "--friction: inf: must lie in (0, 10]"),
    (["mjcf", "--slope", "-60"], "--slope: -60: must lie in (-60, 60) deg"),
    (["mjcf", "--actuators", "hydraulic"], "invalid choice: 'hydraulic'"),
    (
        ["optimize", "--slope", "10", "--foot-length", "0.03"],
        "--foot-length 0.03 m: must lie in (0.051, 5] m with --foot-extend toe",
    ),
    (
        ["optimize", "--slope", "10", "--foot-length", "0.04", "--foot-extend", "heel"],
        "--foot-length 0.04 m: must lie in (0.049, 5] m with --foot-extend heel",
    ),
    (
        ["optimize", "--slope", "10", "--foot-length", "nan"],
        "--foot-length: nan: must be a finite number",
    ),
    (
        ["optimize", "--slope", "10", "--population", "1"],
        "--population: 1: must be an integer in [2, 1000]",
    ),
    (
        ["optimize", "--slope", "10", "--generations", "1e9"],
        "--generations: '1e9' is not an integer",
    ),
    (
        ["optimize", "--slope", "10", "--seed", "-1"],
        "--seed: -1: must be an integer in [0, 4294967295]",
    ),
    (["optimize", "--slope", "inf"], "--slope: inf: must lie in (-60, 60) deg"),
    (
        ["sweep", "--workers", "0", "--out", "{out}"],
        "--workers: 0: must be an integer in [1, 1024]",
    ),
    # sweep tables read by a report: a cut copy is refused, never read as fewer rows
    (
        ["fidelity", "{in}/cut_sweep.csv"],
        "cut_sweep.csv: not a sweep table (its last line has no newline: a torn write or a cut "
        "copy?)",
    ),
    (["fidelity", "{in}/empty.csv"], "empty.csv: is empty, not a results table"),
    (["fidelity", "{in}/cut_header.csv"], "cut_header.csv: not a results table (no whole header"),
    (["fidelity", "{in}/header_only.csv"], "header_only.csv: a header and no row"),
    (["fidelity", "{in}/narrow_line.csv"], "narrow_line.csv: line 2 has 2 fields, not"),
    (["fidelity", "{in}/a_file"], "a_file: not a results table (its first line is not a header"),
    # robot spec files
    ([*ROBOT, "{in}/nan_com.toml"], "links.thigh.com nan m: must lie in [-5, 5] m"),
    ([*ROBOT, "{in}/inf_com.toml"], "links.thigh.com -inf m: must lie in [-5, 5] m"),
    ([*ROBOT, "{in}/huge_com.toml"], "links.thigh.com -70.0 m: must lie in [-5, 5] m"),
    ([*ROBOT, "{in}/nan_inertia.toml"], "links.thigh.inertia nan kg m^2: must be a finite number"),
    ([*ROBOT, "{in}/inf_inertia.toml"], "links.thigh.inertia inf kg m^2: must be a finite number"),
    ([*ROBOT, "{in}/neg_inertia.toml"], "must be > 0 (positive definite)"),
    ([*ROBOT, "{in}/triangle.toml"], "violates the triangle inequality"),
    (
        [*ROBOT, "{in}/short_inertia.toml"],
        "links.thigh.inertia [1e-05, 1e-05]: must be a list of 3 numbers",
    ),
    ([*ROBOT, "{in}/nan_mass.toml"], "links.thigh.mass nan kg: must lie in (0, 1000] kg"),
    ([*ROBOT, "{in}/neg_mass.toml"], "links.thigh.mass -0.066 kg: must lie in (0, 1000] kg"),
    ([*ROBOT, "{in}/huge_mass.toml"], "links.thigh.mass 1000000000.0 kg: must lie in (0, 1000] kg"),
    ([*ROBOT, "{in}/string_mass.toml"], "links.thigh.mass '66 g': must lie in (0, 1000] kg"),
    ([*ROBOT, "{in}/bool_mass.toml"], "links.thigh.mass True: must lie in"),
    ([*ROBOT, "{in}/nan_length.toml"], "geometry.thigh nan m: must lie in (0, 5] m"),
    ([*ROBOT, "{in}/inf_length.toml"], "geometry.shank inf m: must lie in (0, 5] m"),
    ([*ROBOT, "{in}/neg_length.toml"], "geometry.hip_width -0.085 m: must lie in (0, 5] m"),
    ([*ROBOT, "{in}/huge_length.toml"], "geometry.foot_width 1000000000.0 m: must lie in (0, 5] m"),
    ([*ROBOT, "{in}/string_length.toml"], "geometry.thigh '0.111': must lie in (0, 5] m"),
    ([*ROBOT, "{in}/nan_stall.toml"], "servo.stall_torque nan N m: must lie in (0, 10000] N m"),
    ([*ROBOT, "{in}/inf_stall.toml"], "servo.stall_torque inf N m: must lie in (0, 10000] N m"),
    ([*ROBOT, "{in}/neg_stall.toml"], "servo.stall_torque -1.5 N m"),
    ([*ROBOT, "{in}/nan_limit.toml"], "joint_limits.knee nan rad: must lie in"),
    (
        [*ROBOT, "{in}/unknown_key.toml"],
        "unknown key servo.stall_toque (did you mean servo.stall_torque?",
    ),
    ([*ROBOT, "{in}/unknown_table.toml"], "unknown key arms (known: name, geometry"),
    ([*ROBOT, "{in}/unknown_link.toml"], "unknown key links.ankel (did you mean links.ankle?"),
    ([*ROBOT, "{in}/not_toml.toml"], "not_toml.toml': not valid TOML (Invalid value"),
    ([*ROBOT, "{in}/binary.toml"], "binary.toml': not UTF-8 text (byte 0x80 at offset 128)"),
    (["mjcf", "--robot", "{in}/latin1.toml"], "latin1.toml': not UTF-8 text (byte 0xe9"),
    ([*ROBOT, "{in}"], "': is a directory, not a TOML file"),
    ([*ROBOT, "{in}/missing.toml"], "missing.toml': no such file"),
    ([*ROBOT, ""], "robot spec '.': is a directory"),
    # output paths, checked before any work
    ([*PLAN, "--out", "{out}"], "--out '{out}': is a directory; give a file path"),
    ([*PLAN, "--out", ""], "--out '': must be a file path, not empty"),
    ([*PLAN, "--out", "{in}/a_file/p.npz"], "a_file' is a regular file, not a folder"),
    ([*PLAN, "--out", "{in}/a_file/deeper/p.npz"], "a_file' is a regular file, not a folder"),
    (
        [*PLAN, "--out", "/proc/slopewalk.npz"],
        "--out '/proc/slopewalk.npz': cannot create files in '/proc'",
    ),
    ([*PLAN, "--out", "/proc/version"], "--out '/proc/version': cannot create files in '/proc'"),
    (
        ["trial", "--step-time", "1", "--out", "{out}/t.json", "--series", "{out}"],
        "--series '{out}': is a directory",
    ),
    (
        ["trial", "--step-time", "1", "--out", "{out}/t.json", "--record", "{out}"],
        "--record '{out}': is a directory",
    ),
    (
        ["trial", "--step-time", "1", "--out", "{out}/t.json", "--series", "{out}/t.json"],
        "--series '{out}/t.json': is the same file as --out",
    ),
    ([*TRIAL, "--video", "{out}"], "--video '{out}': is a directory"),
    ([*TRIAL, "--video", "{out}/t.avi"], "--video '{out}/t.avi': is written as an MP4 video"),
    ([*TRIAL, "--video", "{out}/t"], "give a name ending in .mp4"),
    ([*TRIAL, "--video", "/dev/null"], "--video '/dev/null': must be a regular file"),
    ([*TRIAL, "--video", "/proc/t.mp4"], "--video '/proc/t.mp4': cannot create files in '/proc'"),
    ([*TRIAL, "--video", "{in}/a_file/t.mp4"], "a_file' is a regular file, not a folder"),
    ([*TRIAL, "--video", "{out}/t.mp4", "--record", "{out}/t.mp4"], "is the same file as --record"),
    ([*TRIAL, "--video-fps", "0"], "--video-fps: 0: must lie in [1, 120] fps"),
    ([*TRIAL, "--video-fps", "nan"], "--video-fps: nan: must lie in [1, 120] fps"),
    ([*TRIAL, "--video-fps", "10"], "--video-fps 10: only with --video, which is not given"),
    ([*TRIAL, "--video-size", "161x120"], "--video-size: 161x120: each side must be an even"),
    ([*TRIAL, "--video-size", "8x8"], "--video-size: 8x8: each side must be an even number"),
    ([*TRIAL, "--video-size", "big"], "--video-size: 'big' is not WIDTHxHEIGHT in pixels"),
    ([*TRIAL, "--video-size", "64x48"], "--video-size 64x48: only with --video"),
    ([*TRIAL, "--record-rate", "0"], "--record-rate: 0: must lie in (0, 1000] Hz"),
    ([*TRIAL, "--record-rate", "5000"], "--record-rate: 5000: must lie in (0, 1000] Hz"),
    ([*TRIAL, "--record-rate", "-1"], "--record-rate: -1: must lie in (0, 1000] Hz"),
    ([*TRIAL, "--record-rate", "inf"], "--record-rate: inf: must lie in (0, 1000] Hz"),
    ([*TRIAL, "--record-rate", "fast"], "--record-rate: 'fast' is not a number"),
    ([*TRIAL, "--record-rate", "100"], "--record-rate 100: only with --record, which is not"),
    (["optimize", "--slope", "10", "--pareto", "--out", "{out}"], "--out '{out}': is a directory"),
    (
        ["optimize", "--slope", "10", "--pareto", "--out", "{in}/a_file/b.json"],
        "a_file' is a regular file",
    ),
    (["compare", "--out", "{out}"], "--out '{out}': is a directory"),
    (["compare", "--write-baseline", "--baseline", "{out}"], "--baseline '{out}': is a directory"),
    (["sweep", "--out", "{in}/a_file"], "--out '{in}/a_file': is a regular file, not a folder"),
    (
        ["sweep", "--out", "/proc/slopewalk"],
        "--out '/proc/slopewalk': cannot create files in '/proc'",
    ),
    # the comparison's baseline
    (["compare", "--baseline", "/nonexistent.json"], "baseline '/nonexistent.json': no such file"),
    (["compare", "--baseline", "{in}/empty.json"], "empty.json': is empty"),
    (
        ["compare", "--baseline", "{in}/empty_list.json"],
        "empty_list.json': must be a non-empty list",
    ),
    (["compare", "--baseline", "{in}/broken.json"], "broken.json': not valid JSON"),
    (["compare", "--baseline", "{in}"], "': is a directory, not a JSON file"),
    (["compare", "--baseline", "{in}/binary.toml"], "binary.toml': not UTF-8 text"),
]


@pytest.fixture
def dirs(tmp_path, monkeypatch):
    inputs, out = tmp_path / "in", tmp_path / "out"
    inputs.mkdir()
    out.mkdir()
    for name, content in INPUTS.items():
        path = inputs / name
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
    monkeypatch.chdir(tmp_path)
    return tmp_path, inputs, out


def _snapshot(root):
    return sorted(
        (str(p.relative_to(root)), p.stat().st_size if p.is_file() else -1) for p in root.rglob("*")
    )


def _fill(text: str, inputs, out) -> str:
    return text.replace("{in}", str(inputs)).replace("{out}", str(out))


def _refused(argv, capsys):
    try:
        code = main(argv)
    except SystemExit as exit_:
        code = exit_.code
    captured = capsys.readouterr()
    return code, captured.err, captured.out


@pytest.mark.parametrize("argv, fragment", CASES, ids=[" ".join(a) for a, _ in CASES])
def test_bad_input_is_one_line_and_leaves_nothing(argv, fragment, dirs, capsys):
    root, inputs, out = dirs
    before = _snapshot(root)
    if "--out" not in argv:
        argv = [*argv, "--out", DEFAULT_OUT[argv[0]]]
    code, err, _ = _refused([_fill(a, inputs, out) for a in argv], capsys)
    assert code not in (0, None), err
    assert _fill(fragment, inputs, out) in err, err
    assert err.endswith("\n") and err.count("\n") == 1, err
    assert "Traceback" not in err
    assert list(out.iterdir()) == []  # nothing half-written
    assert _snapshot(root) == before  # nor any other file, MUJOCO_LOG.TXT included


def test_the_table_covers_every_prepared_input():
    used = " ".join(" ".join(a) for a, _ in CASES)
    assert [name for name in INPUTS if f"{{in}}/{name}" not in used] == []


def test_no_arguments_prints_the_usage_and_fails(capsys):
    code, err, _ = _refused([], capsys)
    assert code == 2
    assert err.startswith("usage: slopewalk") and "plan" in err and "examples:" in err


def test_every_subcommand_describes_itself_with_an_example(capsys):
    from slopewalk.bench.cli import build_parser

    commands = build_parser()._subparsers._group_actions[0].choices
    for name, parser in commands.items():
        text = parser.format_help()
        assert parser.description, name
        assert f"slopewalk {name}" in parser.epilog, name
        assert "docs/robot-spec.md" in text and "docs/sweep-format.md" in text, name
    trial = commands["trial"].format_help()
    assert "{stiff,servo,stiff_ff,servo_ff}" in trial and "(default: stiff)" in trial
    assert "(default: 1.0)" in trial  # --friction
    assert "(default: 4)" in trial  # --steps


def test_the_cli_offers_the_scenes_actuator_modes():
    from slopewalk.bench import flags
    from slopewalk.bench.sim.model import ACTUATOR_MODES

    p = argparse.ArgumentParser()
    flags.add_sim_flags(p)
    (action,) = [a for a in p._actions if a.dest == "actuators"]
    assert tuple(action.choices) == ACTUATOR_MODES and action.default in ACTUATOR_MODES


def test_the_cli_allows_the_trials_command_noise():
    from slopewalk.bench import flags
    from slopewalk.bench.sim.trial_spec import MAX_COMMAND_NOISE_DEG

    assert (flags.COMMAND_NOISE_DEG.low, flags.COMMAND_NOISE_DEG.high) == (0, MAX_COMMAND_NOISE_DEG)


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_a_full_device_is_written_through_and_never_replaced(dirs, capsys):
    code, err, _ = _refused(["mjcf", "--out", "/dev/full"], capsys)
    assert code == 2
    assert err == "slopewalk: error: cannot write '/dev/full': No space left on device\n"
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)  # still the device
    code, err, out = _refused(["mjcf", "--out", os.devnull], capsys)
    assert code == 0, err
    assert stat.S_ISCHR(os.stat(os.devnull).st_mode)


def _cli(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "slopewalk.bench.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=cwd,
    )


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["plan", "--step-time", "inf", "--out", "p.npz"], "--step-time: inf: must lie in"),
        (["compare", "--baseline", "/nonexistent.json"], "/nonexistent.json': no such file"),
        (["mjcf", "--out", "/dev/full"], "'/dev/full': No space left on device"),
    ],
)
def test_bad_input_end_to_end(argv, fragment, tmp_path):
    if "/dev/full" in argv and not os.path.exists("/dev/full"):
        pytest.skip("needs /dev/full")
    result = _cli(*argv, cwd=tmp_path)
    assert result.returncode == 2
    assert fragment in result.stderr
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert result.stdout == ""
    assert list(tmp_path.iterdir()) == []


def test_no_arguments_end_to_end(tmp_path):
    result = _cli(cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.startswith("usage: slopewalk")


def test_a_trial_writes_strict_json_a_series_and_a_recording(tmp_path):
    out, series, record = tmp_path / "t.json", tmp_path / "t.npz", tmp_path / "t.rrd"
    result = _cli(
        "trial", "--step-time", "1", "--steps", "1", "--out", str(out), "--series",
        str(series), "--record", str(record), cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    json.loads(out.read_text(), parse_constant=pytest.fail)  # no NaN or Infinity
    assert record.stat().st_size > 0 and record.read_bytes()[:4] == b"RRF2"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.json", "t.npz", "t.rrd"]
    assert math.isfinite(json.loads(out.read_text())["zmp_rms"])


def test_a_walk_beyond_the_servo_says_so_with_no_numpy_warning(dirs, capsys):
    """0.33 s steps: the ground still pushes, but the ankle needs 1.15 x the stall torque
    and the ZMP is 1.5 m outside the foot; the summary says both, numpy says nothing."""
    root, _, out = dirs
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        code = main(["plan", "--step-time", "0.33", "--out", str(out / "p.npz")])
    printed = capsys.readouterr()
    assert code == 0, printed.err
    assert printed.err == ""
    assert (
        "beyond the robot: swing_ankle_roll needs 1.72 N m, 1.15 x the servo's stall torque "
        "1.5 N m (bioloid-8dof [servo])" in printed.out
    )
    assert (
        "beyond the robot: the ZMP leaves the support by 1.48 m, more than the robot is tall "
        "(0.254 m)" in printed.out
    )
    code = main(["plan", "--step-time", "1", "--out", str(out / "q.npz")])
    assert code == 0 and "beyond the robot" not in capsys.readouterr().out


def test_a_large_walk_says_its_size_first_and_is_refused_beyond_memory(dirs, capsys, monkeypatch):
    from slopewalk.planner import plan

    root, _, out = dirs
    argv = ["plan", "--step-time", "1", "--steps", "101", "--out", str(out / "p.npz")]
    monkeypatch.setattr(plan, "available_memory", lambda: 1e8)  # 100 MB: a 0.4 GB plan won't fit
    code, err, printed = _refused(argv, capsys)
    assert code == 2 and err.count("\n") == 1, err
    assert re.fullmatch(
        r"slopewalk: error: plan: 101,401 samples, about 0\.\d+ GB of memory \(0\.1 GB "
        r"available\) and \d+ s: does not fit in memory \([\d,]+ B per sample, measured on a "
        r"one-step walk\): fewer steps, shorter steps or a longer dt\n",
        err,
    ), err
    assert list(out.iterdir()) == [] and printed == ""
    monkeypatch.undo()
    code, err, printed = _refused(argv, capsys)
    assert code == 0, err
    assert re.fullmatch(r"plan: 101,401 samples, about 0\.\d+ GB of memory \([\d.]+ GB "
                        r"available\) and \d+ s\n", err), err  # fmt: skip
    assert "101401 samples" in printed


def test_slip_with_no_friction_limit_is_judged_without_a_warning():
    """mu = inf on a walk whose feet leave the ground (0.2 s steps): mu * 0 is 0, not NaN."""
    from slopewalk.planner.gait import GaitParams
    from slopewalk.planner.plan import plan_walk
    from slopewalk.planner.spec import load_spec
    from slopewalk.planner.verdict import slip_events

    spec = load_spec()
    walk = plan_walk(spec, GaitParams.nominal(spec, 0.2))
    assert walk.ground_force[:, 2].min() < 0  # the case: a normal force <= 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        events, slide = slip_events(walk, np.inf)
    assert np.all(np.isfinite(slide)) and all(e.kind == "slip" for e in events)


# Words that mislead: what a run prints says what it means, in the user's units.


def test_a_trial_summary_says_na_never_nan_and_names_the_margins_polygon(tmp_path, capsys):
    """A knee limited to 1.0 rad: the robot is lost while settling, so no loaded foot
    rocks during the walk and its largest tilt does not exist: 'n/a', as the fields
    beside it (it printed 'nan deg'). The simulated CoP's margin is measured against
    the *planned* support polygon, and the line says so."""
    robot = tmp_path / "knee.toml"
    robot.write_text(_spec("knee = [-0.10, 2.60]", "knee = [-0.10, 1.0]"))
    argv = [*PLAN, "--steps", "1", "--robot", str(robot), "--out", str(tmp_path / "t.json")]
    code, err, out = _refused(["trial", *argv[1:]], capsys)
    assert code == 0, err
    (simulated,) = [line for line in out.splitlines() if line.startswith("simulated:")]
    assert "loaded foot tilted up to n/a deg" in simulated
    assert "nan" not in out.lower()
    assert "min CoP margin     n/a mm (to the planned support polygon)" in simulated
