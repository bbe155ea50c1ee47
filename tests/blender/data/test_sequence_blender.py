"""Splat sequences through real bpy: import, playback per frame, loop modes, keyframed timing,
missing frames, the .blend keeping only the path, and the read-ahead thread's lifetime."""
from __future__ import annotations

import logging
import os
import shutil
import threading

import numpy as np
import pytest

from addon.core import sequence as core_sequence
from addon.core.formats import read, write
from testing.synth import random_splats
from testing.sequence_files import write_frames

N_FRAMES = 5
FIELDS = ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")
CORRUPT_PLY = b"ply\nformat binary_little_endian 1.0\nelement vertex 9\nend_header\n"


def item_of(bpy, obj, frame):
    from addon.blender.evaluate.items import collect_items

    bpy.context.scene.frame_set(frame)
    items = [i for i in collect_items(bpy.context.evaluated_depsgraph_get()) if i.key[0] == obj.name]
    assert len(items) == 1
    return items[0]


def assert_same(a, b):
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def shown_frames(bpy, obj, frames, truth):
    """Which source frame (by exact position match) is shown at each scene frame."""
    out = []
    for f in frames:
        pos = item_of(bpy, obj, f).splats.positions
        hits = [k for k, t in enumerate(truth) if np.array_equal(pos, t.positions)]
        assert len(hits) == 1, f"frame {f}: matches {hits}"
        out.append(hits[0])
    return out


@pytest.fixture
def frames(tmp_path):
    paths = write_frames(tmp_path / "seq")
    return paths, [read(p) for p in paths]


@pytest.fixture
def seq_import(bpy_empty):
    from addon.blender.data.sequences import import_sequence

    return lambda path, **kw: import_sequence(bpy_empty.context, path, **kw)


def test_import_plays_each_frame_exactly(bpy_empty, frames, seq_import):
    from addon.blender.data.pointcloud import splats_from_pointcloud

    paths, truth = frames
    obj = seq_import(paths[0].parent)
    assert len([o for o in bpy_empty.data.objects]) == 1
    seq = obj.splatline.sequence
    assert (seq.enabled, seq.frame_count, seq.first_number, seq.start_frame) == (True, 5, 1, 1)
    assert_same(splats_from_pointcloud(obj.data), truth[0])  # PointCloud holds frame 1
    for f in (1, 2, 3, 4, 5, 3, 1):  # forwards, then scrubbing back
        assert_same(item_of(bpy_empty, obj, f).splats, truth[f - 1])
    assert_same(item_of(bpy_empty, obj, 9).splats, truth[4])   # HOLD after the end
    assert_same(item_of(bpy_empty, obj, -2).splats, truth[0])  # and before the start
    # cached frames are shared, so read-only: in-place effects cannot corrupt them
    assert not item_of(bpy_empty, obj, 2).splats.positions.flags.writeable
    # the item key changes with the frame, so caches downstream re-upload
    assert item_of(bpy_empty, obj, 2).key != item_of(bpy_empty, obj, 3).key


def test_import_from_a_file_and_scene_start_alignment(bpy_empty, tmp_path, seq_import):
    paths = write_frames(tmp_path / "s", count=3, first=0)
    truth = [read(p) for p in paths]
    bpy_empty.context.scene.frame_start = 10
    obj = seq_import(paths[1], align="SCENE_START", set_scene_range=True)
    assert obj.splatline.sequence.start_frame == 10
    assert (bpy_empty.context.scene.frame_start, bpy_empty.context.scene.frame_end) == (10, 12)
    assert shown_frames(bpy_empty, obj, [9, 10, 11, 12, 13], truth) == [0, 0, 1, 2, 2]


