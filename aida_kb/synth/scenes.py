"""Synthetic scenes: the paper's experiments as scene directories with ground truth.

Presets: ``house`` (the two-view apartment building, paper §6.1), ``turntable`` (the reference
box at 0, 85, 195 and 265 degrees, §6.2), ``lshape``, ``oriel``, and ``chessboard`` (planar
chessboard poses for cv2.calibrateCamera / cv2.stereoCalibrate).

World frame = left camera of view 00 (OpenCV axes), metres. The stereo rig maps left-camera
to right-camera coordinates as x_right = R·x_left + T.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import numpy.typing as npt

from aida_kb.errors import GeometryError
from aida_kb.io.scene import (
    GroundTruth,
    PartTruth,
    PoseTruth,
    SceneTruth,
    StereoCalib,
    ViewData,
    write_scene,
)
from aida_kb.synth import buildings as bld
from aida_kb.synth.render import GROUND_LABEL, Exposure, Lighting, Surface, render, surfaces

FloatArray = npt.NDArray[np.float64]
Progress = Callable[[int, int], None]

STREET = ("street", "terrace", "occluded")  # several houses: `aida_kb.synth.street`
PRESETS = ("house", "turntable", "lshape", "oriel", "tower", "chessboard", *STREET)
ROOF_CONCEPTS = {"gable": "GableRoof", "hip": "HipRoof", "flat": "FlatRoof", "shed": "ShedRoof"}
"""The specialisation each roof kind of `synth.buildings` is (synth's own names, in truth.json)."""
#: the `house` preset's dihedral angles `aida-kb demo` names (its parts' role paths in
#: kb/buildings.kb: the synthetic renderer may name the parts it renders)
HOUSE_ANGLES = (
    ("body.front", "body.left", "wall corner"),
    ("body.floor", "body.front", "wall on the floor"),
    ("body.front", "body.roof.front", "eaves (90 + pitch)"),
    ("body.roof.front", "body.roof.back", "ridge (180 - 2 pitch)"),
    ("body.left", "body.roof.front", "gable"),
)
OCCLUDER_LABEL = 2000  # first render label of occluders (above the ground's); 0 in labels.png


def look_at(
    centre: FloatArray, target: FloatArray, up: FloatArray | None = None
) -> tuple[FloatArray, FloatArray]:
    """OpenCV camera pose (R, t; x_cam = R·x + t) at `centre` looking at `target`, y-up site."""
    up = np.array([0.0, 1.0, 0.0]) if up is None else up
    z = np.asarray(target, float) - np.asarray(centre, float)
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    nx = np.linalg.norm(x)
    if nx < 1e-9:
        raise GeometryError("look_at: viewing direction parallel to up")
    x /= nx
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ np.asarray(centre, float)


def rot_y(angle_rad: float) -> FloatArray:
    """Rotation about the y axis by `angle_rad` (right-handed)."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def make_rig(
    width: int = 640,
    height: int = 480,
    focal_px: float = 800.0,
    baseline_m: float = 0.4,
    toe_in_deg: float = 0.5,
    k1: float = 0.0,
) -> StereoCalib:
    """A horizontal stereo rig; the right camera sits `baseline_m` to the right, turned inwards.

    focal_px 800 at 640x480 is a 8 mm lens on a 1/2" sensor (43.6 degrees horizontal field).
    """
    K1 = np.array([[focal_px, 0.0, (width - 1) / 2], [0.0, focal_px, (height - 1) / 2], [0, 0, 1]])
    K2 = K1.copy()
    K2[0, 0] *= 1.002  # two real cameras never agree exactly
    K2[0, 2] += 1.3
    K2[1, 2] -= 0.8
    D = np.array([k1, 0.0, 0.0, 0.0, 0.0])
    R = rot_y(-math.radians(toe_in_deg)) @ _rot_x(math.radians(0.15))
    C_right = np.array([baseline_m, 0.0, 0.0])
    T = -R @ C_right
    return StereoCalib(K1, D.copy(), K2, D.copy(), R, T, (width, height))


def _rot_x(a: float) -> FloatArray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


@dataclass
class SceneSpec:
    """Everything needed to render a synthetic scene (site frame: y up, ground y = 0)."""

    name: str
    model: bld.Model
    rig: StereoCalib
    views_site: list[tuple[FloatArray, FloatArray]]  # left-camera poses R, t in the site frame
    sun_site: FloatArray
    ground: str | None = "ground"
    ground_half_size_m: float = 2000.0
    background: str = "sky"
    noise_sigma: float = 1.8
    seed: int = 0
    extra_surfaces: list[Surface] = field(default_factory=list)
    occluders: bld.Model | None = None  # rendered, unlabelled (0), not part of the truth
    ground_labelled: bool = True  # False: the ground is 0 (unlabelled) in labels.png
    write_labels: bool = True  # False: no labels.png (segmentation from the images alone)
    right_gain: float = 0.97  # the right camera's exposure relative to the left one's
    sun_intensity: float = 0.75
    ambient: float = 0.38
    shadows: bool = False  # cast shadows (aida_kb.synth.render.in_shadow)
    truth_concepts: dict[str, str] = field(default_factory=dict)  # role -> specialisation


def _sun(azimuth_deg: float = -35.0, elevation_deg: float = 40.0) -> FloatArray:
    a, e = math.radians(azimuth_deg), math.radians(elevation_deg)
    return np.array([math.sin(a) * math.cos(e), math.sin(e), math.cos(a) * math.cos(e)])


def _orbit(
    target: FloatArray, distance: float, height: float, angles_deg: list[float]
) -> list[tuple[FloatArray, FloatArray]]:
    """Cameras on a circle about the vertical through `target` (angle 0 = straight in front)."""
    poses = []
    for a in angles_deg:
        r = math.radians(a)
        C = np.array(
            [target[0] + distance * math.sin(r), height, target[2] + distance * math.cos(r)]
        )
        poses.append(look_at(C, target))
    return poses


# Allowed range of every numeric parameter: (low, high, integer). Units as in the key's name
# (metres unless told; pixels for image_*, focal_px and noise_sigma; degrees for *_deg).
_RANGES: dict[str, tuple[float, float, bool]] = {
    "image_width": (32, 8192, True),
    "image_height": (32, 8192, True),
    "focal_px": (1.0, 1e6, False),
    "baseline": (1e-3, 100.0, False),
    "k1": (-1.0, 1.0, False),
    "noise_sigma": (0.0, 100.0, False),
    "width": (1e-2, 1000.0, False),
    "side": (1e-2, 1000.0, False),
    "depth": (1e-2, 1000.0, False),
    "height": (1e-2, 1000.0, False),
    "wing_width": (1e-2, 1000.0, False),
    "wing_length": (1e-2, 1000.0, False),
    "oriel_width": (1e-2, 1000.0, False),
    "oriel_depth": (1e-2, 1000.0, False),
    "distance": (1e-2, 1e5, False),
    "floors": (1, 100, True),
    "n_oriels": (0, 20, True),
    "cols": (2, 100, True),
    "rows": (2, 100, True),
    "square_m": (1e-3, 10.0, False),
}


def _float(params: Mapping[str, str | float], key: str, default: float) -> float:
    """Parameter `key` as a finite number inside its allowed range (GeometryError if not)."""
    value = params.get(key, default)
    try:
        number = float(value)
    except ValueError:
        raise GeometryError(f"--set {key}={value}: expected a number") from None
    if not math.isfinite(number):
        raise GeometryError(f"--set {key}={value}: expected a finite number")
    if key in _RANGES:
        low, high, integer = _RANGES[key]
        if integer and number != int(number):
            raise GeometryError(f"--set {key}={value}: expected a whole number")
        if not low <= number <= high:
            raise GeometryError(f"--set {key}={value}: must be in [{low:g}, {high:g}]")
    return number


def _rig_from(params: Mapping[str, str | float], baseline: float) -> StereoCalib:
    return make_rig(
        width=int(_float(params, "image_width", 640)),
        height=int(_float(params, "image_height", 480)),
        focal_px=_float(params, "focal_px", 800.0),
        baseline_m=_float(params, "baseline", baseline),
        k1=_float(params, "k1", 0.0),
    )


KNOWN_KEYS = {
    "house": {"width", "depth", "height", "roof", "pitch_deg", "floors", "wall", "distance"},
    "lshape": {
        "width",
        "depth",
        "height",
        "pitch_deg",
        "wing_width",
        "wing_length",
        "meeting_deg",
        "floors",
        "distance",
    },
    "oriel": {
        "width",
        "depth",
        "height",
        "pitch_deg",
        "n_oriels",
        "oriel_width",
        "oriel_depth",
        "floors",
        "distance",
    },
    "tower": {"side", "height", "pitch_deg", "floors", "wall", "distance"},
    "turntable": {"width", "depth", "height", "distance", "angles"},
    "chessboard": {"cols", "rows", "square_m"},
}
MAX_SEED = 2**31 - 1  # seeds are offset per texture and view; this keeps them in numpy's range
WALL_MATERIALS = ("mixed", "plaster", "brick")
COMMON_KEYS = {"image_width", "image_height", "focal_px", "baseline", "k1", "noise_sigma"}


def preset(
    name: str, *, seed: int = 0, views: int | None = None, params: Mapping[str, str] | None = None
) -> SceneSpec:
    """The scene specification of a preset (see PRESETS); `params` override its parameters.

    Raises GeometryError for an unknown preset, an unknown key or an impossible value.
    """
    p: dict[str, str | float] = dict(params or {})
    if not 0 <= seed <= MAX_SEED:
        raise GeometryError(f"--seed {seed}: must be in [0, {MAX_SEED}]")
    if name in STREET:  # several buildings per scene: aida_kb.synth.street
        from aida_kb.synth.street import street_spec

        return street_spec(name, p, seed=seed, views=views)
    if name not in KNOWN_KEYS:
        raise GeometryError(f"unknown preset {name!r}; choose one of {', '.join(PRESETS)}")
    unknown = set(p) - KNOWN_KEYS[name] - COMMON_KEYS
    if unknown:
        allowed = ", ".join(sorted(KNOWN_KEYS[name] | COMMON_KEYS))
        raise GeometryError(f"--set: unknown key(s) {', '.join(sorted(unknown))}; known: {allowed}")
    sigma = _float(p, "noise_sigma", 1.8)
    wall = str(p.get("wall", "mixed"))
    if wall not in WALL_MATERIALS:
        raise GeometryError(f"--set wall={wall}: choose one of {', '.join(WALL_MATERIALS)}")
    if name == "house":
        model = bld.house(
            width=_float(p, "width", 16.0),
            depth=_float(p, "depth", 10.0),
            height=_float(p, "height", 9.0),
            roof=str(p.get("roof", "gable")),
            pitch_deg=_float(p, "pitch_deg", 35.0),
            wall_material=wall,
            floors=int(_float(p, "floors", 3)),
        )
        n = views or 2
        dist = _float(p, "distance", 30.0)
        angles = [-25.0 + 45.0 * k for k in range(n)]
        poses = _orbit(np.array([0.0, 5.0, 0.0]), dist, 5.5, angles)
        return SceneSpec(
            "house",
            model,
            _rig_from(p, 0.4),
            poses,
            _sun(),
            seed=seed,
            noise_sigma=sigma,
            truth_concepts={"body.roof": ROOF_CONCEPTS[str(p.get("roof", "gable"))]},
        )
    if name == "lshape":
        model = bld.lshape_house(
            width=_float(p, "width", 16.0),
            depth=_float(p, "depth", 10.0),
            height=_float(p, "height", 7.0),
            pitch_deg=_float(p, "pitch_deg", 38.0),
            wing_width=_float(p, "wing_width", 8.0),
            wing_length=_float(p, "wing_length", 7.0),
            meeting_deg=_float(p, "meeting_deg", 90.0),
            floors=int(_float(p, "floors", 2)),
        )
        n = views or 2
        dist = _float(p, "distance", 34.0)
        angles = [-30.0 + 45.0 * k for k in range(n)]
        poses = _orbit(np.array([1.0, 4.0, 2.0]), dist, 6.0, angles)
        wing = "RightWing" if model.parameters["meeting_deg"] == 90.0 else "SkewWing"
        return SceneSpec(
            "lshape",
            model,
            _rig_from(p, 0.4),
            poses,
            _sun(),
            seed=seed,
            noise_sigma=sigma,
            truth_concepts={"body.roof": "GableRoof", "body.wings[0]": wing},
        )
    if name == "oriel":
        model = bld.oriel_house(
            width=_float(p, "width", 14.0),
            depth=_float(p, "depth", 10.0),
            height=_float(p, "height", 9.0),
            pitch_deg=_float(p, "pitch_deg", 40.0),
            n_oriels=int(_float(p, "n_oriels", 2)),
            oriel_width=_float(p, "oriel_width", 3.0),
            oriel_depth=_float(p, "oriel_depth", 1.2),
            floors=int(_float(p, "floors", 3)),
        )
        n = views or 2
        dist = _float(p, "distance", 28.0)
        angles = [-25.0 + 45.0 * k for k in range(n)]
        poses = _orbit(np.array([0.0, 5.0, 0.0]), dist, 4.5, angles)
        return SceneSpec(
            "oriel",
            model,
            _rig_from(p, 0.4),
            poses,
            _sun(-50.0, 35.0),
            seed=seed,
            noise_sigma=sigma,
            truth_concepts={"body.roof": "GableRoof"},
        )
    if name == "tower":
        model = bld.tower(
            side=_float(p, "side", 9.0),
            height=_float(p, "height", 10.0),
            pitch_deg=_float(p, "pitch_deg", 45.0),
            wall_material=wall,
            floors=int(_float(p, "floors", 4)),
        )
        n = views or 2
        dist = _float(p, "distance", 30.0)
        angles = [-40.0 + 80.0 * k for k in range(n)]
        eaves = float(model.parameters["height"])
        poses = _orbit(np.array([0.0, 0.6 * eaves, 0.0]), dist, 1.4 * eaves, angles)
        return SceneSpec(
            "tower",
            model,
            _rig_from(p, 0.4),
            poses,
            _sun(-60.0, 40.0),
            seed=seed,
            noise_sigma=sigma,
        )
    if name == "turntable":
        model = bld.reference_box(
            _float(p, "width", 0.40), _float(p, "depth", 0.30), _float(p, "height", 0.25)
        )
        if "angles" in p:
            try:
                angles = [float(a) for a in str(p["angles"]).split(",")]
            except ValueError:
                angles = []
            if not angles or not all(math.isfinite(a) for a in angles):
                raise GeometryError(f"--set angles={p['angles']}: expected comma-separated degrees")
        else:
            angles = [0.0, 85.0, 195.0, 265.0]
        if views is not None:
            angles = (
                angles[:views]
                if views <= len(angles)
                else [360.0 * k / views for k in range(views)]
            )
        # the box turns by +a about its vertical axis = the camera orbits by -a
        dist = _float(p, "distance", 1.4)
        poses = _orbit(np.array([0.0, 0.12, 0.0]), dist, 0.55, [-a for a in angles])
        spec = SceneSpec(
            "turntable",
            model,
            _rig_from(p, 0.12),
            poses,
            _sun(-30.0, 55.0),
            ground="table",
            ground_half_size_m=0.55,
            background="studio",
            seed=seed,
            noise_sigma=sigma,
        )
        return spec
    return chessboard_spec(p, seed=seed, views=views)


def chessboard_spec(
    p: Mapping[str, str | float], *, seed: int = 0, views: int | None = None
) -> SceneSpec:
    """A planar chessboard (cols x rows inner corners) seen by the rig in several poses."""
    cols = int(_float(p, "cols", 9))
    rows = int(_float(p, "rows", 6))
    sq = _float(p, "square_m", 0.06)
    border = sq
    bw, bh = (cols + 1) * sq + 2 * border, (rows + 1) * sq + 2 * border
    poly = np.array([[0.0, 0.0, 0.0], [bw, 0.0, 0.0], [bw, bh, 0.0], [0.0, bh, 0.0]])
    poly -= np.array([bw / 2, bh / 2, 0.0])
    face = bld.Face(
        "board",
        "Chessboard",
        "chessboard",
        poly,
        {"square_m": sq, "border_m": border, "cols": cols + 1, "rows": rows + 1},
    )
    model = bld.Model(
        "Chessboard", (bld.Solid("board", (face,)),), {"cols": cols, "rows": rows, "square_m": sq}
    )
    n = views or 8
    rng = np.random.default_rng(seed + 77)
    poses = []
    for k in range(n):
        # the board stays put; the rig looks at it from varied positions and tilts
        az = math.radians(-30 + 60 * rng.random())
        el = math.radians(-25 + 50 * rng.random())
        dist = 0.9 + 0.5 * rng.random()
        C = dist * np.array(
            [math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)]
        )
        target = np.array([0.05 * rng.standard_normal(), 0.05 * rng.standard_normal(), 0.0])
        R, t = look_at(C, target)
        roll = math.radians(20 * (rng.random() - 0.5)) + (k % 2) * 0.0
        c, s = math.cos(roll), math.sin(roll)
        Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        poses.append((Rz @ R, Rz @ t))
    rig = _rig_from(p, 0.12)
    return SceneSpec(
        "chessboard",
        model,
        rig,
        poses,
        np.array([0.2, 0.4, 0.9]) / 1.02,
        ground=None,
        background="studio",
        seed=seed,
        noise_sigma=_float(p, "noise_sigma", 1.5),
    )


def render_scene(
    spec: SceneSpec,
    directory: str | os.PathLike[str],
    *,
    progress: Progress | None = None,
    supersample: int = 2,
) -> Path:
    """Render `spec` and write its scene directory (images, labels, depth, calib, truth)."""
    R0, t0 = spec.views_site[0]
    surfs = surfaces(
        spec.model, R0, t0, ground=spec.ground, ground_half_size_m=spec.ground_half_size_m
    )
    if spec.occluders is not None:
        first = OCCLUDER_LABEL
        surfs += [
            replace(o, label=first + i)
            for i, o in enumerate(surfaces(spec.occluders, R0, t0, ground=None))
        ]
    up_w = R0 @ np.array([0.0, 1.0, 0.0])
    sun_site = spec.sun_site / np.linalg.norm(spec.sun_site)
    light = Lighting(
        sun=R0 @ sun_site,
        up=up_w,
        background=spec.background,
        sun_intensity=spec.sun_intensity,
        ambient=spec.ambient,
        shadows=spec.shadows,
    )
    rig = spec.rig
    views: list[ViewData] = []
    poses: list[PoseTruth] = []
    total = len(spec.views_site)
    for k, (Rk, tk) in enumerate(spec.views_site):
        # pose in the world (= left camera of view 00) frame
        R = Rk @ R0.T
        t = tk - R @ t0
        Rr = rig.R @ R
        tr = rig.R @ t + rig.T
        ex_l = Exposure(noise_sigma=spec.noise_sigma)
        ex_r = Exposure(gain=spec.right_gain, noise_sigma=spec.noise_sigma)
        left, labels, depth = render(
            surfs,
            rig.K1,
            R,
            t,
            rig.image_size,
            light,
            D=rig.D1,
            supersample=supersample,
            exposure=ex_l,
            seed=spec.seed,
            noise_seed=spec.seed * 1000 + 2 * k,
        )
        right, _, _ = render(
            surfs,
            rig.K2,
            Rr,
            tr,
            rig.image_size,
            light,
            D=rig.D2,
            supersample=supersample,
            exposure=ex_r,
            seed=spec.seed,
            noise_seed=spec.seed * 1000 + 2 * k + 1,
        )
        labels[labels >= OCCLUDER_LABEL] = 0  # nobody labels the trees as house parts
        if not spec.ground_labelled:
            labels[labels == GROUND_LABEL] = 0
        views.append(
            ViewData(
                left=left,
                right=right,
                labels=labels if spec.write_labels else None,
                depth_left=depth,
            )
        )
        poses.append(PoseTruth(view=f"{k:02d}", K=_m3(rig.K1), R=_m3(R), t=_v3(t)))
        if progress is not None:
            progress(k + 1, total)
    parts = [
        PartTruth(
            role=s.role,
            concept=s.concept,
            label=s.label,
            material=s.material,
            normal=_v3(s.normal),
            d=s.d,
            polygon=[_v3(v) for v in s.polygon],
        )
        for s in surfs
        if s.label != GROUND_LABEL and s.label < OCCLUDER_LABEL
    ]
    ground = next((s for s in surfs if s.label == GROUND_LABEL), None)
    truth = SceneTruth(
        object=spec.model.concept,
        parts=parts,
        ground=None
        if ground is None
        else GroundTruth(label=GROUND_LABEL, normal=_v3(ground.normal), d=ground.d),
        views=poses,
        parameters={**spec.model.parameters, "seed": spec.seed, "preset": spec.name},
        concepts=dict(spec.truth_concepts),
    )
    return write_scene(directory, rig, views, truth=truth, name=spec.name)


def _v3(v: FloatArray) -> tuple[float, float, float]:
    a = np.asarray(v, dtype=float).ravel()
    return (float(a[0]), float(a[1]), float(a[2]))


def _m3(
    m: FloatArray,
) -> tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]:
    a = np.asarray(m, dtype=float)
    return (_v3(a[0]), _v3(a[1]), _v3(a[2]))
