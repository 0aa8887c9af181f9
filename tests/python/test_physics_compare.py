"""yamor-physics-compare (yamor.tools.physics_compare) and its MuJoCo side,
yamor-mujoco-eval (yamor.tools.mujoco_eval): the benchmark JSON it reads, its
tables, a robot replayed open loop in MuJoCo, and (with a bench build) one
small comparison end to end."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from yamor.tools import physics_compare

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("YAMOR_BUILD", REPO / "build" / "release"))
STEP = 0.002

# One free body (the "central module") and a leg on a position servo, like
# yamor-mjcf-export's models: the root's free joint first, actuators servo<id>.
MODEL = f"""<mujoco model="hopper">
  <option timestep="{STEP}"/>
  <worldbody>
    <geom type="plane" size="5 5 0.1"/>
    <body name="module0" pos="0 0 0.1">
      <freejoint/>
      <geom type="box" size="0.05 0.05 0.02" mass="0.1"/>
      <body name="module1" pos="0.06 0 0">
        <joint name="hinge1" type="hinge" axis="0 1 0" range="-1.5 1.5"/>
        <geom type="capsule" fromto="0 0 0 0.08 0 -0.06" size="0.01" mass="0.05"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="servo1" joint="hinge1" kp="2"/>
  </actuator>
</mujoco>
"""


def write_robot(folder: Path, seconds: float = 2.0) -> tuple[Path, Path]:
    model, setpoints = folder / "hopper.mjcf.xml", folder / "hopper.setpoints.csv"
    model.write_text(MODEL)
    steps = round(seconds / STEP)
    rows = ["step,1"] + [f"{k},{0.8 * math.sin(2 * math.pi * 2 * k * STEP)!r}" for k in range(1, steps + 1)]
    setpoints.write_text("\n".join(rows) + "\n")
    return model, setpoints


def test_parse_bench_keeps_medians_and_single_runs(tmp_path):
    path = tmp_path / "bench.json"
    path.write_text(json.dumps({"benchmarks": [
        {"run_name": "physics_quadruped_eval/2000us/iterations:1", "run_type": "aggregate",
         "aggregate_name": "mean", "real_time": 9.0},
        {"run_name": "physics_quadruped_eval/2000us/iterations:1", "run_type": "aggregate",
         "aggregate_name": "median", "real_time": 5.0},
        {"run_name": "physics_snake_step/8/min_time:0.500", "run_type": "iteration",
         "real_time": 2.0},
    ]}))
    parsed = physics_compare.parse_bench(path)
    assert set(parsed) == {"physics_quadruped_eval/2000us", "physics_snake_step/8"}
    assert parsed["physics_quadruped_eval/2000us"]["real_time"] == 5.0


def test_table_is_markdown_with_aligned_columns():
    text = physics_compare.table(["engine", "CPU ms"], [["yamor", 12], ["MuJoCo", 3]])
    assert text.splitlines() == [
        "| engine | CPU ms |",
        "|--------|--------|",
        "|  yamor |     12 |",
        "| MuJoCo |      3 |",
    ]
    assert physics_compare.fmt_steps(0.002) == "2 ms"


def test_mujoco_replays_the_setpoints_the_same_in_c_and_in_python(tmp_path):
    pytest.importorskip("mujoco")
    model, setpoints = write_robot(tmp_path)
    results = {}
    for method in ("rollout", "loop"):
        out = tmp_path / f"{method}.json"
        # Through the old path physics_compare's documentation names, run as a file.
        result = subprocess.run([sys.executable, str(REPO / "tools" / "mjcf" / "mujoco_eval.py"),
                                 "--model", str(model), "--setpoints", str(setpoints),
                                 "--repeats", "2", "--warmup", "0.5", "--method", method,
                                 "--json", str(out)], capture_output=True, text=True, timeout=120)
        assert result.returncode == 0, result.stderr
        results[method] = json.loads(out.read_text())
    rollout, loop = results["rollout"], results["loop"]
    assert rollout["steps"] == loop["steps"] == 1000
    assert rollout["time_step"] == STEP and rollout["simulated_s"] == pytest.approx(2.0)
    assert (rollout["bodies"], rollout["joints"]) == (2, 2)
    assert not rollout["diverged"] and not loop["diverged"]
    assert rollout["distance_m"] > 0.001, "the leg moves the body"
    assert rollout["distance_spread_m"] == 0.0, "a repeat starts from the same state"
    assert loop["distance_m"] == pytest.approx(rollout["distance_m"], rel=1e-9)


def test_mujoco_eval_refuses_setpoints_without_the_actuators_column(tmp_path):
    pytest.importorskip("mujoco")
    model, setpoints = write_robot(tmp_path, seconds=0.1)
    setpoints.write_text(setpoints.read_text().replace("step,1", "step,7", 1))
    result = subprocess.run([sys.executable, "-m", "yamor.tools.mujoco_eval", "--model", str(model),
                             "--setpoints", str(setpoints)], capture_output=True, text=True, timeout=120)
    assert result.returncode != 0
    assert "no column for actuator servo1" in result.stderr


def test_a_small_comparison_end_to_end(tmp_path):
    pytest.importorskip("mujoco")
    for binary in (BUILD / "tools" / "bench" / "physics_bench",
                   BUILD / "tools" / "mjcf" / "yamor-mjcf-export"):
        if not binary.is_file():
            pytest.skip(f"not built: {binary} (a build with -DYAMOR_BUILD_BENCH=ON)")
    markdown = tmp_path / "physics.md"
    result = subprocess.run([sys.executable, "-m", "yamor.tools.physics_compare", str(BUILD),
                             "--step", "0.004", "--repeats", "1", "--sweep", "0.004",
                             "--sweep-gaits", "0", "--snakes", "8", "--snake-window", "0.1",
                             "--markdown", str(markdown)],
                            capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stdout + result.stderr
    text = markdown.read_text()
    assert text in result.stdout
    for heading in ("### Quadruped, one 20-s evaluation (8 s warm-up + 12 s) at 4 ms",
                    "### Step size: quadruped distance", "### Snakes: steps per CPU-second at 4 ms"):
        assert heading in text
    engines = [line.split("|")[1].strip() for line in text.splitlines()
               if line.startswith("| ") and "bodies" not in line and "engine" not in line][:4]
    assert engines == ["yamor (bridge path)", "naive ODE", "yamor, iterative solver", "MuJoCo"]
