#!/usr/bin/env python3
"""The old path of `yamor-reproduce` (yamor.tools.reproduce), for command lines that name it."""
import sys

from yamor.tools.reproduce import cli

sys.exit(cli())
