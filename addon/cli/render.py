"""python -m addon render (placeholder until its owner fills it in)."""


def configure(parser):
    pass


def run(args) -> int:
    raise SystemExit("render: not implemented yet")
