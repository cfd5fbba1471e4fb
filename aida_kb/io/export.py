"""Standard 3-D formats of a reconstructed model: OBJ + MTL, binary glTF, CityJSON 2.0, PLY.

The model lives in the frame of the left camera of view 00 (OpenCV axes: x right, y down,
z forward). Viewers expect the vertical on an axis, so every export is in an *export frame*
derived from the model's estimated vertical (``ReconstructedModel.up``; without it, the
camera's -y axis):

* ``y-up`` (OBJ, glTF, PLY): +y up, -z the horizontal direction view 00 looks in (a glTF
  camera looking along -z sees what view 00 saw), +x = y x z (right-handed);
* ``z-up`` (CityJSON): +z up, +y the horizontal direction view 00 looks in, +x = y x z.

The origin is the point below the centre of the model's vertices at the height of its lowest
vertex (the model stands on the plane up = 0). Each file records the 4x4 transform
``T_export_world`` (export = R·world + t). A texture (`Atlas`, from `aida_kb.texture`) is
optional: without it the faces get the neutral material.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from aida_kb.errors import FormatError
from aida_kb.io.atomic import write_bytes_atomic, write_text_atomic
from aida_kb.io.model import ReconstructedModel

FloatArray = npt.NDArray[np.float64]
Axes = Literal["y-up", "z-up"]

EXPORT_FORMATS = ("obj", "glb", "cityjson", "ply")
"""The formats of `aida-kb export --format`."""

# the neutral colour of a face no view sees (linear RGB 0..1): mid grey, clearly untextured
UNSEEN_RGB = (0.6, 0.6, 0.6)
# CityJSON stores integer vertices times a scale: millimetres are finer than any model here
CITYJSON_SCALE_M = 0.001
# a face whose normal is within this angle of up is a roof (steeper than this is a wall):
# roofs pitch up to ~60 degrees, walls lean a few degrees at most
ROOF_MAX_SLOPE_DEG = 70.0
# a face whose normal is within this angle of down is a floor (ground or floor of an oriel)
FLOOR_MAX_SLOPE_DEG = 30.0
# a downward face lower than this above the model's lowest vertex stands on the ground: an
# oriel's bottom is a storey up, a floor off level by half a degree over 20 m spans 0.2 m
GROUND_TOLERANCE_M = 0.5


@dataclass(frozen=True)
class ExportFrame:
    """A rigid transform from the model's world frame to an export frame (metres)."""

    axes: Axes
    R_export_world: FloatArray  # (3, 3), rows: the export axes in world coordinates
    t_export_world: FloatArray  # (3,), metres
    metric: bool = True  # False: the model is known up to scale only (units unknown)

    @property
    def units(self) -> str:
        """The unit of the exported coordinates, as file headers say it."""
        return "metres" if self.metric else "unknown (up to scale: the scene's scale is unknown)"

    def apply(self, points_world: npt.ArrayLike) -> FloatArray:
        """Points (N, 3), world frame -> (N, 3), export frame."""
        p = np.asarray(points_world, dtype=np.float64).reshape(-1, 3)
        out: FloatArray = p @ self.R_export_world.T + self.t_export_world
        return out

    def rotate(self, vectors_world: npt.ArrayLike) -> FloatArray:
        """Directions (N, 3), world frame -> (N, 3), export frame."""
        v = np.asarray(vectors_world, dtype=np.float64).reshape(-1, 3)
        out: FloatArray = v @ self.R_export_world.T
        return out

    @property
    def matrix(self) -> list[list[float]]:
        """T_export_world as a 4x4 row-major list (export = T · [world; 1])."""
        T = np.eye(4)
        T[:3, :3] = self.R_export_world
        T[:3, 3] = self.t_export_world
        return [[float(x) for x in row] for row in T]

    def describe(self) -> str:
        """One line for file headers: the axes and the transform from the world frame."""
        rows = "; ".join(" ".join(f"{x:.9g}" for x in row) for row in self.matrix)
        return (
            f"frame {self.axes} (up = the estimated vertical), units {self.units}; "
            f"T_export_world (export = T·world, world = left camera of view 00, "
            f"OpenCV axes) rows: {rows}"
        )


