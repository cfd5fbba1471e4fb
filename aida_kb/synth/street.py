"""Scenes of several buildings: a street, a terrace of touching houses, a house half hidden.

Each preset places several `synth.buildings.house` models in one site frame (y up, ground
y = 0, the houses' fronts facing +z) and names every face with its house's role in the scene
object: ``houses[K].body.front`` (``houses`` is this module's own name for the scene's
members, as kb/street.kb names them; truth.json's ``object`` is ``Street``). Every house's
faces are in truth.json, hidden or not — a party wall of a terrace is one plane of two houses,
in the truth twice, once per house — so that `aida_kb.interpret.scene.evaluate_scene` can
judge every house.

- ``street``: 2-5 free-standing houses in a row along x (``--set houses=N``, default 3), gaps
  of 3-5 m, roofs cycling gable, hip, flat, shed, sizes drawn from the seed.
- ``terrace``: 3 touching houses (``--set houses=N``, 2-5) sharing party walls: the same
  depth, their own widths, heights and gable pitches.
- ``occluded``: two houses, the back one set back and to the side so that the front one hides
  about half of its front wall in view 00.

The cameras stand on an arc in front of the row, far enough back for the whole row to fit
the image (``--set distance=M`` or ``distance_factor=F`` farther; ``angle=DEG`` view 00's
place on the arc); two views by default, the second from the other side of the row
(`view_angles`). `random_street(seed)` draws a randomised variant of the three presets
(`benchmarks/street.py --random SEEDS`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from aida_kb.errors import GeometryError
from aida_kb.synth import buildings as bld
from aida_kb.synth.randomised import RandomObject
from aida_kb.synth.scenes import (
    ROOF_CONCEPTS,
    SceneSpec,
    _float,
    _orbit,
    _rig_from,
    _sun,
)

SCENE_OBJECT = "Street"  # truth.json's object: the scene concept of kb/street.kb
MEMBERS = "houses"  # the role of the houses in it
ROOF_CYCLE = ("gable", "hip", "flat", "shed")
MIN_HOUSES, MAX_HOUSES = 2, 5
STREET_KEYS = {"houses", "distance", "gap", "angle", "distance_factor"}
# a house's share of the image width seen from view 00: the row's extent over this fraction
# of the field of view sets the camera's distance
FILL = 0.85
STREET_ANGLE_DEG = -25.0  # view 00 from the front left: the houses' left walls are seen
# view 00 of `occluded` from the front right: the front house hides the back one's left
OCCLUDED_ANGLE_DEG = 15.0
# A street preset has STREET_VIEWS views (`--views` more or fewer): the second from the other
# side of the row, turned SECOND_VIEW_DEG on the arc from view 00 towards it, so that every
# house shows both its side walls (one view shows one side: every back wall and hidden side
# was placed by the knowledge alone, none verified); further views VIEW_STEP_DEG apart beyond.
STREET_VIEWS = 2
SECOND_VIEW_DEG = 50.0
VIEW_STEP_DEG = 30.0  # between further views on the arc
CAMERA_HEIGHT_M = 9.0  # above the eaves of most houses: flat roofs are seen from above
# a street is seen from 40-80 m: a vehicle's wide stereo rig gives 15-30 px of disparity there
BASELINE_M = 1.5
# a row of houses needs more pixels than one house: each house is about 300 px wide in
# view 00 (the single-house presets' 640 x 480 leave it 150 px, its planes 1 deg off)
IMAGE: dict[str, str | float] = {"image_width": 1280, "image_height": 960, "focal_px": 1600.0}


def _member(k: int) -> str:
    return f"{MEMBERS}[{k}]"


def _placed(model: bld.Model, k: int, offset: np.ndarray, material: str) -> list[bld.Solid]:
    """The house's solids moved by `offset` (site frame, metres), roles under houses[k]."""
    solids = []
    for s in model.solids:
        faces = []
        for f in s.faces:
            mat = material if f.material in ("mixed", "plaster", "brick") else f.material
            faces.append(
                replace(
                    f,
                    role=f"{_member(k)}.{f.role}",
                    polygon=f.polygon + offset,
                    material=mat,
                )
            )
        solids.append(bld.Solid(f"{_member(k)}.{s.name}", tuple(faces)))
    return solids


def _count(p: Mapping[str, str | float], default: int) -> int:
    n = _float(p, "houses", default)
    if n != int(n) or not MIN_HOUSES <= n <= MAX_HOUSES:
        raise GeometryError(
            f"--set houses={p.get('houses')}: a whole number in [{MIN_HOUSES}, {MAX_HOUSES}]"
        )
    return int(n)


