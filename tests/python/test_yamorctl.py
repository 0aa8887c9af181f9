"""yamorctl as a subprocess against the session's real yamord: output, --json,
exit codes."""

from __future__ import annotations

import json
import math


def test_info_readable_and_json(yamorctl):
    r = yamorctl("info")
    assert r.returncode == 0, r.stderr
    assert "backend           simulation" in r.stdout
    r = yamorctl("--json", "info")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    assert info["backend"] == "simulation" and "quadruped" in info["builtin_worlds"]


def test_thesis_session(yamorctl, host):
    host.set_free_run(0)
    assert yamorctl("open", "--world", "quadruped", "--seed", "1").returncode == 0
    start = json.loads(yamorctl("--json", "position").stdout)["position"]
    r = yamorctl("connect")
    assert r.returncode == 0 and r.stdout.startswith("connected: 8 links"), r.stdout + r.stderr
    r = yamorctl("control", "--uart", "on", "--cpg", "on", "--motors", "on", "all")
    assert (r.returncode, r.stdout, r.stderr) == (0, "", "")
    r = yamorctl("sleep", "20")
    assert (r.returncode, r.stdout) == (0, "time 20.000 s\n"), r.stderr
    r = yamorctl("--json", "position")
    end = json.loads(r.stdout)
    assert end["time"] == 20.0 and end["source"] == "simulation"
    moved = math.hypot(end["position"]["x"] - start["x"], end["position"]["y"] - start["y"])
    assert moved > 0.05
    assert yamorctl("time").stdout == "20.000 s\n"


def test_get_set_round_trip(yamorctl, host):
    host.open_simulation(world="quadruped")
    assert yamorctl("set", "amplitude", "3", "0.5").returncode == 0
    assert yamorctl("get", "amplitude", "3").stdout == "amplitude.3 = 0.5 rad\n"
    assert host.amplitude(3) == 0.5
    assert yamorctl("set", "offset", "3", "-0.25").returncode == 0  # negative value
    assert json.loads(yamorctl("get", "offset", "3", "--json").stdout) == {"value": -0.25}
    assert yamorctl("couple", "0", "2", "0.5", "0.75").returncode == 0
    assert yamorctl("set", "phase", "0", "2", "1.57").returncode == 0
    assert yamorctl("get", "phase", "0", "2").stdout == "phase.0.2 = 1.57 rad\n"
    assert yamorctl("get", "weight", "0", "2").stdout == "weight.0.2 = 0.75\n"
    assert yamorctl("modules").stdout == "0 1 2 3 4 5 6 7 8\n"


def test_exit_codes_follow_the_grpc_status(yamorctl, host):
    host.open_simulation(world="quadruped")
    r = yamorctl("get", "amplitude", "42")
    assert r.returncode == 5
    assert r.stderr.startswith("yamorctl: NOT_FOUND: ") and "42" in r.stderr
    assert r.stdout == ""
    r = yamorctl("set", "amplitude", "3", "nan")
    assert r.returncode == 3 and r.stderr.startswith("yamorctl: INVALID_ARGUMENT: ")
    r = yamorctl("set", "maxangle", "3", "-3")
    assert r.returncode == 11 and "OUT_OF_RANGE" in r.stderr
    r = yamorctl("--json", "get", "amplitude", "42")
    assert r.returncode == 5 and r.stdout == ""
    r = yamorctl("get", "amplitude")  # usage error
    assert r.returncode == 2 and r.stderr
    r = yamorctl("sleep", "30", "--real", "--timeout", "0.3")
    assert r.returncode == 4 and "DEADLINE_EXCEEDED" in r.stderr
    host.close_simulation()
    r = yamorctl("position")
    assert r.returncode == 9 and "FAILED_PRECONDITION" in r.stderr
    host.open_simulation()


def test_evaluate_json_is_deterministic(yamorctl, host):
    host.open_simulation(world="quadruped")
    args = ("--json", "evaluate", "--param", "amplitude.0=0.6", "--warmup", "2", "--duration",
            "4", "--seed", "3")
    a, b = json.loads(yamorctl(*args).stdout), json.loads(yamorctl(*args).stdout)
    assert a["velocity"] == b["velocity"] and not a["diverged"]
    via_python = host.evaluate({"amplitude.0": 0.6}, warmup=2, duration=4, seed=3)
    assert via_python.velocity == a["velocity"]
    r = yamorctl("evaluate", "--param", "amplitude.42=1")
    assert r.returncode == 5


def test_watch_json_lines(yamorctl, host):
    host.open_simulation(world="quadruped")
    r = yamorctl("--json", "watch", "--count", "1")  # the first update comes at once
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert len(lines) == 1 and json.loads(lines[0])["time"] == 0.0


def test_save_and_load_files(yamorctl, host, tmp_path):
    host.open_simulation(world="quadruped")
    host.set_amplitude(2, 0.321)
    saved = tmp_path / "robot.xml"
    assert yamorctl("save", str(saved)).returncode == 0
    assert 'amplitude="0.321"' in saved.read_text()
    host.open_simulation(world="quadruped")
    assert yamorctl("load", str(saved)).returncode == 0
    assert host.amplitude(2) == 0.321
    bad = tmp_path / "bad.xml"
    bad.write_text("<yamorconfig>")
    r = yamorctl("load", str(bad))
    assert r.returncode == 3 and str(bad) in r.stderr  # the message names the file
    assert yamorctl("load", str(tmp_path / "missing.xml")).returncode == 2


def test_snapshot_and_record_an_mp4(yamorctl, host, tmp_path):
    import shutil
    import subprocess
    host.open_simulation(world="quadruped")
    png = tmp_path / "now.png"
    r = yamorctl("snapshot", str(png), "--width", "320", "--height", "240")
    assert r.returncode == 0, r.stderr
    assert r.stdout == f"{png}: 320x240, t = 0.000 s\n"
    assert png.read_bytes()[:4] == b"\x89PNG"
    r = yamorctl("snapshot", str(png), "--width", "0")
    assert r.returncode == 11 and "frame width 0" in r.stderr  # OUT_OF_RANGE
    if shutil.which("ffmpeg") is None or shutil.which("ffprobe") is None:
        return  # the PNG-sequence path is covered by render_test
    video = tmp_path / "walk.mp4"
    r = yamorctl("record", "--seconds", "1", "--fps", "10", "--width", "160", "--height", "120",
                 str(video))
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith(f"{video}: 10 frames, 160x120, 10 fps"), r.stdout
    probe = subprocess.run(
        ["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
         "stream=nb_read_frames,width,height", "-of", "csv=p=0", str(video)],
        capture_output=True, text=True, check=True)
    assert probe.stdout == "160,120,10\n"
    assert yamorctl("time").stdout == "1.000 s\n"
