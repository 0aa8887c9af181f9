"""yamor-film-bench (yamor.tools.film_bench): its options, and a short run against the real build.

The run starts a real yamord, films a 2-s evaluation at 64x48 as an MP4 made
by the daemon and as PNG frames piped to ffmpeg here, and checks the table.
The build is $YAMOR_BUILD, else the one $YAMORD lives in (build/release).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO, YAMORD

from yamor.tools import film_bench

BUILD = Path(os.environ.get("YAMOR_BUILD", YAMORD.parent.parent))
BENCH = [sys.executable, "-m", "yamor.tools.film_bench"]


def load_bench():
    return film_bench


def test_options_and_bad_values(capsys):
    bench = load_bench()
    args = bench.parse_args([])
    assert (args.runs, args.seconds, args.fps, args.width, args.height) == (7, 20.0, 25.0, 320, 240)
    for bad, says in ((["--runs", "0"], "--runs must be at least 1"),
                      (["--seconds", "0"], "--seconds must be > 0"),
                      (["--fps", "300"], "--fps must be in (0, 240]"),
                      (["--size", "32"], "expected WIDTHxHEIGHT"),
                      (["--size", "0x10"], "width and height must be 1..4096")):
        with pytest.raises(SystemExit):
            bench.parse_args(bad)
        assert says in capsys.readouterr().err


@pytest.mark.skipif(shutil.which("ffmpeg") is None, reason="ffmpeg not installed")
def test_a_short_run_prints_both_ways_of_filming(tmp_path):
    if not YAMORD.is_file():
        pytest.skip(f"yamord not built: {YAMORD}")
    result = subprocess.run([*BENCH, "--runs", "1", "--seconds", "2",
                             "--size", "64x48", "--build", str(BUILD)],
                            cwd=REPO, capture_output=True, text=True, timeout=300)
    if "no renderer" in result.stderr:
        pytest.skip("no renderer on this machine")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "2-s quadruped evaluation filmed at 25 fps, 64x48 (50 frames), medians of 1 runs" \
        in result.stdout
    ratios = re.findall(r"the video's cost / the evaluation\s+(-?[\d.]+)x", result.stdout)
    assert len(ratios) == 2, result.stdout
    assert re.search(r"Evaluate with an MP4 \(the daemon \+ its ffmpeg\)\s+[\d.]+ s CPU",
                     result.stdout)
