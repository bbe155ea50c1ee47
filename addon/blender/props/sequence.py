"""SequenceSettings (Object.splatline.sequence): where a splat sequence's frames live and
how scene time maps onto them. The .blend stores this pattern, never the frames."""
import bpy

from ...core import sequence as core_sequence

_LOOP_ITEMS = (
    (core_sequence.HOLD, "Hold", "Hold the first and last frames outside the sequence"),
    (core_sequence.LOOP, "Loop", "Repeat the sequence"),
    (core_sequence.PING_PONG, "Ping-Pong", "Play forwards, then backwards, and repeat"),
)


def _tag(self, _context):
    # a Python-side change does not reach the evaluated copy by itself; tag the object so
    # the next depsgraph evaluation (viewport, render, frame_set) sees the new value
    self.id_data.update_tag()


class SequenceSettings(bpy.types.PropertyGroup):
    enabled: bpy.props.BoolProperty(update=_tag, 
        name="Sequence", default=False, options=set(),
        description="Show the frames of a splat sequence instead of the object's own points")
    directory: bpy.props.StringProperty(update=_tag, 
        name="Directory", subtype="DIR_PATH", options={"PATH_SUPPORTS_BLEND_RELATIVE"},
        description="Folder of the frame files ('//' = relative to the .blend)")
    prefix: bpy.props.StringProperty(update=_tag, name="Prefix", options=set(),
                                     description="File name before the frame number")
    suffix: bpy.props.StringProperty(update=_tag, name="Suffix", default=".ply", options=set(),
                                     description="File name after the frame number (extension)")
    digits: bpy.props.IntProperty(update=_tag, name="Digits", default=4, min=1, max=12, options=set(),
                                  description="Zero padding of the frame number")
    first_number: bpy.props.IntProperty(update=_tag, name="First Number", default=1, min=0, options=set(),
                                        description="Number in the first frame's file name")
    frame_count: bpy.props.IntProperty(update=_tag, name="Frames", default=1, min=1, options=set(),
                                       description="Frames in the sequence (missing files included)")
    start_frame: bpy.props.IntProperty(update=_tag, 
        name="Start Frame", default=1, options=set(),
        description="Scene frame at which the sequence shows its first frame (before offset)")
    frame_offset: bpy.props.FloatProperty(update=_tag, 
        name="Offset", default=0.0,
        description="Sequence frames added to the mapped time (animatable)")
    speed: bpy.props.FloatProperty(update=_tag, 
        name="Speed", default=1.0, soft_min=-4.0, soft_max=4.0,
        description="Sequence frames per scene frame; 0 freezes on the offset frame (animatable)")
    loop_mode: bpy.props.EnumProperty(update=_tag, 
        name="Loop", items=_LOOP_ITEMS, default=core_sequence.HOLD,
        description="What plays outside the sequence's range (animatable)")
    cache_budget_mb: bpy.props.IntProperty(update=_tag, 
        name="Cache Budget (MB)", default=512, min=0, soft_max=16384, options=set(),
        description="Memory for decoded frames beyond the current one (read-ahead and recent frames)")
    read_ahead: bpy.props.IntProperty(update=_tag, 
        name="Read-Ahead", default=4, min=0, max=64, options=set(),
        description="Upcoming frames decoded in the background while the budget allows")

    def pattern(self, directory: str) -> core_sequence.SequencePattern:
        """The frames' pattern with directory resolved by the caller (bpy.path.abspath)."""
        return core_sequence.SequencePattern(directory, self.prefix, self.suffix, self.digits,
                                             self.first_number, self.frame_count)


classes = (SequenceSettings,)
