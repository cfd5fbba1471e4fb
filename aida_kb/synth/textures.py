"""Procedural materials: albedo (RGB, 0..1) as a function of face coordinates (u, v) in metres.

Each material is built from tileable texture images generated once per seed (brick courses
with per-brick colour, plaster noise, roof-tile courses, gravel, grass) and sampled with
``cv2.remap`` (bilinear, wrapping; prefiltered to the camera's sample spacing when it is
given, like mip-mapping), plus windows and doors drawn analytically from the wall's
window grid. Textures are fixed on the surfaces (functions of world position), so both
cameras of a stereo pair and all views see the same detail.
"""

from __future__ import annotations

import functools

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
F32 = npt.NDArray[np.float32]

TILE = 512  # texels per tile side


def _fbm_tile(rng: np.random.Generator, size: int, octaves: tuple[int, ...]) -> F32:
    """Tileable fractal noise (size x size), zero mean, unit std; octaves = lattice cells."""
    import cv2

    out = np.zeros((size, size), np.float32)
    amp = 1.0
    for cells in octaves:
        grid = rng.standard_normal((cells, cells)).astype(np.float32)
        big = np.tile(grid, (3, 3))
        up = cv2.resize(big, (3 * size, 3 * size), interpolation=cv2.INTER_CUBIC)
        out += amp * up[size : 2 * size, size : 2 * size]
        amp *= 0.6
    out -= out.mean()
    out /= max(float(out.std()), 1e-6)
    return out


def _hash01(i: npt.NDArray[np.int64], j: npt.NDArray[np.int64], seed: int) -> FloatArray:
    """Deterministic pseudo-random numbers in [0, 1) for integer lattice cells (i, j)."""
    h = (i.astype(np.uint64) * np.uint64(73856093)) ^ (j.astype(np.uint64) * np.uint64(19349663))
    h ^= np.uint64(seed * 83492791 + 12345)
    h = (h ^ (h >> np.uint64(13))) * np.uint64(0x5BD1E995)
    h ^= h >> np.uint64(15)
    out: FloatArray = (h & np.uint64(0xFFFFFF)).astype(np.float64) / float(0x1000000)
    return out


