"""DynamicSettings (Object.splatline.dynamic): how scene frames map onto a dynamic capture's
own time (a 4D capture whose splats move, turn and fade by themselves).

The capture's per-splat time model lives in the object's PointCloud (data/dynamic_source.py);
these settings hold its time range, as the file gave it, and the user's mapping of it onto
the timeline: where it starts, how fast it plays, what plays outside its range, or a keyed
capture time that replaces the mapping (slow motion, freeze, reverse by keyframes).
"""
import bpy

from ...core.dynamic import timeline

_MODE_ITEMS = (
    (timeline.HOLD, "Hold", "Hold the first and last moments outside the capture's range"),
    (timeline.LOOP, "Loop", "Repeat the capture"),
    (timeline.PING_PONG, "Ping-Pong", "Play forwards, then backwards, and repeat"),
)
_UNIT_ITEMS = (
    (timeline.SECONDS, "Seconds", "The capture's time is in seconds"),
    (timeline.SEGMENT, "Segments", "The capture's time runs from 0 to 1 over each segment "
                                   "(Spacetime Gaussians' normalised time)"),
)


def _tag(self, _context):
    # a Python-side change does not reach the evaluated copy by itself (props/sequence.py)
    self.id_data.update_tag()


class DynamicSettings(bpy.types.PropertyGroup):
    enabled: bpy.props.BoolProperty(
        update=_tag, name="Dynamic", default=False, options=set(),
        description="Play the capture's own motion (set by the import of a dynamic capture)")
    model: bpy.props.StringProperty(
        name="Model", options=set(), description="The capture's time model, as its file gave it")
    unit: bpy.props.EnumProperty(update=_tag, name="Time Unit", items=_UNIT_ITEMS,
                                 default=timeline.SECONDS, options=set())
    time_start: bpy.props.FloatProperty(
        update=_tag, name="Capture Start", default=0.0, options=set(),
        description="The first moment of the capture, in its own time unit")
    time_end: bpy.props.FloatProperty(
        update=_tag, name="Capture End", default=1.0, options=set(),
        description="The last moment of the capture, in its own time unit")
    cutoff: bpy.props.FloatProperty(
        update=_tag, name="Cut-Off", default=0.0, options={"HIDDEN"},
        description="The .4dgs visibility cut-off of a splat's temporal weight")
    start_frame: bpy.props.FloatProperty(
        update=_tag, name="Start Frame", default=1.0,
        description="Scene frame at which the capture shows its first moment")
    frames_per_unit: bpy.props.FloatProperty(
        update=_tag, name="Frames per Unit", default=24.0, min=1e-3, soft_max=1000.0,
        description="Scene frames one unit of the capture's time spans (a capture in seconds "
                    "plays in real time at the scene's frame rate; a Spacetime segment spans "
                    "50 frames, as its training does)")
    mode: bpy.props.EnumProperty(
        update=_tag, name="Outside Range", items=_MODE_ITEMS, default=timeline.HOLD,
        description="What plays before and after the capture's range")
    use_capture_time: bpy.props.BoolProperty(
        update=_tag, name="Keyed Capture Time", default=False,
        description="Show the capture at Capture Time (keyframe it: slow motion, freeze, "
                    "reverse) instead of mapping the scene frame")
    capture_time: bpy.props.FloatProperty(
        update=_tag, name="Capture Time", default=0.0,
        description="The moment of the capture shown, in its own time unit (animatable)")

    def mapping(self) -> timeline.Mapping:
        return timeline.Mapping(
            time_start=self.time_start, time_end=self.time_end, start_frame=self.start_frame,
            frames_per_unit=self.frames_per_unit, mode=self.mode,
            capture_time=self.capture_time if self.use_capture_time else None)


classes = (DynamicSettings,)