def model_up(model: ReconstructedModel) -> FloatArray:
    """The model's up direction (3,), unit, world frame: its estimate, else the camera's -y."""
    up = np.array(model.up if model.up is not None else (0.0, -1.0, 0.0), dtype=np.float64)
    out: FloatArray = up / np.linalg.norm(up)
    return out


def export_frame(model: ReconstructedModel, axes: Axes = "y-up") -> ExportFrame:
    """The export frame of `model` (module docstring): vertical from `model.up`, origin below."""
    up = model_up(model)
    look = np.array([0.0, 0.0, 1.0])  # view 00's optical axis in the world frame
    h = look - float(look @ up) * up
    if float(np.linalg.norm(h)) < 1e-6:  # looking straight down: the camera's y axis instead
        h = np.array([0.0, 1.0, 0.0]) - up[1] * up
    h /= np.linalg.norm(h)
    if axes == "y-up":
        y, z = up, -h
        x = np.cross(y, z)
    else:
        y, z = h, up
        x = np.cross(y, z)
    R = np.stack([x, y, z])
    points = np.array([v for p in model.parts for v in p.polygon], dtype=np.float64)
    centre = points.mean(axis=0)
    lowest = float(np.min(points @ up))
    origin = centre - (float(centre @ up) - lowest) * up
    return ExportFrame(axes, R, -R @ origin, metric=model.units == "m")


@dataclass(frozen=True)
class Georeference:
    """Where the z-up export frame lies on the map (CityJSON only; given by the user).

    origin : (easting, northing, height) of the export frame's origin, metres, in `epsg`'s
    coordinates. heading_deg : the compass bearing (clockwise from north) of the export
    frame's +y axis, the horizontal direction view 00 looks in. epsg : the code of the
    coordinate reference system, or None.
    """

    origin: tuple[float, float, float]
    heading_deg: float = 0.0
    epsg: int | None = None

    def apply(self, frame: ExportFrame) -> ExportFrame:
        """`frame` (z up) followed by the turn to the map and the shift to the origin."""
        if frame.axes != "z-up":
            raise FormatError("a georeference applies to the z-up (CityJSON) frame only")
        if not frame.metric:
            raise FormatError(
                "a model known up to scale only (units: unknown) cannot be put on the map"
            )
        values = (*self.origin, self.heading_deg)
        if not all(math.isfinite(v) and abs(v) <= 1e9 for v in values):
            raise FormatError(f"georeference {values}: not finite numbers")
        h = math.radians(self.heading_deg)
        # local +y -> (sin h, cos h) in (east, north); local +x -> (cos h, -sin h)
        turn = np.array(
            [[math.cos(h), math.sin(h), 0.0], [-math.sin(h), math.cos(h), 0.0], [0.0, 0.0, 1.0]]
        )
        return ExportFrame(
            frame.axes,
            turn @ frame.R_export_world,
            turn @ frame.t_export_world + np.array(self.origin, dtype=np.float64),
        )


@dataclass(frozen=True)
class Atlas:
    """A texture atlas for a model's parts (built by `aida_kb.texture`).

    image : (H, W, 3) uint8, RGB. uv : per part (in the model's order) (K, 2) texture
    coordinates of its polygon's vertices, OBJ convention (0, 0 = bottom left of the image).
    seen : per part, whether any view saw it (an unseen part is drawn in the neutral material).
    views : per part, the ids of the cameras its texture came from (best first).
    """

    image: npt.NDArray[np.uint8]
    uv: tuple[FloatArray, ...]
    seen: tuple[bool, ...]
    views: tuple[tuple[str, ...], ...] = field(default=())

    def png(self) -> bytes:
        """The atlas image as PNG bytes."""
        import cv2

        ok, data = cv2.imencode(".png", self.image[:, :, ::-1])
        if not ok:  # pragma: no cover - cv2 encodes any uint8 image
            raise FormatError("the texture atlas could not be encoded as PNG")
        return bytes(data.tobytes())


