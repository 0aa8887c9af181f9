"""End to end: yamor-optimize films its best gait (issue 14).

Real yamord daemons (one Evaluate worker each) on ephemeral ports and the
real yamor-optimize binary, with short evaluations (1 s warm-up + 2 s) and a
tiny budget. Checks best.mp4 with ffprobe (frame count and size) when ffmpeg
is installed (made by the daemon, or here from PNG frames when the daemon
has no ffmpeg), best-strip.png's size, the numbered PNG sequence and its
note when neither can run ffmpeg, that --no-video writes neither, and that a pool
whose daemons cannot render loses nothing of the run (a warning only).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import struct
import subprocess
from pathlib import Path

import pytest

from conftest import REPO, YAMORD
from test_optimize import CONFIG, OPTIMIZE, read_csv

import yamor
from yamor.launcher import start_daemon

SHORT = ["--world", "quadruped", "--warmup", "1", "--duration", "2", "--no-plot", "--quiet",
         "--log-level", "warn", "--plugin", "powell", "--set", "max_evaluations=4", "--seed", "2",
         "--config", str(CONFIG)]
FRAMES = 75  # 3 s at 25 frames per second


def _start_daemon(log_path: Path, env=None):
    return start_daemon(YAMORD, ["--workers", "1"], log=log_path, env=env)


@pytest.fixture(scope="module")
def daemon(tmp_path_factory):
    if not YAMORD.is_file():
        pytest.skip(f"yamord not built: {YAMORD}")
    if not OPTIMIZE.is_file():
        pytest.skip(f"yamor-optimize not built: {OPTIMIZE}")
    with _start_daemon(tmp_path_factory.mktemp("daemon") / "yamord.log") as daemon:
        # Skip (not fail) on a machine without any renderer.
        with yamor.Host(daemon.address, timeout=60) as host:
            try:
                host.snapshot(width=8, height=8)
            except Exception as e:  # noqa: BLE001
                if "UNAVAILABLE" in str(e) or "no renderer" in str(e):
                    pytest.skip(f"no renderer on this machine: {e}")
        yield daemon.address


def _run(args, env=None, timeout=300):
    result = subprocess.run([str(OPTIMIZE), *args], cwd=REPO, capture_output=True, text=True,
                            timeout=timeout, env=env)
    assert result.returncode == 0, f"exit {result.returncode}\n{result.stdout}\n{result.stderr}"
    return result


def _png_size(path: Path):
    data = path.read_bytes()[:24]
    assert data[:8] == b"\x89PNG\r\n\x1a\n", path
    return struct.unpack(">II", data[16:24])


def _summary_without_timing(folder: Path):
    summary = json.loads((folder / "summary.json").read_text())
    for key in ("wall_seconds", "evaluations_per_second"):
        summary.pop(key, None)
    return summary


@pytest.mark.skipif(shutil.which("ffprobe") is None or shutil.which("ffmpeg") is None,
                    reason="ffmpeg/ffprobe not installed")
def test_best_mp4_and_strip_of_the_best_gait(daemon, tmp_path):
    out = tmp_path / "run"
    # The daemon makes the MP4 (EvaluationFrames.mp4): yamor-optimize needs no ffmpeg of its own.
    client_without_ffmpeg = dict(os.environ, YAMOR_FFMPEG=str(tmp_path / "no-such-ffmpeg"))
    result = _run([*SHORT, "--hosts", daemon, "--video-size", "160x120", "--out", str(out)],
                  env=client_without_ffmpeg)
    assert f"video:     {out / 'best.mp4'} ({FRAMES} frames, 25 fps" in result.stdout
    probe = json.loads(subprocess.run(
        ["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
         "stream=nb_read_frames,width,height,codec_name", "-of", "json", str(out / "best.mp4")],
        capture_output=True, text=True, check=True).stdout)["streams"][0]
    assert (probe["width"], probe["height"]) == (160, 120)
    assert int(probe["nb_read_frames"]) == FRAMES
    assert probe["codec_name"] == "h264"
    # Six frames side by side with 4-pixel gaps.
    assert _png_size(out / "best-strip.png") == (6 * 160 + 5 * 4, 120)
    assert "strip:     " + str(out / "best-strip.png") in result.stdout
    # The video changes nothing of the run's results.
    reference = tmp_path / "reference"
    _run([*SHORT, "--hosts", daemon, "--no-video", "--out", str(reference)])
    assert _summary_without_timing(out) == _summary_without_timing(reference)
    assert (out / "best.xml").read_text() == (reference / "best.xml").read_text()


def test_no_video_writes_neither(daemon, tmp_path):
    out = tmp_path / "run"
    result = _run([*SHORT, "--hosts", daemon, "--no-video", "--out", str(out)])
    assert not (out / "best.mp4").exists()
    assert not (out / "best-strip.png").exists()
    assert not list(out.glob("best-0*.png"))
    assert "video:" not in result.stdout
    assert len(read_csv(out / "evaluations.csv")) == 4


def test_without_ffmpeg_a_png_sequence_and_a_note(daemon, tmp_path):
    """Neither the daemon nor yamor-optimize can run ffmpeg."""
    env = dict(os.environ, YAMOR_FFMPEG=str(tmp_path / "no-such-ffmpeg"))
    out = tmp_path / "run"
    with _start_daemon(tmp_path / "no-ffmpeg.log", env=env) as plain:
        result = _run([*SHORT, "--hosts", plain.address, "--video-size", "64x48", "--out", str(out)],
                      env=env)
    frames = sorted(out.glob("best-0*.png"))
    assert [f.name for f in frames] == [f"best-{i:06d}.png" for i in range(FRAMES)]
    assert _png_size(frames[0]) == (64, 48)
    assert not (out / "best.mp4").exists()
    assert f"{FRAMES} frames as {out / 'best-%06d.png'}" in result.stdout
    assert re.search(r"note: .*cannot run .*no-such-ffmpeg.*ffmpeg -framerate 25", result.stdout)
    assert _png_size(out / "best-strip.png") == (6 * 64 + 5 * 4, 48)


@pytest.mark.skipif(shutil.which("ffprobe") is None or shutil.which("ffmpeg") is None,
                    reason="ffmpeg/ffprobe not installed")
def test_a_daemon_without_ffmpeg_sends_frames_and_the_video_is_made_here(daemon, tmp_path):
    """The daemon makes best.mp4 itself when it can; when it cannot, it sends
    every frame as PNG and yamor-optimize makes the same-sized video."""
    env = dict(os.environ, YAMOR_FFMPEG=str(tmp_path / "no-such-ffmpeg"))
    out = tmp_path / "run"
    with _start_daemon(tmp_path / "no-ffmpeg.log", env=env) as plain:
        result = _run([*SHORT, "--hosts", plain.address, "--video-size", "64x48", "--out", str(out)])
    assert f"video:     {out / 'best.mp4'} ({FRAMES} frames, 25 fps" in result.stdout
    probe = json.loads(subprocess.run(
        ["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
         "stream=nb_read_frames,width,height", "-of", "json", str(out / "best.mp4")],
        capture_output=True, text=True, check=True).stdout)["streams"][0]
    assert (probe["width"], probe["height"], int(probe["nb_read_frames"])) == (64, 48, FRAMES)
    assert _png_size(out / "best-strip.png") == (6 * 64 + 5 * 4, 48)
    assert "cannot run ffmpeg" in (tmp_path / "no-ffmpeg.log").read_text()


def test_a_pool_that_cannot_film_keeps_the_run(daemon, tmp_path):
    """A daemon without a renderer: the video is a warning, the run's results stay."""
    env = dict(os.environ, YAMOR_RENDER_BACKEND="none")
    with _start_daemon(tmp_path / "blind.log", env=env) as blind:
        out = tmp_path / "run"
        result = _run([*SHORT, "--hosts", blind.address, "--out", str(out)])
    assert "warning: no video of the best gait (the results are kept)" in result.stderr
    assert "no host could film" in result.stderr
    assert not (out / "best.mp4").exists() and not (out / "best-strip.png").exists()
    assert json.loads((out / "summary.json").read_text())["status"] == "budget"
    assert len(read_csv(out / "evaluations.csv")) == 4
