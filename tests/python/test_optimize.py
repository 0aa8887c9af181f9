"""End to end: yamor-optimize with the powell plugin against two real yamord.

Starts two daemons (one Evaluate worker each) on ephemeral ports and runs
the real yamor-optimize binary on configs/optimize/quadruped-7.xml with short
evaluations (1 s warm-up + 2 s) so the suite stays quick. Checks the results
folder, that best.xml reproduces the best velocity on a daemon, batch start,
errors, and stopping with SIGINT.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import socket
import subprocess
import time
from pathlib import Path

import pytest

from conftest import REPO, YAMORD

import yamor
from yamor.launcher import start_daemons

OPTIMIZE = Path(os.environ.get("YAMOR_OPTIMIZE",
                               REPO / "build" / "release" / "optimizer-plugins" / "yamor-optimize"))
CONFIG = REPO / "configs" / "optimize" / "quadruped-7.xml"
SHORT = ["--world", "quadruped", "--warmup", "1", "--duration", "2"]


@pytest.fixture(scope="module")
def two_daemons(tmp_path_factory):
    if not YAMORD.is_file():
        pytest.skip(f"yamord not built: {YAMORD}")
    if not OPTIMIZE.is_file():
        pytest.skip(f"yamor-optimize not built: {OPTIMIZE}")
    with start_daemons(2, YAMORD, ["--workers", "1"],
                       log_dir=tmp_path_factory.mktemp("daemons")) as daemons:
        yield daemons.addresses


def run_optimize(args, timeout=600, check=True):
    result = subprocess.run([str(OPTIMIZE), "--log-level", "warn", "--quiet", *args], cwd=REPO,
                            capture_output=True, text=True, timeout=timeout)
    if check:
        assert result.returncode == 0, f"exit {result.returncode}\n{result.stdout}\n{result.stderr}"
    return result


def read_csv(path: Path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_powell_learns_on_two_daemons_and_writes_the_results_folder(two_daemons, tmp_path):
    out = tmp_path / "run"
    result = run_optimize(["--plugin", "powell", "--config", str(CONFIG), "--hosts",
                           ",".join(two_daemons), *SHORT, "--set", "max_evaluations=45",
                           "--set", "line_search=interval", "--seed", "3", "--out", str(out)])
    assert "best velocity" in result.stdout
    rows = read_csv(out / "evaluations.csv")
    assert len(rows) == 45
    assert [int(r["index"]) for r in rows] == list(range(45))
    # Every optimized and constrained parameter is a column; no NaN anywhere.
    for name in ("amplitude.0", "amplitude.5", "offset.5", "phase.0.5", "phase.0.1",
                 "phase.3.0", "phase.1.0", "velocity", "host", "wall_seconds"):
        assert name in rows[0], name
    text = (out / "evaluations.csv").read_text().lower()
    assert "nan" not in text and "inf" not in text
    # Interval line searches are batches of 10 and 5: both daemons took work.
    assert {r["host"] for r in rows} == set(two_daemons)

    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "budget"
    assert summary["evaluations"] == 45
    velocities = [float(r["velocity"]) for r in rows]
    assert summary["best"]["velocity"] == max(velocities)
    assert summary["best"]["index"] == velocities.index(max(velocities))
    assert (out / "progress.png").stat().st_size > 10_000

    # best.xml is a robot configuration a daemon loads and that walks as fast
    # as the best evaluation (same world, timing and seed: bit-identical).
    best_xml = (out / "best.xml").read_text()
    assert "<optimize" not in best_xml
    with yamor.Host(two_daemons[0], timeout=60) as host:
        again = host.evaluate(config_xml=best_xml, world="quadruped", warmup=1, duration=2)
        host.load_config(best_xml, "best.xml")
    assert again.velocity == summary["best"]["velocity"]


def test_the_same_seed_gives_the_same_run(two_daemons, tmp_path):
    args = ["--plugin", "powell", "--config", str(CONFIG), "--hosts", ",".join(two_daemons), *SHORT,
            "--set", "max_evaluations=12", "--seed", "5"]
    run_optimize([*args, "--no-plot", "--out", str(tmp_path / "a")])
    run_optimize([*args, "--no-plot", "--out", str(tmp_path / "b")])

    def strip_hosts(path):
        return [{k: v for k, v in r.items() if k not in ("host", "wall_seconds")}
                for r in read_csv(path / "evaluations.csv")]
    assert strip_hosts(tmp_path / "a") == strip_hosts(tmp_path / "b")


def test_batch_start_runs_every_instance_over_one_pool(two_daemons, tmp_path):
    batch = tmp_path / "batch.toml"
    batch.write_text('[[instance]]\nname = "classic"\nseed = 1\n\n'
                     '[[instance]]\nname = "interval"\nseed = 2\n'
                     '[instance.set]\nline_search = "interval"\nmax_evaluations = 15\n')
    out = tmp_path / "batch"
    result = run_optimize(["--plugin", "powell", "--config", str(CONFIG), "--hosts",
                           ",".join(two_daemons), *SHORT, "--set", "max_evaluations=8",
                           "--batch", str(batch), "--no-plot", "--out", str(out)])
    assert "[classic]" in result.stdout and "[interval]" in result.stdout
    assert len(read_csv(out / "classic" / "evaluations.csv")) == 8
    assert len(read_csv(out / "interval" / "evaluations.csv")) == 15
    assert json.loads((out / "interval" / "summary.json").read_text())["fields"]["line_search"] == "interval"


def test_list_plugins_shows_powell_and_its_fields():
    if not OPTIMIZE.is_file():
        pytest.skip(f"yamor-optimize not built: {OPTIMIZE}")
    result = run_optimize(["--list-plugins"])
    assert "powell" in result.stdout
    assert "--set max_evaluations=" in result.stdout
    assert "--set line_search=brent" in result.stdout


@pytest.mark.parametrize("args, message", [
    (["--set", "max_evaluations=zero"], "field 'max_evaluations': 'zero' is not an integer"),
    (["--set", "nosuch=1"], "has no field 'nosuch'"),
    (["--plugin", "nosuch"], "no optimizer plugin named 'nosuch'"),
    (["--config", "/nonexistent.xml"], "/nonexistent.xml"),
    (["--hosts", "localhost:99999"], "localhost:99999"),
    (["--video-size", "320"], "--video-size 320: expected WIDTHxHEIGHT"),
    (["--video-size", "0x240"], "--video-size 0x240: width and height must be 1..4096"),
    (["--video-fps", "0"], "--video-fps 0 is outside (0, 240]"),
])
def test_bad_arguments_exit_2_naming_the_problem(tmp_path, args, message):
    if not OPTIMIZE.is_file():
        pytest.skip(f"yamor-optimize not built: {OPTIMIZE}")
    base = {"--plugin": "powell", "--config": str(CONFIG), "--hosts": "127.0.0.1:1",
            "--out": str(tmp_path / "out")}
    for i in range(0, len(args), 2):
        base[args[i]] = args[i + 1] if args[i] != "--set" else base.get("--set", "") + "|" + args[i + 1]
    argv = []
    for k, v in base.items():
        if k == "--set":
            for s in v.strip("|").split("|"):
                argv += ["--set", s]
        else:
            argv += [k, v]
    result = run_optimize(argv, timeout=60, check=False)
    assert result.returncode == 2, result.stderr
    assert message in result.stderr


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_no_reachable_host_fails_clearly(tmp_path):
    if not OPTIMIZE.is_file():
        pytest.skip(f"yamor-optimize not built: {OPTIMIZE}")
    out = tmp_path / "out"
    result = run_optimize(["--plugin", "powell", "--config", str(CONFIG), "--hosts",
                           f"127.0.0.1:{_free_port()}", *SHORT, "--give-up-after", "2",
                           "--no-plot", "--out", str(out)], timeout=120, check=False)
    assert result.returncode == 1, result.stdout + result.stderr
    assert "UNAVAILABLE" in result.stdout
    assert json.loads((out / "summary.json").read_text())["status"] == "failed"


def test_sigint_stops_and_keeps_the_results(two_daemons, tmp_path):
    out = tmp_path / "run"
    proc = subprocess.Popen([str(OPTIMIZE), "--log-level", "warn", "--quiet", "--plugin", "powell",
                             "--config", str(CONFIG), "--hosts", ",".join(two_daemons), *SHORT,
                             "--no-plot", "--out", str(out)], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    csv_path = out / "evaluations.csv"
    while time.monotonic() < deadline:
        if csv_path.exists() and len(csv_path.read_text().splitlines()) >= 4:
            break
        time.sleep(0.1)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stdout + stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "stopped"
    assert summary["evaluations"] == len(read_csv(csv_path)) >= 3


def test_a_plugin_built_outside_the_tree_from_the_header_alone_runs(two_daemons, tmp_path):
    """docs/optimizers.md's promise: the example plugin builds with nothing but the header."""
    plugin = tmp_path / "my_random.so"
    subprocess.run(["g++", "-std=c++17", "-O1", "-shared", "-fPIC", "-fvisibility=hidden",
                    "-I", str(REPO / "optimizer-plugins" / "include"),
                    str(REPO / "optimizer-plugins" / "random" / "random.cc"), "-o", str(plugin)],
                   check=True, timeout=120)
    symbols = subprocess.run(["nm", "-D", "--defined-only", str(plugin)], capture_output=True,
                             text=True, check=True).stdout.split()
    assert "yamor_optimizer_plugin" in symbols
    out = tmp_path / "run"
    run_optimize(["--plugin", str(plugin), "--config", str(CONFIG), "--hosts", ",".join(two_daemons),
                  *SHORT, "--set", "max_evaluations=5", "--set", "batch=4", "--no-plot",
                  "--out", str(out)])
    assert len(read_csv(out / "evaluations.csv")) == 5
