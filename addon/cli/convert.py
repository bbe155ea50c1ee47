"""python -m addon convert (placeholder until its owner fills it in)."""


def configure(parser):
    pass


def run(args) -> int:
    raise SystemExit("convert: not implemented yet")
