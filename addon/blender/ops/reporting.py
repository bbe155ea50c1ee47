"""How an operator that does one thing which may fail ends: a line saying what it did
(INFO, FINISHED), or why it did nothing (ERROR, CANCELLED)."""
from __future__ import annotations


def finish_reporting(op, action, errors=(), describe=str) -> set:
    """Run action() -> the line saying what it did (None: it reported why not itself). An
    exception of the `errors` types becomes an ERROR report, describe(exc)."""
    try:
        done = action()
    except errors as exc:
        op.report({"ERROR"}, describe(exc))
        return {"CANCELLED"}
    if done is None:
        return {"CANCELLED"}
    op.report({"INFO"}, done)
    return {"FINISHED"}
