#!/usr/bin/env python3
"""The old path of `yamor-film-bench` (yamor.tools.film_bench), for command lines that name it."""
import sys

from yamor.tools.film_bench import cli

sys.exit(cli())
