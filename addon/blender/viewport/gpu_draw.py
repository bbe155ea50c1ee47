"""The gpu-module half of the viewport: shaders, textures and the two passes.

1. Preprocess: a fragment pass over the record textures, one fragment per drawn splat
   (in draw order), computes its projection, footprint and colour once
   (viewport_preprocess_frag.glsl). It runs only when the data, order, object table
   or view changed since the records were made.
2. Quads: one instanced quad per splat, its four vertices read the splat's records.

Works in any GPU context Blender provides: the 3D viewport's draw handler, the
render engine's view_draw, and a GPUOffScreen (tests, benchmarks). Texture formats are
ones every supported Blender offers (RGBA32F, RGBA16F, R32F; see packing.py); a texture
is filled only from a FLOAT Buffer there, so integer formats are not used. gpu.compute
exists in 4.5 to 5.2 too, but a fragment pass needs no image store and draws the same on
every backend.
"""
from __future__ import annotations

import pathlib
from contextlib import contextmanager

import numpy as np

import gpu
from gpu_extras.batch import batch_for_shader

from .packing import DISPLACE, MORPH, WIDTH, padded

SHADERS = pathlib.Path(__file__).resolve().parents[3] / "shaders"
CORNERS = ((-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0))
DATA = ("pos", "shape", "sh", "order")
# per-splat view records the preprocess pass writes: name -> format. float32: a half
# colour record cost 7 dB against the reference on the bench's degree-3 scene.
RECORDS = {"rec_pos": "RGBA32F", "rec_conic": "RGBA32F", "rec_color": "RGBA32F"}
FORMATS = {"pos": "RGBA32F", "shape": "RGBA16F", "sh": "RGBA16F", "order": "R32F", "objects": "RGBA32F",
           "rest": "RGBA32F", "fields": "R32F", "morph_pos": "RGBA32F", "morph_shape": "RGBA16F", "morph_sh": "RGBA16F",
           "morph_centres": "RGBA32F", "displace_a": "RGBA32F", "displace_b": "RGBA32F"}
OPTIONAL = ("rest", "fields", *MORPH, *DISPLACE)  # textures only some scenes need
TEXEL_BYTES = {"RGBA32F": 16, "RGBA16F": 8, "R32F": 4}


def _source(*names: str) -> str:
    return "\n".join((SHADERS / name).read_text() for name in names)


QUAD_CONSTANTS = ("frame", "flags")  # the quad pass's share of packing.view_constants


def _constants(info, names=("focal_centre", "jac_bounds", "frame", "proj_z", "misc")) -> None:
    for name in names:
        info.push_constant("VEC4", name)
    info.push_constant("IVEC4", "sizes")  # texture width, SH halves per splat, objects, drawn
    info.push_constant("IVEC4", "flags")  # ortho, antialiased, capped extent, linear out


def _create(info):
    shader = gpu.shader.create_from_info(info)
    del info  # the shader keeps what it needs; the info must outlive only the call
    return shader


def preprocess_shader():
    info = gpu.types.GPUShaderCreateInfo()
    _constants(info)
    for slot, name in enumerate(("pos_tex", "shape_tex", "sh_tex", "order_tex", "object_tex", "rest_tex",
                                 "field_tex", *(f"{m}_tex" for m in (*MORPH, *DISPLACE)))):
        info.sampler(slot, "FLOAT_2D", name)
    info.vertex_in(0, "VEC2", "corner")
    for slot, name in enumerate(RECORDS):
        info.fragment_out(slot, "VEC4", name)
    info.vertex_source(_source("viewport_preprocess_vert.glsl"))
    info.fragment_source(_source("splat_math.glsl", "viewport_effects.glsl", "viewport_lighting.glsl",
                                 "viewport_preprocess_frag.glsl"))
    return _create(info)


def quad_shader():
    info = gpu.types.GPUShaderCreateInfo()
    _constants(info, ("frame",))
    for slot, name in enumerate(RECORDS):
        info.sampler(slot, "FLOAT_2D", f"{name}_tex")
    info.vertex_in(0, "VEC2", "corner")
    iface = gpu.types.GPUStageInterfaceInfo("splatline_splat")
    iface.smooth("VEC2", "v_offset")
    iface.flat("VEC3", "v_conic")
    iface.flat("VEC3", "v_color")
    iface.flat("FLOAT", "v_opacity")
    iface.flat("FLOAT", "v_extent")
    iface.flat("INT", "v_mode")
    info.vertex_out(iface)
    info.fragment_out(0, "VEC4", "frag_color")
    info.vertex_source(_source("splat_math.glsl", "viewport_splat_vert.glsl"))
    info.fragment_source(_source("splat_math.glsl", "viewport_splat_frag.glsl"))
    shader = _create(info)
    del iface
    return shader


