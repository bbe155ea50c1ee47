"""The offscreen renderer's preprocess stage, record by record, against core/preprocess.py.

As gsplat pins each CUDA stage to its torch reference: the real compute shader
(shaders/gl_preprocess.comp) runs on the renderer's own moderngl context, its records are
read back (FrameState.preprocess_records) and every field is compared with core.preprocess's
float64 value: centre (rec0.xy), conic (rec0.zw, rec1.x), quad radius (rec1.y), view depth
(rec1.z), opacity (rec1.w), colour (rec2.rgb), the sort depth, and which splats are culled.
Scenes: the real captures with their real transform (guitar and test64 read from the .ply,
the RDF axes as a rotation on the object matrix; test64 at SH degree 3) and edge cases
(behind the camera, across the near plane, beyond the frame where J's clamp acts, scales
from 1e-8 to 1e3, needles, opacities at the 1/255 cut).

Bounds. Every field is a chain of at most ~20 float32 operations, each rounded to within
u = EPS/2 (GLSL 4.30 allows 2.5-3 ULP for division, inversesqrt and log); to first order the
errors add, so a field is off by at most ~32 EPS of its natural scale. K = 64 is twice that.
The natural scale of each field, from the float64 values (its condition):
- camera-space centre t = M (p - eye): K EPS |M| |p - eye| per component (M the
  object-to-camera linear part, |.| the 2-norm); depth is -t.z, the pixel centre
  u = cx + fx t.x/d moves by fx/d (1 + |t.x/d|) times that.
- 2D covariance: each entry is a sum over the three projected axes m_k, so it is off by
  K EPS tr0 (tr0 = sum |m_k|^2, the covariance's trace before the low-pass). The
  determinant (Cauchy-Binet, squared 2x2 minors) is off by K EPS (tr0^2 + tr0 + det): a
  minor is off by K EPS |m_i||m_j|. The conic (c, -b, a)/det then follows, so a thin splat
  (det << tr0^2) is allowed proportionally more: its inverse is ill-conditioned.
- extent^2 = 2 ln(255 o): GLSL's log is within 2^-21 absolute near 1, so extent is off by
  that over 2 extent (at most its square root, near the 1/255 cut where extent -> 0).
- colour: the SH polynomials (INRIA constants) and their gradients are below SH_LIP on the
  unit sphere (checked below); with the direction off by K EPS the colour is off by
  K EPS (0.5 + C0 |dc| + SH_LIP sum |rest|).
A semantic slip is far outside these bounds. Each of these edits of splat_math.glsl fails
here: the low-pass left off one diagonal, or 0.3001 instead of 0.3; J's clamp dropped; the
quaternion's norm off by 1e-4; the sign of one band-1 SH term flipped.
"""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.camera import Camera, look_at, simple_camera
from addon.core.formats import read
from addon.core.preprocess import j_clamp_bounds, project
from addon.core.render_constants import ALPHA_MIN, LOW_PASS
from addon.core.scene import RenderItem, RenderOptions
from addon.core.sh import C0 as SH_C0, sh_basis
from addon.core.sort import back_to_front
from addon.core.splats import SplatSet
from addon.gl import OffscreenRenderer
from addon.gl.fallback import cpu_records
from addon.gl.uniforms import depth_origin
from testing.gl_scenes import framing_camera, world_for

EPS = float(np.finfo(np.float32).eps)
K = 64.0
LOG_ABS = 2.0 ** -21   # GLSL 4.30: log's absolute error for arguments in [0.5, 2]
SH_LIP = 12.0          # bound on |Y_k| + |grad Y_k| over the sphere, degrees 1..3
CAP = 1.0e7            # splat_math.glsl SL_MAX_AXIS_PX: projected axes are cut at this length
OPTIONS = {"default": RenderOptions(), "antialiased": RenderOptions(antialiased=True),
           "capped": RenderOptions(capped_extent=True)}


@pytest.fixture(scope="module")
def renderer():
    r = OffscreenRenderer()
    assert r.uses_compute, "these tests need the GL 4.3 compute path"
    yield r
    r.close()


