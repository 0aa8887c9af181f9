#!/usr/bin/env python3
"""The old path of `yamor-plot-setpoints` (yamor.tools.plot_setpoints), for command lines that name it."""
import sys

from yamor.tools.plot_setpoints import main

sys.exit(main())