def _check_atlas(model: ReconstructedModel, atlas: Atlas | None) -> None:
    if atlas is None:
        return
    if len(atlas.uv) != len(model.parts) or len(atlas.seen) != len(model.parts):
        raise FormatError(
            f"texture atlas has {len(atlas.uv)} faces, the model {len(model.parts)} parts"
        )
    for part, uv in zip(model.parts, atlas.uv, strict=True):
        if uv.shape != (len(part.polygon), 2):
            raise FormatError(f"texture atlas: part {part.role!r}: uv has shape {uv.shape}")


def triangulate(points_2d: FloatArray) -> list[tuple[int, int, int]]:
    """Ear-clipping triangulation of a simple counter-clockwise 2-D polygon (K, 2).

    Returns K-2 index triples, counter-clockwise in the plane (so a face's triangles keep its
    outward orientation). A degenerate polygon falls back to a fan.
    """
    n = len(points_2d)
    p = np.asarray(points_2d, dtype=np.float64)
    area = 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))
    order = list(range(n)) if area >= 0 else list(range(n))[::-1]

    def cross(a: int, b: int, c: int) -> float:
        return float(
            (p[b, 0] - p[a, 0]) * (p[c, 1] - p[a, 1]) - (p[b, 1] - p[a, 1]) * (p[c, 0] - p[a, 0])
        )

    def inside(q: int, a: int, b: int, c: int) -> bool:
        return cross(a, b, q) > 0 and cross(b, c, q) > 0 and cross(c, a, q) > 0

    out: list[tuple[int, int, int]] = []
    ring = order[:]
    guard = 0
    while len(ring) > 3 and guard < n * n:
        guard += 1
        for k in range(len(ring)):
            a, b, c = ring[k - 1], ring[k], ring[(k + 1) % len(ring)]
            if cross(a, b, c) <= 0:
                continue
            if any(inside(q, a, b, c) for q in ring if q not in (a, b, c)):
                continue
            out.append((a, b, c))
            ring.pop(k)
            break
        else:
            break
    if len(ring) == 3:
        out.append((ring[0], ring[1], ring[2]))
        return out
    return [(order[0], order[k], order[k + 1]) for k in range(1, n - 1)]


@dataclass(frozen=True)
class _Face:
    role: str
    points: FloatArray  # (K, 3) export frame
    normal: FloatArray  # (3,) export frame
    uv: FloatArray | None  # (K, 2) or None (unseen / untextured)


def _faces(model: ReconstructedModel, frame: ExportFrame, atlas: Atlas | None) -> list[_Face]:
    _check_atlas(model, atlas)
    out = []
    for k, part in enumerate(model.parts):
        uv = None
        if atlas is not None and atlas.seen[k]:
            uv = np.asarray(atlas.uv[k], dtype=np.float64)
        out.append(
            _Face(
                part.role,
                frame.apply(part.polygon),
                frame.rotate(part.normal)[0],
                uv,
            )
        )
    return out