@functools.lru_cache(maxsize=8)
def texture_set(seed: int) -> dict[str, tuple[F32, float]]:
    """Tileable texture images for one seed: name -> (image (T, T, 3) float32 RGB, metres/texel)."""
    import cv2

    rng = np.random.default_rng(seed + 1000)
    T = TILE
    out: dict[str, tuple[F32, float]] = {}

    # generic grain used everywhere for fine stereo detail (0.6 mm .. 5 cm features)
    grain = _fbm_tile(rng, T, (128, 256))
    medium = _fbm_tile(rng, T, (8, 16, 32, 64))
    out["grain"] = (np.repeat(grain[:, :, None], 3, axis=2), 0.004)
    out["macro"] = (np.repeat(medium[:, :, None], 3, axis=2), 0.03)

    # plaster: warm off-white with blotches and fine roughness; tile 4.1 m (8 mm texels)
    n1 = _fbm_tile(rng, T, (4, 8, 16, 32, 64, 128))
    n2 = _fbm_tile(rng, T, (64, 128, 256))
    base = np.array([0.80, 0.74, 0.62], np.float32)
    plaster = base[None, None, :] * (1.0 + 0.07 * n1[:, :, None] + 0.06 * n2[:, :, None])
    out["plaster"] = (plaster.astype(np.float32), 0.008)

    # brick: 240 x 71 mm bricks, 10 mm joints, running bond; tile 2.5 m x 2.5 m (texel 5 mm)
    texel = 0.005
    yy, xx = np.mgrid[0:T, 0:T].astype(np.float64) * texel
    course_h, brick_l = 0.081, 0.25
    n_courses = round(T * texel / course_h)
    course_h = T * texel / n_courses
    n_bricks = round(T * texel / brick_l)
    brick_l = T * texel / n_bricks
    row = np.floor(yy / course_h).astype(np.int64)
    shift = (row % 2) * 0.5 * brick_l
    col = np.floor(((xx + shift) % (T * texel)) / brick_l).astype(np.int64) % n_bricks
    fy = (yy - row * course_h) / course_h
    fx = (((xx + shift) % (T * texel)) - col * brick_l) / brick_l
    joint = (fy < 0.12) | (fx < 0.04)
    r = _hash01(row, col, seed)
    g = _hash01(row + 977, col, seed)
    tone = 0.75 + 0.45 * r
    brick_rgb = np.stack([0.62 * tone, (0.30 + 0.06 * g) * tone, (0.22 + 0.04 * g) * tone], axis=2)
    # occasional dark, burnt bricks
    burnt = _hash01(row + 31, col + 7, seed) > 0.9
    brick_rgb[burnt] *= 0.6
    mortar = np.array([0.70, 0.68, 0.63])
    rough = _fbm_tile(rng, T, (64, 128, 256)).astype(np.float64)
    brick = np.where(joint[:, :, None], mortar[None, None, :], brick_rgb)
    brick *= (1.0 + 0.10 * rough)[:, :, None]
    out["brick"] = (brick.astype(np.float32), texel)

    # roof tiles: courses 0.30 m, tiles 0.24 m wide, staggered, shadow under each course
    texel = 0.006
    yy, xx = np.mgrid[0:T, 0:T].astype(np.float64) * texel
    size = T * texel
    ch = size / round(size / 0.30)
    tw = size / round(size / 0.24)
    row = np.floor(yy / ch).astype(np.int64)
    shift = (row % 2) * 0.5 * tw
    col = np.floor(((xx + shift) % size) / tw).astype(np.int64)
    fy = (yy - row * ch) / ch  # 0 at the top of a course (v grows downwards in the tile)
    fx = (((xx + shift) % size) - col * tw) / tw
    t1 = _hash01(row, col, seed + 5)
    # each tile: curved profile across (brighter in the middle), darker towards its lower lip
    profile = 0.80 + 0.20 * np.sin(np.pi * fx) - 0.25 * np.clip(fy - 0.75, 0, 1) / 0.25
    gap = (fx < 0.03) | (fy > 0.94)
    tone = (0.72 + 0.5 * t1) * profile
    tile = np.stack([0.55 * tone, 0.23 * tone, 0.15 * tone], axis=2)
    tile[gap] *= 0.35
    moss = _fbm_tile(rng, T, (4, 8, 16)).astype(np.float64)
    tile *= (1.0 + 0.08 * rough[::-1])[:, :, None]
    tile = tile * (1 - 0.15 * np.clip(moss, 0, 2)[:, :, None]) + 0.06 * np.clip(moss, 0, 2)[
        :, :, None
    ] * np.array([0.25, 0.30, 0.15])
    out["tiles"] = (tile.astype(np.float32), texel)

    # flat roof: grey gravel
    n = _fbm_tile(rng, T, (32, 64, 128, 256)).astype(np.float64)
    gravel = np.array([0.45, 0.44, 0.42])[None, None, :] * (1.0 + 0.18 * n[:, :, None])
    out["flatroof"] = (gravel.astype(np.float32), 0.006)

    # ground: grass and earth patches, with fine structure; 15 cm macro, 2 cm texels
    n1 = _fbm_tile(rng, T, (4, 8, 16, 32)).astype(np.float64)
    n2 = _fbm_tile(rng, T, (64, 128, 256)).astype(np.float64)
    w = np.clip(0.5 + 0.35 * n1, 0, 1)[:, :, None]
    grass = np.array([0.30, 0.40, 0.16])
    earth = np.array([0.42, 0.36, 0.27])
    ground = (w * grass + (1 - w) * earth) * (1.0 + 0.22 * n2[:, :, None])
    out["ground"] = (ground.astype(np.float32), 0.02)

    # turntable / table top: wood-grain-like grey-brown
    n1 = _fbm_tile(rng, T, (2, 4, 8)).astype(np.float64)
    n2 = _fbm_tile(rng, T, (32, 64, 128)).astype(np.float64)
    stretch = cv2.resize(n2, (T, T // 8))
    stretch = cv2.resize(stretch, (T, T))
    table = np.array([0.55, 0.45, 0.34])[None, None, :] * (
        1 + 0.08 * n1[:, :, None] + 0.15 * stretch[:, :, None]
    )
    out["table"] = (table.astype(np.float32), 0.002)

    # reference box: random grey blocks (5 mm) under a fine noise, like a printed pattern
    cells = rng.random((T // 4, T // 4))
    blocks = cv2.resize(cells, (T, T), interpolation=cv2.INTER_NEAREST)
    blocks = cv2.GaussianBlur(blocks, (0, 0), 0.8)
    boxtex = (0.15 + 0.75 * blocks)[:, :, None] * np.array([0.95, 0.93, 0.88])[None, None, :]
    out["box"] = (boxtex.astype(np.float32), 0.00125)

    # soffit / floor: smooth grey concrete
    n = _fbm_tile(rng, T, (16, 32, 64, 128)).astype(np.float64)
    out["soffit"] = (
        (np.array([0.6, 0.6, 0.58])[None, None, :] * (1 + 0.08 * n[:, :, None])).astype(np.float32),
        0.008,
    )
    out["floor"] = out["soffit"]
    oriel = plaster * np.array([0.92, 0.97, 1.08], np.float32)[None, None, :]
    out["oriel"] = (oriel.astype(np.float32), 0.008)

    # siding: horizontal boards 0.16 m high (stripes along the image rows of a level camera),
    # a shadow line under each board's lap, faint grain along the boards; texel 5 mm
    texel = 0.005
    yy = np.mgrid[0:T, 0:T][0].astype(np.float64) * texel
    board = T * texel / round(T * texel / 0.16)
    fy = (yy % board) / board
    lap = 0.72 + 0.28 * fy - 0.45 * (fy > 0.93)
    streak = cv2.resize(_fbm_tile(rng, T, (16, 32, 64)), (T, T // 16))
    streak = cv2.resize(streak, (T, T)).astype(np.float64)
    siding = np.array([0.70, 0.72, 0.70])[None, None, :] * (lap + 0.03 * streak)[:, :, None]
    out["siding"] = (siding.astype(np.float32), texel)

    # dark roof: slate-black with little texture (weak stereo evidence)
    n = _fbm_tile(rng, T, (8, 32, 128)).astype(np.float64)
    dark = np.array([0.075, 0.075, 0.085])[None, None, :] * (1.0 + 0.06 * n[:, :, None])
    out["darkroof"] = (dark.astype(np.float32), 0.008)
    return out


MIP_LEVELS = 10  # a texture and its halvings: footprints of 1, 2, 4, ... 512 texels
_PYRAMIDS: dict[int, tuple[F32, list[F32]]] = {}


def _pyramid(tex: F32) -> list[F32]:
    """Mip-map of a square tile: level L has side size / 2^L, each level the previous one
    low-passed with OpenCV's 5-tap Gaussian and decimated (``cv2.pyrDown``, periodic: the
    tile is padded by wrapping). A smooth kernel keeps the levels nearly shift-invariant
    (box averages would tie fine texture to the block grid). Cached per texture image."""
    import cv2

    cached = _PYRAMIDS.get(id(tex))
    if cached is not None and cached[0] is tex:
        return cached[1]
    levels = [tex]
    pad = 4
    while len(levels) < MIP_LEVELS and levels[-1].shape[0] % 2 == 0 and levels[-1].shape[0] > 1:
        prev = levels[-1]
        half = prev.shape[0] // 2
        wrapped = np.pad(prev, ((pad, pad), (pad, pad), (0, 0)), mode="wrap")
        down = np.asarray(cv2.pyrDown(wrapped), np.float32)
        levels.append(
            np.ascontiguousarray(down[pad // 2 : pad // 2 + half, pad // 2 : pad // 2 + half])
        )
    if len(_PYRAMIDS) > 64:
        _PYRAMIDS.clear()
    _PYRAMIDS[id(tex)] = (tex, levels)
    return levels


def _remap(tex: F32, u_tex: FloatArray, v_tex: FloatArray) -> F32:
    """Bilinear, wrapping lookup of `tex` at texel coordinates; (N, 3)."""
    import cv2

    from aida_kb.vision.rectify import sample_points

    size = tex.shape[0]
    res = sample_points(tex, np.mod(u_tex, size), np.mod(v_tex, size), border=cv2.BORDER_WRAP)
    return np.asarray(res, np.float32).reshape(-1, 3)


def _coarser(x: FloatArray, level: int) -> FloatArray:
    """Level-0 texel coordinates -> those of mip level `level` (cv2.pyrDown keeps every
    second texel's position: texel i of level L sits at 2^L·i on level 0)."""
    return x / 2.0**level


def sample(
    tex: F32,
    texel_m: float,
    u: FloatArray,
    v: FloatArray,
    footprint_m: FloatArray | None = None,
) -> F32:
    """Sample a tileable texture at face coordinates (u, v) metres; returns (N, 3) RGB.

    footprint_m : (N,) the spacing of the image samples on the face, metres. Given, each sample
    reads the texture prefiltered to that scale (trilinear between the levels of a mip-map),
    as a camera integrates over its pixel: without it, fine periodic detail such as
    mortar joints aliases into moiré that differs between the two cameras of a stereo pair.
    """
    u_tex = u / texel_m
    v_tex = v / texel_m
    if footprint_m is None:
        return _remap(tex, u_tex, v_tex)
    levels = _pyramid(tex)
    top = len(levels) - 1
    ell = np.clip(np.log2(np.maximum(footprint_m / texel_m, 1.0)), 0.0, float(top))
    lo = np.minimum(np.floor(ell).astype(np.int64), max(top - 1, 0))
    frac = np.clip(ell - lo, 0.0, 1.0).astype(np.float32)[:, None]
    out = np.empty((len(u), 3), np.float32)
    for level in np.unique(lo).tolist():
        sel = lo == level
        a = _remap(levels[level], _coarser(u_tex[sel], level), _coarser(v_tex[sel], level))
        if level + 1 > top:
            out[sel] = a
            continue
        nxt = level + 1
        b = _remap(levels[nxt], _coarser(u_tex[sel], nxt), _coarser(v_tex[sel], nxt))
        out[sel] = a + (b - a) * frac[sel]
    return out


def windows_mask(
    u: FloatArray,
    v: FloatArray,
    *,
    length: float,
    floors: int,
    floor_h: float,
    v0: float = 0.0,
    door: bool = False,
    bay: float = 3.2,
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_], FloatArray]:
    """Windows on a wall: (frame mask, glass mask, glass vertical coordinate 0..1).

    u : metres along the wall from its left end; v : metres above the wall's base v0.
    Bays of about `bay` metres; per floor one window per bay (1.2 x 1.4 m, sill 0.9 m).
    """
    nb = max(1, int(length // bay))
    bw = length / nb
    win_w = min(1.25, 0.55 * bw)
    win_h = min(1.45, 0.55 * floor_h)
    sill = min(0.9, 0.3 * floor_h)
    vv = v - v0
    fl = np.floor(vv / floor_h)
    bi = np.floor(u / bw)
    lu = u - (bi + 0.5) * bw  # relative to the bay centre
    lv = vv - fl * floor_h - sill
    valid = (fl >= 0) & (fl < floors) & (bi >= 0) & (bi < nb)
    half = win_w / 2
    if door:
        is_door = valid & (fl == 0) & (bi == nb // 2)
        lv = np.where(is_door, vv, lv)
        hh = np.where(is_door, min(2.2, 0.85 * floor_h), win_h)
        hw = np.where(is_door, 0.6, half)
    else:
        hh = np.full(u.shape, win_h)
        hw = np.full(u.shape, half)
    fw = 0.08  # frame width
    outer = valid & (np.abs(lu) <= hw + fw) & (lv >= -fw) & (lv <= hh + fw)
    inner = valid & (np.abs(lu) <= hw) & (lv >= 0) & (lv <= hh)
    mullion = inner & ((np.abs(lu) < 0.035) | (np.abs(lv - 0.62 * hh) < 0.035))
    glass = inner & ~mullion
    frame = outer & ~glass
    gy = np.clip(lv / np.maximum(hh, 1e-6), 0.0, 1.0)
    return frame, glass, gy
