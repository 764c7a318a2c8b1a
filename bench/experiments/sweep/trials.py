"""The trials of a sweep: one trial's inputs and id, and the lazy set of a file's grids.

``SweepTrial`` is one trial as written in a sweep file (degrees at this edge);
its ``trial_id`` is a stable hash of everything that decides its outcome.
``TrialSet`` is the de-duplicated union of a file's grids, counted without
being listed and walked lazily, so a 10^6-trial grid costs no memory.
``sweep/config.py`` reads and checks the file and builds these.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from slopewalk.bench.actuators import DEFAULT_MODE
from slopewalk.bench.robot_import.model_file import ModelFile
from slopewalk.bench.sim.playback import HOLD_TIME, SETTLE_TIME
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.bench.tables.sweep import NOMINAL
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.spec import RobotSpec

TIMESTEP = 0.001  # [s], the simulation step of every sweep trial
CLOSING_DSP = 1 - GaitParams.ssp_fraction  # [steps] the double support that ends a walk


DRAW_BATCH = 64  # gaits drawn at once, the first admissible one taken
DRAW_ROUNDS = 16  # batches tried before a cell is refused
GAIT_FIELDS = ("hip_height", "swing_lift", "tilt", "pelvis_offset", "step_length", "sway_share")


@dataclass(frozen=True)
class GaitChoice:
    """Which gait a trial walks instead of its robot's nominal one.

    Either drawn (``family`` set): the ``index``-th gait drawn uniformly from the
    admissible part of the family's search box (``gait_search.GaitProblem`` of the trial's
    robot, step time and slope: reachable, every pitch joint within its limits, as the GA
    admits them; the first admissible one of batches of ``DRAW_BATCH`` uniform draws), by
    a generator seeded with ``draw_seed``, the gait's number and the trial's cell; or
    given (``values`` set): (field, value) pairs of ``GAIT_FIELDS`` in SI units and
    radians, e.g. an envelope's GA gait, ``source`` saying whose.

    Attributes:
        source: What the gait is, for the table's ``gait`` column ("paper draw 3",
            "envelope.csv maxmargin").
        family: "paper" or "extended" for a drawn gait, else "".
        index: The draw's number within its cell and family.
        draw_seed: The sweep's draw seed.
        values: The given gait's (field, value) pairs, else ().
    """

    source: str
    family: str = ""
    index: int = 0
    draw_seed: int = 0
    values: tuple[tuple[str, float], ...] = ()

    @property
    def key(self) -> str:
        """The text that identifies this choice in a ``trial_id``."""
        if self.family:
            return f"draw:{self.family}:{self.draw_seed}:{self.index}"
        return json.dumps(dict(self.values), sort_keys=True, default=float)

    def overrides(self, spec: RobotSpec, step_time: float, slope: float, cell: str) -> dict:
        """``GaitParams`` fields of this gait for a trial of ``spec`` at ``step_time`` [s] on
        ``slope`` [rad]; ``cell``: the text that seeds a draw with the trial's cell."""
        if not self.family:
            return dict(self.values)
        from slopewalk.planner.gait_search import FAMILIES, GaitProblem, ga_params

        problem = GaitProblem(spec, ga_params(spec, step_time, slope), family=self.family)
        bounds = problem.bounds
        text = f"{self.key}|{cell}".encode()
        rng = np.random.default_rng(int(hashlib.sha256(text).hexdigest()[:16], 16))
        for _ in range(DRAW_ROUNDS):
            x = bounds.xl + rng.random((DRAW_BATCH, bounds.xl.size)) * (bounds.xu - bounds.xl)
            ok = np.flatnonzero(problem.measure(x).admissible)
            if ok.size:
                return {n: float(v) for n, v in zip(FAMILIES[self.family], x[ok[0]], strict=True)}
        raise SlopewalkError(
            f"{self.source}: none of {DRAW_ROUNDS * DRAW_BATCH} gaits drawn from the "
            f"{self.family} family's box is admissible at {step_time:g} s on "
            f"{np.rad2deg(slope):g} deg (every one out of reach or past a joint limit)"
        )


def spec_text(spec: RobotSpec) -> str:
    """The robot's part of the ``trial_id`` text: its fields as sorted JSON."""
    return json.dumps(spec.as_dict(), sort_keys=True, default=float)


