"""Splat objects of a .blend as `convert` inputs: `python -m addon convert SCENE.blend
--object NAME OUT.spz` writes what File > Export writes for that object.

Any splat object with data counts: Splatline's imports and Blender 5.3's own (wm.ply_import,
wm.spz_import), which Blender itself cannot export. The stored data is read, object-local,
in the frame data/files.object_axes gives it (Splatline's recorded file frame, else a PLY's
RDF; `--axes` says it where the object cannot, e.g. RFU for Blender's SPZ import).
"""
from __future__ import annotations

import os

from ..core.errors import SplatFormatError
from ..core.formats import ReadReport
from ..core.splats import RENDER_MAX_DEGREE, sh_coeff_count
from . import UserError


def read_objects(path, names, axes=None) -> list:
    """[(SplatSet, ReadReport)] of the named splat objects of the .blend at `path`, in the
    order named; with no names, its one splat object (a UserError lists them if it holds
    several). The report's path is 'SCENE.blend:NAME', its format 'blend'."""
    from .blender_session import start

    if not os.path.isfile(path):  # before starting Blender, which would print its own error
        raise SplatFormatError(path, "no such file" if not os.path.exists(path) else "is not a regular file")
    bpy = start(path)  # an unreadable .blend: SplatFormatError naming it
    from ..blender.data.files import object_splats
    from ..blender.data.sources import is_splat_object

    found = sorted(o.name for o in bpy.data.objects if is_splat_object(o, with_splat_data=True))
    if not names:
        if len(found) != 1:
            raise UserError(f"{path}: holds {len(found)} splat objects"
                            f"{': ' + ', '.join(found) if found else ''}; name one with --object")
        names = found
    out = []
    for name in names:
        obj = bpy.data.objects.get(name)
        if obj is None or not is_splat_object(obj, with_splat_data=True):
            what = "no object" if obj is None else f"a {obj.type} object, not splats"
            raise UserError(f"{path}: --object {name!r}: {what}; its splat objects: "
                            f"{', '.join(found) or 'none'}")
        splats = object_splats(obj, axes=axes)
        report = ReadReport(f"{path}:{name}", "blend", splats.count, _degree_in_data(obj.data))
        out.append((splats, report))
    return out


def _degree_in_data(pointcloud) -> int:
    """SH degree of the complete radiance:sh_k bands the data holds (4 for Blender 5.3's
    own degree-4 imports, of which Splatline reads degree 3)."""
    from ..blender.data.pointcloud import sh_name

    k = 0
    while sh_name(k) in pointcloud.attributes:
        k += 1
    return max(d for d in range(RENDER_MAX_DEGREE + 2) if sh_coeff_count(d) <= k)
