#!/usr/bin/env python3
"""The old path of `yamor-plot-progress` (yamor.tools.plot_progress); yamor-optimize runs this file (its progress.png) with any Python that has matplotlib,
so the module runs from its file, the yamor package need not be installed."""
import runpy
from pathlib import Path

runpy.run_path(str(Path(__file__).resolve().parents[1] / "python" / "yamor" / "tools" / "plot_progress.py"),
               run_name="__main__")
