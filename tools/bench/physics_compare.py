#!/usr/bin/env python3
"""The old path of `yamor-physics-compare` (yamor.tools.physics_compare), for command lines that name it."""
import sys

from yamor.tools.physics_compare import main

sys.exit(main())
