"""python -m addon info (placeholder until its owner fills it in)."""


def configure(parser):
    pass


def run(args) -> int:
    raise SystemExit("info: not implemented yet")
