"""Command line: python -m addon {info,convert,import,render,demo} ...

Each subcommand lives in addon/cli/<name>.py with configure(parser) and run(args) -> int.
Errors a user can cause exit non-zero with one line naming the file and the problem.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from .cli import UserError
from .core.errors import SplatFormatError

COMMANDS = {
    "info": "print a splat file's count, SH degree, format and bounds",
    "convert": "convert a splat file to another format",
    "import": "import splat files into a new .blend",
    "render": "render a .blend with the Splatline engine",
    "demo": "build, animate and render the demo scene",
}


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m addon", description="Splatline command line")
    sub = parser.add_subparsers(dest="command", required=True)
    for name, help_text in COMMANDS.items():
        module = importlib.import_module(f".cli.{name}", __package__)
        module.configure(sub.add_parser(name, help=help_text, description=help_text))
    return parser


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    module = importlib.import_module(f".cli.{args.command}", __package__)
    try:
        return int(module.run(args) or 0)
    except (SplatFormatError, UserError, FileNotFoundError, IsADirectoryError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
