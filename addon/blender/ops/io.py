"""File > Import / Export > Gaussian Splats, and the drag-and-drop FileHandler."""
from __future__ import annotations

import os

import bpy
from bpy.props import CollectionProperty, EnumProperty, FloatProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper, poll_file_object_drop

from ...core.dynamic import is_dynamic_file
from ...core.errors import SplatFormatError
from ...core.formats import table
from ..data.dynamic_files import import_dynamic
from ..data.files import export_object, import_file_with_report, object_axes
from ..data.sources import is_splat_object
from ..registration import classes_and_menus

_AXES_ENUM = [
    ("AUTO", "From File", "Y down, z forward for .ply, .splat and .sog; y up, z back for .spz (SPZ's "
                          "documented frame, or the one its coordinate-system extension names); glTF "
                          "is read into the Y-down frame"),
    ("RDF", "Y Down, Z Forward", "3DGS / COLMAP camera frame: pick this for a .spz that holds the PLY's "
                                 "values (splat-transform 3.7 writes them so)"),
    ("RUB", "Y Up, Z Back", "OpenGL-like frame, SPZ's own"),
    ("RFU", "Z Up (Blender)", "No rotation"),
]
# Export: the frame the selected objects' data is in (data/files.object_axes); the file is
# written in its format's own frame from it.
DATA_AXES_ITEMS = [
    ("AUTO", "From Object", "A Splatline import's recorded file frame; an object Blender imported "
                            "(File > Import > PLY) holds the PLY's own values: Y down, Z forward"),
    ("RDF", "Y Down, Z Forward", "The data holds a 3DGS / COLMAP file's values (Blender's PLY importer keeps them)"),
    ("RUB", "Y Up, Z Back", "The data holds an OpenGL-like frame"),
    ("RFU", "Z Up (Blender)", "The data is in Blender's frame: pick this for an object from "
                              "Blender's own SPZ importer, which turns the data itself"),
]
_BAD_ENUM = [
    ("fix", "Neutralise", "Splats with NaN/Inf values become invisible; zero quaternions become identity; scales <= 0 become |scale|"),
    ("drop", "Drop", "Remove splats with NaN/Inf values, zero quaternions or scales <= 0"),
    ("error", "Refuse File", "Refuse a file holding any NaN/Inf value, zero quaternion or scale <= 0"),
]


def picked_paths(operator) -> list[str]:
    """The files picked in an import operator's browser (its `files` in `directory`), in
    the order picked, else its `filepath` (a script's call)."""
    names = [f.name for f in operator.files if f.name]
    if names and operator.directory:
        return [os.path.join(operator.directory, name) for name in names]
    return [operator.filepath] if operator.filepath else []


