"""Property groups: what the user sets on objects and scenes (Object.splatline, Scene.splatline).

One module per concern (display, look, effect, sequence, render); root.py nests them and is
the one that registers. Props hold values only: they may import core constants and tag the
evaluation cache, nothing else in blender/.
"""
