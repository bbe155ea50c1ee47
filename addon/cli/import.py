"""python -m addon import (placeholder until its owner fills it in)."""


def configure(parser):
    pass


def run(args) -> int:
    raise SystemExit("import: not implemented yet")
