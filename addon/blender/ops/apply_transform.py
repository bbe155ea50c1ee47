"""Object > Apply > Splat Rotation & Scale: the object's rotation and scale baked into its
splats (centres, shapes, SH bands: core/linear_map.py, the maths of `convert --rotate/
--scale`), leaving it an identity rotation and scale and the same rendered frame.

Blender's own Apply > Rotation & Scale moves a PointCloud's points only: the splats'
rotations, scales and SH stay as they were, so the capture changes its look. This operator
works on Splatline's imports and on Blender 5.3's own (wm.ply_import).
"""
from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix

from ...core.linear_map import bake
from ..data.files import AXES_PROP
from ..data.pointcloud import overwrite_pointcloud, splats_from_pointcloud
from ..data.sources import is_splat_object, source_of
from ..registration import classes_and_menus
from .reporting import finish_reporting


def _refusal(obj) -> str | None:
    """Why obj's transform cannot be baked into its data, or None."""
    if not source_of(obj).stored:
        return f"{obj.name}: its splats come from {source_of(obj).label}, not its own data"
    if obj.data.users > 1:
        return f"{obj.name}: its data has {obj.data.users} users (make it single user first)"
    if obj.data.library is not None or obj.library is not None:
        return f"{obj.name}: linked from a library"
    return None


def apply_rotation_scale(obj) -> None:
    """Bake obj's own rotation and scale (matrix_basis, not its parent's) into its data;
    its location stays. Raises ValueError (core.linear_map) where that is not exact."""
    basis = np.array(obj.matrix_basis, np.float64)
    linear = basis[:3, :3]
    if np.allclose(linear, np.eye(3), rtol=0, atol=1e-12):
        return
    splats = bake(splats_from_pointcloud(obj.data), linear)
    overwrite_pointcloud(obj.data, splats)
    obj.matrix_basis = Matrix.Translation(obj.matrix_basis.translation)
    turn = np.eye(4)
    turn[:3, :3] = linear  # what the object's matrix lost: its children keep their place,
    for child in obj.children:  # as with Blender's own Apply
        child.matrix_parent_inverse = Matrix(turn.tolist()) @ child.matrix_parent_inverse
    # the data is now in the frame the object showed it in: Blender's (export reframes it)
    obj[AXES_PROP] = "RFU"


class OBJECT_OT_splatline_apply_transform(bpy.types.Operator):
    """Bake the selected splat objects' rotation and scale into their splats (positions, shapes and view-dependent colour), keeping how they look"""

    bl_idname = "object.splatline_apply_transform"
    bl_label = "Splat Rotation & Scale"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return any(is_splat_object(o, with_splat_data=True) for o in context.selected_objects)

    def execute(self, context):
        objects = [o for o in context.selected_objects if is_splat_object(o, with_splat_data=True)]
        refused = [why for why in map(_refusal, objects) if why]
        if refused:
            self.report({"ERROR"}, "; ".join(refused))
            return {"CANCELLED"}

        def action():
            for obj in objects:
                try:
                    apply_rotation_scale(obj)
                except ValueError as exc:
                    raise ValueError(f"{obj.name}: {exc}") from None
            return f"Baked rotation and scale into {len(objects)} splat object(s)"

        return finish_reporting(self, action, (ValueError,))


def _menu(self, _context):
    self.layout.operator(OBJECT_OT_splatline_apply_transform.bl_idname)


register, unregister = classes_and_menus((OBJECT_OT_splatline_apply_transform,),
                                         (("VIEW3D_MT_object_apply", _menu),))
