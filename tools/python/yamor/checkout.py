"""The source checkout the package runs from, and the binaries of its build trees.

The package is installed editable from ``tools/python`` (``make deps``), so its
files sit inside the checkout: the tools find ``configs/`` and ``build/`` from
here. ``YAMOR_SOURCE_DIR`` names another checkout (a wheel installed elsewhere).
"""

from __future__ import annotations

import os
from pathlib import Path

#: The checkout's root (the folder holding configs/, build/, tools/).
REPO = Path(os.environ.get("YAMOR_SOURCE_DIR") or Path(__file__).resolve().parents[3])

#: The build tree `make build` and the tests use.
RELEASE = REPO / "build" / "release"


def binary(env: str, relative: str) -> Path:
    """The program named by the environment variable `env`, else RELEASE / `relative`."""
    return Path(os.environ.get(env) or RELEASE / relative)
