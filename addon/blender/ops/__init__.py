"""Operators: import/export, effect stack, sequences, render and effect presets, camera
tracks. Their panels and menus are ui/'s; library code they share with the command line
(presets, effect presets) is data/'s."""
