#!/usr/bin/env python3
"""The old path of `yamor-mujoco-eval` (yamor.tools.mujoco_eval); any Python that has mujoco runs it,
so the module runs from its file, the yamor package need not be installed."""
import runpy
from pathlib import Path

runpy.run_path(str(Path(__file__).resolve().parents[1] / "python" / "yamor" / "tools" / "mujoco_eval.py"),
               run_name="__main__")