@pytest.mark.parametrize("mode", ["LOOP", "PING_PONG", "HOLD"])
def test_loop_modes(bpy_empty, frames, seq_import, mode):
    paths, truth = frames
    obj = seq_import(paths[0].parent, loop_mode=mode)
    scene_frames = list(range(-3, 14))
    expected = [core_sequence.frame_index(t, 5, 1, 1.0, 0.0, mode) for t in scene_frames]
    assert shown_frames(bpy_empty, obj, scene_frames, truth) == expected
    assert len(set(expected)) == 5
    if mode == "PING_PONG":
        assert expected[4:14] == [0, 1, 2, 3, 4, 3, 2, 1, 0, 1]  # frames 1..10


def test_offset_speed_and_loop_mode_keyframed(bpy_empty, frames, seq_import):
    paths, truth = frames
    obj = seq_import(paths[0].parent)
    seq = obj.splatline.sequence
    seq.speed = 0.0
    seq.keyframe_insert("speed", frame=1)
    seq.frame_offset = 0.0
    seq.keyframe_insert("frame_offset", frame=1)
    seq.frame_offset = 4.0
    seq.keyframe_insert("frame_offset", frame=3)       # linear 0 -> 4 over frames 1..3
    seq.speed = 2.0
    seq.keyframe_insert("speed", frame=6)
    seq.loop_mode = "HOLD"
    seq.keyframe_insert("loop_mode", frame=1)
    seq.loop_mode = "LOOP"
    seq.keyframe_insert("loop_mode", frame=7)
    for fc in _fcurves(obj):
        for key in fc.keyframe_points:
            key.interpolation = "LINEAR"
    # frame 1: offset 0 speed 0 -> 0; frame 2: offset 2 -> 2; frame 3..5: offset 4 -> 4 (speed
    # ramps 0 -> 2 over 1..6 but the local time is (t-1)*speed + 4 >= 4: HOLD keeps 4);
    # frame 7: speed 2, LOOP: (7-1)*2 + 4 = 16 -> 16 % 5 = 1
    got = shown_frames(bpy_empty, obj, [1, 2, 3, 7], truth)
    assert got == [0, 2, 4, 1]
    # the evaluated object carries the animated values the mapping used
    bpy_empty.context.scene.frame_set(2)
    ev = obj.evaluated_get(bpy_empty.context.evaluated_depsgraph_get()).splatline.sequence
    assert ev.frame_offset == pytest.approx(2.0) and ev.speed == pytest.approx(0.4)


def _fcurves(obj):
    """Blender 5 slotted actions keep fcurves in layers/strips/channelbags."""
    action = obj.animation_data.action
    for layer in action.layers:
        for strip in layer.strips:
            for bag in strip.channelbags:
                yield from bag.fcurves


def test_missing_frame_holds_previous_and_is_reported_once(bpy_empty, frames, seq_import, caplog):
    from addon.blender.data import sequence_source

    paths, truth = frames
    obj = seq_import(paths[0].parent)
    os.remove(paths[2])  # frame 3 goes missing after import
    caplog.set_level(logging.WARNING, logger="splatline.sequence")
    for _ in range(3):
        assert_same(item_of(bpy_empty, obj, 3).splats, truth[1])  # holds frame 2
    report = sequence_source.report_for(obj)
    assert "frame_0003.ply" in report and "missing" in report and "holding frame 1" in report
    warnings = [r for r in caplog.records if "frame_0003.ply" in r.getMessage()]
    assert len(warnings) == 1
    assert_same(item_of(bpy_empty, obj, 4).splats, truth[3])
    assert sequence_source.report_for(obj) == ""
    # a corrupt frame is held over as well, and its reason reported (the read-ahead thread
    # may be reading this file as it is rewritten: see the next test)
    paths[3].write_bytes(CORRUPT_PLY)
    assert_same(item_of(bpy_empty, obj, 4).splats, truth[1])
    assert "frame_0004.ply" in sequence_source.report_for(obj)
    # no earlier frame to hold: the next available one shows
    os.remove(paths[0])
    assert_same(item_of(bpy_empty, obj, 1).splats, truth[1])
    assert "holding frame 1" in sequence_source.report_for(obj)
    for path in paths:  # nothing left: an empty set, and the report says so
        if path.exists():
            os.remove(path)
    assert item_of(bpy_empty, obj, 2).splats.count == 0
    assert "nothing to show" in sequence_source.report_for(obj)