@dataclass(frozen=True)
class SweepTrial:
    """One trial of a sweep, with its inputs as written in the sweep file.

    Attributes:
        step_time: Step completion time [s].
        slope_deg: Plane inclination [deg].
        friction: Coulomb μ of the feet on the plane.
        actuators: A mode of ``bench.actuators.MODES``.
        robot: The spec path as written in the file, or "default".
        mass_scale: (group, factor) pairs in file order; () = no scaling.
        steps: Steps per walk.
        seed: One of the sweep's seeds, recorded with the row; it seeds the command noise.
        spec: The robot, mass scaling applied.
        controller: ``MODULE:CALLABLE`` of a closed-loop controller, or None (open loop).
        command_noise_deg: σ of the noise on every command row [deg], as written in the
            sweep file; 0: none.
        gait_choice: The gait walked instead of the nominal one (drawn or given), or None.
        model: The unmodified model the plan is played on (``sweep --model``), ``spec``
            its imported spec; None: the spec's twin.
        spec_end: ``"KEY:low"`` or ``"KEY:high"`` where ``spec`` has one value of its
            robot's ``[uncertain]`` table at that end (``sweep/config.py``), else
            ``"nominal"``.
        draw_spec: The spec a drawn gait is drawn on, where ``spec`` is at a spec end
            (the nominal one, mass scaling applied: a replica walks the nominal trial's
            gait); None: ``spec``. ``draw_json``: its ``spec_text``, made once per robot.
    """

    step_time: float
    slope_deg: float
    friction: float
    actuators: str
    robot: str
    mass_scale: tuple[tuple[str, float], ...]
    steps: int
    seed: int
    spec: RobotSpec = field(repr=False, compare=False)
    spec_json: str = field(default="", repr=False, compare=False)  # spec_text(spec), if known
    controller: str | None = None
    command_noise_deg: float = 0.0
    gait_choice: GaitChoice | None = None
    model: ModelFile | None = None
    spec_end: str = NOMINAL
    draw_spec: RobotSpec | None = field(default=None, repr=False, compare=False)
    draw_json: str = field(default="", repr=False, compare=False)

    @cached_property
    def trial_id(self) -> str:
        """12 hex digits of a SHA-256 over the inputs that decide the outcome (module doc).

        The hashed text is ``json.dumps`` (keys sorted) of the inputs with the
        spec as a dict; the spec's part is made once per robot (``spec_text``)
        and set in, which gives the same text at a fraction of the cost.
        """
        key = {
            "step_time": self.step_time,
            "slope_deg": self.slope_deg,
            "friction": self.friction,
            "actuators": self.actuators,
            "steps": self.steps,
            "seed": self.seed,
            "timestep": TIMESTEP,
            "spec": "\0",
        }
        if self.controller is not None:  # only then: open-loop ids stay what they were
            key["controller"] = self.controller
        if self.command_noise_deg:  # likewise: ids without noise stay what they were
            key["command_noise_deg"] = self.command_noise_deg
        if self.gait_choice is not None:  # likewise: nominal gaits keep their ids
            key["gait"] = self.gait_choice.key
        if self.model is not None:  # likewise: the twin's ids stay; the files' digest, not path
            key["model"] = self.model.digest
        text = json.dumps(key, sort_keys=True, default=float)
        text = text.replace('"\\u0000"', self.spec_json or spec_text(self.spec), 1)
        return hashlib.sha256(text.encode()).hexdigest()[:12]

    @property
    def plan_group(self) -> tuple:
        """Which trials walk one plan (``Batch.group``): the plan's inputs, not the actuators,
        the seed and the command noise, which only play it, nor the friction, but where the
        gait is drawn (a draw is seeded by its cell, friction included: ``GaitChoice``).
        A hint: the worker's plan memo (``run.plan_of``) is keyed by the spec and the gait
        themselves."""
        drawn = self.gait_choice is not None and bool(self.gait_choice.family)
        return (
            self.friction if drawn else None,
            self.step_time,
            self.slope_deg,
            self.robot,
            self.mass_scale,
            self.steps,
            self.spec_end,
            None if self.gait_choice is None else self.gait_choice.key,
            None if self.model is None else self.model.digest,
        )

    @property
    def mass_scale_text(self) -> str:
        """``"legs=2"``, ``"all=10;legs=2"``, or ``"none"``."""
        return ";".join(f"{g}={f:g}" for g, f in self.mass_scale) or "none"

    @property
    def label(self) -> str:
        """Short human description, e.g. ``T=0.5 s slope=0 mu=0.6``."""
        text = f"T={self.step_time:g} s slope={self.slope_deg:g} mu={self.friction:g}"
        if self.actuators != DEFAULT_MODE:
            text += f" {self.actuators}"
        if self.mass_scale:
            text += f" mass {self.mass_scale_text}"
        if self.robot != "default":
            text += f" robot {self.robot}"
        if self.controller is not None:
            text += f" controller {self.controller.rpartition(':')[2]}"
        if self.command_noise_deg:
            text += f" noise {self.command_noise_deg:g} deg seed {self.seed}"
        if self.gait_choice is not None:
            text += f" gait {self.gait_choice.source}"
        if self.model is not None:
            text += f" model {self.model.name}"
        if self.spec_end != NOMINAL:
            text += f" spec {self.spec_end}"
        return text

    @cached_property
    def _overrides(self) -> dict:
        """The gait's fields beside the nominal ones (``gait_choice``); {} for the nominal gait."""
        if self.gait_choice is None:
            return {}
        if self.draw_spec is None:
            spec, text = self.spec, self.spec_json or spec_text(self.spec)
        else:  # a spec end's replica walks the nominal trial's gait
            spec, text = self.draw_spec, self.draw_json
        cell = json.dumps([self.step_time, self.slope_deg, self.friction, text])
        slope = float(np.deg2rad(self.slope_deg))
        return self.gait_choice.overrides(spec, self.step_time, slope, cell)

    def gait(self) -> GaitParams:
        """The gait of this trial: the nominal one, or ``gait_choice``'s (radians from here on)."""
        return GaitParams.nominal(
            self.spec,
            self.step_time,
            slope=float(np.deg2rad(self.slope_deg)),
            steps=self.steps,
            **self._overrides,
        )

    def trial_spec(self) -> TrialSpec:
        return TrialSpec(
            self.gait(),
            friction=self.friction,
            actuators=self.actuators,
            timestep=TIMESTEP,
            controller=self.controller,
            command_noise=float(np.deg2rad(self.command_noise_deg)),
            noise_seed=int(self.trial_id, 16),  # the seed, and everything else, hashed
        )

    def inputs(self) -> dict:
        """The input columns of this trial's row."""
        return (
            {
                "trial_id": self.trial_id,
                "step_time": self.step_time,
                "slope_deg": self.slope_deg,
                "friction": self.friction,
                "actuators": self.actuators,
                "robot": self.robot,
                "mass_scale": self.mass_scale_text,
                "steps": self.steps,
                "seed": self.seed,
                "controller": self.controller or "none",  # written only by closed-loop sweeps
                "command_noise_deg": self.command_noise_deg,  # written only by noisy sweeps
                "spec_end": self.spec_end,  # written only by sweeps with spec_ends
            }
            | self.gait_inputs()
            | model_inputs(self.model)
        )

    def gait_inputs(self) -> dict:
        """The gait's columns (written only by sweeps of drawn or given gaits): its source and
        every ``GAIT_FIELDS`` value of the gait walked (tilt in degrees)."""
        if self.gait_choice is None:
            return {"gait": "nominal"}
        try:
            params = self.gait()
        except SlopewalkError:  # an error row's inputs: its message says why
            return {"gait": self.gait_choice.source}
        return {
            "gait": self.gait_choice.source,
            "hip_height_m": params.hip_height,
            "swing_lift_m": params.swing_lift,
            "tilt_deg": float(np.rad2deg(params.tilt)),
            "pelvis_offset_m": params.pelvis_offset,
            "step_length_m": params.step_length,
            "sway_share": params.lean_share,
        }


