"""Blender data <-> SplatSet: PointCloud attributes, splat files, sequences, cameras.

pointcloud.py is the attribute schema (and the one splat-object predicate), files.py imports
and exports splat files (side by side, as Blender's glTF importer keeps them), sequences.py
imports numbered folders and bakes, native.py knows Blender 5.3's own splats,
capture_camera.py keys a camera from a framing or a camera track, transforms.py reads an
object's world matrix at a frame; presets.py and effect_presets.py are the preset library that
the operators, the command line and the demo share.
"""