def test_blend_stores_the_path_only(bpy_empty, tmp_path, seq_import):
    project = tmp_path / "project"
    paths = write_frames(project / "frames", count=12, n=400, degree=2)
    truth = [read(p) for p in paths]
    blend = project / "scene.blend"
    bpy = bpy_empty
    obj = seq_import(paths[0].parent)  # unsaved .blend: an absolute path for now
    name = obj.name
    assert obj.splatline.sequence.directory == str(paths[0].parent)
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    assert obj.splatline.sequence.directory == "//frames/"  # made relative by the save
    # a copy saved elsewhere gets its own relative path; the open file keeps its own
    (tmp_path / "elsewhere").mkdir()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "elsewhere" / "copy.blend"), copy=True)
    assert obj.splatline.sequence.directory == "//frames/"
    frame_bytes = sum(p.stat().st_size for p in paths)
    one_frame = paths[0].stat().st_size
    # the .blend holds the first frame's PointCloud (Solid mode, Blender 5.3) and the
    # pattern: far less than two frames beyond an empty scene, not all twelve
    bpy.ops.wm.read_factory_settings(use_empty=True)
    empty = tmp_path / "empty.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(empty))
    extra = blend.stat().st_size - empty.stat().st_size
    print(f"blend extra {extra} B, one frame {one_frame} B, all frames {frame_bytes} B")
    assert frame_bytes == 12 * one_frame
    assert extra < 1.5 * one_frame
    # move the whole project: the relative path still finds the frames
    moved = tmp_path / "moved"
    shutil.move(str(project), str(moved))
    bpy.ops.wm.open_mainfile(filepath=str(moved / "scene.blend"))
    obj = bpy.data.objects[name]
    for f in (1, 7, 12):
        assert_same(item_of(bpy, obj, f).splats, truth[f - 1])
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "elsewhere" / "copy.blend"))
    assert bpy.data.objects[name].splatline.sequence.directory == "//../project/frames/"


def test_cache_budget_and_read_ahead_thread_lifetime(bpy_empty, frames, seq_import):
    from addon.blender.data import sequence_source

    paths, truth = frames
    obj = seq_import(paths[0].parent)
    seq = obj.splatline.sequence
    item_of(bpy_empty, obj, 1)
    rt = sequence_source.runtime()
    assert rt.read_ahead.wait_idle(30)
    mine = str(paths[0].parent)
    cached = {k[1] for k in rt.cache.keys() if k[0].startswith(mine)}
    assert cached == {0, 1, 2, 3, 4}  # frame 1 plus read-ahead of 4 (default)
    frame_bytes = core_sequence.splats_nbytes(truth[0])
    seq.cache_budget_mb = 0  # only the current frame may stay
    item_of(bpy_empty, obj, 3)
    assert rt.read_ahead.wait_idle(30)
    # earlier tests' objects went with their files (load_post unpinned them): only the
    # current frame of this object is left
    assert [k[1] for k in rt.cache.keys()] == [2] and rt.cache.nbytes == frame_bytes
    assert rt.read_ahead.running
    sequence_source.unregister()  # the cache's owner: its unregister joins the thread
    try:
        assert not any(t.name == "splatline-readahead" for t in threading.enumerate())
    finally:
        sequence_source.register()
    assert_same(item_of(bpy_empty, obj, 4).splats, truth[3])  # a fresh runtime after re-register


