"""``python -m taichi_shell_mpm.bench`` (the same as ``python -m taichi_shell_mpm bench``)."""
import argparse
import sys

from .cli import add_arguments, main

_p = argparse.ArgumentParser(prog="python -m taichi_shell_mpm bench")
add_arguments(_p)
sys.exit(main(_p.parse_args()))
