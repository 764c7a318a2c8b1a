"""One import root owned by the project: ``slopewalk``, with planner/ and bench/ under it.

A distribution or a folder named ``planner`` or ``bench`` (PyPI has both names) may sit
anywhere on ``sys.path`` without touching the bench: nothing imports those names.
``.ci/run`` also installs PyPI's real ``planner`` distribution ahead of the project.
"""

import ast
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import slopewalk

ROOT = Path(__file__).resolve().parents[1]
FOREIGN = ("planner", "bench")


def _pyproject() -> dict:
    with open(ROOT / "pyproject.toml", "rb") as f:
        return tomllib.load(f)


def test_the_package_list_is_every_folder_with_an_init():
    setuptools = _pyproject()["tool"]["setuptools"]
    roots = setuptools["package-dir"]
    found = set()
    for name, folder in roots.items():
        for init in (ROOT / folder).rglob("__init__.py"):
            if "__pycache__" in init.parts:
                continue
            parts = init.parent.relative_to(ROOT / folder).parts
            found.add(".".join((name, *parts)))
    assert sorted(setuptools["packages"]) == sorted(found)


def test_no_module_imports_a_top_level_planner_or_bench():
    offenders = []
    for folder in ("slopewalk", "planner", "bench", "tests"):
        for path in (ROOT / folder).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Import):
                    names = [alias.name for alias in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0:
                    names = [node.module or ""]
                else:
                    continue
                offenders += [
                    f"{path.relative_to(ROOT)}:{node.lineno} {name}"
                    for name in names
                    if name.split(".")[0] in FOREIGN
                ]
    assert offenders == []


def test_foreign_planner_and_bench_packages_break_nothing(tmp_path):
    """Packages named planner and bench first on sys.path and in the working directory."""
    for name in FOREIGN:
        (tmp_path / name).mkdir()
        (tmp_path / name / "__init__.py").write_text(f"raise ImportError('foreign {name}')\n")
    code = (
        "import slopewalk, slopewalk.bench.sim.model, slopewalk.bench.cli;"
        "spec = slopewalk.load_spec();"
        "plan = slopewalk.plan_walk(spec, slopewalk.GaitParams(step_time=1.0, steps=1));"
        "print(plan.stable)"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(tmp_path)},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() in ("True", "False")


def test_the_public_api_names_what_it_loads():
    assert sorted(slopewalk.__all__) == sorted(slopewalk._API)
    for name in slopewalk.__all__:
        value = getattr(slopewalk, name)
        assert value is getattr(sys.modules[slopewalk._API[name]], name)


def test_the_api_loads_without_mujoco():
    code = (
        "import sys; sys.modules['mujoco'] = None; import slopewalk;"
        "slopewalk.load_spec(); slopewalk.GaitParams; slopewalk.plan_walk; slopewalk.Plan"
    )
    assert subprocess.run([sys.executable, "-c", code], timeout=300).returncode == 0


def test_the_readme_snippet_runs():
    text = (ROOT / "README.md").read_text()
    section = text.split("## Python API", 1)[1]
    snippet = section.split("```python\n", 1)[1].split("```", 1)[0]
    done = subprocess.run(
        [sys.executable, "-c", snippet], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    analytic, simulated = done.stdout.splitlines()
    assert analytic.startswith("analytic: ")
    assert simulated.split()[0] in ("stable", "tip", "slip", "fall", "diverged", "torque_limit")