def gpu_records(renderer, items, camera, options):
    return renderer._worker.call(renderer._state.preprocess_records, items, camera, options)


# -- scenes -----------------------------------------------------------------------------
def capture_items(testdata, name):
    s = read(testdata / name)
    items = [RenderItem(s, world=world_for(s), key=(name, 0))]
    if name == "test64.ply":  # a second object: record offsets, a non-uniform object scale
        assert s.sh_degree == 3
        w = world_for(s, (0.3, -0.2, 0.1))
        w[:3, :3] = w[:3, :3] @ np.diag([1.4, 0.7, 1.0])
        items.append(RenderItem(s, world=w, key=(name, 1), splat_scale=1.2, opacity_scale=0.8,
                                color_matrix=np.array([[0.9, 0.1, 0, 0.02], [0, 1.1, 0, 0],
                                                       [0.05, 0, 0.8, 0.01]])))
    return items


def edge_scene() -> tuple[list[RenderItem], Camera]:
    """Splats placed in camera space, then given to an object turned, scaled and moved."""
    camera = simple_camera(200, 150, 60.0, look_at((0.4, -3.0, 1.2), (0.0, 0.2, 0.5)),
                           near=0.05, far=40.0)
    rng = np.random.default_rng(11)
    rows = []  # (x/d, y/d, depth, scale xyz, opacity)

    def add(tx, ty, d, scale, opacity=0.8):
        rows.append((tx, ty, d, *np.broadcast_to(scale, 3), opacity))

    lo_x, hi_x, lo_y, hi_y = j_clamp_bounds(camera)
    for d in (-1.0, -0.01, 0.0, 0.049, 0.0501, 0.2):          # behind, at and across the near plane
        add(0.1, 0.05, d, 0.05)
    for tx in np.linspace(lo_x - 0.8, hi_x + 0.8, 15):          # across the frame, J clamped outside
        for ty in (lo_y - 0.5, 0.0, hi_y + 0.5):
            add(tx, ty, 2.0, 0.5)
    for s in 10.0 ** np.arange(-8, 4):                          # tiny to huge
        add(rng.uniform(-0.4, 0.4), rng.uniform(-0.3, 0.3), rng.uniform(0.5, 8.0), s)
    add(0.02, 0.01, 0.3, (1e6, 1e6, 1e-3))                      # axes past SL_MAX_AXIS_PX
    for _ in range(20):                                         # needles and discs, anisotropy 1e6
        add(rng.uniform(-0.4, 0.4), rng.uniform(-0.3, 0.3), rng.uniform(0.5, 4.0),
            rng.permutation([1e-1, 1e-7, 1e-4]))
    for o in (ALPHA_MIN * 0.999, ALPHA_MIN * 1.0001, ALPHA_MIN * 1.5, 0.999):  # at the 1/255 cut
        add(0.05, -0.05, 1.5, 0.02, o)
    for _ in range(200):
        add(rng.uniform(-0.7, 0.7), rng.uniform(-0.5, 0.5), rng.uniform(0.3, 20.0),
            np.exp(rng.normal(-3, 1, 3)), rng.uniform(0.01, 1.0))
    a = np.asarray(rows, np.float64)
    n = len(a)
    s = SplatSet.allocate(n, 3)
    cam_pts = np.c_[a[:, 0] * a[:, 2], a[:, 1] * a[:, 2], -a[:, 2], np.ones(n)]  # Blender: -z ahead
    world = np.eye(4)
    turn = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    world[:3, :3] = turn * np.array([1.3, 0.6, 0.9])
    world[:3, 3] = (0.2, 0.1, -0.3)
    local = (np.linalg.inv(world) @ np.linalg.inv(camera.world_to_camera) @ cam_pts.T).T
    s.positions[:] = local[:, :3]
    s.scales[:] = a[:, 3:6]
    q = rng.normal(size=(n, 4))
    s.rotations[:] = q / np.linalg.norm(q, axis=1, keepdims=True)
    s.opacities[:] = a[:, 6]
    s.sh_dc[:] = rng.normal(0, 1, (n, 3))
    s.sh_rest[:] = rng.normal(0, 0.3, s.sh_rest.shape)
    return [RenderItem(s, world=world, key=("edges", 0))], camera


