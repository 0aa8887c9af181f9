#!/usr/bin/env python3
"""The old path of `yamor-soak` (yamor.tools.soak), for command lines that name it."""
import sys

from yamor.tools.soak import main

sys.exit(main())
