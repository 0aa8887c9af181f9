#!/usr/bin/env python3
"""The old path of `yamor-learning-bench` (yamor.tools.learning_bench), for command lines that name it."""
import sys

from yamor.tools.learning_bench import cli

sys.exit(cli())