# -- the bounds ---------------------------------------------------------------------------
def bounds(item: RenderItem, camera: Camera, p, options, anchor: float = 0.0) -> dict:
    """Allowed |GPU - float64| per field and splat (see the module's docstring)."""
    world = np.asarray(item.world, np.float64)
    o2c = np.asarray(camera.world_to_camera, np.float64) @ world
    m_norm = np.linalg.norm(o2c[:3, :3], 2)
    eye = np.linalg.inv(world) @ np.append(camera.position, 1.0)
    pos = item.splats.positions.astype(np.float64)
    dt = K * EPS * m_norm * (np.linalg.norm(pos - eye[:3], axis=1) + np.linalg.norm(eye[:3]) * EPS)
    d = p.depth
    with np.errstate(all="ignore"):
        tx, ty = (p.means2d[:, 0] - camera.cx) / camera.fx, (p.means2d[:, 1] - camera.cy) / camera.fy
        du = camera.fx / d * dt * (1 + np.abs(tx)) + EPS * np.abs(p.means2d[:, 0])
        dv = camera.fy / d * dt * (1 + np.abs(ty)) + EPS * np.abs(p.means2d[:, 1])
        a, b, c = p.cov2d.T
        det = a * c - b * b
        tr0 = a + c - 2 * LOW_PASS
        dcov = K * EPS * (tr0 + 2 * LOW_PASS)
        ddet = K * EPS * (tr0 * tr0 + tr0 + det)
        dconic = dcov[:, None] / det[:, None] + np.abs(p.conic) * (ddet / det + EPS)[:, None]
        own = item.splats.opacities.astype(np.float64) * item.opacity_scale
        do = 2 * EPS * p.opacity
        if options.antialiased:
            do = do + own * (np.sqrt(ddet / det) + K * EPS)
        ext2 = 2 * np.log(255 * p.opacity)
        dext2 = 2 * (do / p.opacity + LOG_ABS + K * EPS * np.abs(ext2))
        dext = np.minimum(dext2 / (2 * p.extent), np.sqrt(dext2)) + K * EPS * p.extent
        if options.capped_extent:
            dext = np.where(ext2 > 9 + dext2, 0.0, dext)  # min(3, ...): flat where it cuts
        lam = (p.radius / p.extent) ** 2  # lambda_max, from core's own radius
        dr = dext * np.sqrt(lam) + p.extent * dcov / np.sqrt(lam) + K * EPS * p.radius
        sp = item.splats
        sh = 0.5 + SH_C0 * np.abs(sp.sh_dc).max(1)
        if item.effective_sh_degree > 0:
            k = (item.effective_sh_degree + 1) ** 2 - 1
            sh = sh + SH_LIP * np.abs(sp.sh_rest[:, :k]).sum(1).max(1)
        cm = np.asarray(item.color_matrix, np.float64)
        drgb = K * EPS * (np.abs(cm[:, :3]).sum(1).max() * sh + np.abs(cm[:, 3]).max())
    # sort depth = dot(depth axis, p) + (origin depth - anchor, summed in float64): p itself,
    # not p - eye, so its scale is |M| |p| plus the offset
    dsort = K * EPS * (m_norm * np.linalg.norm(pos, axis=1) + abs(o2c[2, 3] + anchor))
    return {"u": du, "v": dv, "conic": dconic, "radius": dr, "depth": dt,
            "opacity": do, "rgb": drgb, "sort": dsort}


def on_frame(p, camera, slack_u=0.0, slack_r=0.0):
    """Core's own visibility as the renderers use it: valid, and the quad meets the frame."""
    u, v, r = p.means2d[:, 0], p.means2d[:, 1], p.radius + slack_r
    with np.errstate(invalid="ignore"):
        return p.valid & (u + r >= -slack_u) & (u - r <= camera.width + slack_u) \
            & (v + r >= -slack_u) & (v - r <= camera.height + slack_u)


