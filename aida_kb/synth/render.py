"""A renderer for textured planar polyhedra: exact ray-plane depth, labels, shaded images.

Visibility: every front-facing face is clipped to the view frustum, rasterised with
``cv2.fillPoly`` (sub-pixel vertex precision) and z-buffered with the exact depth of the ray
through each pixel centre (OpenCV convention: pixel centres at integer coordinates). Colour:
supersampled (default 2x2) and averaged down (anti-aliasing); albedo from procedural materials
(aida_kb.synth.textures), prefiltered to each sample's footprint on the face (no texture
moiré); Lambert sun plus sky light so that faces differ in brightness, a sky gradient,
vignetting, sensor noise, and optional lens distortion with OpenCV's model.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from aida_kb.synth import textures as tx
from aida_kb.synth.buildings import Model

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

NEAR_M = 0.02
GROUND_LABEL = 1000


@dataclass(frozen=True)
class Surface:
    """A face ready to render, in world coordinates.

    label : id in label images (>= 1). normal, d : plane normal·x = d, normal out of the solid.
    origin, axis_u, axis_v : the texture frame (metres; u horizontal to the right seen from
    outside, v up the face). length : extent of the face along u.
    """

    label: int
    role: str
    concept: str
    material: str
    polygon: FloatArray
    normal: FloatArray
    d: float
    origin: FloatArray
    axis_u: FloatArray
    axis_v: FloatArray
    length: float
    params: dict[str, float] = field(default_factory=dict)


def _texture_frame(
    polygon: FloatArray, normal: FloatArray, up: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, float]:
    if abs(float(normal @ up)) > 0.99:
        ref = np.array([1.0, 0.0, 0.0]) - up * up[0]
        eu = ref / np.linalg.norm(ref)
    else:
        eu = np.cross(up, normal)
        eu /= np.linalg.norm(eu)
    ev = np.cross(normal, eu)
    pu, pv = polygon @ eu, polygon @ ev
    origin = eu * pu.min() + ev * pv.min() + normal * float(normal @ polygon[0])
    return origin, eu, ev, float(pu.max() - pu.min())


def surfaces(
    model: Model,
    R_world_site: FloatArray,
    t_world_site: FloatArray,
    *,
    ground: str | None = "ground",
    ground_half_size_m: float = 2000.0,
) -> list[Surface]:
    """Renderable surfaces of `model` (site frame, y up) mapped to world: x_w = R·x_site + t.

    Labels are 1, 2, ... in the order of `model.faces`; the ground (material `ground`, a square
    of half size `ground_half_size_m` at y = 0, label GROUND_LABEL) is appended unless None.
    """
    up_site = np.array([0.0, 1.0, 0.0])
    out: list[Surface] = []
    faces = list(model.faces)
    for i, f in enumerate(faces):
        n = f.normal
        origin, eu, ev, length = _texture_frame(f.polygon, n, up_site)
        out.append(
            Surface(
                label=i + 1,
                role=f.role,
                concept=f.concept,
                material=f.material,
                polygon=f.polygon @ R_world_site.T + t_world_site,
                normal=R_world_site @ n,
                d=float((R_world_site @ n) @ (f.polygon[0] @ R_world_site.T + t_world_site)),
                origin=R_world_site @ origin + t_world_site,
                axis_u=R_world_site @ eu,
                axis_v=R_world_site @ ev,
                length=length,
                params=dict(f.params),
            )
        )
    if ground is not None:
        g = ground_half_size_m
        poly = np.array([[-g, 0.0, g], [g, 0.0, g], [g, 0.0, -g], [-g, 0.0, -g]])
        n = np.array([0.0, 1.0, 0.0])
        poly_w = poly @ R_world_site.T + t_world_site
        n_w = R_world_site @ n
        out.append(
            Surface(
                label=GROUND_LABEL,
                role="ground",
                concept="Ground",
                material=ground,
                polygon=poly_w,
                normal=n_w,
                d=float(n_w @ poly_w[0]),
                origin=t_world_site.copy(),
                axis_u=R_world_site @ np.array([1.0, 0.0, 0.0]),
                axis_v=R_world_site @ np.array([0.0, 0.0, -1.0]),
                length=2 * g,
            )
        )
    return out


# ---------------------------------------------------------------------------------------------
# visibility


def _clip(poly: FloatArray, planes: FloatArray) -> FloatArray:
    """Clip a convex or concave polygon (N, 3) to the half-spaces a·x + b >= 0 (rows a, b)."""
    for a0, a1, a2, b in planes:
        if len(poly) == 0:
            break
        dist = poly @ np.array([a0, a1, a2]) + b
        keep = dist >= 0
        if keep.all():
            continue
        out = []
        n = len(poly)
        for i in range(n):
            j = (i + 1) % n
            if keep[i]:
                out.append(poly[i])
            if keep[i] != keep[j]:
                s = dist[i] / (dist[i] - dist[j])
                out.append(poly[i] + s * (poly[j] - poly[i]))
        poly = np.array(out) if out else np.zeros((0, 3))
    return poly


def _inside(pix: FloatArray, x0: int, y0: int, x1: int, y1: int) -> npt.NDArray[np.bool_]:
    """Pixel centres of the box [x0, x1] x [y0, y1] inside the polygon pix (even-odd rule)."""
    xs = np.arange(x0, x1 + 1, dtype=np.float64)[None, :]
    ys = np.arange(y0, y1 + 1, dtype=np.float64)[:, None]
    inside = np.zeros((y1 - y0 + 1, x1 - x0 + 1), bool)
    n = len(pix)
    for i in range(n):
        ax, ay = pix[i]
        bx, by = pix[(i + 1) % n]
        if ay == by:
            continue
        crosses = (ay > ys) != (by > ys)  # (h, 1): the edge spans this row
        xc = ax + (ys - ay) * ((bx - ax) / (by - ay))
        inside ^= crosses & (xs < xc)
    return inside


def rasterise(
    surfs: Sequence[Surface],
    K: FloatArray,
    R: FloatArray,
    t: FloatArray,
    size: tuple[int, int],
) -> tuple[npt.NDArray[np.int32], FloatArray]:
    """Visible surface per pixel and its exact depth.

    K : (3, 3) pixels; R, t : world to camera (x_cam = R·x + t); size : (width, height).
    Returns labels (H, W) int32 (0 = nothing) and depth (H, W) float64 z in metres (inf =
    nothing), both at pixel centres (integer pixel coordinates).
    """

    W, H = size
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    skew = K[0, 1]
    margin = 4.0
    # frustum planes in camera coordinates, a·X >= 0 (pixel x in [-m, W-1+m], y likewise)
    planes = np.array(
        [
            [0.0, 0.0, 1.0, -NEAR_M],
            [fx, skew, cx + margin, 0.0],
            [-fx, -skew, W - 1 + margin - cx, 0.0],
            [0.0, fy, cy + margin, 0.0],
            [0.0, -fy, H - 1 + margin - cy, 0.0],
        ]
    )
    depth = np.full((H, W), np.inf)
    labels = np.zeros((H, W), np.int32)
    C = -R.T @ t
    Kinv = np.linalg.inv(K)
    for s in surfs:
        if float(s.normal @ C) - s.d <= 1e-9:
            continue  # back face (or seen edge-on)
        pc = _clip(s.polygon @ R.T + t, planes)
        if len(pc) < 3:
            continue
        pix = pc @ K.T
        pix = pix[:, :2] / pix[:, 2:3]
        x0 = max(math.floor(pix[:, 0].min()), 0)
        y0 = max(math.floor(pix[:, 1].min()), 0)
        x1 = min(math.ceil(pix[:, 0].max()), W - 1)
        y1 = min(math.ceil(pix[:, 1].max()), H - 1)
        if x1 < x0 or y1 < y0:
            continue
        mask = _inside(pix, x0, y0, x1, y1)
        ys, xs = np.nonzero(mask)
        if len(xs) == 0:
            continue
        xs = xs + x0
        ys = ys + y0
        n_c = R @ s.normal
        d_c = s.d + float(n_c @ t)
        rays = Kinv @ np.vstack([xs, ys, np.ones_like(xs)]).astype(np.float64)
        denom = n_c @ rays
        with np.errstate(divide="ignore", invalid="ignore"):
            z = d_c / denom
        ok = np.isfinite(z) & (z > NEAR_M) & (z < depth[ys, xs])
        depth[ys[ok], xs[ok]] = z[ok]
        labels[ys[ok], xs[ok]] = s.label
    return labels, depth


# ---------------------------------------------------------------------------------------------
# shading


@dataclass(frozen=True)
class Lighting:
    """Sun direction (unit, towards the sun) and up direction, world frame; intensities."""

    sun: FloatArray
    up: FloatArray
    sun_intensity: float = 0.75
    ambient: float = 0.38
    background: str = "sky"  # "sky" (gradient) or "studio" (plain backdrop)
    shadows: bool = False  # cast shadows: a point whose ray to the sun meets a face is unlit


SHADOW_EPS_M = 1e-4  # a shadow ray starts this far along: its own face must not shadow it


def in_shadow(X: FloatArray, sun: FloatArray, blockers: Sequence[Surface]) -> npt.NDArray[np.bool_]:
    """Which world points X (N, 3) see the sun (unit, world) blocked by a face of `blockers`.

    Only faces turned towards the sun are tested: a ray that leaves a closed solid towards the
    sun crosses one of them. Even-odd point-in-polygon in each face's texture frame.
    """
    blocked = np.zeros(len(X), bool)
    for b in blockers:
        cos_b = float(b.normal @ sun)
        if cos_b <= 1e-6:
            continue
        dist = (b.d - X @ b.normal) / cos_b  # along the ray to b's plane
        cand = np.nonzero((dist > SHADOW_EPS_M) & ~blocked)[0]
        if len(cand) == 0:
            continue
        P = X[cand] + dist[cand, None] * sun
        pu, pv = (P - b.origin) @ b.axis_u, (P - b.origin) @ b.axis_v
        qu, qv = (b.polygon - b.origin) @ b.axis_u, (b.polygon - b.origin) @ b.axis_v
        inside = np.zeros(len(cand), bool)
        for i in range(len(qu)):
            au, av, bu, bv = qu[i], qv[i], qu[i - 1], qv[i - 1]
            if av == bv:
                continue
            crosses = (av > pv) != (bv > pv)
            uc = au + (pv - av) * ((bu - au) / (bv - av))
            inside ^= crosses & (pu < uc)
        blocked[cand[inside]] = True
    return blocked


def _albedo(
    s: Surface,
    X: FloatArray,
    seed: int,
    footprint: FloatArray | None = None,
) -> npt.NDArray[np.float32]:
    """Albedo (N, 3) of face `s` at world points X (N, 3); footprint (N,) the image sample
    spacing on the face, metres (textures are prefiltered to it; None: point samples)."""
    tex = tx.texture_set(seed)
    fp = footprint

    def scaled(k: float) -> FloatArray | None:
        return None if fp is None else fp * k

    rel = X - s.origin
    u = rel @ s.axis_u
    v = rel @ s.axis_v
    mat = s.material
    floor_h = s.params.get("floor_h", 3.0)
    if mat == "mixed":  # brick ground floor, plaster above
        brick = tx.sample(*tex["brick"], u, -v, fp)
        plaster = tx.sample(*tex["plaster"], u, -v, fp)
        alb = np.where((v < floor_h)[:, None], brick, plaster)
        band = np.abs(v - floor_h) < 0.12
        alb[band] = alb[band] * 0.8 + 0.15
    elif mat in ("tiles", "box", "table") or mat in tex:
        alb = tx.sample(*tex[mat], u, -v, fp)
    elif mat == "chessboard":
        sq = s.params["square_m"]
        border = s.params["border_m"]
        nx, ny = int(s.params["cols"]), int(s.params["rows"])
        iu = np.floor((u - border) / sq)
        iv = np.floor((v - border) / sq)
        inside = (iu >= 0) & (iu < nx) & (iv >= 0) & (iv < ny)
        black = inside & ((iu + iv) % 2 == 0)
        val = np.where(black, 0.06, 0.92).astype(np.float32)
        alb = np.repeat(val[:, None], 3, axis=1)
    else:
        alb = np.full((len(u), 3), 0.6, np.float32)
    # fine grain and large-scale weathering on every material except the calibration target
    if mat != "chessboard":
        g = tx.sample(*tex["grain"], u, v, fp)[:, 0]
        m = tx.sample(*tex["macro"], u * 0.25, v * 0.25, scaled(0.25))[:, 0]
        alb = alb * (1.0 + 0.05 * g + 0.05 * m)[:, None]
    if "floors" in s.params:  # walls with a window grid (`buildings._with_windows`)
        frame, glass, gy = tx.windows_mask(
            u,
            v,
            length=s.length,
            floors=int(s.params["floors"]),
            floor_h=floor_h,
            door=s.role == "body.front",
        )
        alb[frame] = np.array([0.88, 0.88, 0.86], np.float32)
        if glass.any():
            gg = gy[glass]
            fp_glass = None if fp is None else fp[glass] * 2
            refl = tx.sample(*tex["macro"], u[glass] * 2, v[glass] * 2, fp_glass)[:, 0]
            col = np.stack([0.16 + 0.18 * gg, 0.20 + 0.20 * gg, 0.25 + 0.22 * gg], axis=1)
            alb[glass] = (col * (1.0 + 0.15 * refl)[:, None]).astype(np.float32)
    return np.asarray(alb, np.float32)


def _sky(rays_world: FloatArray, light: Lighting) -> npt.NDArray[np.float32]:
    if light.background == "studio":
        e = np.clip(rays_world @ light.up / np.linalg.norm(rays_world, axis=1), -1.0, 1.0)
        col = np.array([0.55, 0.56, 0.58]) + 0.08 * e[:, None]
        return np.asarray(col, dtype=np.float32)
    e = np.clip(rays_world @ light.up / np.linalg.norm(rays_world, axis=1), -1.0, 1.0)
    k = np.clip(e * 2.2, 0.0, 1.0)[:, None] ** 0.8
    horizon = np.array([0.86, 0.89, 0.93])
    zenith = np.array([0.42, 0.60, 0.86])
    return np.asarray(horizon * (1 - k) + zenith * k, dtype=np.float32)


def shade(
    surfs: Sequence[Surface],
    labels: npt.NDArray[np.int32],
    depth: FloatArray,
    K: FloatArray,
    R: FloatArray,
    t: FloatArray,
    light: Lighting,
    seed: int,
) -> npt.NDArray[np.float32]:
    """Linear RGB radiance (H, W, 3) for the labels and depths of `rasterise`."""
    H, W = labels.shape
    ys, xs = np.mgrid[0:H, 0:W]
    pix = np.stack([xs.ravel(), ys.ravel(), np.ones(H * W)], axis=0).astype(np.float64)
    rays_cam = np.linalg.inv(K) @ pix  # z = 1
    rays_world = (R.T @ rays_cam).T
    C = -R.T @ t
    f_px = float(np.sqrt(K[0, 0] * K[1, 1]))
    img = np.empty((H * W, 3), np.float32)
    lab = labels.ravel()
    order = np.argsort(lab, kind="stable")
    sorted_lab = lab[order]
    by_label = {s.label: s for s in surfs}
    uniq, starts = np.unique(sorted_lab, return_index=True)
    ends = np.append(starts[1:], len(sorted_lab))
    zf = depth.ravel()
    for lb, a, b in zip(uniq, starts, ends, strict=True):
        idx = order[a:b]
        if lb == 0:
            img[idx] = _sky(rays_world[idx], light)
            continue
        s = by_label[int(lb)]
        r = rays_world[idx]
        X = C + r * zf[idx, None]
        # sample spacing on the face: z / f across the ray, stretched by 1 / cos of the
        # incidence along the slant; the geometric mean of the two (isotropic prefilter)
        cos_in = np.abs(r @ s.normal) / np.linalg.norm(r, axis=1)
        footprint = zf[idx] / (f_px * np.maximum(cos_in, 0.05))
        alb = _albedo(s, X, seed, footprint)
        lam = max(float(s.normal @ light.sun), 0.0)
        sky = 0.5 + 0.5 * float(s.normal @ light.up)
        k = light.ambient * (0.55 + 0.45 * sky) + light.sun_intensity * lam
        if light.shadows and lam > 0:
            sun_k = np.full(len(idx), light.sun_intensity * lam)
            sun_k[in_shadow(X, light.sun, [b for b in surfs if b.label != s.label])] = 0.0
            kk = light.ambient * (0.55 + 0.45 * sky) + sun_k
            img[idx] = alb * kk.astype(np.float32)[:, None]
        else:
            img[idx] = alb * np.float32(k)
    return img.reshape(H, W, 3)


# ---------------------------------------------------------------------------------------------
# the camera pipeline


@dataclass(frozen=True)
class Exposure:
    """Sensor model: gain, noise (8-bit counts), vignetting strength, gamma."""

    gain: float = 1.0
    noise_sigma: float = 1.8
    vignetting: float = 0.25
    gamma: float = 1.0 / 1.15


def render(
    surfs: Sequence[Surface],
    K: FloatArray,
    R: FloatArray,
    t: FloatArray,
    size: tuple[int, int],
    light: Lighting,
    *,
    D: FloatArray | None = None,
    supersample: int = 2,
    exposure: Exposure | None = None,
    seed: int = 0,
    noise_seed: int = 0,
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint16], npt.NDArray[np.float32]]:
    """Render one camera: 8-bit BGR image, 16-bit labels, float32 depth (z, metres, NaN none).

    K : (3, 3), R, t : world to camera, size : (width, height) pixels. D : OpenCV distortion
    (k1 k2 p1 p2 k3) or None; with D the image, labels and depth are those of the distorted
    camera (depth stays exact: the ray of each distorted pixel is intersected with its plane).
    """
    import cv2

    W, H = size
    ss = max(1, int(supersample))
    exposure = exposure or Exposure()
    distorted = D is not None and bool(np.any(np.asarray(D) != 0))
    if distorted:
        assert D is not None
        # ideal (undistorted) positions of the distorted sample grid, then an ideal canvas
        Dv = np.asarray(D, np.float64).ravel()
        grid = _sample_grid(W, H, ss)
        und = np.asarray(
            cv2.undistortPoints(grid.reshape(-1, 1, 2), K, Dv, P=K), np.float64
        ).reshape(-1, 2)
        lo = np.floor(und.min(axis=0)) - 2
        hi = np.ceil(und.max(axis=0)) + 2
        ox, oy = -lo
        Wi = int(hi[0] - lo[0]) + 1
        Hi = int(hi[1] - lo[1]) + 1
        K_id = K.copy()
        K_id[0, 2] += ox
        K_id[1, 2] += oy
        Kss, Wss, Hss = _scaled_K(K_id, ss), Wi * ss, Hi * ss
        lab_ss, dep_ss = rasterise(surfs, Kss, R, t, (Wss, Hss))
        rad = shade(surfs, lab_ss, dep_ss, Kss, R, t, light, seed)
        # sample the ideal supersampled canvas at the distorted grid's ideal positions
        mx = ((und[:, 0] + ox + 0.5) * ss - 0.5).astype(np.float32).reshape(H * ss, W * ss)
        my = ((und[:, 1] + oy + 0.5) * ss - 0.5).astype(np.float32).reshape(H * ss, W * ss)
        rad = np.asarray(
            cv2.remap(rad, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE), np.float32
        )
        # exact labels/depth at the distorted pixel centres
        und1 = np.asarray(
            cv2.undistortPoints(_sample_grid(W, H, 1).reshape(-1, 1, 2), K, Dv, P=K), np.float64
        ).reshape(-1, 2)
        labels, depth = _labels_along_rays(surfs, K, R, t, und1, W, H, K_id, lab_ss, dep_ss, ss)
    else:
        Kss = _scaled_K(K, ss)
        lab_ss, dep_ss = rasterise(surfs, Kss, R, t, (W * ss, H * ss))
        rad = shade(surfs, lab_ss, dep_ss, Kss, R, t, light, seed)
        if ss == 1:
            labels, depth = lab_ss, dep_ss
        else:
            labels, depth = rasterise(surfs, K, R, t, (W, H))
    if ss > 1:
        rad = np.asarray(cv2.resize(rad, (W, H), interpolation=cv2.INTER_AREA), np.float32)
    img = _sensor(rad, exposure, noise_seed)
    depth32 = np.where(np.isfinite(depth), depth, np.nan).astype(np.float32)
    return img, labels.astype(np.uint16), depth32


def _sample_grid(W: int, H: int, ss: int) -> npt.NDArray[np.float64]:
    """Positions (H*ss, W*ss, 2) of the sub-pixel samples, in pixel coordinates."""
    xs = (np.arange(W * ss) + 0.5) / ss - 0.5
    ys = (np.arange(H * ss) + 0.5) / ss - 0.5
    gx, gy = np.meshgrid(xs, ys)
    return np.stack([gx, gy], axis=2)


def _scaled_K(K: FloatArray, ss: int) -> FloatArray:
    Ks = K.copy()
    Ks[0, :] *= ss
    Ks[1, :] *= ss
    Ks[0, 2] = (K[0, 2] + 0.5) * ss - 0.5
    Ks[1, 2] = (K[1, 2] + 0.5) * ss - 0.5
    return Ks


def _labels_along_rays(
    surfs: Sequence[Surface],
    K: FloatArray,
    R: FloatArray,
    t: FloatArray,
    und: FloatArray,
    W: int,
    H: int,
    K_id: FloatArray,
    lab_ss: npt.NDArray[np.int32],
    dep_ss: FloatArray,
    ss: int,
) -> tuple[npt.NDArray[np.int32], FloatArray]:
    """Labels (nearest sample of the ideal canvas) and exact depths for given ideal positions.

    Where a pixel's ray meets the plane of its nearest sample's face behind the camera or
    nearly along it (a face's edge seen at a grazing angle: development seed 63002's ground at
    a distorted pixel, -494,090 m), the depth is that sample's, as the label is."""
    ox, oy = K_id[0, 2] - K[0, 2], K_id[1, 2] - K[1, 2]
    sx = np.clip(np.round((und[:, 0] + ox + 0.5) * ss - 0.5), 0, lab_ss.shape[1] - 1).astype(int)
    sy = np.clip(np.round((und[:, 1] + oy + 0.5) * ss - 0.5), 0, lab_ss.shape[0] - 1).astype(int)
    lab = lab_ss[sy, sx]
    rays = np.linalg.inv(K) @ np.vstack([und.T, np.ones(len(und))])
    depth = np.full(len(und), np.inf)
    for s in surfs:
        sel = lab == s.label
        if not sel.any():
            continue
        n_c = R @ s.normal
        with np.errstate(divide="ignore", invalid="ignore"):
            depth[sel] = (s.d + float(n_c @ t)) / (n_c @ rays[:, sel])
    sampled = dep_ss[sy, sx]
    missed = (lab != 0) & ~(depth > NEAR_M)
    depth[missed] = sampled[missed]
    return lab.reshape(H, W), depth.reshape(H, W)


def _sensor(rad: npt.NDArray[np.float32], exposure: Exposure, seed: int) -> npt.NDArray[np.uint8]:
    H, W = rad.shape[:2]
    ys, xs = np.mgrid[0:H, 0:W].astype(np.float32)
    r2 = ((xs - W / 2) ** 2 + (ys - H / 2) ** 2) / ((W / 2) ** 2 + (H / 2) ** 2)
    vig = 1.0 - exposure.vignetting * r2
    lin = np.clip(rad * (exposure.gain * vig)[:, :, None], 0.0, 1.0)
    val = 255.0 * lin ** np.float32(exposure.gamma)
    rng = np.random.default_rng(seed)
    val += rng.normal(0.0, exposure.noise_sigma, size=val.shape).astype(np.float32)
    rgb = np.clip(np.round(val), 0, 255).astype(np.uint8)
    return np.ascontiguousarray(rgb[:, :, ::-1])  # BGR, as OpenCV writes it
