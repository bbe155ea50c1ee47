"""The one documented error type for bad splat input."""
from __future__ import annotations

import os


class SplatFormatError(Exception):
    """A splat file could not be read or written.

    Always names the file and the reason, so the command line and the Blender
    operators can show it as one line without a traceback.
    """

    def __init__(self, path, reason: str):
        self.path = os.fspath(path) if path is not None else "<memory>"
        self.reason = reason
        super().__init__(f"{self.path}: {reason}")
