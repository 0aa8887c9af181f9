"""Runs a YaMoR robot exported by yamor-mjcf-export in MuJoCo, open loop.

Usage: yamor-mujoco-eval --model ROBOT.mjcf.xml --setpoints ROBOT.setpoints.csv
                         [--repeats 5] [--warmup 8] [--skip 0] [--method rollout|loop]
                         [--json OUT]

The set-point CSV is what `physics_bench --export=ROBOT` writes: a header
`step,<id>,<id>,...` and, for each step k = 1..N, the servo set-point (rad) the
gait hands to every module before step k, computed by yamor's own CPG code at
the model's step. Each row becomes the control of actuator `servo<id>` for one
mj_step, exactly as physics::World gets it, so MuJoCo replays the same gait.

Each repeat resets the model and simulates all N steps; its wall time (and the
thread's CPU time) covers the stepping only, not the XML compile (reported
apart), and not the first --skip seconds (for steps/s of a running gait). `rollout` (default) steps in C through mujoco.rollout, so Python adds
nothing per step; `loop` calls mj_step from Python, for comparison.

Reported: median wall and CPU time over the repeats, steps/s, and the
horizontal distance of the central module (the root body's free joint)
between t = warm-up and the end (8 s to 20 s for a 20-s CSV), as in
DESIGN.md's gait velocity. Divergence: non-finite state or a MuJoCo
instability warning.
"""
import argparse
import csv
import json
import statistics
import sys
import time

import numpy as np

import mujoco
from mujoco import rollout


def read_setpoints(path, model):
    """Returns an (N, nu) control array ordered as the model's actuators."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        if not header or header[0] != "step":
            raise ValueError(f"{path}: expected a header 'step,<id>,...', got {header!r}")
        rows = np.array([[float(cell) for cell in row] for row in reader])
    if rows.size == 0:
        raise ValueError(f"{path}: no rows")
    column = {f"servo{module}": i + 1 for i, module in enumerate(header[1:])}
    controls = np.zeros((rows.shape[0], model.nu))
    for a in range(model.nu):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a)
        if name not in column:
            raise ValueError(f"{path}: no column for actuator {name}")
        controls[:, a] = rows[:, column[name]]
    return controls


def unstable(data):
    return any(data.warning[w].number > 0 for w in (mujoco.mjtWarning.mjWARN_BADQACC,
                                                    mujoco.mjtWarning.mjWARN_BADQPOS,
                                                    mujoco.mjtWarning.mjWARN_BADQVEL))


def run_once(model, data, controls, warmup_steps, skip_steps, method):
    """One run from the initial state: the first skip_steps untimed, the rest
    timed. Returns (wall, cpu, p_warm, p_end, diverged)."""
    mujoco.mj_resetData(model, data)
    steps = controls.shape[0]
    positions = {}
    if method == "rollout":
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        state = np.empty(mujoco.mj_stateSize(model, spec))
        mujoco.mj_getState(model, data, state, spec)
        # State layout: time, then qpos (the root's free joint position first).
        states = np.empty((1, steps, state.size))
        if skip_steps > 0:
            rollout.rollout(model, data, state, controls[None, :skip_steps],
                            state=states[:, :skip_steps])
            state = states[0, skip_steps - 1].copy()
        wall0, cpu0 = time.perf_counter(), time.thread_time()
        rollout.rollout(model, data, state, controls[None, skip_steps:],
                        state=states[:, skip_steps:])
        wall, cpu = time.perf_counter() - wall0, time.thread_time() - cpu0
        p_warm = states[0, warmup_steps - 1, 1:4].copy()
        p_end = states[0, -1, 1:4].copy()
        diverged = not np.all(np.isfinite(states[0, -1])) or unstable(data)
    else:
        def step(k):
            data.ctrl[:] = controls[k]
            mujoco.mj_step(model, data)
            if k + 1 == warmup_steps:
                positions["warm"] = data.qpos[0:3].copy()
        for k in range(skip_steps):
            step(k)
        wall0, cpu0 = time.perf_counter(), time.thread_time()
        for k in range(skip_steps, steps):
            step(k)
        wall, cpu = time.perf_counter() - wall0, time.thread_time() - cpu0
        p_warm = positions["warm"]
        p_end = data.qpos[0:3].copy()
        diverged = not np.all(np.isfinite(data.qpos)) or unstable(data)
    return wall, cpu, p_warm, p_end, diverged


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", required=True, help="MJCF from yamor-mjcf-export")
    parser.add_argument("--setpoints", required=True, help="CSV from physics_bench --export")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--warmup", type=float, default=8.0, help="s before the distance starts")
    parser.add_argument("--skip", type=float, default=0.0,
                        help="s simulated untimed before the timed part (steps/s runs)")
    parser.add_argument("--method", choices=("rollout", "loop"), default="rollout")
    parser.add_argument("--json", help="write the result here as JSON")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be >= 1")

    t0 = time.perf_counter()
    model = mujoco.MjModel.from_xml_path(args.model)
    compile_s = time.perf_counter() - t0
    data = mujoco.MjData(model)
    controls = read_setpoints(args.setpoints, model)
    steps = controls.shape[0]
    h = model.opt.timestep
    warmup_steps = min(steps, max(1, round(args.warmup / h)))
    skip_steps = min(steps - 1, max(0, round(args.skip / h)))
    if model.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE:
        raise ValueError(f"{args.model}: the first joint must be the root's free joint")

    walls, cpus, distances, diverged = [], [], [], False
    for _ in range(args.repeats):
        wall, cpu, p_warm, p_end, bad = run_once(model, data, controls, warmup_steps, skip_steps,
                                                  args.method)
        walls.append(wall)
        cpus.append(cpu)
        distances.append(float(np.linalg.norm((p_end - p_warm)[:2])))
        diverged = diverged or bad
    result = {
        "model": args.model,
        "method": args.method,
        "mujoco": mujoco.__version__,
        "time_step": h,
        "steps": steps,
        "timed_steps": steps - skip_steps,
        "simulated_s": steps * h,
        "repeats": args.repeats,
        "compile_s": compile_s,
        "wall_s": walls,
        "cpu_s": cpus,
        "median_wall_s": statistics.median(walls),
        "median_cpu_s": statistics.median(cpus),
        "steps_per_s": (steps - skip_steps) / statistics.median(walls),
        "steps_per_cpu_s": (steps - skip_steps) / statistics.median(cpus),
        "distance_m": distances[0],
        "distance_spread_m": max(distances) - min(distances),
        "diverged": bool(diverged),
        "bodies": model.nbody - 1,
        "joints": model.njnt,
    }
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)
    print(f"{args.model}: {steps} steps of {h} s, median {result['median_wall_s']:.3f} s wall "
          f"({result['steps_per_s']:,.0f} steps/s timed), distance {result['distance_m']:.4f} m"
          f"{', DIVERGED' if diverged else ''}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
