"""Operators (and the panels and menus that belong to one operator family): import/export,
effect stack, sequences, render and effect presets, camera tracks."""
