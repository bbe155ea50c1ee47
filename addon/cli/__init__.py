"""Command-line subcommands (python -m addon ...): one module per command."""


class UserError(Exception):
    """A problem with the command's input that deserves one line, not a traceback.

    Defined here, not in addon/__main__.py: under `python -m addon` that module runs as
    __main__, and importing addon.__main__ again would make a second, different class.
    """


class UsageError(UserError):
    """An option outside what the command accepts (exit code 2, as argparse's usage errors)."""
