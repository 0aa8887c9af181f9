"""Film benchmark: the CPU of a filmed Evaluate against the evaluation it shows (issue 14).

Usage: yamor-film-bench [--runs 7] [--seconds 20] [--fps 25] [--size 320x240]
                        [--build build/release]

Where render_bench times the pieces in one process, this times what a user
gets, end to end, through a real yamord (one Evaluate worker) on a loopback
port: the quadruped's configured gait for --seconds (warm-up 8 s included)
evaluated three ways, --runs times in turn:

  * plain: Evaluate with no frames (the evaluation itself);
  * mp4: Evaluate with EvaluationFrames.mp4 (the daemon pipes raw frames to
    its ffmpeg and returns the MP4 and 6 PNG stills: what yamor-optimize's
    best.mp4 asks for);
  * png: Evaluate with a PNG per frame, the PNGs then piped here to ffmpeg
    (H.264, as VideoWriter does: what a client does with frames it gets, and
    what yamor-optimize falls back to with a daemon without ffmpeg).

CPU is the daemon's (/proc/PID/stat: its threads plus the children it has
reaped, its ffmpeg) and, for png, this script's ffmpeg child. A film's video
cost is its CPU minus the plain evaluation's measured in the same run; the
ratio is video cost / plain. This script's own CPU (the Python gRPC client
receiving the reply) is printed apart: yamor-optimize is C++. Medians over
the runs.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from yamor.launcher import start_daemon
from yamor.tools import daemons
from yamor.tools.daemons import ToolError



def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=7, help="runs of the three (medians)")
    parser.add_argument("--seconds", type=float, default=20.0,
                        help="simulated seconds per evaluation, warm-up (8 s, or less) included")
    parser.add_argument("--fps", type=float, default=25.0, help="frames per simulated second")
    parser.add_argument("--size", default="320x240", help="frame size WIDTHxHEIGHT")
    parser.add_argument("--build", default="build/release", help="build tree with yamord")
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error(f"--runs must be at least 1, got {args.runs}")
    if not args.seconds > 0:
        parser.error(f"--seconds must be > 0, got {args.seconds}")
    if not 0 < args.fps <= 240:
        parser.error(f"--fps must be in (0, 240], got {args.fps}")
    try:
        width, height = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        parser.error(f"--size {args.size!r}: expected WIDTHxHEIGHT, e.g. 320x240")
    if not (1 <= width <= 4096 and 1 <= height <= 4096):
        parser.error(f"--size {args.size!r}: width and height must be 1..4096")
    args.width, args.height = width, height
    return args


def process_cpu(pid: int) -> float:
    """CPU seconds of `pid`: its threads and the children it has waited for."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    ticks = sum(int(fields[i]) for i in (11, 12, 13, 14))  # utime stime cutime cstime
    return ticks / os.sysconf("SC_CLK_TCK")


