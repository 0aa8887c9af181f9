#!/usr/bin/env python3
"""The old path of `yamor-plot-characterize` (yamor.tools.plot_characterize), for command lines that name it."""
import sys

from yamor.tools.plot_characterize import main

sys.exit(main())
