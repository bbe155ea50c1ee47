# SPDX-License-Identifier: GPL-3.0-or-later
"""Splatline extension entry point: everything lives in addon/."""
from .addon import register, unregister  # noqa: F401
