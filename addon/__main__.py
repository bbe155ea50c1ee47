"""Command line: python -m addon {info,convert,import,render,demo} ... (from the checkout), or
`splatline ...` once installed with pip (pyproject.toml: the console script is `console`).

Each subcommand lives in addon/cli/<name>.py (import: import_files.py) with configure(parser)
and run(args) -> int.
Errors a user can cause exit non-zero with one line naming the file and the problem.
"""
from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import signal
import sys
import threading

# OpenBLAS starts a thread per core as numpy loads, and idle ones spin a while before they
# sleep: 0.07 s of system CPU at start here, and more after every product. Only convert's
# SOG k-means (core/quantize.py) has products worth sharing out (on one thread: +9% wall
# time, -30% CPU on 300k splats); the other commands' paths make none (render's frames
# took the same time either way). So they run with one, unless the user set it; set before
# numpy's first import, which is this process's own only when numpy is not loaded yet.
BLAS_COMMANDS = frozenset({"convert"})
if "numpy" not in sys.modules and sys.argv[1:2] and sys.argv[1] not in BLAS_COMMANDS:
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402 (after the thread count)

from .cli import UsageError, UserError
from .core import atomic, budget, stop
from .core.errors import SplatFormatError

COMMANDS = {
    "info": "print a splat file's count, SH degree, format and bounds",
    "convert": "convert splat files, or splat objects of a .blend, to another format",
    "import": "import splat files into a new .blend",
    "render": "render a .blend, or a bare capture under an added camera, with the Splatline engine",
    "demo": "build, animate and render the demo scene",
}


# A command's module is named for it, but for `import`, a Python keyword (no module can be
# imported by that name with an import statement).
_MODULES = {"import": "import_files"}


def _command_module(command: str):
    return importlib.import_module(f".cli.{_MODULES.get(command, command)}", __package__)


def _parser(prog: str = "python -m addon") -> argparse.ArgumentParser:
    # allow_abbrev=False: `--sh-degre` is a misspelling to report, not --sh-degree; an
    # abbreviation accepted today would change meaning when a longer option is added.
    parser = argparse.ArgumentParser(prog=prog, description="Splatline command line", allow_abbrev=False)
    parser.add_argument("--version", action="version", version=f"%(prog)s {version()}")
    sub = parser.add_subparsers(dest="command", required=True)
    for name, help_text in COMMANDS.items():
        module = _command_module(name)
        module.configure(command := sub.add_parser(name, help=help_text, description=help_text,
                                                   allow_abbrev=False))
        command.set_defaults(command_parser=command)
        command.add_argument("--max-memory", type=_size, metavar="SIZE",
                             help="memory budget, e.g. 1.5G: a file or option that would need more is "
                                  "refused before allocating (default: available memory with headroom)")
    return parser


def version() -> str:
    """blender_manifest.toml's version (beside addon/ in the checkout, the extension and the
    pip install alike), else the installed distribution's."""
    import tomllib

    manifest = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "blender_manifest.toml")
    try:
        with open(manifest, "rb") as f:
            return str(tomllib.load(f)["version"])
    except (OSError, KeyError, tomllib.TOMLDecodeError):
        from importlib import metadata
        try:
            return metadata.version("splatline")
        except metadata.PackageNotFoundError:
            return "(version unknown)"


