"""The gpu-module half of the viewport: shader, textures and the instanced draw.

Works in any GPU context Blender provides: the 3D viewport's draw handler, the
render engine's view_draw, and a GPUOffScreen (tests, benchmarks).
"""
from __future__ import annotations

import pathlib

import numpy as np

import gpu
from gpu_extras.batch import batch_for_shader

from .packing import OBJECT_TEXELS, WIDTH, padded

SHADERS = pathlib.Path(__file__).resolve().parents[3] / "shaders"


def _source(*names: str) -> str:
    return "\n".join((SHADERS / name).read_text() for name in names)


def create_shader():
    info = gpu.types.GPUShaderCreateInfo()
    for name in ("focal_centre", "jac_bounds", "frame", "proj_z", "misc"):
        info.push_constant("VEC4", name)
    info.push_constant("IVEC4", "sizes")  # texture width, sh texels per splat, 0, 0
    info.push_constant("IVEC4", "flags")  # ortho, antialiased, capped extent, linear out
    for slot, name in enumerate(("pos_tex", "shape_tex", "sh_tex", "order_tex", "object_tex")):
        info.sampler(slot, "FLOAT_2D", name)
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
    shader = gpu.shader.create_from_info(info)
    del iface, info  # the shader keeps what it needs; the infos must outlive only the call
    return shader


def float_texture(flat: np.ndarray, channels: int = 4, width: int = WIDTH):
    """An RGBA32F (channels 4) or R32F (channels 1) texture `width` texels wide from a
    float32 array already padded to whole rows (packing.padded)."""
    flat = np.ascontiguousarray(flat, np.float32).reshape(-1)
    texels = flat.size // channels
    if texels % width:
        raise ValueError(f"{texels} texels are not whole rows of {width}")
    buf = gpu.types.Buffer("FLOAT", flat.size, flat)  # wraps the array's memory, no copy
    fmt = "RGBA32F" if channels == 4 else "R32F"
    return gpu.types.GPUTexture((width, texels // width), format=fmt, data=buf)


def texture_bytes(texture, channels: int) -> int:
    return texture.width * texture.height * channels * 4


class SplatGPU:
    """GPU resources of the current splat data: shader, quad batch, textures."""

    CHANNELS = {"pos": 4, "shape": 4, "sh": 4, "order": 1, "objects": 4}

    def __init__(self):
        self.shader = create_shader()
        corners = ((-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0))
        self.batch = batch_for_shader(self.shader, "TRI_STRIP", {"corner": corners})
        self.textures: dict = {}
        self.sh_stride = 0
        self.order_count = 0

    def set_texture(self, name: str, flat: np.ndarray) -> None:
        self.textures[name] = float_texture(flat, self.CHANNELS[name])

    def set_order(self, order: np.ndarray) -> None:
        if order.size and int(order.max()) >= 1 << 24:
            raise ValueError("more than 2^24 splats: indices no longer exact in an R32F texture")
        values = np.zeros(padded(max(1, order.size)), np.float32)
        values[:order.size] = order
        self.textures["order"] = float_texture(values, 1)
        self.order_count = int(order.size)

    def set_objects(self, table: np.ndarray) -> None:
        self.textures["objects"] = float_texture(table, 4, table.shape[0])

    @property
    def nbytes(self) -> int:
        return sum(texture_bytes(t, self.CHANNELS[n]) for n, t in self.textures.items())

    def draw(self, constants: dict) -> None:
        if not self.order_count or len(self.textures) < len(self.CHANNELS):
            return
        shader = self.shader
        shader.bind()
        for name, value in constants.items():
            if name == "flags":
                shader.uniform_int(name, value)
            else:
                shader.uniform_float(name, value)
        shader.uniform_int("sizes", (WIDTH, self.sh_stride, 0, 0))
        for name in ("pos", "shape", "sh", "order"):
            shader.uniform_sampler(f"{name}_tex", self.textures[name])
        shader.uniform_sampler("object_tex", self.textures["objects"])
        gpu.state.blend_set("ALPHA_PREMULT")
        gpu.state.depth_mask_set(False)
        self.batch.draw_instanced(shader, instance_start=0, instance_count=self.order_count)
        gpu.state.blend_set("NONE")


def object_rows(local_to_camera: np.ndarray, splat_scale: float, opacity_scale: float,
                sh_degree: int, mode: int, sh_only: bool, color_matrix: np.ndarray,
                ortho: bool) -> np.ndarray:
    """(OBJECT_TEXELS, 4) float32 for one object (layout in viewport_splat_vert.glsl)."""
    m = np.asarray(local_to_camera, np.float64)
    lin = m[:3, :3]
    with np.errstate(all="ignore"):
        inv = np.linalg.pinv(lin)
        eye = -inv @ m[:3, 3]  # camera centre in the object's frame
        fwd = inv @ np.array([0.0, 0.0, -1.0])
        fwd /= np.linalg.norm(fwd)
    eye_hi = eye.astype(np.float32)
    eye_lo = (eye - eye_hi.astype(np.float64)).astype(np.float32)
    rows = np.zeros((OBJECT_TEXELS, 4), np.float32)
    rows[0:3, :3] = lin.T  # columns of cam_from_local
    rows[0, 3], rows[1, 3], rows[2, 3] = splat_scale, opacity_scale, sh_degree
    rows[3, :3], rows[3, 3] = eye_hi, mode
    rows[4, :3], rows[4, 3] = eye_lo, float(sh_only)
    rows[5:8] = np.asarray(color_matrix, np.float32).reshape(3, 4)
    rows[8, :3] = fwd if ortho else 0.0
    return rows


def view_constants(projection: np.ndarray, width: int, height: int, *, antialiased=False,
                   capped_extent=False, linear_output=False, point_size=2.0) -> dict:
    """Push constants from an OpenGL projection matrix and the viewport size in pixels."""
    p = np.asarray(projection, np.float64)
    ortho = abs(p[3, 3] - 1.0) < 1e-9 and abs(p[3, 2]) < 1e-12
    fx, fy = 0.5 * width * p[0, 0], 0.5 * height * p[1, 1]
    if ortho:
        cx, cy = 0.5 * width * (1.0 + p[0, 3]), 0.5 * height * (1.0 - p[1, 3])
        near = (p[2, 3] + 1.0) / p[2, 2]
        far = (p[2, 3] - 1.0) / p[2, 2]
    else:
        cx, cy = 0.5 * width * (1.0 - p[0, 2]), 0.5 * height * (1.0 + p[1, 2])
        near = p[2, 3] / (p[2, 2] - 1.0)
        far = p[2, 3] / (p[2, 2] + 1.0)
    m = 0.15
    bounds = ((-m * width - cx) / fx, (cy - height - m * height) / fy,
              (width + m * width - cx) / fx, (cy + m * height) / fy)
    return {
        "focal_centre": (fx, fy, cx, cy),
        "jac_bounds": bounds,
        "frame": (float(width), float(height), float(near), float(far)),
        "proj_z": (p[2, 2], p[2, 3], p[3, 2], p[3, 3]),
        "misc": (float(point_size), 0.0, 0.0, 0.0),
        "flags": (int(ortho), int(antialiased), int(capped_extent), int(linear_output)),
    }
