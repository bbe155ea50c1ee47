"""Where the repository and its real captures are, for tests and benches: one place, so a
test file's depth under tests/ never enters a path."""
from __future__ import annotations

import pathlib

REPO = pathlib.Path(__file__).resolve().parents[1]
TESTS = REPO / "tests"
# The read-only real captures beside the repository (never write here).
SHARED_TESTDATA = REPO.parent / "shared" / "testdata"
