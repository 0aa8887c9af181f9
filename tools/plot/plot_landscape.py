#!/usr/bin/env python3
"""The old path of `yamor-plot-landscape` (yamor.tools.plot_landscape), for command lines that name it."""
import sys

from yamor.tools.plot_landscape import main

sys.exit(main())