def _size(text: str) -> int:
    try:
        return budget.parse_size(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _unrecognized(parser, unknown) -> None:
    import difflib

    known = [o for action in parser._actions for o in action.option_strings if o.startswith("--")]
    guesses = [g for u in unknown if u.startswith("-")
               for g in difflib.get_close_matches(u.split("=")[0], known, n=1)]
    hint = f" (did you mean {', '.join(guesses)}?)" if guesses else ""
    parser.error(f"unrecognized arguments: {' '.join(unknown)}{hint}")  # exits 2


def _name(filename) -> str:
    return os.fsdecode(filename) if isinstance(filename, (bytes, os.PathLike)) else str(filename)  # may be an fd


def _os_error_text(exc: OSError) -> str:
    """'<file>: <reason>' without Python's '[Errno N]' and quoting; rename-like errors name both."""
    reason = exc.strerror or str(exc) or type(exc).__name__
    names = [_name(n) for n in (exc.filename, exc.filename2) if n is not None]
    return f"{' -> '.join(names)}: {reason}" if names else reason


def main(argv=None, prog: str = "python -m addon") -> int:
    # SIGTERM is a stop from here on: on a loaded machine the parser's imports alone took
    # over a second, and a SIGTERM then ended the process by the signal, unreported
    with _sigterm_as_sigint() as terminated:
        try:
            args, module = _command(argv, prog)
        except KeyboardInterrupt:
            print("interrupted", file=sys.stderr)
            return 130
        # a command's budget and record of what it replaced are its own: tests and scripts run
        # several commands in one process, and a later read must not count an earlier plan
        budget.set_max_memory(args.max_memory)
        atomic.forget_attempts()
        try:
            rc = _run(module, args)
        finally:
            budget.after_read(None)
    if terminated and rc == 0:  # caught where Blender swallows exceptions (a handler): the work
        print(_interrupted("interrupted (SIGTERM)"), file=sys.stderr)  # finished whole, but still a stop
        return 130
    return rc


def _command(argv, prog):
    """(parsed arguments, the command's module)."""
    args, unknown = _parser(prog).parse_known_args(argv)
    if unknown:  # the sub-command's usage, not the top level's, and a guess at a misspelling
        _unrecognized(args.command_parser, unknown)
    return args, _command_module(args.command)


def _interrupted(head: str = "interrupted") -> str:
    """The interrupted line says what is on disk: 'interrupted' when the command replaced
    nothing, else what it wrote (each whole: core/atomic.replacing), as the disk shows it."""
    wrote = atomic.written()
    if not wrote:
        return head
    if len(wrote) > 2:
        return f"{head}: wrote {len(wrote)} files ({wrote[0]} ... {wrote[-1]}), each whole"
    return f"{head}: wrote {' and '.join(wrote)}, whole"


@contextlib.contextmanager
def _sigterm_as_sigint():
    """SIGTERM is handled as Ctrl+C for the command: KeyboardInterrupt, so every writer
    removes its temporaries and claims and the command ends with "interrupted", exit 130
    (a render stops after its finished frames: cli/render_job.py). Python code runs only
    between Blender's C steps, so a .blend save in progress finishes, whole, first."""
    terminated = []  # the SIGTERMs caught
    if threading.current_thread() is not threading.main_thread():
        yield terminated
        return

    def handler(signum, frame):
        terminated.append(signum)
        stop.terminate()
        raise KeyboardInterrupt

    stop.forget_termination()
    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield terminated
    finally:
        signal.signal(signal.SIGTERM, old)
        stop.forget_termination()


def _run(module, args) -> int:
    try:
        # Overflow in decoding (exp of a huge log-scale, ...) gives Inf, which the bad-value
        # policy then drops, fixes or refuses and reports on one line: numpy's own warnings
        # would only add noise to stderr.
        with np.errstate(all="ignore"):
            return int(module.run(args) or 0)
    except UsageError as exc:  # an option out of range: usage, as argparse's own errors
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except (SplatFormatError, UserError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:  # permission denied, not a directory, disk full...: the user's to fix
        print(f"error: {_os_error_text(exc)}", file=sys.stderr)
        return 1
    except MemoryError:
        print(f"error: out of memory running {args.command!r}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # Ctrl+C, or SIGTERM (_sigterm_as_sigint)
        print(_interrupted(), file=sys.stderr)
        return 130


def console() -> None:
    """The `splatline` command that `pip install .` puts on PATH."""
    sys.exit(main(prog="splatline"))


if __name__ == "__main__":
    sys.exit(main())