# ---- OBJ --------------------------------------------------------------------------------------
def obj_files(
    model: ReconstructedModel, stem: str = "model", atlas: Atlas | None = None
) -> dict[str, bytes]:
    """OBJ, MTL (and the atlas PNG) of the model in the y-up frame: file name -> content.

    One group per part (named by its role), vertices welded across parts, one normal per
    face; textured faces use material ``atlas`` with texture coordinates, unseen ones
    ``unseen`` (neutral grey).
    """
    frame = export_frame(model, "y-up")
    faces = _faces(model, frame, atlas)
    vertices: list[tuple[float, float, float]] = []
    index: dict[tuple[int, int, int], int] = {}
    lines = [
        f"# aida-kb reconstructed model; units: {frame.units}",
        "# " + frame.describe(),
        f"mtllib {stem}.mtl",
    ]
    body: list[str] = []
    n_vt = 0
    for k, face in enumerate(faces):
        ids = []
        for v in face.points:
            key = (round(v[0] * 1e6), round(v[1] * 1e6), round(v[2] * 1e6))
            if key not in index:
                vertices.append((float(v[0]), float(v[1]), float(v[2])))
                index[key] = len(vertices)
            ids.append(index[key])
        nx, ny, nz = face.normal
        body.append(f"vn {nx:.9g} {ny:.9g} {nz:.9g}")
        body.append(f"g {face.role.replace(' ', '_')}")
        if face.uv is not None:
            body.extend(f"vt {u:.9g} {v:.9g}" for u, v in face.uv)
            body.append("usemtl atlas")
            corners = [f"{i}/{n_vt + j + 1}/{k + 1}" for j, i in enumerate(ids)]
            n_vt += len(ids)
        else:
            body.append("usemtl unseen")
            corners = [f"{i}//{k + 1}" for i in ids]
        body.append("f " + " ".join(corners))
    lines.extend(f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in vertices)
    lines.extend(body)
    grey = " ".join(f"{c:g}" for c in UNSEEN_RGB)
    mtl = [
        "# aida-kb materials",
        "newmtl unseen",
        f"Kd {grey}",
        "Ka 0 0 0",
        "illum 1",
    ]
    files: dict[str, bytes] = {}
    if atlas is not None and any(atlas.seen):
        mtl += ["", "newmtl atlas", "Kd 1 1 1", "Ka 0 0 0", "illum 1", f"map_Kd {stem}_atlas.png"]
        files[f"{stem}_atlas.png"] = atlas.png()
    files[f"{stem}.obj"] = ("\n".join(lines) + "\n").encode()
    files[f"{stem}.mtl"] = ("\n".join(mtl) + "\n").encode()
    return files


