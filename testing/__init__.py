"""What the tests and benches share and the product never uses: the random-splat and PLY
variant generators (synth.py) and starting Blender's GPU in background mode (headless.py).

Beside addon/, not in it: the extension zip (blender_manifest.toml's paths_exclude_pattern)
and `pip install .` (pyproject.toml lists its packages) leave it out, and
tests/test_extension.py lists the built zip to check. Tests and benches import it as
`testing` from the repository root (tests/conftest.py and `python -m bench` put the root on
sys.path)."""
