"""compat: one entry point for the API differences between Blender 4.5 and 5.x.

Stand-ins give both API shapes in any venv; the real-bpy test checks the running one."""
from __future__ import annotations

from types import SimpleNamespace

import pytest

from addon.blender import compat


class _Image:
    """ImageFormatSettings of 5.0 (with_media=True: a format needs its media type first)
    or 4.5 (no media_type, every format accepted)."""

    ACCEPTS = {"IMAGE": {"PNG", "OPEN_EXR"}, "MULTI_LAYER_IMAGE": {"OPEN_EXR_MULTILAYER"},
               "VIDEO": {"FFMPEG"}}

    def __init__(self, with_media: bool):
        props = {"file_format": None, **({"media_type": None} if with_media else {})}
        object.__setattr__(self, "bl_rna", SimpleNamespace(properties=props))
        object.__setattr__(self, "file_format", "PNG")
        if with_media:
            object.__setattr__(self, "media_type", "IMAGE")

    def __setattr__(self, name, value):
        if name == "file_format" and hasattr(self, "media_type"):
            if value not in self.ACCEPTS[self.media_type]:
                raise TypeError(f"enum {value!r} not found")
        object.__setattr__(self, name, value)


@pytest.mark.parametrize("with_media", [True, False], ids=["5.0", "4.5"])
@pytest.mark.parametrize("fmt, media", [("OPEN_EXR_MULTILAYER", "MULTI_LAYER_IMAGE"),
                                        ("FFMPEG", "VIDEO"), ("PNG", "IMAGE"), ("OPEN_EXR", "IMAGE")])
def test_set_file_format_on_either_api(with_media, fmt, media):
    image = _Image(with_media)
    compat.set_file_format(image, "FFMPEG" if fmt != "FFMPEG" else "PNG")  # start elsewhere
    compat.set_file_format(image, fmt)
    assert image.file_format == fmt
    assert compat.media_type(image) == media
    assert compat.has_media_type(image) == with_media


def _world(tree, use_nodes, deprecated):
    prop = SimpleNamespace(is_deprecated=deprecated)
    return SimpleNamespace(node_tree=tree, use_nodes=use_nodes,
                           bl_rna=SimpleNamespace(properties={"use_nodes": prop}))


@pytest.mark.parametrize("tree, use_nodes, deprecated, want", [
    (None, False, False, False),      # 4.5: a new world, no tree
    ("tree", False, False, False),    # 4.5: Use Nodes unticked renders world.color
    ("tree", True, False, True),
    ("tree", False, True, True),      # 5.0: use_nodes deprecated, the tree always renders
    (None, True, True, False),
])
def test_world_uses_nodes(tree, use_nodes, deprecated, want):
    assert compat.world_uses_nodes(_world(tree, use_nodes, deprecated)) is want


def test_real_bpy_formats_and_world(bpy_empty):
    bpy = bpy_empty
    image = bpy.context.scene.render.image_settings
    for fmt in ("OPEN_EXR_MULTILAYER", "FFMPEG", "PNG"):
        compat.set_file_format(image, fmt)
        assert image.file_format == fmt
    world = bpy.data.worlds.new("w")
    tree = compat.world_node_tree(world)
    assert tree is not None and "Background" in tree.nodes
    assert compat.world_uses_nodes(world)