def model_inputs(model: ModelFile | None) -> dict:
    """The model's columns of a row (written only by runs on a model): its name and the
    first digits of its files' digest (``robot_import.model_file``)."""
    if model is None:
        return {}
    return {"model": model.name, "model_digest": model.short_digest}


@dataclass(frozen=True)
class Body:
    """A robot as one grid value: the spec file, its mass scaling, the scaled spec, and the
    spec end it is at (``SweepTrial.spec_end``, ``draw_spec``)."""

    robot: str
    mass_scale: tuple[tuple[str, float], ...]
    spec: RobotSpec = field(repr=False)
    spec_json: str = field(repr=False)  # its part of the trial_id text
    spec_end: str = NOMINAL
    draw_spec: RobotSpec | None = field(default=None, repr=False)
    draw_json: str = field(default="", repr=False)  # draw_spec's part of a draw's seed


AXES = ("step_time", "slope", "friction", "actuators", "body", "controller", "gait", "seed")


@dataclass(frozen=True)
class Box:
    """One ``[grid]`` (or one ``[[trial]]``, a box of single values): checked values per axis.

    ``values[k]`` holds (identity key, value) pairs of axis ``AXES[k]`` in file
    order, duplicates (same key) dropped; the keys decide a trial's ``trial_id``,
    so two trials are the same trial exactly when all their keys are equal.
    """

    where: str
    values: tuple[tuple[tuple[str, object], ...], ...]

    @cached_property
    def keys(self) -> tuple[frozenset, ...]:
        return tuple(frozenset(k for k, _ in axis) for axis in self.values)

    @property
    def size(self) -> int:
        return math.prod(len(axis) for axis in self.values)

    def holds(self, keys: tuple[str, ...]) -> bool:
        return all(k in s for k, s in zip(keys, self.keys, strict=True))

    def meet(self, other: Box) -> tuple[frozenset, ...] | None:
        """The key sets of the intersection with ``other``, or None if empty."""
        out = tuple(a & b for a, b in zip(self.keys, other.keys, strict=True))
        return out if all(out) else None


