#!/usr/bin/env python3
"""The old path of `yamor-generated-bench` (yamor.tools.generated_bench), for command lines that name it."""
import sys

from yamor.tools.generated_bench import cli

sys.exit(cli())
