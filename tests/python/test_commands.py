"""The yamor-* commands of tools/python/pyproject.toml name functions that exist, and
the old script paths under tools/ (named by docs and scripts) still run their tool."""

from __future__ import annotations

import importlib
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
tomllib = pytest.importorskip("tomllib")  # Python 3.11
SCRIPTS = tomllib.loads((REPO / "tools" / "python" / "pyproject.toml").read_text())["project"]["scripts"]
# Old path -> the command it stands for.
OLD_PATHS = {
    "tools/reproduce/reproduce.py": "yamor-reproduce",
    "tools/bench/learning_bench.py": "yamor-learning-bench",
    "tools/bench/generated_bench.py": "yamor-generated-bench",
    "tools/bench/lifelong_bench.py": "yamor-lifelong-bench",
    "tools/bench/film_bench.py": "yamor-film-bench",
    "tools/bench/physics_compare.py": "yamor-physics-compare",
    "tools/mjcf/mujoco_eval.py": "yamor-mujoco-eval",
    "tools/soak/soak.py": "yamor-soak",
    "tools/plot/plot_progress.py": "yamor-plot-progress",
    "tools/plot/plot_landscape.py": "yamor-plot-landscape",
    "tools/plot/plot_timeline.py": "yamor-plot-timeline",
    "tools/plot/plot_setpoints.py": "yamor-plot-setpoints",
    "tools/characterize/plot_characterize.py": "yamor-plot-characterize",
}
NEEDS = {"yamor-mujoco-eval": "mujoco"}


def test_every_tool_module_has_a_command():
    modules = {p.stem for p in (REPO / "tools" / "python" / "yamor" / "tools").glob("*.py")}
    # daemons: the tools' shared pool; soak_client: started by yamor-soak.
    commanded = {target.split(":")[0].rsplit(".", 1)[1] for target in SCRIPTS.values()}
    assert modules - {"__init__", "daemons", "soak_client"} == commanded
    assert sorted(OLD_PATHS.values()) == sorted(SCRIPTS)


@pytest.mark.parametrize("command", sorted(SCRIPTS))
def test_a_command_names_a_function(command):
    if command in NEEDS:
        pytest.importorskip(NEEDS[command])
    pytest.importorskip("matplotlib")
    module, function = SCRIPTS[command].split(":")
    assert callable(getattr(importlib.import_module(module), function))


@pytest.mark.parametrize("path", sorted(OLD_PATHS))
def test_an_old_path_runs_its_tool(path, tmp_path):
    command = OLD_PATHS[path]
    if command in NEEDS:
        pytest.importorskip(NEEDS[command])
    pytest.importorskip("matplotlib")
    result = subprocess.run([sys.executable, str(REPO / path), "--help"], cwd=tmp_path,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    # argparse's usage line names the program; the help is the module's own.
    module = importlib.import_module(SCRIPTS[command].split(":")[0])
    assert "usage:" in result.stdout
    assert module.__doc__.strip().splitlines()[0].split(":")[0][:40] in result.stdout.replace("\n", " ")