def test_a_frame_rewritten_while_the_read_ahead_reads_it_is_held(bpy_empty, frames, seq_import, monkeypatch):
    """The 5.2 worker crash (issue 41): test_missing_frame_holds_previous_and_is_reported_once
    rewrites frame_0004.ply in place (write_bytes: truncate, then 56 bytes) while the read-ahead
    thread may still be decoding it (it loads a frame the main thread is also loading, as
    wait_if_loading only waits for a decode already started). The memory-mapped body then
    raised SIGBUS in that thread, killing the worker. The same rewrite, landed inside the
    thread's read by readfile.after_block: the thread's read fails, the process lives, and
    the frame shown holds the previous one until the file is whole again."""
    from addon.blender.data import sequence_source
    from addon.core.formats import readfile

    paths, truth = frames
    obj = seq_import(paths[0].parent)
    hit = []

    def rewrite_in_thread(path, k):
        if not hit and threading.current_thread().name == "splatline-readahead" \
                and os.path.samefile(path, paths[2]):
            hit.append(k)
            paths[2].write_bytes(CORRUPT_PLY)
    monkeypatch.setattr(readfile, "BLOCK", 256)
    monkeypatch.setattr(readfile, "after_block", rewrite_in_thread)
    item_of(bpy_empty, obj, 1)  # reads ahead frames 2-5
    rt = sequence_source.runtime()
    assert rt.read_ahead.wait_idle(30)
    assert hit == [0] and rt.read_ahead.running
    assert (str(paths[2]), 2) not in rt.cache
    assert_same(item_of(bpy_empty, obj, 3).splats, truth[1])
    report = sequence_source.report_for(obj)
    assert "frame_0003.ply" in report and "holding frame 1" in report
    write(paths[2], truth[2])
    assert_same(item_of(bpy_empty, obj, 3).splats, truth[2])
    assert sequence_source.report_for(obj) == ""


def test_import_operator_from_folder_or_file(bpy_empty, tmp_path):
    bpy = bpy_empty
    write_frames(tmp_path / "a", count=3)
    other = write_frames(tmp_path / "a", count=2, first=7)  # same prefix, later numbers
    assert bpy.ops.import_scene.splatline_sequence(directory=str(tmp_path / "a")) == {"FINISHED"}
    seq = bpy.context.active_object.splatline.sequence
    assert (seq.first_number, seq.frame_count) == (1, 8)  # 4..6 are missing frames
    assert bpy.ops.import_scene.splatline_sequence(filepath=str(other[0]), loop_mode="LOOP") == {"FINISHED"}
    assert bpy.context.active_object.splatline.sequence.loop_mode == "LOOP"
    assert len(_users_objects(bpy)) == 2
    with pytest.raises(RuntimeError, match="no numbered splat files"):
        bpy.ops.import_scene.splatline_sequence(directory=str(tmp_path))
    assert len(_users_objects(bpy)) == 2
    assert {o.data for o in _users_objects(bpy)} == {p for p in bpy.data.pointclouds if p.users
                                                     and not _companion_data(bpy, p)}


def _users_objects(bpy):
    """Objects the user made (on 5.3 a sequence also has a companion holding its frame for
    Blender's engines: data/evaluated_geometry.py)."""
    from addon.blender.data.evaluated_geometry import is_companion

    return [o for o in bpy.data.objects if not is_companion(o)]


def _companion_data(bpy, pointcloud):
    from addon.blender.data.evaluated_geometry import is_companion

    return any(is_companion(o) and o.data == pointcloud for o in bpy.data.objects)


def test_splat_format_frames_and_subframes(bpy_empty, tmp_path, seq_import):
    """Any readable format works as frames; subframes (motion blur) map through speed."""
    (tmp_path / "sp").mkdir()
    truth = []
    for i in range(6):
        path = tmp_path / "sp" / f"cap{i}.splat"
        write(path, random_splats(30, degree=0, seed=i))
        truth.append(read(path))
    obj = seq_import(tmp_path / "sp", align="SCENE_START")
    obj.splatline.sequence.speed = 2.0
    scene = bpy_empty.context.scene
    from addon.blender.evaluate.items import collect_items

    for frame, subframe, want in ((1, 0.0, 0), (1, 0.5, 1), (2, 0.25, 2), (2, 0.5, 3), (3, 0.0, 4)):
        scene.frame_set(frame, subframe=subframe)
        (item,) = collect_items(bpy_empty.context.evaluated_depsgraph_get())
        np.testing.assert_array_equal(item.splats.positions, truth[want].positions)