def _layout(
    name: str, p: Mapping[str, str | float], rng: np.random.Generator
) -> list[tuple[bld.Model, np.ndarray, str]]:
    """The houses of a preset: model, offset of its centre (site frame, m), roof kind."""
    walls = ("plaster", "brick", "mixed")
    out: list[tuple[bld.Model, np.ndarray, str]] = []
    if name == "street":
        n = _count(p, 3)
        x = 0.0
        for k in range(n):
            roof = ROOF_CYCLE[k % len(ROOF_CYCLE)]
            width = float(rng.uniform(9.0, 12.0))
            depth = float(rng.uniform(7.5, 9.5))
            height = float(rng.uniform(6.0, 8.5))
            pitch = float(rng.uniform(12.0, 18.0) if roof == "shed" else rng.uniform(30.0, 40.0))
            floors = max(1, round(height / 3.0))
            model = bld.house(width, depth, height, roof, pitch, walls[k % 3], "tiles", floors)
            if k:
                x += width / 2 + float(rng.uniform(5.0, 7.0))
            out.append((model, np.array([x, 0.0, float(rng.uniform(-1.0, 1.0))]), roof))
            x += width / 2
    elif name == "terrace":
        n = _count(p, 3)
        depth = float(rng.uniform(8.0, 9.5))
        x = 0.0
        for k in range(n):
            width = float(rng.uniform(8.0, 11.0))
            height = float(rng.uniform(6.0, 7.5))
            pitch = float(rng.uniform(30.0, 40.0))
            floors = max(1, round(height / 3.0))
            model = bld.house(width, depth, height, "gable", pitch, walls[k % 3], "tiles", floors)
            x += width / 2
            out.append((model, np.array([x, 0.0, 0.0]), "gable"))
            x += width / 2
    else:  # occluded
        front = bld.house(10.0, 8.0, 6.5, "gable", 35.0, "plaster", "tiles", 2)
        back = bld.house(12.0, 9.0, 8.0, "hip", 32.0, "brick", "tiles", 3)
        out.append((front, np.array([0.0, 0.0, 0.0]), "gable"))
        out.append((back, np.array([-7.0, 0.0, -14.0]), "hip"))
    # centre the row on x = 0
    xs = [float(off[0]) for _, off, _ in out]
    mid = (min(xs) + max(xs)) / 2
    return [(m, off - np.array([mid, 0.0, 0.0]), r) for m, off, r in out]


def street_model(
    name: str, p: Mapping[str, str | float], rng: np.random.Generator
) -> tuple[bld.Model, dict[str, str]]:
    """The houses of a preset in one model (site frame, roles under ``houses[K]``) and the
    roof each must be taken for (role path -> concept), sizes drawn from `rng`."""
    layout = _layout(name, p, rng)
    solids: list[bld.Solid] = []
    concepts: dict[str, str] = {}
    params: dict[str, float | str | bool] = {"houses": float(len(layout))}
    for k, (model, offset, roof) in enumerate(layout):
        solids += _placed(model, k, offset, ("plaster", "brick", "mixed")[k % 3])
        concepts[f"{_member(k)}.body.roof"] = ROOF_CONCEPTS[roof]
        params[f"{_member(k)}.roof"] = roof
        for key in ("width", "depth", "height", "pitch_deg"):
            params[f"{_member(k)}.{key}"] = float(model.parameters[key])
        params[f"{_member(k)}.x"] = float(offset[0])
        params[f"{_member(k)}.z"] = float(offset[2])
    return bld.Model(SCENE_OBJECT, tuple(solids), params), concepts


def street_spec(
    name: str, p: Mapping[str, str | float], *, seed: int = 0, views: int | None = None
) -> SceneSpec:
    """The scene specification of a preset of `STREET_PRESETS` (GeometryError: bad key/value)."""
    unknown = set(p) - STREET_KEYS - {"image_width", "image_height", "focal_px", "baseline"}
    unknown -= {"k1", "noise_sigma"}
    if unknown:
        raise GeometryError(f"--set: unknown key(s) {', '.join(sorted(unknown))} for {name}")
    if name == "occluded" and "houses" in p:
        raise GeometryError("--set houses: the occluded preset has two houses")
    model, concepts = street_model(name, p, np.random.default_rng(seed + 1901))
    pts = np.concatenate([f.polygon for f in model.faces])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre = (lo + hi) / 2
    rig = _rig_from({**IMAGE, **p}, BASELINE_M)
    fov = 2 * math.atan(rig.image_size[0] / 2 / float(rig.K1[0, 0]))
    extent = float(hi[0] - lo[0])
    fit = extent / 2 / math.tan(FILL * fov / 2) + float(hi[2])
    dist = _float(p, "distance", max(fit, 25.0)) * _float(p, "distance_factor", 1.0)
    first = _float(p, "angle", OCCLUDED_ANGLE_DEG if name == "occluded" else STREET_ANGLE_DEG)
    angles = view_angles(first, views or STREET_VIEWS)
    target = np.array([centre[0], 0.45 * float(hi[1]), centre[2]])
    poses = _orbit(target, dist, CAMERA_HEIGHT_M, angles)
    return SceneSpec(
        name,
        model,
        rig,
        poses,
        _sun(-40.0, 40.0),
        seed=seed,
        noise_sigma=_float(p, "noise_sigma", 1.8),
        truth_concepts=concepts,
    )