def compare(items, camera, options, rec) -> dict:
    """Assert every field of every visible record within its bound; return the worst
    error as a fraction of its bound, per field."""
    worst = {}
    base = 0
    anchor = depth_origin(items[0], camera)
    for item in items:
        n = item.splats.count
        r = {k: v[base:base + n].astype(np.float64) for k, v in rec.items()}
        base += n
        p = project(item, camera, options.antialiased, options.capped_extent)
        tol = bounds(item, camera, p, options, anchor)
        want = on_frame(p, camera)
        got = np.isfinite(r["depth"])
        slack = np.maximum(tol["u"], tol["v"])
        edge = on_frame(p, camera, slack, tol["radius"]) & ~on_frame(p, camera, -slack, -tol["radius"])
        with np.errstate(invalid="ignore"):
            edge |= np.abs(p.opacity - ALPHA_MIN) <= tol["opacity"]
            edge |= np.abs(p.depth - camera.near) <= tol["depth"]
        assert not ((got != want) & ~edge).any(), \
            f"{((got != want) & ~edge).sum()} splats culled differently, not at a threshold"
        assert (r["rec1"][~got] == 0).all()  # culled: rec1 cleared, depth +inf
        both = got & want
        assert both.sum() > 0.5 * want.sum() and both.any()
        fields = {
            "u": (r["rec0"][:, 0], p.means2d[:, 0], tol["u"]),
            "v": (r["rec0"][:, 1], p.means2d[:, 1], tol["v"]),
            "conic": (np.c_[r["rec0"][:, 2:4], r["rec1"][:, 0]], p.conic, tol["conic"]),
            "radius": (r["rec1"][:, 1], p.radius, tol["radius"]),
            "depth": (r["rec1"][:, 2], p.depth, tol["depth"]),
            "opacity": (r["rec1"][:, 3], p.opacity, tol["opacity"]),
            "rgb": (r["rec2"][:, :3], p.rgb, tol["rgb"][:, None]),
            "sort depth": (r["depth"], p.depth - anchor, tol["sort"]),
        }
        capped = _cap_acts(item, camera, p)
        for name, (gpu, ref, allowed) in fields.items():
            sel = both & ~capped if name in ("conic", "radius", "opacity") else both
            err = np.abs(gpu[sel] - ref[sel])
            ratio = err / np.asarray(allowed)[sel]
            assert np.isfinite(ratio).all() and ratio.max() <= 1.0, \
                f"{name}: off by {ratio.max():.3g} times the bound ({err.max():.3g})"
            worst[name] = max(worst.get(name, 0.0), float(ratio.max()))
        if capped.any():
            _check_cap(r, p, capped & got)
            worst["cut axes"] = int((capped & got).sum())
    return worst


def _cap_acts(item, camera, p) -> np.ndarray:
    """Splats with a projected axis past SL_MAX_AXIS_PX: the shader shortens it (by design),
    core does not. Their trace then exceeds CAP^2, from float64."""
    tr0 = p.cov2d[:, 0] + p.cov2d[:, 2] - 2 * LOW_PASS
    with np.errstate(invalid="ignore"):
        return tr0 > (0.5 * CAP) ** 2


def _check_cap(r, p, sel):
    """Where an axis is cut, the quad is no larger than three cut axes allow (so smaller
    than core's uncut one), yet still covers the frame many times over."""
    limit = p.extent[sel] * np.sqrt(3 * CAP ** 2 + 2 * LOW_PASS) * (1 + 1e-5)
    assert (r["rec1"][sel, 1] <= limit).all() and (limit < p.radius[sel]).all()
    assert (r["rec1"][sel, 1] >= p.extent[sel] * 0.5 * CAP).all()