def children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def self_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def png_video(frames, fps: float, path: Path) -> None:
    """PNG frames piped to ffmpeg, H.264, as VideoWriter makes a video of PNG frames."""
    command = ["ffmpeg", "-hide_banner", "-loglevel", "error", "-y", "-f", "image2pipe",
               "-framerate", repr(fps), "-c:v", "png", "-i", "-", "-vf",
               "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p", "-c:v", "libx264",
               "-preset", "ultrafast", "-crf", "20", "-threads", "1", str(path)]
    with subprocess.Popen(command, stdin=subprocess.PIPE) as proc:
        for frame in frames:
            proc.stdin.write(frame.png)
        proc.stdin.close()
        if proc.wait() != 0:
            raise ToolError(f"ffmpeg failed making {path}")


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    import yamor  # tools/python: the client

    bins = daemons.binaries(args.build)
    warmup = min(8.0, args.seconds / 2)
    duration = args.seconds - warmup
    count = max(1, round(args.seconds * args.fps))
    stills = sorted({min(count - 1, round(i * (count - 1) / 5)) for i in range(6)})
    film = dict(frame_rate=args.fps, width=args.width, height=args.height)
    rows = {name: [] for name in ("plain", "mp4", "mp4_client", "png", "png_ffmpeg", "png_client")}
    with tempfile.TemporaryDirectory(prefix="film-bench-") as tmp, \
            start_daemon(bins["yamord"], ["--workers", "1", "--log-level", "warn"],
                         log=Path(tmp) / "yamord.log") as daemon:
        pid = daemon.pid
        with yamor.Host(daemon.address, timeout=600) as host:
            host.evaluate(seed=1, warmup=0.1, duration=0.1, frame_rate=args.fps,
                          width=args.width, height=args.height)  # renderer, shaders: warm
            for run in range(args.runs):
                t0 = process_cpu(pid)
                plain = host.evaluate(seed=1, warmup=warmup, duration=duration)
                t1 = process_cpu(pid)
                c0 = self_cpu()
                made = host.evaluate(seed=1, warmup=warmup, duration=duration, mp4=True,
                                     png_frames=stills, **film)
                c1 = self_cpu()
                t2 = process_cpu(pid)
                if not made.mp4:
                    raise ToolError(f"the daemon made no MP4: {made.video_note}")
                if made.mp4_frames != count or made.velocity != plain.velocity:
                    raise ToolError(f"the MP4 film has {made.mp4_frames} frames (expected {count}) "
                                    f"or another velocity ({made.velocity} vs {plain.velocity})")
                c2 = self_cpu()
                pngs = host.evaluate(seed=1, warmup=warmup, duration=duration, **film)
                c3 = self_cpu()
                t3 = process_cpu(pid)
                f0 = children_cpu()
                png_video(pngs.frames, args.fps, Path(tmp) / "png.mp4")
                f1 = children_cpu()
                rows["plain"].append(t1 - t0)
                rows["mp4"].append(t2 - t1)
                rows["mp4_client"].append(c1 - c0)
                rows["png"].append(t3 - t2)
                rows["png_ffmpeg"].append(f1 - f0)
                rows["png_client"].append(c3 - c2)
                print(f"film_bench: run {run + 1}/{args.runs}: plain {t1 - t0:.2f} s, "
                      f"mp4 {t2 - t1:.2f} s, png {t3 - t2:.2f} + ffmpeg {f1 - f0:.2f} s", flush=True)

    def median(name):
        return statistics.median(rows[name])

    mp4_ratio = statistics.median((m - p) / p for m, p in zip(rows["mp4"], rows["plain"]))
    png_ratio = statistics.median((g + f - p) / p for g, f, p in
                                  zip(rows["png"], rows["png_ffmpeg"], rows["plain"]))
    print(f"\n{args.seconds:g}-s quadruped evaluation filmed at {args.fps:g} fps, "
          f"{args.width}x{args.height} ({count} frames), medians of {args.runs} runs:")
    print(f"  plain Evaluate (the daemon)                      {median('plain'):6.2f} s CPU")
    print(f"  Evaluate with an MP4 (the daemon + its ffmpeg)   {median('mp4'):6.2f} s CPU")
    print(f"    the video's cost / the evaluation              {mp4_ratio:6.2f}x")
    print(f"  Evaluate with PNG frames (the daemon)            {median('png'):6.2f} s CPU")
    print(f"  ... piped to ffmpeg here                         {median('png_ffmpeg'):6.2f} s CPU")
    print(f"    the video's cost / the evaluation              {png_ratio:6.2f}x")
    print(f"  this Python client receiving: MP4 {median('mp4_client'):.2f} s, "
          f"PNG frames {median('png_client'):.2f} s CPU (not counted)")
    return 0


def cli() -> int:
    """The yamor-film-bench command: main() with errors and Ctrl-C mapped to exit statuses."""
    return daemons.main_guard(main)


if __name__ == "__main__":
    sys.exit(cli())