def _union_size(boxes: list[tuple[frozenset, ...]]) -> int:
    """Number of distinct points in a union of boxes (per-axis key sets), by inclusion-exclusion.

    Each box adds its points not in the earlier ones; the earlier ones it meets
    are few in any real sweep file, so the recursion stays small.
    """
    total = 0
    for i, box in enumerate(boxes):
        meets = []
        for other in boxes[:i]:
            both = tuple(a & b for a, b in zip(box, other, strict=True))
            if all(both):
                meets.append(both)
        total += math.prod(len(s) for s in box) - _union_size(meets)
    return total


class TrialSet(Sequence):
    """The trials of a sweep, in file order, unique by ``trial_id``, made as they are taken.

    Nothing is expanded up front: ``len()`` counts the union of the grids
    without listing it, and iterating walks each grid's product lazily,
    skipping a trial an earlier grid (or ``[[trial]]``) already holds. A
    10^6-trial grid costs its size in time only when it is walked, and no memory.
    Indexing walks from the start (for tests and small sweeps).
    """

    def __init__(
        self,
        boxes: tuple[Box, ...],
        steps: int,
        command_noise_deg: float = 0.0,
        model: ModelFile | None = None,
    ):
        self._boxes, self._steps, self._noise = boxes, steps, command_noise_deg
        self._model = model

    @cached_property
    def _len(self) -> int:
        return _union_size([box.keys for box in self._boxes])

    def __len__(self) -> int:
        return self._len

    def __iter__(self) -> Iterator[SweepTrial]:
        for i, box in enumerate(self._boxes):
            earlier = [b for b in self._boxes[:i] if box.meet(b) is not None]
            for combo in itertools.product(*box.values):
                if earlier and any(b.holds(tuple(k for k, _ in combo)) for b in earlier):
                    continue
                yield self.make([v for _, v in combo])

    def __getitem__(self, index):
        if isinstance(index, slice):
            return list(itertools.islice(self, *index.indices(len(self))))
        if index < 0:
            index += len(self)
        if not 0 <= index < len(self):
            raise IndexError(index)
        return next(itertools.islice(self, index, None))

    def make(self, values: list) -> SweepTrial:
        """The trial of one value per axis (``AXES`` order)."""
        step_time, slope, friction, actuators, body, controller, gait, seed = values
        return SweepTrial(
            step_time,
            slope,
            friction,
            actuators,
            body.robot,
            body.mass_scale,
            self._steps,
            seed,
            body.spec,
            body.spec_json,
            controller,
            self._noise,
            gait,
            self._model,
            body.spec_end,
            body.draw_spec,
            body.draw_json,
        )

    def simulated_steps(self) -> float:
        """Estimated MuJoCo steps of all trials (settle + walk + hold at ``TIMESTEP``).

        The sum over the grids as written, scaled by the share of distinct
        trials (grids that overlap count their common trials once).
        """
        written = total = 0.0
        for box in self._boxes:
            per_time = sum(
                (SETTLE_TIME + HOLD_TIME + t * (self._steps + CLOSING_DSP)) / TIMESTEP
                for _, t in box.values[0]
            )
            total += per_time * box.size / len(box.values[0])
            written += box.size
        return total * len(self) / written if written else 0.0
