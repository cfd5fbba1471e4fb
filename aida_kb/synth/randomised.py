"""Randomised scenes: one seed -> one reproducible scene specification with ground truth.

`random_scene(seed)` draws a kind of scene from `RANDOM_KINDS` (the building presets with
randomised dimensions and pitches, an asymmetric gable, the turntable box, the tower of
kb/tower.kb, and scenes without a building: a chessboard on a stand, or only ground and
occluders), then everything around
it: wall and roof materials (including siding and roof tiles whose stripes run along the
image rows, and dark low-texture roofs), 1 to 8 views on an orbit with the camera's distance,
height, yaw and elevation (20 degrees down to 20 degrees up), focal length, image size,
baseline, sun, cast shadows, the ground labelled, unlabelled (0) or absent, labels.png
present or not, occluders (trees, poles, cars as simple solids) covering up to 30 % of the
object in view 00, lens distortion and left/right exposure differences. Every view's left
image holds the whole object (the orbit grows where the drawn distance would cut it off:
occlusion is the occluders' part, not the frame's).

The kinds are a registry: `register_kind(name, weight, maker)` adds one (street presets of
later work); a maker turns a numpy Generator into a `RandomObject`. Every draw comes from
``numpy.random.default_rng(seed)`` in a fixed order, so a seed always gives the same scene.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from aida_kb.errors import GeometryError
from aida_kb.io.scene import StereoCalib
from aida_kb.synth import buildings as bld
from aida_kb.synth.render import rasterise, surfaces
from aida_kb.synth.scenes import MAX_SEED, ROOF_CONCEPTS, SceneSpec, look_at, make_rig

FloatArray = npt.NDArray[np.float64]

MAX_OCCLUSION = 0.30  # occluders may hide at most this fraction of the object in view 00
MAX_DRAWS = 20  # attempts at dimensions the generators accept, or occluders that fit
COVERAGE_SCALE = 4  # occlusion is measured on images this many times smaller (fast)
# A photographer frames the whole object: every corner of it lies at least FRAME_MARGIN of the
# image's width and height inside the border of both images of every view. A part beyond the
# border is measured by nothing, so no interpreter can be right about it (dev seed 60019: a
# shed's left end 25 % of its corners outside all three views); occluders are how the scenes
# hide parts. Where the drawn distance leaves a corner outside, the orbit and the baseline
# grow by FRAME_STEP until none is, at most FRAME_STEPS times (scenes already framed stay
# exactly as drawn: no random number is drawn for this).
FRAME_MARGIN = 0.0
FRAME_STEP = 1.08
FRAME_STEPS = 20
WALL_MATERIALS = ("mixed", "plaster", "brick", "siding")
ROOF_MATERIALS = ("tiles", "tiles", "darkroof")  # tiles twice: the common case
NOTHING = "nothing"  # truth.object of a scene without an object


@dataclass(frozen=True)
class RandomObject:
    """What a kind's maker returns: the object (site frame) and how to look at it.

    model : the object, or an empty model (no solids) for a scene without one.
    concepts : role path -> specialisation the interpretation must choose (truth.json).
    size_m : the object's extent (metres) the camera distance is scaled to.
    target_y_m : height of the point the cameras look at.
    knowledge : the knowledge file (under ``kb/``) a user reconstructs this object with;
        recorded as the scene's ``knowledge`` parameter (truth.json).
    """

    model: bld.Model
    concepts: dict[str, str]
    size_m: float
    target_y_m: float
    ground: str = "ground"
    background: str = "sky"
    occluders_allowed: bool = True
    extra: dict[str, float | str | bool] = field(default_factory=dict)
    knowledge: str = "buildings.kb"  # the file under kb/ that describes the object


Maker = Callable[[np.random.Generator], RandomObject]
RANDOM_KINDS: dict[str, tuple[float, Maker]] = {}


def register_kind(name: str, weight: float, maker: Maker) -> None:
    """Add a kind of random scene (`weight` relative to the others)."""
    if weight <= 0:
        raise ValueError(f"kind {name!r}: weight must be positive")
    RANDOM_KINDS[name] = (weight, maker)


def _u(rng: np.random.Generator, low: float, high: float) -> float:
    return float(rng.uniform(low, high))


def _floors(height: float) -> int:
    return max(1, round(height / 3.0))


def _house(roof: str) -> Maker:
    def make(rng: np.random.Generator) -> RandomObject:
        width = _u(rng, 9.0, 22.0)
        depth = _u(rng, 7.0, min(width - 1.5, 14.0))
        height = _u(rng, 4.0, 11.0)
        pitch = _u(rng, 8.0, 25.0) if roof == "shed" else _u(rng, 20.0, 50.0)
        model = bld.house(width, depth, height, roof, pitch, "plaster", "tiles", _floors(height))
        rise = (
            0.0
            if roof == "flat"
            else (depth if roof == "shed" else depth / 2) * math.tan(math.radians(pitch))
        )
        return RandomObject(
            model,
            {"body.roof": ROOF_CONCEPTS[roof]},
            math.hypot(width, depth, height + rise),
            (height + rise) / 2,
        )

    return make


def _asymmetric_gable(rng: np.random.Generator) -> RandomObject:
    width = _u(rng, 9.0, 22.0)
    depth = _u(rng, 7.0, min(width - 1.5, 14.0))
    height = _u(rng, 4.0, 11.0)
    front = _u(rng, 20.0, 50.0)
    back = float(np.clip(front + rng.choice([-1.0, 1.0]) * _u(rng, 10.0, 20.0), 12.0, 60.0))
    model = bld.house(
        width, depth, height, "gable", front, "plaster", "tiles", _floors(height), back
    )
    # no symmetric gable fits: the knowledge's gable whose slopes differ must be chosen
    return RandomObject(
        model,
        {"body.roof": "AsymmetricGableRoof"},
        math.hypot(width, depth, height + depth / 2),
        height * 0.7,
    )


def _lshape(meeting_deg: float) -> Maker:
    def make(rng: np.random.Generator) -> RandomObject:
        width = _u(rng, 13.0, 22.0)
        depth = _u(rng, 8.0, 13.0)
        height = _u(rng, 4.0, 9.0)
        pitch = _u(rng, 25.0, 45.0)
        model = bld.lshape_house(
            width=width,
            depth=depth,
            height=height,
            pitch_deg=pitch,
            wing_width=_u(rng, 0.5 * depth, depth),
            wing_length=_u(rng, 4.0, 9.0),
            meeting_deg=meeting_deg,
            floors=_floors(height),
        )
        wing = "RightWing" if meeting_deg == 90.0 else "SkewWing"
        return RandomObject(
            model,
            {"body.roof": "GableRoof", "body.wings[0]": wing},
            math.hypot(width + 6.0, depth + 8.0, height),
            height * 0.7,
        )

    return make


def _oriel(rng: np.random.Generator) -> RandomObject:
    width = _u(rng, 10.0, 20.0)
    depth = _u(rng, 8.0, 12.0)
    height = _u(rng, 7.0, 11.0)
    n = int(rng.integers(1, 4))
    model = bld.oriel_house(
        width=width,
        depth=depth,
        height=height,
        pitch_deg=_u(rng, 25.0, 45.0),
        oriel_width=_u(rng, 1.5, min(3.5, 0.8 * width / (n + 1))),
        oriel_depth=_u(rng, 0.8, 1.6),
        oriel_bottom=_u(rng, 2.5, 3.5),
        oriel_top=min(height - 0.5, _u(rng, 6.5, 8.5)),
        n_oriels=n,
        floors=_floors(height),
    )
    return RandomObject(
        model, {"body.roof": "GableRoof"}, math.hypot(width, depth, height + 4.0), height * 0.6
    )


def _box(rng: np.random.Generator) -> RandomObject:
    w, d, h = _u(rng, 0.25, 0.5), _u(rng, 0.2, 0.4), _u(rng, 0.15, 0.35)
    return RandomObject(
        bld.reference_box(w, d, h),
        {},
        math.hypot(w, d, h),
        h / 2,
        ground="table",
        background="studio",
        occluders_allowed=False,
        knowledge="reference_box.kb",
    )


def _tower(rng: np.random.Generator) -> RandomObject:
    """A square tower with a pyramid roof (kb/tower.kb: side 2-20 m, slopes 25-75 deg)."""
    side = _u(rng, 4.0, 10.0)
    height = _u(rng, 1.2 * side, 2.5 * side)
    pitch = _u(rng, 30.0, 65.0)
    model = bld.tower(side, height, pitch, "brick", "tiles", _floors(height))
    rise = 0.5 * side * math.tan(math.radians(pitch))
    return RandomObject(
        model,
        {},
        math.hypot(side, side, height + rise),
        0.55 * (height + rise),
        knowledge="tower.kb",
    )


def _chessboard(rng: np.random.Generator) -> RandomObject:
    """A chessboard on a stand: a planar object that is no building."""
    sq = _u(rng, 0.05, 0.12)
    cols, rows = int(rng.integers(6, 11)), int(rng.integers(4, 8))
    bw, bh = (cols + 3) * sq, (rows + 3) * sq
    lift = _u(rng, 0.6, 1.2)
    poly = np.array([[-bw / 2, lift, 0.0], [bw / 2, lift, 0.0], [bw / 2, lift + bh, 0.0]])
    poly = np.vstack([poly, [-bw / 2, lift + bh, 0.0]])
    face = bld.Face(
        "board",
        "Chessboard",
        "chessboard",
        poly,
        {"square_m": sq, "border_m": sq, "cols": cols + 1, "rows": rows + 1},
    )
    model = bld.Model("Chessboard", (bld.Solid("board", (face,)),), {"square_m": sq})
    return RandomObject(model, {}, math.hypot(bw, bh), lift + bh / 2)


def _clutter(rng: np.random.Generator) -> RandomObject:
    """No object at all: the ground and the occluders only."""
    return RandomObject(bld.Model(NOTHING, ()), {}, _u(rng, 10.0, 25.0), _u(rng, 1.0, 3.0))


for _roof in ("gable", "hip", "flat", "shed"):
    register_kind(_roof, 1.0, _house(_roof))
register_kind("asymmetric_gable", 0.6, _asymmetric_gable)
register_kind("lshape90", 0.8, _lshape(90.0))
register_kind("lshape135", 0.6, _lshape(135.0))
register_kind("oriel", 0.8, _oriel)
register_kind("turntable", 0.3, _box)
register_kind("tower", 0.5, _tower)
register_kind("chessboard", 0.3, _chessboard)
register_kind("clutter", 0.3, _clutter)


# ---- occluders -------------------------------------------------------------------------------
def _box_solid(name: str, centre: FloatArray, size: FloatArray, yaw: float) -> bld.Solid:
    """An upright box (site frame): centre of its base, size (x, y, z) metres, turned by yaw."""
    sx, sy, sz = size / 2
    c, s = math.cos(yaw), math.sin(yaw)
    R = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    corners = np.array([[x, y, z] for y in (0.0, 2 * sy) for z in (-sz, sz) for x in (-sx, sx)])
    P = corners @ R.T + centre
    quads = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]
    inside = centre + np.array([0.0, sy, 0.0])
    faces = [
        bld.Face(
            f"{name}.{k}",
            "Occluder",
            material,
            bld._oriented(P[list(q)], inside),
        )
        for k, (q, material) in enumerate(zip(quads, _OCCLUDER_MATERIALS[name[:4]], strict=True))
    ]
    return bld.Solid(name, tuple(faces))


_OCCLUDER_MATERIALS = {  # materials of synth.textures: bark and poles concrete-grey,
    "tree": ("soffit",) * 6,  # leaves grass-green, cars gravel-grey
    "leaf": ("ground",) * 6,
    "pole": ("soffit",) * 6,
    "car_": ("flatroof",) * 6,
}


def _tree(
    k: int, at: FloatArray, scale: float, yaw: float, rng: np.random.Generator
) -> list[bld.Solid]:
    trunk_h = _u(rng, 1.5, 3.0) * scale
    crown = _u(rng, 2.0, 4.5) * scale
    return [
        _box_solid(
            f"tree{k}", at, np.array([0.3, trunk_h, 0.3]) * np.array([scale, 1, scale]), yaw
        ),
        _box_solid(f"leaf{k}", at + np.array([0.0, trunk_h, 0.0]), np.array([crown] * 3), yaw),
    ]


def _pole(
    k: int, at: FloatArray, scale: float, yaw: float, rng: np.random.Generator
) -> list[bld.Solid]:
    return [_box_solid(f"pole{k}", at, np.array([0.2, 6.0, 0.2]) * scale, yaw)]


def _car(
    k: int, at: FloatArray, scale: float, yaw: float, rng: np.random.Generator
) -> list[bld.Solid]:
    return [_box_solid(f"car_{k}", at, np.array([4.3, 1.5, 1.8]) * scale, yaw)]


#: The occluders, by name: each builds its solids (k, at, scale, yaw, rng).
_OCCLUDERS = {"tree": _tree, "pole": _pole, "car": _car}


def _occluder(rng: np.random.Generator, k: int, at: FloatArray, scale: float) -> list[bld.Solid]:
    """One tree (trunk + crown), pole or car standing at `at` (site frame, ground level)."""
    build = _OCCLUDERS[str(rng.choice(list(_OCCLUDERS)))]
    yaw = _u(rng, 0.0, math.pi)
    return build(k, at, scale, yaw, rng)


def _coverage(
    model: bld.Model,
    occluders: bld.Model,
    R: FloatArray,
    t: FloatArray,
    K: FloatArray,
    size: tuple[int, int],
) -> float:
    """The fraction of the object's pixels in a camera (site-frame pose) the occluders hide."""
    Ks = K.copy()
    Ks[:2] /= COVERAGE_SCALE
    small = (max(size[0] // COVERAGE_SCALE, 8), max(size[1] // COVERAGE_SCALE, 8))
    eye = np.eye(3)
    zero = np.zeros(3)
    obj = surfaces(model, eye, zero, ground=None)
    occ = surfaces(occluders, eye, zero, ground=None)
    n = len(obj)
    occ = [replace(o, label=n + 1 + i) for i, o in enumerate(occ)]
    alone, _ = rasterise(obj, Ks, R, t, small)
    both, _ = rasterise(obj + occ, Ks, R, t, small)
    seen = alone > 0
    if not seen.any():
        return 0.0
    return float(np.count_nonzero(seen & (both > n))) / float(np.count_nonzero(seen))


def _corners(model: bld.Model) -> FloatArray:
    """Every corner of the model's faces, (N, 3) metres, site frame ((0, 3) without solids)."""
    polys = [np.asarray(f.polygon, dtype=np.float64) for s in model.solids for f in s.faces]
    return np.vstack(polys) if polys else np.zeros((0, 3))


def framed(
    corners: FloatArray, poses: list[tuple[FloatArray, FloatArray]], rig: StereoCalib
) -> bool:
    """True if every corner (N, 3; metres, site frame) lies in front of both cameras of every
    view (left poses R, t site frame -> camera; the right camera by the rig's R, T) and at
    least FRAME_MARGIN of the image's width and height inside its border (pinhole; the lens
    distortion of these scenes moves a corner by less than the margin)."""
    if len(corners) == 0:
        return True
    width, height = rig.image_size
    lo = FRAME_MARGIN * np.array([width, height])
    hi = np.array([width, height]) - lo
    for R, t in poses:
        left = corners @ R.T + t  # (N, 3) left camera frame
        if (left[:, 2] <= 0.0).any():
            return False
        uv = (left @ rig.K1.T)[:, :2] / left[:, 2:3]
        if (uv < lo).any() or (uv > hi).any():
            return False
    return True


# ---- the scene -------------------------------------------------------------------------------
def _with_materials(model: bld.Model, wall: str, roof: str) -> bld.Model:
    """The model with its walls' and roof planes' materials replaced (oriels stay)."""
    solids = []
    for s in model.solids:
        faces = []
        for f in s.faces:
            if f.material in ("mixed", "plaster", "brick"):
                f = replace(f, material=wall)
            elif f.material == "tiles":
                f = replace(f, material=roof)
            faces.append(f)
        solids.append(bld.Solid(s.name, tuple(faces)))
    return bld.Model(model.concept, tuple(solids), dict(model.parameters))


IMAGE_SIZES = ((480, 360), (640, 480), (720, 540), (800, 600))


def random_scene(
    seed: int, *, kind: str | None = None, max_views: int = 8, max_width: int = 800
) -> SceneSpec:
    """The scene of `seed` (0 .. MAX_SEED): always the same for the same arguments.

    kind : force one of RANDOM_KINDS (else drawn by weight). max_views, max_width : caps
    for quick runs (tests); the draws are the same, only clipped.
    """
    if not 0 <= seed <= MAX_SEED:
        raise GeometryError(f"--seed {seed}: must be in [0, {MAX_SEED}]")
    if kind is not None and kind not in RANDOM_KINDS:
        raise GeometryError(f"unknown kind {kind!r}; choose one of {', '.join(RANDOM_KINDS)}")
    rng = np.random.default_rng(seed)
    names = sorted(RANDOM_KINDS)
    weights = np.array([RANDOM_KINDS[n][0] for n in names])
    drawn = str(rng.choice(names, p=weights / weights.sum()))
    name = kind or drawn
    obj = None
    for _ in range(MAX_DRAWS):
        try:
            obj = RANDOM_KINDS[name][1](rng)
            break
        except GeometryError:
            continue
    if obj is None:
        raise GeometryError(f"kind {name!r}: no valid dimensions in {MAX_DRAWS} draws")
    model = _with_materials(
        obj.model, str(rng.choice(WALL_MATERIALS)), str(rng.choice(ROOF_MATERIALS))
    )
    # cameras
    w, h = IMAGE_SIZES[int(rng.integers(len(IMAGE_SIZES)))]
    if w > max_width:
        w, h = max_width, round(max_width * h / w)
    focal = _u(rng, 0.9, 2.0) * w  # horizontal field of view 28 .. 58 degrees
    half_fov = math.atan(0.5 * w / focal)
    distance = obj.size_m / (2 * math.tan(half_fov)) * _u(rng, 1.15, 1.8)
    n_views = min(int(rng.choice([1, 2, 2, 2, 3, 3, 4, 5, 6, 8])), max_views)
    azimuth = _u(rng, -50.0, 50.0)
    step = _u(rng, 20.0, 45.0) * float(rng.choice([-1.0, 1.0]))
    elevation = _u(rng, -20.0, 20.0)  # the optical axis above (+) or below (-) the horizontal
    yaw_off = _u(rng, -0.4, 0.4) * math.degrees(half_fov)
    baseline = distance * _u(rng, 1 / 50, 1 / 15)
    k1 = _u(rng, -0.12, 0.06) if rng.random() < 0.4 else 0.0
    target = np.array([0.0, obj.target_y_m, 0.0])
    low = 0.02 * obj.size_m + 0.1  # the camera stays above the ground

    def orbit(d: float) -> list[tuple[FloatArray, FloatArray]]:
        poses = []
        for k in range(n_views):
            a = math.radians(azimuth + k * step)
            horizontal = d * math.cos(math.radians(elevation))
            y = max(obj.target_y_m - d * math.sin(math.radians(elevation)), low)
            C = np.array([horizontal * math.sin(a), y, horizontal * math.cos(a)])
            aim = np.array([math.sin(a + math.pi), 0.0, math.cos(a + math.pi)])
            side = np.cross(aim, [0.0, 1.0, 0.0])
            look = target + side * math.tan(math.radians(yaw_off)) * d
            poses.append(look_at(C, look))
        return poses

    corners = _corners(obj.model)
    grow = 1.0
    for _ in range(FRAME_STEPS):
        rig = make_rig(width=w, height=h, focal_px=focal, baseline_m=baseline * grow, k1=k1)
        poses = orbit(distance * grow)
        if framed(corners, poses, rig):
            break
        grow *= FRAME_STEP
    distance, baseline = distance * grow, baseline * grow
    # light
    sun_az, sun_el = math.radians(_u(rng, -180.0, 180.0)), math.radians(_u(rng, 15.0, 70.0))
    sun = np.array(
        [math.sin(sun_az) * math.cos(sun_el), math.sin(sun_el), math.cos(sun_az) * math.cos(sun_el)]
    )
    ground_mode = str(rng.choice(["labelled", "unlabelled", "absent"], p=[0.4, 0.4, 0.2]))
    write_labels = bool(rng.random() < 0.5)
    # occluders between view 00's camera and the object
    occluders = None
    n_occ = int(rng.integers(1, 4)) if obj.occluders_allowed and rng.random() < 0.5 else 0
    if not model.solids and n_occ == 0:
        n_occ = 2
    R0, t0 = poses[0]
    C0 = -R0.T @ t0
    scale = 1.0
    for _ in range(MAX_DRAWS if n_occ else 0):
        solids: list[bld.Solid] = []
        for k in range(n_occ):
            f = _u(rng, 0.25, 0.6)
            at = C0 * f
            at = (
                at
                + np.cross([0.0, 1.0, 0.0], C0 / np.linalg.norm(C0))
                * _u(rng, -0.3, 0.3)
                * obj.size_m
            )
            at[1] = 0.0
            solids += _occluder(rng, k, at, scale)
        candidate = bld.Model("occluders", tuple(solids))
        if (
            not model.solids
            or _coverage(model, candidate, R0, t0, rig.K1, rig.image_size) <= MAX_OCCLUSION
        ):
            occluders = candidate
            break
        scale *= 0.8
    params: dict[str, float | str | bool] = {
        "kind": name,
        "knowledge": obj.knowledge,
        "n_views": n_views,
        "focal_px": focal,
        "distance_m": distance,
        "elevation_deg": elevation,
        "azimuth_deg": azimuth,
        "step_deg": step,
        "baseline_m": baseline,
        "k1": k1,
        "ground": ground_mode,
        "labels": write_labels,
        "occluders": 0 if occluders is None else len(occluders.solids),
        **obj.extra,
    }
    model = bld.Model(model.concept, model.solids, {**model.parameters, **params})
    return SceneSpec(
        f"random-{seed}",
        model,
        rig,
        poses,
        sun,
        ground=None if ground_mode == "absent" else obj.ground,
        ground_half_size_m=2000.0 if obj.ground == "ground" else 3.0 * obj.size_m,
        background=obj.background,
        noise_sigma=_u(rng, 0.8, 3.0),
        seed=seed,
        occluders=occluders,
        ground_labelled=ground_mode == "labelled",
        write_labels=write_labels,
        right_gain=_u(rng, 0.85, 1.15),
        sun_intensity=_u(rng, 0.5, 0.9),
        ambient=_u(rng, 0.25, 0.45),
        shadows=bool(rng.random() < 0.5),
        truth_concepts=dict(obj.concepts),
    )
