#!/usr/bin/env python3
"""The old path of `yamor-lifelong-bench` (yamor.tools.lifelong_bench), for command lines that name it."""
import sys

from yamor.tools.lifelong_bench import cli

sys.exit(cli())