# ---- glTF -------------------------------------------------------------------------------------
def _triangles(faces: Sequence[_Face]) -> tuple[FloatArray, npt.NDArray[np.int64], FloatArray]:
    """Unwelded triangle soup of faces: vertices (V, 3), triangles (T, 3), uv (V, 2)."""
    verts: list[FloatArray] = []
    uvs: list[FloatArray] = []
    tris: list[tuple[int, int, int]] = []
    base = 0
    for face in faces:
        u = np.cross(face.normal, [1.0, 0.0, 0.0])
        if np.linalg.norm(u) < 0.1:
            u = np.cross(face.normal, [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        v = np.cross(face.normal, u)
        flat = np.stack([face.points @ u, face.points @ v], axis=1)
        tris += [(base + a, base + b, base + c) for a, b, c in triangulate(flat)]
        verts.append(face.points)
        uvs.append(face.uv if face.uv is not None else np.zeros((len(face.points), 2)))
        base += len(face.points)
    return (
        np.concatenate(verts) if verts else np.zeros((0, 3)),
        np.array(tris, dtype=np.int64).reshape(-1, 3),
        np.concatenate(uvs) if uvs else np.zeros((0, 2)),
    )


def glb_bytes(model: ReconstructedModel, atlas: Atlas | None = None) -> bytes:
    """The model as binary glTF 2.0 (y-up frame, metres), the atlas embedded (trimesh).

    Two meshes: ``textured`` (the faces a view saw, with texture coordinates) and ``unseen``
    (neutral grey). The asset's ``extras`` hold the frame description and T_export_world.
    """
    import trimesh
    from PIL import Image

    frame = export_frame(model, "y-up")
    faces = _faces(model, frame, atlas)
    scene = trimesh.Scene()
    seen = [f for f in faces if f.uv is not None]
    unseen = [f for f in faces if f.uv is None]
    if seen and atlas is not None:
        v, t, uv = _triangles(seen)
        material = trimesh.visual.material.PBRMaterial(
            name="atlas",
            baseColorTexture=Image.fromarray(atlas.image),
            metallicFactor=0.0,
            roughnessFactor=1.0,
        )
        visual = trimesh.visual.TextureVisuals(uv=uv, material=material)
        mesh = trimesh.Trimesh(v, t, visual=visual, process=False)
        mesh.metadata["roles"] = [f.role for f in seen]
        scene.add_geometry(mesh, geom_name="textured")
    if unseen:
        v, t, _ = _triangles(unseen)
        grey = [*(round(255 * c) for c in UNSEEN_RGB), 255]
        material = trimesh.visual.material.PBRMaterial(
            name="unseen", baseColorFactor=grey, metallicFactor=0.0, roughnessFactor=1.0
        )
        mesh = trimesh.Trimesh(
            v, t, visual=trimesh.visual.TextureVisuals(material=material), process=False
        )
        scene.add_geometry(mesh, geom_name="unseen")
    extras = {"aida_kb_frame": frame.describe(), "T_export_world": frame.matrix}

    def annotate(tree: dict[str, Any]) -> None:
        tree.setdefault("asset", {})["extras"] = extras

    data = trimesh.exchange.gltf.export_glb(
        scene, include_normals=True, tree_postprocessor=annotate
    )
    return bytes(data)


# ---- PLY --------------------------------------------------------------------------------------
def ply_bytes(
    points_world: npt.ArrayLike,
    colours_rgb: npt.ArrayLike,
    model: ReconstructedModel,
) -> bytes:
    """Binary PLY of coloured points (N, 3) world frame, metres, in the model's y-up frame.

    colours_rgb : (N, 3) uint8. The header's comment records T_export_world.
    """
    import trimesh

    frame = export_frame(model, "y-up")
    pts = frame.apply(points_world)
    rgb = np.asarray(colours_rgb, dtype=np.uint8).reshape(-1, 3)
    if len(rgb) != len(pts):
        raise FormatError(f"PLY: {len(pts)} points but {len(rgb)} colours")
    cloud = trimesh.PointCloud(pts, colors=np.hstack([rgb, np.full((len(rgb), 1), 255, np.uint8)]))
    data = cloud.export(file_type="ply")
    assert isinstance(data, bytes)
    # one comment line after the first: PLY readers skip comments
    head, rest = data.split(b"\n", 1)
    comment = b"comment aida-kb " + frame.describe().encode("ascii", "replace") + b"\n"
    return head + b"\n" + comment + rest


# ---- CityJSON ---------------------------------------------------------------------------------
def solids(model: ReconstructedModel) -> list[list[int]]:
    """The parts grouped into solids: faces connected by shared edges (welded vertices).

    Returns part indices into ``model.parts``, one list per solid (a house body, each wing).
    """
    keys = [
        [(round(v[0] * 1e6), round(v[1] * 1e6), round(v[2] * 1e6)) for v in p.polygon]
        for p in model.parts
    ]
    owner: dict[tuple[tuple[int, int, int], tuple[int, int, int]], int] = {}
    parent = list(range(len(model.parts)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for k, ring in enumerate(keys):
        for a, b in zip(ring, ring[1:] + ring[:1], strict=True):
            edge = (min(a, b), max(a, b))
            if edge in owner:
                parent[find(k)] = find(owner[edge])
            else:
                owner[edge] = k
    groups: dict[int, list[int]] = {}
    for k in range(len(model.parts)):
        groups.setdefault(find(k), []).append(k)
    return sorted(groups.values(), key=lambda g: g[0])


def surface_class(normal_up: float, height_m: float) -> str:
    """CityJSON semantic class of a face from its normal and height (export frame, z up).

    normal_up : the z component of the face's outward unit normal. height_m : the face's
    lowest point above the model's lowest vertex. Roofs face up (slope within
    ROOF_MAX_SLOPE_DEG), floors face down: on the ground a GroundSurface, higher up (an
    oriel's bottom) an OuterFloorSurface; everything else is a WallSurface.
    """
    slope = math.degrees(math.acos(max(-1.0, min(1.0, normal_up))))
    if slope <= ROOF_MAX_SLOPE_DEG:
        return "RoofSurface"
    if slope >= 180.0 - FLOOR_MAX_SLOPE_DEG:
        return "GroundSurface" if height_m <= GROUND_TOLERANCE_M else "OuterFloorSurface"
    return "WallSurface"


def _common_role(roles: Sequence[str]) -> str:
    """The longest common prefix of role paths, by path components ('body.wings[0]')."""
    split = [r.split(".") for r in roles]
    prefix: list[str] = []
    for parts in zip(*split, strict=False):
        if len(set(parts)) != 1:
            break
        prefix.append(parts[0])
    return ".".join(prefix)


def _buildings(
    model: ReconstructedModel, identifier: str
) -> list[tuple[str, list[list[int]], dict[str, str]]]:
    """The model's buildings: (id, solids (part indices each, `solids`), attributes).

    One object: one building `identifier` of all solids. A scene of several objects
    (`ReconstructedModel.objects`): one building per object, ``IDENTIFIER-K``, of the solids
    under its role, with its role and verdict as attributes.
    """
    if not model.objects:
        return [(identifier, solids(model), {})]
    out = []
    for k, obj in enumerate(model.objects):
        # touching objects share edges (a party wall): each object's solids on their own
        index = [i for i, p in enumerate(model.parts) if p.role.startswith(obj.role + ".")]
        own = model.model_copy(update={"parts": [model.parts[i] for i in index]})
        mine = [[index[i] for i in g] for g in solids(own)]
        if mine:
            extra = {"aida-kb:object": obj.role, "aida-kb:verdict": obj.verdict}
            out.append((f"{identifier}-{k}", mine, extra))
    return out


def cityjson_document(
    model: ReconstructedModel,
    atlas: Atlas | None = None,
    texture_file: str = "model_atlas.png",
    *,
    identifier: str = "building",
    georeference: Georeference | None = None,
) -> dict[str, Any]:
    """The model as a CityJSON 2.0 document (z-up frame, metres; on the map with a
    `georeference`, whose EPSG code becomes the metadata's referenceSystem).

    The solid containing the model's first part (the structure the interpreter verified
    first) is the ``Building``'s LoD2 ``Solid``; every other solid a ``BuildingPart``. Each
    face is one semantic surface (`surface_class`, with the part's role and concept as
    attributes and whether a view saw it). With an atlas: the texture as appearance (theme
    ``texture``) on the seen faces, the material ``unseen`` on the others.
    """
    _check_atlas(model, atlas)
    frame = export_frame(model, "z-up")
    if georeference is not None:
        frame = georeference.apply(frame)
    faces = _faces(model, frame, atlas)
    points = np.concatenate([f.points for f in faces])
    lowest = float(points[:, 2].min())
    translate = np.floor(points.min(axis=0) / CITYJSON_SCALE_M) * CITYJSON_SCALE_M
    vertices: list[list[int]] = []
    index: dict[tuple[int, int, int], int] = {}
    uv_vertices: list[list[float]] = []
    textured = atlas is not None and any(atlas.seen)

    def vid(p: FloatArray) -> int:
        q = np.round((p - translate) / CITYJSON_SCALE_M).astype(np.int64)
        key = (int(q[0]), int(q[1]), int(q[2]))
        if key not in index:
            index[key] = len(vertices)
            vertices.append(list(key))
        return index[key]

    objects: dict[str, Any] = {}
    for building, solids, extra in _buildings(model, identifier):
        children = [f"{building}-part-{i}" for i in range(1, len(solids))]
        for s, group in enumerate(solids):
            boundaries = []
            surfaces = []
            tex_values: list[list[list[int | None]]] = []
            mat_values: list[int | None] = []
            for k in group:
                face = faces[k]
                ring = [vid(p) for p in face.points]
                # a ring must not repeat a vertex (welded neighbours closer than 1 mm)
                ring = [v for i, v in enumerate(ring) if v != ring[i - 1]]
                boundaries.append([ring])
                part = model.parts[k]
                seen = atlas is not None and atlas.seen[k]
                surfaces.append(
                    {
                        "type": surface_class(
                            float(face.normal[2]), float(face.points[:, 2].min()) - lowest
                        ),
                        "role": part.role,
                        "concept": part.concept,
                        "seen": bool(seen),
                    }
                )
                if textured:
                    if face.uv is not None and len(ring) == len(face.uv):
                        start = len(uv_vertices)
                        uv_vertices += [[float(u), float(v)] for u, v in face.uv]
                        tex_values.append([[0, *range(start, start + len(ring))]])
                        mat_values.append(None)
                    else:
                        tex_values.append([[None]])
                        mat_values.append(0)
                else:
                    mat_values.append(0)
            geometry: dict[str, Any] = {
                "type": "Solid",
                "lod": "2",
                "boundaries": [boundaries],
                "semantics": {"surfaces": surfaces, "values": [list(range(len(group)))]},
                "material": {"neutral": {"values": [mat_values]}},
            }
            if textured:
                geometry["texture"] = {"texture": {"values": [tex_values]}}
            role = _common_role([model.parts[k].role for k in group])
            if s == 0:
                objects[building] = {
                    "type": "Building",
                    "attributes": {"role": role, **extra},
                    "geometry": [geometry],
                    **({"children": children} if children else {}),
                }
            else:
                objects[children[s - 1]] = {
                    "type": "BuildingPart",
                    "attributes": {"role": role},
                    "parents": [building],
                    "geometry": [geometry],
                }
    appearance: dict[str, Any] = {
        "materials": [
            {"name": "unseen", "diffuseColor": list(UNSEEN_RGB), "isSmooth": False},
        ]
    }
    if textured:
        appearance["textures"] = [{"type": "PNG", "image": texture_file}]
        appearance["vertices-texture"] = uv_vertices
    extent = [*points.min(axis=0).tolist(), *points.max(axis=0).tolist()]
    metadata: dict[str, Any] = {
        "title": "aida-kb reconstructed model; " + frame.describe(),
        "geographicalExtent": [float(x) for x in extent],
    }
    if georeference is not None and georeference.epsg is not None:
        metadata["referenceSystem"] = (
            f"https://www.opengis.net/def/crs/EPSG/0/{int(georeference.epsg)}"
        )
    return {
        "type": "CityJSON",
        "version": "2.0",
        "transform": {
            "scale": [CITYJSON_SCALE_M] * 3,
            "translate": [float(x) for x in translate],
        },
        "metadata": metadata,
        "CityObjects": objects,
        "vertices": vertices,
        "appearance": appearance,
        "+aida-kb": {"T_export_world": frame.matrix, "frame": frame.describe()},
    }


def cityjson_bytes(
    model: ReconstructedModel,
    atlas: Atlas | None = None,
    texture_file: str = "model_atlas.png",
    georeference: Georeference | None = None,
) -> bytes:
    """`cityjson_document` as UTF-8 JSON text."""
    doc = cityjson_document(model, atlas, texture_file, georeference=georeference)
    return (json.dumps(doc, separators=(",", ":")) + "\n").encode()


# ---- writing ----------------------------------------------------------------------------------
def export_files(
    model: ReconstructedModel,
    fmt: str,
    *,
    stem: str = "model",
    atlas: Atlas | None = None,
    points: tuple[npt.ArrayLike, npt.ArrayLike] | None = None,
    georeference: Georeference | None = None,
) -> dict[str, bytes]:
    """The files of one export format: file name -> content (not written yet).

    fmt : one of EXPORT_FORMATS. points : (points (N, 3) world, colours (N, 3) uint8 RGB),
    needed for ``ply``. georeference : places the CityJSON on the map.
    """
    if fmt == "obj":
        return obj_files(model, stem, atlas)
    if fmt == "glb":
        return {f"{stem}.glb": glb_bytes(model, atlas)}
    if fmt == "cityjson":
        files = {
            f"{stem}.city.json": cityjson_bytes(model, atlas, f"{stem}_atlas.png", georeference)
        }
        if atlas is not None and any(atlas.seen):
            files[f"{stem}_atlas.png"] = atlas.png()
        return files
    if fmt == "ply":
        if points is None:
            raise FormatError("PLY export: no stereo points (give the scene directory)")
        return {f"{stem}_points.ply": ply_bytes(points[0], points[1], model)}
    raise FormatError(f"unknown export format {fmt!r}; choose one of {', '.join(EXPORT_FORMATS)}")


def write_files(directory: str | os.PathLike[str], files: dict[str, bytes]) -> list[Path]:
    """Write each file atomically into `directory`; the paths written."""
    out = []
    for name, data in files.items():
        path = Path(directory) / name
        if name.endswith((".obj", ".mtl", ".json")):
            write_text_atomic(path, data.decode())
        else:
            write_bytes_atomic(path, data)
        out.append(path)
    return out