def view_angles(first_deg: float, views: int) -> list[float]:
    """The views' places on the arc, degrees (0: straight in front of the row): view 00 at
    `first_deg`, the second SECOND_VIEW_DEG from it towards the other side of the row (a view
    straight in front turns right), each further one VIEW_STEP_DEG beyond."""
    towards = -1.0 if first_deg > 0 else 1.0
    return [first_deg] + [
        first_deg + towards * (SECOND_VIEW_DEG + VIEW_STEP_DEG * (k - 1)) for k in range(1, views)
    ]


# randomised street variants (`random_street`): view 00's angle within this of the preset's,
# the camera this much farther (a factor) and the image noise in this range (grey levels)
RANDOM_ANGLE_DEG = 10.0
RANDOM_DISTANCE = (1.0, 1.25)
RANDOM_NOISE = (1.0, 2.5)


def random_street(seed: int) -> tuple[str, dict[str, str]]:
    """A randomised street variant: (preset name, its parameters) drawn from `seed` — a street
    of 2-5 houses, a terrace of 2-5 or the occluded pair, view 00 turned by up to
    `RANDOM_ANGLE_DEG` from the preset's, farther by a factor in `RANDOM_DISTANCE`, the
    image noise in `RANDOM_NOISE`; the houses' sizes and pitches come from `preset(name,
    seed=seed)` itself. The same seed always gives the same variant."""
    rng = np.random.default_rng(seed + 7717)
    name = ("street", "terrace", "occluded")[int(rng.integers(0, 3))]
    params: dict[str, str] = {}
    if name != "occluded":
        params["houses"] = str(int(rng.integers(MIN_HOUSES, MAX_HOUSES + 1)))
    base = OCCLUDED_ANGLE_DEG if name == "occluded" else STREET_ANGLE_DEG
    params["angle"] = f"{base + float(rng.uniform(-RANDOM_ANGLE_DEG, RANDOM_ANGLE_DEG)):.2f}"
    params["distance_factor"] = f"{float(rng.uniform(*RANDOM_DISTANCE)):.3f}"
    params["noise_sigma"] = f"{float(rng.uniform(*RANDOM_NOISE)):.2f}"
    return name, params


def random_street_spec(
    seed: int,
    *,
    views: int | None = None,
    max_width: int | None = None,
    labels: bool | None = None,
) -> SceneSpec:
    """The randomised street variant of `seed` (`random_street`) as a scene specification: what
    a robustness benchmark renders, reconstructs against kb/street.kb (goal ``Street``) and
    judges house by house (`aida_kb.interpret.scene.evaluate_scene`, members ``houses``).
    views : the number of views (default: the presets' STREET_VIEWS). max_width : the image
    narrower than the presets' (pixels; height and focal length scaled alike, the view's
    field unchanged). labels : whether labels.png is written (None: as the presets, always;
    `random_street_labels(seed)` draws it)."""
    from aida_kb.synth.scenes import preset

    name, params = random_street(seed)
    width = float(IMAGE["image_width"])
    if max_width is not None and max_width < width:
        scale = max_width / width
        params = {
            **params,
            "image_width": str(int(max_width)),
            "image_height": str(round(float(IMAGE["image_height"]) * scale)),
            "focal_px": f"{float(IMAGE['focal_px']) * scale:.3f}",
        }
    spec = preset(name, seed=seed, views=views, params=params)
    return spec if labels is None else replace(spec, write_labels=labels)


def street_object(rng: np.random.Generator) -> RandomObject:
    """A street, terrace or occluded pair drawn from `rng` as a kind of
    `aida_kb.synth.randomised` (``register_kind("street", weight, street_object)``): the
    houses' model, the roof each must be taken for, the row's extent. Its truth's object is
    ``Street`` (kb/street.kb): a benchmark interpreting it with kb/buildings.kb's ``House``
    would judge one house of several."""
    name = ("street", "terrace", "occluded")[int(rng.integers(0, 3))]
    p: dict[str, str | float] = {}
    if name != "occluded":
        p["houses"] = float(rng.integers(MIN_HOUSES, MAX_HOUSES + 1))
    model, concepts = street_model(name, p, rng)
    pts = np.concatenate([f.polygon for f in model.faces])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return RandomObject(
        model, concepts, float(np.linalg.norm(hi - lo)), 0.45 * float(hi[1]), extra={"preset": name}
    )


# a randomised street variant writes labels.png half the time (as the single-object random
# scenes do, `aida_kb.synth.randomised`): segmentation from the images alone is reported apart
STREET_LABELS_SHARE = 0.5


def random_street_labels(seed: int) -> bool:
    """Whether the randomised street variant of `seed` writes labels.png: drawn from a
    generator of its own, so that `random_street`'s draws (the preset, houses, angle, distance
    and noise of every seed) stay as they were."""
    return bool(np.random.default_rng(seed + 7719).random() < STREET_LABELS_SHARE)
