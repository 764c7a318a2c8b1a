"""An imported model as a batch job carries it: ``sweep``/``envelope --model``.

A job travels to a worker (a local worker process or a Dask cluster's) as a pickle,
so it carries the model by name, never as a compiled ``MjModel``: the model file's and
the map file's **absolute** paths (a worker's working directory is not the client's)
and a sha256 over their contents (``digest``). A worker fits the model from those paths
once per process (``scene``), after checking the files there still have that digest: a
model edited (or a different file at that path on a cluster's machine) while a sweep runs
makes that job's row an error naming both digests, never a row of another model. The
digest enters every ``trial_id`` and ``cell_id`` of a run on a model, so a resumed run
never mixes rows of two models (or of one model under two map files).

The digest covers the model file and the map file only, not the files an MJCF
``<include>``\\ s or its meshes: a model split over several files is identified by its
main file.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from slopewalk.bench.digest import sha256
from slopewalk.bench.robot_import.mapfile import RobotImportError

if TYPE_CHECKING:
    from slopewalk.bench.robot_import.scene import ModelScene
    from slopewalk.planner.spec import RobotSpec

DIGEST_DIGITS = 16  # hex digits of the digest written in a table's ``model_digest`` column


@dataclass(frozen=True)
class ModelFile:
    """A model and its map file by absolute path and content digest (module doc).

    Attributes:
        path: The MJCF or URDF file, absolute.
        map_path: Its map file, absolute, or None (detect everything).
        digest: sha256 (hex) over the model's and the map's bytes (``contents_digest``).
        name: The model's name (the map's ``name``, else MuJoCo's model name, else the
            file's stem), marking every row played on it.
    """

    path: str
    map_path: str | None
    digest: str
    name: str

    @classmethod
    def of(cls, path, map_path=None) -> ModelFile:
        """The model at ``path`` (relative to the working directory, or absolute) with
        the map at ``map_path``, fitted once here so that a model or map the planner
        cannot use is refused before any job runs.

        Raises:
            RobotImportError: a file missing, unreadable, or a model that does not fit,
                in one line naming it.
        """
        from slopewalk.bench.robot_import.scene import model_scene

        model = Path(path).absolute()
        mapped = None if map_path is None else Path(map_path).absolute()
        for flag, file in (("model", model), ("map file", mapped)):
            if file is not None and not file.is_file():
                raise RobotImportError(f"{flag} {str(file)!r}: no such file")
        digest = contents_digest(model, mapped)  # before the fit: the bytes it reads
        scene = model_scene(model, mapped)
        out = cls(str(model), None if mapped is None else str(mapped), digest, scene.name)
        _SCENES[out] = scene  # this process needs not fit it again
        return out

    @property
    def short_digest(self) -> str:
        """``sha256:`` and the digest's first ``DIGEST_DIGITS`` hex digits, for tables and
        messages (the prefix keeps a table reader from taking the digits for a number)."""
        return f"sha256:{self.digest[:DIGEST_DIGITS]}"

    def check(self) -> None:
        """Raise unless the files at ``path`` and ``map_path`` still have ``digest``."""
        try:
            now = contents_digest(self.path, self.map_path)
        except OSError as err:
            raise RobotImportError(
                f"model {self.path!r} (map {self.map_path!r}): unreadable here "
                f"({err.strerror or err}); a worker needs the files at the same absolute path"
            ) from None
        if now != self.digest:
            raise RobotImportError(
                f"model {self.path!r} (map {self.map_path!r}): its files' sha256 is "
                f"sha256:{now[:DIGEST_DIGITS]} here, not {self.short_digest} as when the run "
                "started: the model or map changed (or differs on this machine)"
            )

    def scene(self, spec: RobotSpec | None = None) -> ModelScene:
        """The model's trial scene with ``spec`` as the plan's robot (None: the spec
        imported now), its files checked first; fitted once per process and spec."""
        self.check()
        fitted = _fitted(self)
        return fitted if spec is None else replace(fitted, spec=spec)


_SCENES: dict[ModelFile, ModelScene] = {}  # per process: a model is fitted once


def _fitted(model: ModelFile) -> ModelScene:
    from slopewalk.bench.robot_import.scene import model_scene

    if model not in _SCENES:
        _SCENES[model] = model_scene(model.path, model.map_path)
    return _SCENES[model]


def contents_digest(path, map_path=None) -> str:
    """sha256 (hex) over the model's bytes' sha256 and the map's ("" without a map)."""
    text = f"model {sha256(path)}\nmap {sha256(map_path) if map_path else ''}\n"
    return hashlib.sha256(text.encode()).hexdigest()
