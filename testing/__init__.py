"""What the tests and benches share and the product never uses: the random-splat and PLY
variant generators (synth.py), starting Blender's GPU in background mode (headless.py),
Blender's bundled OpenImageIO on the path (blender_packages.py), and the scenes both build:
engine_scene.py (splat objects, cameras, render output, reading EXR/PNG back),
viewport_scene.py (offscreen viewport draws, PSNR), engine_paths_scene.py, holdout_scenes.py
and mesh_layer_scene.py; the helpers several test files use (capture_scenes.py,
gl_scenes.py, reference_oracle.py, cli_runs.py, ...; a test module never imports another); and
paths.py, where the repository and ../shared/testdata are.

Beside addon/, not in it: the extension zip (blender_manifest.toml's paths_exclude_pattern)
and `pip install .` (pyproject.toml lists its packages) leave it out, and
tests/project/test_extension.py lists the built zip to check. Tests and benches import it as
`testing` from the repository root (pytest.ini's `pythonpath = .` and `python -m bench` put
the root on sys.path), so neither reaches into the other's folder.
"""