def float_texture(flat: np.ndarray, fmt: str, width: int = WIDTH):
    """A `fmt` texture `width` texels wide from float32 values already padded to whole rows
    (packing.padded); RGBA16F takes values packing already rounded to halves."""
    channels = 1 if fmt == "R32F" else 4
    flat = np.ascontiguousarray(flat, np.float32).reshape(-1)
    texels = flat.size // channels
    if texels % width:
        raise ValueError(f"{texels} texels are not whole rows of {width}")
    buf = gpu.types.Buffer("FLOAT", flat.size, flat)  # wraps the array's memory, no copy
    return gpu.types.GPUTexture((width, texels // width), format=fmt, data=buf)


def alpha_shader():
    """Writes an R32F texture's values into the alpha of the bound target (colour mask)."""
    info = gpu.types.GPUShaderCreateInfo()
    info.sampler(0, "FLOAT_2D", "alpha_tex")
    info.vertex_in(0, "VEC2", "corner")
    info.fragment_out(0, "VEC4", "frag_color")
    info.vertex_source(_source("viewport_preprocess_vert.glsl"))
    info.fragment_source("void main()\n{\n  frag_color = vec4(0.0, 0.0, 0.0, "
                         "texelFetch(alpha_tex, ivec2(gl_FragCoord.xy), 0).r);\n}\n")
    return _create(info)


def texture_bytes(texture) -> int:
    return texture.width * texture.height * TEXEL_BYTES[texture.format]


@contextmanager
def _pass_state():
    """A full-target pass with no depth test and no blending; the caller's viewport,
    scissor, depth test and blending are put back afterwards."""
    viewport, scissor = gpu.state.viewport_get(), gpu.state.scissor_get()
    depth_test, blend = gpu.state.depth_test_get(), gpu.state.blend_get()
    gpu.state.depth_test_set("NONE")
    gpu.state.blend_set("NONE")
    try:
        yield
    finally:
        gpu.state.viewport_set(*viewport)
        gpu.state.scissor_set(*scissor)
        gpu.state.depth_test_set(depth_test)
        gpu.state.blend_set(blend)


class SplatGPU:
    """GPU resources of the current splat data: shaders, quad batches, textures, records."""

    def __init__(self):
        self.pre_shader = preprocess_shader()
        self.shader = quad_shader()
        self.pre_batch = batch_for_shader(self.pre_shader, "TRI_STRIP", {"corner": CORNERS})
        self.batch = batch_for_shader(self.shader, "TRI_STRIP", {"corner": CORNERS})
        self.textures: dict = {}
        self.records: dict = {}
        self.framebuffer = None
        self.sh_values = 0
        self.object_count = 0
        self.order_count = 0
        self.version = 0           # bumped by every upload: the records go stale
        self.records_for = None    # (version, constants) the records were made for
        self.preprocesses = 0      # preprocess passes run so far
        self.uploaded = 0          # bytes sent to the GPU so far (textures, alpha updates)
        self._order_values = np.zeros(0, np.float32)  # kept: no full-size allocation a sort
        self._alpha = None         # (shader, batch) of set_alpha
        self._alpha_target = None  # (texture, framebuffer) set_alpha last wrote

    def _upload(self, name: str, flat: np.ndarray, fmt: str, width: int = WIDTH) -> None:
        if self._alpha_target is not None and self._alpha_target[0] is self.textures.get(name):
            self._alpha_target = None  # let the replaced texture go
        self.textures[name] = float_texture(flat, fmt, width)
        self.uploaded += texture_bytes(self.textures[name])
        self.version += 1

    def set_texture(self, name: str, flat: np.ndarray) -> None:
        self._upload(name, flat, FORMATS[name])

    def set_alpha(self, name: str, values: np.ndarray) -> None:
        """Replace the alpha channel of RGBA32F texture `name` in place on the GPU with
        `values` (one float32 per texel, the texture's size): a quarter of the bytes of
        re-uploading it. The gpu module cannot write into a texture from the CPU, so the
        values go up as a temporary R32F texture and a colour-masked pass copies them."""
        target = self.textures[name]
        source = float_texture(values, "R32F", target.width)
        self.uploaded += texture_bytes(source)
        if self._alpha is None:
            shader = alpha_shader()
            self._alpha = (shader, batch_for_shader(shader, "TRI_STRIP", {"corner": CORNERS}))
        if self._alpha_target is None or self._alpha_target[0] is not target:
            self._alpha_target = (target, gpu.types.GPUFrameBuffer(color_slots=(target,)))
        shader, batch = self._alpha
        with _pass_state(), self._alpha_target[1].bind():
            gpu.state.viewport_set(0, 0, target.width, target.height)
            gpu.state.scissor_set(0, 0, target.width, target.height)
            gpu.state.color_mask_set(False, False, False, True)
            try:
                shader.bind()
                shader.uniform_sampler("alpha_tex", source)
                batch.draw(shader)
            finally:
                gpu.state.color_mask_set(True, True, True, True)
        self.version += 1

    def drop(self, name: str) -> None:
        if self.textures.pop(name, None) is not None:
            self.version += 1

    def set_order(self, order: np.ndarray) -> None:
        if order.size and int(order.max()) >= 1 << 24:
            raise ValueError("more than 2^24 splats: indices no longer exact in an R32F texture")
        size = padded(max(1, order.size))
        if self._order_values.size < size:
            self._order_values = np.zeros(size, np.float32)
        values = self._order_values[:size]
        values[:order.size] = order
        values[order.size:] = 0.0
        self._upload("order", values, "R32F")
        self.order_count = int(order.size)

    def set_objects(self, table: np.ndarray, count: int) -> None:
        """The object table ((texels, 4)): one row while it fits in WIDTH texels (a scrubbed
        frame uploads it alone), else whole rows of WIDTH, as the data textures: one row
        would cap it at the texture size (1,489 objects and instances)."""
        if table.shape[0] <= WIDTH:
            self._upload("objects", table, "RGBA32F", table.shape[0])
        else:
            flat = np.zeros((padded(table.shape[0]), 4), np.float32)
            flat[:table.shape[0]] = table
            self._upload("objects", flat, "RGBA32F")
        self.object_count = count

    @property
    def nbytes(self) -> int:
        return sum(texture_bytes(t) for t in (*self.textures.values(), *self.records.values()))

    def per_splat_bytes(self) -> dict:
        """{texture: bytes} of every texture whose size grows with the splat count."""
        named = {**{n: self.textures[n] for n in (*DATA, *OPTIONAL) if n in self.textures}, **self.records}
        return {n: texture_bytes(t) for n, t in named.items()}

    def _records_target(self) -> int:
        rows = padded(max(1, self.order_count)) // WIDTH
        if not self.records or self.records["rec_pos"].height != rows:
            self.records = {n: gpu.types.GPUTexture((WIDTH, rows), format=f) for n, f in RECORDS.items()}
            self.framebuffer = gpu.types.GPUFrameBuffer(color_slots=tuple(self.records.values()))
            self.records_for = None
        return rows

    def _bind(self, shader, constants: dict) -> None:
        shader.bind()
        for name, value in constants.items():
            if name == "flags":
                shader.uniform_int(name, value)
            else:
                shader.uniform_float(name, value)
        shader.uniform_int("sizes", (WIDTH, self.sh_values, self.object_count, self.order_count))

    def preprocess(self, constants: dict) -> None:
        """Fill the records for this view, unless they already are (the GPU state of the
        caller: viewport, scissor, depth test and blending are put back)."""
        rows = self._records_target()
        key = (self.version, tuple((k, tuple(v)) for k, v in constants.items()))
        if self.records_for == key:
            return
        with _pass_state(), self.framebuffer.bind():
            gpu.state.viewport_set(0, 0, WIDTH, rows)
            gpu.state.scissor_set(0, 0, WIDTH, rows)
            self._bind(self.pre_shader, constants)
            for name in ("pos", "shape", "sh", "order"):
                self.pre_shader.uniform_sampler(f"{name}_tex", self.textures[name])
            self.pre_shader.uniform_sampler("object_tex", self.textures["objects"])
            # read only by objects whose table row says so: any texture will do otherwise
            self.pre_shader.uniform_sampler("rest_tex", self.textures.get("rest", self.textures["pos"]))
            self.pre_shader.uniform_sampler("field_tex", self.textures.get("fields", self.textures["order"]))
            for name, stand_in in {**MORPH, **DISPLACE}.items():
                self.pre_shader.uniform_sampler(f"{name}_tex", self.textures.get(name, self.textures[stand_in]))
            self.pre_batch.draw(self.pre_shader)
        self.records_for = key
        self.preprocesses += 1

    def draw(self, constants: dict) -> None:
        if not self.order_count or any(n not in self.textures for n in (*DATA, "objects")):
            return
        self.preprocess(constants)
        self._bind(self.shader, {k: constants[k] for k in QUAD_CONSTANTS})
        for name, texture in self.records.items():
            self.shader.uniform_sampler(f"{name}_tex", texture)
        gpu.state.blend_set("ALPHA_PREMULT")
        gpu.state.depth_mask_set(False)
        self.batch.draw_instanced(self.shader, instance_start=0, instance_count=self.order_count)
        gpu.state.blend_set("NONE")
