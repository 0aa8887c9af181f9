#!/usr/bin/env python3
"""The old path of `yamor-plot-timeline` (yamor.tools.plot_timeline); yamor-lifelong runs this file (its timeline.png) with any Python that has matplotlib,
so the module runs from its file, the yamor package need not be installed."""
import runpy
from pathlib import Path

runpy.run_path(str(Path(__file__).resolve().parents[1] / "python" / "yamor" / "tools" / "plot_timeline.py"),
               run_name="__main__")