class IMPORT_SCENE_OT_splatline_gaussians(bpy.types.Operator, ImportHelper):
    """Import Gaussian splat captures as PointCloud objects"""

    bl_idname = "import_scene.splatline_gaussians"
    bl_label = "Gaussian Splats"  # and filter_glob: from the format table (_from_table)
    bl_options = {"REGISTER", "UNDO", "PRESET"}

    directory: StringProperty(subtype="DIR_PATH", options={"SKIP_SAVE", "HIDDEN"})
    files: CollectionProperty(type=bpy.types.OperatorFileListElement, options={"SKIP_SAVE", "HIDDEN"})

    max_sh_degree: IntProperty(name="Max SH Degree", default=3, min=0, max=3,
                               description="Keep spherical harmonics up to this degree; higher bands are not stored")
    min_opacity: FloatProperty(name="Min Opacity", default=0.0, min=0.0, max=1.0,
                               description="Drop splats less opaque than this")
    max_count: IntProperty(name="Max Splats", default=0, min=0,
                           description="Keep at most this many splats, the most important first (0: all)")
    axes: EnumProperty(name="Axes", items=_AXES_ENUM, default="AUTO",
                       description="Axis convention of the file, applied as the object's rotation")
    bad_values: EnumProperty(name="Bad Values", items=_BAD_ENUM, default="fix",
                             description="What to do with splats holding NaN/Inf values or zero quaternions")
    lod: IntProperty(name="Level of Detail", default=0, min=0,
                     description="The level to read from a file holding several (a streamed SOG "
                                 "lod-meta.json, .lcc, .lcc2): 0 is the finest; other files have level 0 only")

    def paths(self) -> list[str]:
        return picked_paths(self)

    def invoke(self, context, event):
        return self.invoke_popup(context)

    def execute(self, context):
        paths = self.paths()
        if not paths:
            self.report({"ERROR"}, "no file given")
            return {"CANCELLED"}
        for obj in context.view_layer.objects if context.view_layer else ():
            obj.select_set(False)
        wm = context.window_manager
        wm.progress_begin(0, len(paths))
        imported, errors = [], []
        try:
            for i, path in enumerate(paths):
                try:
                    if is_dynamic_file(path):  # a 4D capture: one object that plays by itself
                        imported.append(import_dynamic(context, path, axes=self.axes))
                        continue
                    obj, report = import_file_with_report(
                        context, path, max_sh_degree=self.max_sh_degree, min_opacity=self.min_opacity,
                        max_count=self.max_count, axes=self.axes, bad=self.bad_values, lod=self.lod,
                        progress=lambda done, i=i: wm.progress_update(i + done))
                except SplatFormatError as exc:
                    errors.append(str(exc))
                except (OSError, MemoryError) as exc:
                    errors.append(f"{path}: {exc.strerror if isinstance(exc, OSError) else 'out of memory'}")
                else:
                    imported.append(obj)
                    if report.bad.total:
                        self.report({"WARNING"}, f"{path}: {report.bad.summary()}")
                    if report.dropped_sh:
                        self.report({"WARNING"}, f"{path}: {report.dropped_sh}")
        finally:
            wm.progress_end()
        # As Blender's own importers do: with something imported, a failed file is a warning
        # and the operator finishes (an ERROR report would make bpy.ops raise after the good
        # files were already in the scene); with nothing imported it is an error.
        level = {"WARNING"} if imported else {"ERROR"}
        for message in errors:
            self.report(level, message)
        if not imported:
            return {"CANCELLED"}
        failed = f", {len(errors)} file(s) failed" if errors else ""
        self.report({"INFO"}, f"imported {len(imported)} splat object(s){failed}")
        return {"FINISHED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        for name in ("max_sh_degree", "min_opacity", "max_count", "axes", "bad_values", "lod"):
            layout.prop(self, name)


def _export_formats() -> tuple:
    """(enum id, label, description, file extension) of each writable row of the format table."""
    return tuple((r.name.upper(), f"{r.label} ({r.extensions[0]})", r.description, r.extensions[0])
                 for r in table.rows(writable=True))


def __getattr__(name):
    if name == "_EXPORT_EXT":  # enum id -> extension, as the table holds it now
        return {key: ext for key, _, _, ext in _export_formats()}
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class EXPORT_SCENE_OT_splatline_gaussians(bpy.types.Operator, ExportHelper):
    """Export the selected splat objects' data (object-local) to any writable splat format"""

    bl_idname = "export_scene.splatline_gaussians"
    bl_label = "Gaussian Splats"  # and filter_glob, file_format: from the format table (_from_table)
    bl_options = {"REGISTER", "PRESET"}

    data_axes: EnumProperty(name="Data Axes", items=DATA_AXES_ITEMS, default="AUTO",
                            description="The axis convention the objects' data is in; the file is "
                                        "written in its format's own")

    @property
    def filename_ext(self):
        return table.row(self.file_format.lower()).extensions[0]

    @classmethod
    def poll(cls, context):
        return any(is_splat_object(o, with_splat_data=True) for o in context.selected_objects)

    def _root(self) -> str:
        """The chosen path without any known extension: the format picks the extension."""
        path = self.filepath
        for ext in sorted({e for r in table.rows(writable=True) for e in r.extensions}, key=len, reverse=True):
            if path.lower().endswith(ext):
                return path[: -len(ext)]
        return path

    def execute(self, context):
        objects = [o for o in context.selected_objects if is_splat_object(o, with_splat_data=True)]
        if not objects:
            self.report({"ERROR"}, "select a splat object to export")
            return {"CANCELLED"}
        root, ext = self._root(), self.filename_ext
        axes = None if self.data_axes == "AUTO" else self.data_axes
        written = []
        for obj in objects:
            path = root + ext if len(objects) == 1 else f"{root}_{bpy.path.clean_name(obj.name)}{ext}"
            try:
                notes = export_object(obj, path, axes=axes)
            except SplatFormatError as exc:
                self.report({"ERROR"}, str(exc))
            else:
                written.append(path)
                for note in notes:  # what the format could not keep as it was (spz scales)
                    self.report({"WARNING"}, f"{path}: {note}")
        if not written:
            return {"CANCELLED"}
        self.report({"INFO"}, f"wrote {', '.join(written)} (data in {object_axes(objects[0], axes)} axes)")
        return {"FINISHED"}


class IO_FH_splatline_gaussians(bpy.types.FileHandler):
    """Drops of .ply/.splat/.spz on the 3D viewport or outliner. Blender's own handlers take
    .ply (every mesh PLY; splats from 5.3 on) and, in 5.3+, .spz: where several handlers
    accept a file, Blender asks which one to use, so Splatline stays in that list under a
    label that names it rather than guessing from the file (poll_drop cannot see the path).
    Either choice gives a splat object Splatline animates (native.py)."""
    bl_idname = "IO_FH_splatline_gaussians"
    bl_label = "Gaussian Splats (Splatline)"
    bl_import_operator = "import_scene.splatline_gaussians"
    # Not .glb/.gltf: poll_drop sees only the context, never the dropped file, so it cannot
    # tell a splat glTF from a plain one, and listing the extensions would put Splatline in
    # front of every glTF drop. Dropped glTF stays Blender's own importer's; splat glTF comes
    # in through File > Import > Gaussian Splats, which names Blender's importer for a plain
    # one (formats/gltf.py); their rows say drop=False. Not meta.json either: any .json drop
    # would be offered to us. bl_file_extensions: the rows' (_from_table).

    @classmethod
    def poll_drop(cls, context):
        return poll_file_object_drop(context)


def _menu_import(self, context):
    self.layout.operator(IMPORT_SCENE_OT_splatline_gaussians.bl_idname, text=table.menu_label(table.rows()))


def _menu_export(self, context):
    self.layout.operator(EXPORT_SCENE_OT_splatline_gaussians.bl_idname,
                         text=table.menu_label(table.rows(writable=True)))


OPERATOR_NAME_MAX = 63  # Blender keeps an operator's name in 64 bytes, its NUL included


def _operator_label(rows) -> str:
    """The operator's name (the file browser's button, F3 search): the menu's label while it
    fits Blender's 63 characters, else the plain name; the menus always list every suffix."""
    label = table.menu_label(rows)
    return label if len(label) <= OPERATOR_NAME_MAX else "Gaussian Splats"


def _from_table() -> None:
    """Labels, file filters, export choices and drop extensions from the format table, set
    on the classes before Blender registers them (a row added later shows after the next
    register)."""
    readable, writable = table.rows(), table.rows(writable=True)
    imp, exp = IMPORT_SCENE_OT_splatline_gaussians, EXPORT_SCENE_OT_splatline_gaussians
    imp.bl_label, exp.bl_label = _operator_label(readable), _operator_label(writable)
    _put_first(imp, filter_glob=StringProperty(default=table.file_glob(readable), options={"HIDDEN"}))
    _put_first(exp, filter_glob=StringProperty(default=table.file_glob(writable, with_names=False), options={"HIDDEN"}),
               file_format=EnumProperty(name="Format", default=writable[0].name.upper(),
                                        items=[item[:3] for item in _export_formats()]))
    IO_FH_splatline_gaussians.bl_file_extensions = ";".join(table.suffixes(r for r in readable if r.drop))


def _put_first(cls, **props) -> None:
    """Properties ahead of the class's own, where they stood when they were written in it
    (the order the operator's panel draws them in)."""
    cls.__annotations__ = props | {k: v for k, v in cls.__annotations__.items() if k not in props}


_CLASSES = (IMPORT_SCENE_OT_splatline_gaussians, EXPORT_SCENE_OT_splatline_gaussians, IO_FH_splatline_gaussians)


_register, unregister = classes_and_menus(
    _CLASSES, (("TOPBAR_MT_file_import", _menu_import), ("TOPBAR_MT_file_export", _menu_export)))


def register():
    _from_table()
    _register()
