"""python -m addon demo (placeholder until its owner fills it in)."""


def configure(parser):
    pass


def run(args) -> int:
    raise SystemExit("demo: not implemented yet")
