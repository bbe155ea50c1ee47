"""`python -m addon demo`: the showcase scene (demo/scene.py) and its video output (demo/video.py)."""
