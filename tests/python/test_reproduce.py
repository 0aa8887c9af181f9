"""yamor-reproduce and yamor-learning-bench (yamor.tools) in --quick mode.

Each figure command runs against the real build (yamord + yamor-optimize +
plugins) with tiny settings (4x4 landscape, budgets of 10, 1 s warm-up + 2 s
walk) and the PNG and CSV files are checked: they exist, the images load,
the CSVs have the rows the settings imply and no NaN. Also: Ctrl-C stops the
daemons the script started, and the learning benchmark writes its table.

The build is $YAMOR_BUILD, else the one $YAMORD lives in (build/release).
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from conftest import REPO, YAMORD

from yamor.launcher import start_daemons
from yamor.tools import learning_bench

image = pytest.importorskip("matplotlib.image")

BUILD = Path(os.environ.get("YAMOR_BUILD", YAMORD.parent.parent))
OPTIMIZE = BUILD / "optimizer-plugins" / "yamor-optimize"
REPRODUCE = "yamor.tools.reproduce"
BENCH = "yamor.tools.learning_bench"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def built():
    """Skips the test when the build lacks a binary or plugin it needs."""
    for path in (BUILD / "host" / "yamord", OPTIMIZE, BUILD / "plugins" / "powell.so",
                 BUILD / "plugins" / "grid.so"):
        if not path.exists():
            pytest.skip(f"not built: {path} (make build, or set YAMOR_BUILD)")


def run_tool(module: str, *args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """Runs a tool (python -m `module`) against BUILD; without --hosts it starts 2 daemons of its own."""
    result = subprocess.run([sys.executable, "-m", module, *args, "--build", str(BUILD), "--daemons", "2"],
                            cwd=REPO, capture_output=True, text=True, timeout=timeout)
    assert result.returncode == 0, f"exit {result.returncode}\n{result.stdout}\n{result.stderr}"
    return result


def read_csv(path: Path) -> tuple[list[str], list[list[str]]]:
    text = path.read_text()
    assert "nan" not in text.lower() and "inf" not in text.lower(), path
    rows = list(csv.reader(text.splitlines()))
    return rows[0], rows[1:]


def check_png(path: Path) -> None:
    assert path.read_bytes()[:8] == PNG_SIGNATURE, path
    pixels = image.imread(path)
    assert pixels.shape[0] > 300 and pixels.shape[1] > 500, (path, pixels.shape)
    assert pixels.std() > 0.05, f"{path} looks blank"


@pytest.fixture(scope="module")
def landscape_out(built, tmp_path_factory):
    """The results folder after `reproduce.py fig6-3 --quick`."""
    out = tmp_path_factory.mktemp("reproduce")
    run_tool(REPRODUCE, "fig6-3", "--quick", "--quiet", "--out", str(out))
    return out


def test_fig6_3_writes_the_4x4_landscape_and_its_heatmap(landscape_out):
    header, rows = read_csv(landscape_out / "fig6-3" / "landscape.csv")
    # x = the first swept parameter (phase lag), y = the second (offset).
    assert header == ["phase.0.5", "offset.5", "value"]
    assert len(rows) == 4 * 4
    phases = sorted({float(r[0]) for r in rows})
    offsets = sorted({float(r[1]) for r in rows})
    assert len(phases) == len(offsets) == 4
    assert phases[0] == 0 and phases[-1] == pytest.approx(2 * math.pi)
    assert offsets[0] == pytest.approx(-math.pi / 2) and offsets[-1] == 0
    header, labelled = read_csv(landscape_out / "fig6-3" / "fig6-3.csv")
    assert len(labelled) == 16 and "velocity [cm/s]" in header
    # The labelled CSV is the same landscape in cm/s.
    assert [100 * float(r[2]) for r in rows] == pytest.approx([float(r[2]) for r in labelled])
    check_png(landscape_out / "fig6-3" / "fig6-3.png")


def test_fig6_5_7_draws_three_powell_paths_from_the_thesis_starts(landscape_out):
    run_tool(REPRODUCE, "fig6-5-7", "--quick", "--quiet", "--out", str(landscape_out))
    out = landscape_out / "fig6-5-7"
    for name, start in (("fig6-5", (0.0, -0.5)), ("fig6-6", (2.0, -1.5)), ("fig6-7", (2.0, 0.0))):
        _, evaluations = read_csv(out / "runs" / name / "evaluations.csv")
        header, path = read_csv(out / f"{name}.csv")
        assert header[0] == "index" and len(header) == 4
        assert 1 <= len(path) == len(evaluations) <= 10
        assert (float(path[0][1]), float(path[0][2])) == start  # Powell evaluates its start first
        check_png(out / f"{name}.png")


def test_fig6_12_runs_both_methods_from_the_same_ten_starts(built, tmp_path):
    run_tool(REPRODUCE, "fig6-12", "--quick", "--quiet", "--out", str(tmp_path))
    out = tmp_path / "fig6-12"
    _, starts = read_csv(out / "starts.csv")
    assert [s[0] for s in starts] == list("abcdefghij")
    header, curves = read_csv(out / "curves.csv")
    assert header == ["method", "run", "evaluation", "velocity_cm_s", "best_cm_s"]
    total = 0
    for method in ("classic", "interval"):
        for start in starts:
            run = out / "runs" / f"{method}-{start[0]}"
            eval_header, evaluations = read_csv(run / "evaluations.csv")
            assert 1 <= len(evaluations) <= 10
            total += len(evaluations)
            first = dict(zip(eval_header, evaluations[0]))
            assert [float(first[name]) for name in eval_header[1:8]] == [float(v) for v in start[1:]]
            best = [float(r[4]) for r in curves if r[0] == method and r[1] == start[0]]
            assert len(best) == len(evaluations)
            assert best == sorted(best)  # best so far never decreases
            # Figures come from the CSVs: no run films its best gait.
            assert not list(run.glob("best*.mp4")) and not (run / "best-strip.png").exists()
    assert len(curves) == total
    _, final = read_csv(out / "final.csv")
    assert len(final) == 10
    check_png(out / "fig6-12.png")


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def test_ctrl_c_stops_the_daemons_it_started(built, tmp_path):
    # Started with SIGINT ignored, as `reproduce.py &` in a script or a CI job
    # starts it; the tool must still stop on SIGINT (it once ran on).
    proc = subprocess.Popen([sys.executable, "-m", REPRODUCE, "fig6-12", "--quick", "--budget", "1000",
                             "--build", str(BUILD), "--daemons", "2", "--out", str(tmp_path)],
                            cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            preexec_fn=_ignore_sigint)
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True)
    reader.start()  # drains the pipe so yamor-optimize's progress never blocks
    try:
        pids = None
        deadline = time.monotonic() + 60
        while pids is None and time.monotonic() < deadline and proc.poll() is None:
            match = next((m for m in (re.search(r"pids ([\d,]+)", line) for line in list(lines)) if m),
                         None)
            if match:
                pids = [int(p) for p in match.group(1).split(",")]
            time.sleep(0.05)
        assert pids and len(pids) == 2, "".join(lines)
        for pid in pids:
            os.kill(pid, 0)  # running
        first = tmp_path / "fig6-12" / "runs" / "classic-a" / "evaluations.csv"
        while time.monotonic() < deadline and not (first.exists()
                                                    and len(first.read_text().splitlines()) >= 3):
            time.sleep(0.1)
        proc.send_signal(signal.SIGINT)
        # reproduce.py gives yamor-optimize up to 60 s to write its results and
        # each daemon up to 30 s to drain (yamor.tools.daemons); a wait of
        # exactly that sum failed twice on a loaded machine.
        try:
            proc.wait(timeout=150)
        except subprocess.TimeoutExpired:
            alive = subprocess.run(["ps", "-o", "pid,ppid,stat,etime,args", "--ppid", str(proc.pid)],
                                   capture_output=True, text=True).stdout
            pytest.fail(f"reproduce.py still running 150 s after SIGINT; its children:\n{alive}\n"
                        f"its output:\n{''.join(lines)}")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        reader.join(timeout=10)
    output = "".join(lines)
    assert proc.returncode == 130, output
    assert "interrupted" in output
    for pid in pids:
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)
    # yamor-optimize stopped cleanly and kept what it had evaluated.
    summary = json.loads((first.parent / "summary.json").read_text())
    assert summary["status"] == "stopped"
    assert summary["evaluations"] == len(read_csv(first)[1]) >= 2


def test_learning_bench_quick_writes_the_table_using_running_daemons(built, tmp_path):
    with start_daemons(2, BUILD / "host" / "yamord", ["--workers", "1", "--log-level", "warn"],
                       log_dir=tmp_path / "logs") as pool:
        result = run_tool(BENCH, "--quick", "--plugins", "random,powell-interval", "--seeds", "2",
                          "--budget", "6", "--quiet", "--hosts", pool.hosts_arg(), "--out", str(tmp_path))
        # --hosts: the tool used these daemons and left them running.
        assert pool.running()
        assert pool.hosts_arg() in result.stdout
    table = (tmp_path / "learning-bench.md").read_text()
    assert table in result.stdout
    rows = [line for line in table.splitlines() if line.startswith("| ") and "---" not in line]
    assert rows[0].startswith("| variant |")
    assert [r.split("|")[1].strip() for r in rows[1:]] == ["powell-interval", "random"]
    assert "best after 2 [cm/s]" in rows[0] and "best after 6 [cm/s]" in rows[0]
    assert "grid" in table  # says why it is not benchmarked
    header, runs = read_csv(tmp_path / "runs.csv")
    assert len(runs) == 4 and header[:3] == ["variant", "seed", "status"]
    assert all(r[2] == "budget" and r[3] == "6" for r in runs)


def load_bench():
    return learning_bench


def test_learning_bench_statistics():
    bench = load_bench()
    curve = [0.01, 0.03, 0.03, 0.05]
    assert bench.best_after(curve, 2) == 0.03
    assert bench.best_after(curve, 1000) == 0.05  # a converged run keeps its final best
    assert bench.evaluations_to_reach(curve, 0.03) == 2
    assert bench.evaluations_to_reach(curve, 0.06) is None
    # Never reaching ranks above every count; the median is "never" once half never reach.
    assert bench.median_with_never([5, None, 3]) == 5
    assert bench.median_with_never([5, None, None]) is None
    assert bench.median_with_never([4, 2, None, 10]) == 7
    assert bench.median_with_never([4, None, None, 10]) is None


def test_learning_bench_refuses_grid_with_the_reason(capsys):
    bench = load_bench()
    with pytest.raises(SystemExit):
        bench.parse_args(["--plugins", "grid"])
    assert "not an optimizer for 7 parameters" in capsys.readouterr().err
    args = bench.parse_args(["--plugins", "powell,pso"])
    assert [v.name for v in args.variants][-1] == "pso"
    assert len(args.variants) == 6
    assert bench.parse_args([]).checkpoints == [100, 300]  # 1000 = the budget, its own column


def test_ch4_writes_table_4_1_and_the_19_appendix_b_figures(tmp_path):
    tool = BUILD / "tools" / "characterize" / "yamor-characterize"
    if not tool.exists():
        pytest.skip(f"not built: {tool}")
    result = run_tool(REPRODUCE, "ch4", "--out", str(tmp_path))
    folder = tmp_path / "ch4"
    header, rows = read_csv(folder / "table4-1.csv")
    assert [r[0] for r in rows] == ["x", "y", "z"]
    for row in rows:
        values = dict(zip(header, row))
        # Within one ADC count of the thesis at each end of the band.
        assert abs(float(values["n_min"]) - float(values["thesis_n_min"])) <= 0.0395, row
        assert abs(float(values["n_max"]) - float(values["thesis_n_max"])) <= 0.0395, row
        assert int(values["samples"]) > 1000
    for move in ("sine", "circle", "go-and-return", "random", "drop"):
        header, rows = read_csv(folder / f"{move}.csv")
        assert "filtered_position_x" in header and len(rows) > 200, move
    for number in range(1, 20):
        check_png(folder / f"figB-{number}.png")
    assert not list(folder.glob("*.partial*"))
    assert "Table 4.1" in result.stdout


def test_fig7_4_draws_one_life_through_the_transformation(tmp_path):
    tool = BUILD / "optimizer-plugins" / "lifelong" / "yamor-lifelong"
    if not tool.exists():
        pytest.skip(f"not built: {tool}")
    run_tool(REPRODUCE, "fig7-4", "--quick", "--quiet", "--out", str(tmp_path), timeout=180)
    folder = tmp_path / "fig7-4"
    check_png(folder / "fig7-4.png")
    header, rows = read_csv_allowing_gaps(folder / "fig7-4.csv")
    assert header == ["time", "velocity", "ema", "state", "event", "gait"]
    states = {r[3] for r in rows}
    assert {"walking", "relearning"} <= states, states
    assert any(r[4].startswith("anomaly: module_") for r in rows), rows
    events = [json.loads(line) for line in (folder / "life" / "events.jsonl").read_text().splitlines()]
    relearn = [e for e in events if e["kind"] == "relearn"]
    assert relearn and relearn[0]["how"] == "rebuilt"
    assert any(e["kind"] == "relearned" for e in events)


def test_fig7_5_films_the_fall_off_the_table_and_the_relearned_gait(tmp_path):
    tool = BUILD / "optimizer-plugins" / "lifelong" / "yamor-lifelong"
    if not tool.exists():
        pytest.skip(f"not built: {tool}")
    run_tool(REPRODUCE, "fig7-5", "--quick", "--quiet", "--out", str(tmp_path), timeout=300)
    folder = tmp_path / "fig7-5"
    for name in ("fig7-5.png", "fig7-5-trajectory.png", "fig7-5-timeline.png"):
        check_png(folder / name)
    header, frames = read_csv(folder / "fig7-5-frames.csv")
    assert header == ["file", "time", "label"]
    labels = [f[2] for f in frames]
    assert labels[0] == "on the table" and "fallen, on its back" in labels, labels
    assert labels[-1] == "walking on its back", labels
    for f in frames:  # 480 x 360 frames: smaller than check_png's figures
        assert (folder / f[0]).read_bytes()[:8] == PNG_SIGNATURE
        pixels = image.imread(folder / f[0])
        assert pixels.shape[:2] == (360, 480) and pixels.std() > 0.05, f[0]
    header, path = read_csv(folder / "fig7-5-trajectory.csv")
    assert header == ["time", "x", "y", "z", "gait"]
    on_table = [float(r[3]) for r in path if r[4] == "starting gait"]
    on_back = [float(r[3]) for r in path if r[4] == "relearned gait"]
    assert on_table[0] > 0.4 and on_back and max(on_back) < 0.2, (on_table[:3], on_back[:3])
    events = [json.loads(line) for line in (folder / "life" / "events.jsonl").read_text().splitlines()]
    assert any(e["kind"] == "relearned" for e in events)
    assert not any(e["kind"] == "scenario_change" for e in events)


def read_csv_allowing_gaps(path: Path) -> tuple[list[str], list[list[str]]]:
    """A timeline: empty cells stand for no measurement (event rows); no NaN text."""
    text = path.read_text()
    assert "nan" not in text.lower(), path
    rows = list(csv.reader(text.splitlines()))
    return rows[0], rows[1:]