# -- the tests ----------------------------------------------------------------------------
def test_sh_lipschitz_constant_holds():
    """SH_LIP bounds the INRIA SH polynomials and their gradients (degrees 1..3)."""
    rng = np.random.default_rng(0)
    d = rng.normal(size=(20000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    y = sh_basis(d, 3)[:, 1:]
    h = 1e-6
    grad = np.zeros_like(y)
    for axis in range(3):
        e = np.zeros(3)
        e[axis] = h
        grad += ((sh_basis(d + e, 3)[:, 1:] - sh_basis(d - e, 3)[:, 1:]) / (2 * h)) ** 2
    assert (np.abs(y) + np.sqrt(grad)).max() < SH_LIP


@pytest.mark.parametrize("option", list(OPTIONS))
@pytest.mark.parametrize("capture", ["guitar.ply", "test64.ply"])
def test_capture_records_match_core_preprocess(renderer, testdata, capture, option):
    items = capture_items(testdata, capture)
    camera = framing_camera(items[0], 320, 240)
    rec = gpu_records(renderer, items, camera, OPTIONS[option])
    worst = compare(items, camera, OPTIONS[option], rec)
    print(capture, option, {k: round(v, 4) for k, v in worst.items()})


@pytest.mark.parametrize("option", list(OPTIONS))
def test_edge_case_records_match_core_preprocess(renderer, option):
    items, camera = edge_scene()
    rec = gpu_records(renderer, items, camera, OPTIONS[option])
    worst = compare(items, camera, OPTIONS[option], rec)
    print("edges", option, {k: round(v, 4) for k, v in worst.items()})
    p = project(items[0], camera)
    got = np.isfinite(rec["depth"])
    t = p.means2d[:, 0]
    lo_x, hi_x, _, _ = j_clamp_bounds(camera)
    clamped = (np.abs(p.depth - 2.0) < 1e-6) & (((t - camera.cx) / camera.fx < lo_x)
                                                 | ((t - camera.cx) / camera.fx > hi_x))
    assert (clamped & got).sum() >= 4, "the scene must hold visible splats where J is clamped"
    assert not got[p.depth <= camera.near].any(), "splats behind or at the near plane are culled"
    assert worst.get("cut axes", 0) >= 1, "the scene must hold a splat whose axes the shader cuts"


def test_fallback_records_are_core_preprocess_in_back_to_front_order(testdata):
    """The GL 3.3 path's records (gl/fallback.cpu_records): core.preprocess's values, rounded
    to float32 once, for exactly the splats whose quad meets the frame, back to front."""
    items = capture_items(testdata, "test64.ply") + edge_scene()[0]
    camera = framing_camera(items[0], 320, 240)
    for options in OPTIONS.values():
        records, visible = cpu_records(items, camera, options)
        ps = [project(i, camera, options.antialiased, options.capped_extent) for i in items]
        on = np.concatenate([on_frame(p, camera) for p in ps])
        depth = np.concatenate([p.depth for p in ps])
        order = back_to_front(np.where(on, depth, np.inf), options.key_bits, on)
        assert visible == on.sum() == order.size > 0
        cat = lambda f: np.concatenate([f(p) for p in ps])  # noqa: E731
        want = np.stack([
            np.c_[cat(lambda p: p.means2d), cat(lambda p: p.conic[:, :2])],
            np.c_[cat(lambda p: p.conic[:, 2]), cat(lambda p: p.radius), depth, cat(lambda p: p.opacity)],
            np.c_[cat(lambda p: p.rgb), np.zeros(on.size)]])[:, order].astype(np.float32)
        np.testing.assert_array_equal(records, want)
        assert (np.diff(depth[order]) <= 0).all() or options.key_bits == 16


def test_fallback_and_compute_records_agree(renderer, testdata):
    """Both paths' records for the same splats, within the compute path's bounds."""
    items = capture_items(testdata, "guitar.ply")
    camera = framing_camera(items[0], 320, 240)
    options = RenderOptions()
    rec = gpu_records(renderer, items, camera, options)
    records, visible = cpu_records(items, camera, options)
    p = project(items[0], camera)
    on = on_frame(p, camera)
    order = back_to_front(np.where(on, p.depth, np.inf), options.key_bits, on)
    tol = bounds(items[0], camera, p, options)
    gpu = rec["rec0"][order].astype(np.float64)
    assert visible == order.size and np.isfinite(rec["depth"][order]).all()
    assert (np.abs(gpu[:, :2] - records[0][:, :2]) <= np.c_[tol["u"], tol["v"]][order] + 1e-4).all()
    assert (np.abs(rec["rec1"][order, 1] - records[1][:, 1]) <= tol["radius"][order] + 1e-4).all()
