"""Building generators: closed planar polyhedra whose faces carry role paths and concepts.

Generators work in a *site frame*: metres, x to the right as seen from the house's front,
y up, z out of the front wall (towards the viewer), ground at y = 0. `to_world` maps a model
into the world frame (the left camera of view 00, OpenCV axes) once the cameras are placed.

Every face is a `Face`: role path (DOMAIN.md: ``body.front``, ``body.roof.back``,
``body.wings[0].left`` ...), concept (Wall, RoofPlane, Floor, ...), material name, and its
polygon ordered counter-clockwise seen from outside, so that the Newell normal points out of
the solid. A model is a union of closed solids (`Solid`); faces of one solid that lie inside
another are simply never visible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from aida_kb.errors import GeometryError

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Face:
    """One planar face: role path, concept, material and polygon (N, 3) in metres."""

    role: str
    concept: str
    material: str
    polygon: FloatArray
    # texture parameters: e.g. window grid for walls
    params: dict[str, float] = field(default_factory=dict)

    @property
    def normal(self) -> FloatArray:
        """Unit outward normal (Newell's method over the polygon)."""
        return polygon_normal(self.polygon)

    @property
    def d(self) -> float:
        """Plane offset: normal·x = d for every x on the face."""
        return float(self.normal @ self.polygon.mean(axis=0))


@dataclass(frozen=True)
class Solid:
    """A closed convex polyhedron given by its faces (used to orient faces and test closure)."""

    name: str
    faces: tuple[Face, ...]


@dataclass(frozen=True)
class Model:
    """A scene object: its concept (House, ReferenceObject) and its solids, in one frame."""

    concept: str
    solids: tuple[Solid, ...]
    parameters: dict[str, float | str | bool] = field(default_factory=dict)

    @property
    def faces(self) -> tuple[Face, ...]:
        """All faces of all solids, in a fixed order."""
        return tuple(f for s in self.solids for f in s.faces)

    def face(self, role: str) -> Face:
        """The face with role path `role` (KeyError if none)."""
        for f in self.faces:
            if f.role == role:
                return f
        raise KeyError(role)

    def transformed(self, R: FloatArray, t: FloatArray) -> Model:
        """The model with every vertex mapped x -> R·x + t (R a rotation)."""
        solids = tuple(
            Solid(
                s.name,
                tuple(replace(f, polygon=f.polygon @ R.T + t) for f in s.faces),
            )
            for s in self.solids
        )
        return Model(self.concept, solids, dict(self.parameters))


def polygon_normal(polygon: FloatArray) -> FloatArray:
    """Unit normal of a planar polygon (N, 3) by Newell's method; CCW order gives the normal."""
    p = np.asarray(polygon, dtype=np.float64)
    q = np.roll(p, -1, axis=0)
    n = np.array(
        [
            np.sum((p[:, 1] - q[:, 1]) * (p[:, 2] + q[:, 2])),
            np.sum((p[:, 2] - q[:, 2]) * (p[:, 0] + q[:, 0])),
            np.sum((p[:, 0] - q[:, 0]) * (p[:, 1] + q[:, 1])),
        ]
    )
    norm = float(np.linalg.norm(n))
    if norm < 1e-12:
        raise GeometryError("degenerate polygon: zero area")
    return n / norm


def _oriented(polygon: FloatArray, inside: FloatArray) -> FloatArray:
    """`polygon` ordered so that its normal points away from the interior point `inside`."""
    poly = np.asarray(polygon, dtype=np.float64)
    n = polygon_normal(poly)
    if float(n @ (poly.mean(axis=0) - inside)) < 0:
        poly = poly[::-1].copy()
    return poly


def _solid(name: str, inside: FloatArray, faces: list[tuple[str, str, str, FloatArray]]) -> Solid:
    out = []
    for role, concept, material, poly in faces:
        out.append(Face(role, concept, material, _oriented(np.asarray(poly, float), inside)))
    return Solid(name, tuple(out))


def _walls_and_roof(
    prefix: str,
    width: float,
    depth: float,
    height: float,
    roof: str,
    pitch_deg: float,
    wall_material: str,
    roof_material: str,
    pitch_back_deg: float | None = None,
) -> tuple[list[tuple[str, str, str, FloatArray]], FloatArray]:
    """Faces of a box-shaped house body centred on the origin (site frame), and an inside point.

    A gable roof whose back half has another pitch (`pitch_back_deg`) is asymmetric: its ridge
    moves towards the steeper side so that both halves meet.
    """
    if min(width, depth, height) <= 0:
        raise GeometryError(f"{prefix}: width, depth and height must be positive")
    w, d, h = width / 2, depth / 2, height
    tan = math.tan(math.radians(pitch_deg))
    F = [
        np.array([-w, 0, d]),  # 0 front-left
        np.array([w, 0, d]),  # 1 front-right
        np.array([w, 0, -d]),  # 2 back-right
        np.array([-w, 0, -d]),  # 3 back-left
    ]
    up = np.array([0.0, 1.0, 0.0])

    def top(p: FloatArray, y: float) -> FloatArray:
        return np.array([p[0], y, p[2]])

    faces: list[tuple[str, str, str, FloatArray]] = []
    faces.append((f"{prefix}.floor", "Floor", "floor", np.array(F)))
    wall = wall_material
    if roof == "gable":
        back_deg = pitch_deg if pitch_back_deg is None else pitch_back_deg
        if not (0 < pitch_deg < 80 and 0 < back_deg < 80):
            raise GeometryError(f"{prefix}: gable roof pitch must be in (0, 80) degrees")
        tan_b = math.tan(math.radians(back_deg))
        # front half rises from z = d, back half from z = -d; they meet at the ridge z_r
        z_r = d * (tan - tan_b) / (tan + tan_b)
        hr = h + (d - z_r) * tan
        rl, rr = np.array([-w, hr, z_r]), np.array([w, hr, z_r])
        faces += [
            (f"{prefix}.front", "Wall", wall, np.array([F[0], F[1], top(F[1], h), top(F[0], h)])),
            (f"{prefix}.back", "Wall", wall, np.array([F[2], F[3], top(F[3], h), top(F[2], h)])),
            (
                f"{prefix}.left",
                "Wall",
                wall,
                np.array([F[3], F[0], top(F[0], h), rl, top(F[3], h)]),
            ),
            (
                f"{prefix}.right",
                "Wall",
                wall,
                np.array([F[1], F[2], top(F[2], h), rr, top(F[1], h)]),
            ),
            (
                f"{prefix}.roof.front",
                "RoofPlane",
                roof_material,
                np.array([top(F[0], h), top(F[1], h), rr, rl]),
            ),
            (
                f"{prefix}.roof.back",
                "RoofPlane",
                roof_material,
                np.array([top(F[2], h), top(F[3], h), rl, rr]),
            ),
        ]
        inside = np.array([0.0, h / 2, 0.0])
    elif roof == "hip":
        if not 0 < pitch_deg < 80:
            raise GeometryError(f"{prefix}: hip roof pitch must be in (0, 80) degrees")
        if width <= depth:
            raise GeometryError(f"{prefix}: a hip roof needs width > depth")
        hr = h + d * tan
        rl, rr = np.array([-w + d, hr, 0.0]), np.array([w - d, hr, 0.0])
        e = [top(p, h) for p in F]
        faces += [
            (f"{prefix}.front", "Wall", wall, np.array([F[0], F[1], e[1], e[0]])),
            (f"{prefix}.back", "Wall", wall, np.array([F[2], F[3], e[3], e[2]])),
            (f"{prefix}.left", "Wall", wall, np.array([F[3], F[0], e[0], e[3]])),
            (f"{prefix}.right", "Wall", wall, np.array([F[1], F[2], e[2], e[1]])),
            (f"{prefix}.roof.front", "RoofPlane", roof_material, np.array([e[0], e[1], rr, rl])),
            (f"{prefix}.roof.back", "RoofPlane", roof_material, np.array([e[2], e[3], rl, rr])),
            (f"{prefix}.roof.left", "RoofPlane", roof_material, np.array([e[3], e[0], rl])),
            (f"{prefix}.roof.right", "RoofPlane", roof_material, np.array([e[1], e[2], rr])),
        ]
        inside = np.array([0.0, h / 2, 0.0])
    elif roof == "flat":
        e = [top(p, h) for p in F]
        faces += [
            (f"{prefix}.front", "Wall", wall, np.array([F[0], F[1], e[1], e[0]])),
            (f"{prefix}.back", "Wall", wall, np.array([F[2], F[3], e[3], e[2]])),
            (f"{prefix}.left", "Wall", wall, np.array([F[3], F[0], e[0], e[3]])),
            (f"{prefix}.right", "Wall", wall, np.array([F[1], F[2], e[2], e[1]])),
            (f"{prefix}.roof.top", "RoofPlane", "flatroof", np.array(e)),
        ]
        inside = np.array([0.0, h / 2, 0.0])
    elif roof == "shed":
        if not 0 < pitch_deg < 80:
            raise GeometryError(f"{prefix}: shed roof pitch must be in (0, 80) degrees")
        hb = h + depth * tan  # rises towards the back
        ef, er = top(F[0], h), top(F[1], h)
        bb, bl = top(F[2], hb), top(F[3], hb)
        faces += [
            (f"{prefix}.front", "Wall", wall, np.array([F[0], F[1], er, ef])),
            (f"{prefix}.back", "Wall", wall, np.array([F[2], F[3], bl, bb])),
            (f"{prefix}.left", "Wall", wall, np.array([F[3], F[0], ef, bl])),
            (f"{prefix}.right", "Wall", wall, np.array([F[1], F[2], bb, er])),
            (f"{prefix}.roof.top", "RoofPlane", roof_material, np.array([ef, er, bb, bl])),
        ]
        inside = np.array([0.0, h / 2, 0.0])
    else:
        raise GeometryError(f"unknown roof type {roof!r} (gable, hip, flat, shed)")
    del up
    return faces, inside


def house(
    width: float = 16.0,
    depth: float = 10.0,
    height: float = 9.0,
    roof: str = "gable",
    pitch_deg: float = 35.0,
    wall_material: str = "plaster",
    roof_material: str = "tiles",
    floors: int = 3,
    pitch_back_deg: float | None = None,
) -> Model:
    """A free-standing house: HouseBody with four walls, floor and a roof (site frame).

    width : along x (front wall length), depth : along z, height : eaves height, metres.
    roof : "gable", "hip", "flat" or "shed"; pitch_deg : roof pitch, degrees;
    pitch_back_deg : the back half's pitch of an asymmetric gable (None: as the front).
    """
    faces, inside = _walls_and_roof(
        "body",
        width,
        depth,
        height,
        roof,
        pitch_deg,
        wall_material,
        roof_material,
        pitch_back_deg,
    )
    solid = _solid("body", inside, faces)
    solid = _with_windows(solid, floors=floors, height=height)
    params: dict[str, float | str | bool] = {
        "width": width,
        "depth": depth,
        "height": height,
        "roof": roof,
        "pitch_deg": pitch_deg,
        "floors": floors,
    }
    if pitch_back_deg is not None:
        params["pitch_back_deg"] = pitch_back_deg
    return Model("House", (solid,), params)


def _with_windows(solid: Solid, *, floors: int, height: float) -> Solid:
    """Attach the window grid (number of floors and floor height) to the walls' parameters."""
    faces = []
    for f in solid.faces:
        if f.concept == "Wall":
            f = replace(f, params={"floors": float(floors), "floor_h": height / max(floors, 1)})
        faces.append(f)
    return Solid(solid.name, tuple(faces))


def _rot_y(angle_rad: float) -> FloatArray:
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _inside_convex(solid: Solid, points: FloatArray, tol: float = 1e-6) -> bool:
    return all(not np.any(points @ f.normal - f.d > tol) for f in solid.faces)


def lshape_house(
    width: float = 16.0,
    depth: float = 10.0,
    height: float = 8.0,
    pitch_deg: float = 35.0,
    wing_width: float = 8.0,
    wing_length: float = 8.0,
    meeting_deg: float = 90.0,
    wall_material: str = "brick",
    floors: int = 3,
) -> Model:
    """An L-shaped house: a gable HouseBody and one gable Wing (``body.wings[0]``).

    meeting_deg = 90: the wing leaves the front wall at its right end, ridge perpendicular to
    the main ridge. meeting_deg = 135: the wing leaves the right gable wall, turned 45 degrees
    towards the front, so that its front wall meets the body's front wall at 135 degrees.
    The wing's inner end lies inside the body; its ridge is not higher than the main ridge.
    """
    body = house(width, depth, height, "gable", pitch_deg, wall_material, "tiles", floors)
    body_solid = body.solids[0]
    tan = math.tan(math.radians(pitch_deg))
    if wing_width > depth:
        raise GeometryError("lshape: wing_width must not exceed the body depth")
    if meeting_deg == 90.0:
        # wing axis +z (out of the front wall), flush with the body's right wall
        axis_angle = 0.0
        base = np.array([width / 2 - wing_width / 2, 0.0, 0.0])  # on the main ridge line
        length = depth / 2 + wing_length
    elif meeting_deg == 135.0:
        axis_angle = math.radians(45.0)  # the +z' axis turned to (sin 45, 0, cos 45)
        base = np.array([width / 2 - depth / 2, 0.0, 0.0])
        length = depth / 2 + wing_length
    else:
        raise GeometryError("lshape: meeting_deg must be 90 or 135")
    # wing in its own frame: axis along +z' from z'=0 (inner end) to z'=length; x' across.
    Rw = _rot_y(axis_angle)
    ww, h = wing_width / 2, height
    hr = h + ww * tan
    P = [
        np.array([-ww, 0.0, 0.0]),
        np.array([ww, 0.0, 0.0]),
        np.array([ww, 0.0, length]),
        np.array([-ww, 0.0, length]),
    ]

    def top(p: FloatArray, y: float) -> FloatArray:
        return np.array([p[0], y, p[2]])

    r0, r1 = np.array([0.0, hr, 0.0]), np.array([0.0, hr, length])
    pre = "body.wings[0]"
    # wing eave sides face +-x' (its front is the side towards the camera of view 00)
    local = [
        (f"{pre}.floor", "Floor", "floor", np.array(P)),
        (f"{pre}.front", "Wall", wall_material, np.array([P[1], P[2], top(P[2], h), top(P[1], h)])),
        (f"{pre}.back", "Wall", wall_material, np.array([P[3], P[0], top(P[0], h), top(P[3], h)])),
        (
            f"{pre}.left",
            "Wall",
            wall_material,
            np.array([P[2], P[3], top(P[3], h), r1, top(P[2], h)]),
        ),
        (
            f"{pre}.right",
            "Wall",
            wall_material,
            np.array([P[0], P[1], top(P[1], h), r0, top(P[0], h)]),
        ),
        (
            f"{pre}.roof.front",
            "RoofPlane",
            "tiles",
            np.array([top(P[1], h), top(P[2], h), r1, r0]),
        ),
        (
            f"{pre}.roof.back",
            "RoofPlane",
            "tiles",
            np.array([top(P[3], h), top(P[0], h), r0, r1]),
        ),
    ]
    if float((Rw @ np.array([1.0, 0.0, 0.0]))[2]) < -1e-9:
        # the +x' eave side faces away from the camera: it is the wing's back
        swap = {"front": "back", "back": "front", "left": "right", "right": "left"}
        local = [
            (
                r.rsplit(".", 1)[0] + "." + swap.get(r.rsplit(".", 1)[1], r.rsplit(".", 1)[1]),
                c,
                m,
                q,
            )
            for r, c, m, q in local
        ]
    faces = [(r, c, m, poly @ Rw.T + base) for r, c, m, poly in local]
    inside = np.array([0.0, h / 2, length / 2]) @ Rw.T + base
    wing = _with_windows(_solid("wing0", inside, faces), floors=floors, height=height)
    axis = Rw[:, 2]
    inner = next(
        f.polygon for f in wing.faces if np.allclose((f.polygon - base) @ axis, 0.0, atol=1e-9)
    )  # the wing's inner gable end: it must be hidden inside the body
    if not _inside_convex(body_solid, inner, tol=1e-6):
        raise GeometryError("lshape: the wing's inner end is not inside the body; adjust sizes")
    params = dict(body.parameters)
    params.update(
        {
            "wing_width": wing_width,
            "wing_length": wing_length,
            "meeting_deg": meeting_deg,
        }
    )
    return Model("House", (body_solid, wing), params)


def oriel_house(
    width: float = 14.0,
    depth: float = 10.0,
    height: float = 9.0,
    pitch_deg: float = 40.0,
    oriel_width: float = 3.0,
    oriel_depth: float = 1.2,
    oriel_bottom: float = 3.2,
    oriel_top: float = 8.0,
    n_oriels: int = 2,
    floors: int = 3,
) -> Model:
    """A gable house with box oriels standing out of the front wall (``body.oriels[i]``).

    Oriels are spread evenly along the front wall; each is a box oriel_width x oriel_depth
    (metres), from oriel_bottom to oriel_top above the ground, with a flat top.
    """
    body = house(width, depth, height, "gable", pitch_deg, "plaster", "tiles", floors)
    if oriel_top > height or oriel_bottom >= oriel_top:
        raise GeometryError("oriel: need oriel_bottom < oriel_top <= eaves height")
    spacing = width / (n_oriels + 1)
    if n_oriels and oriel_width >= (spacing if n_oriels > 1 else 2 * spacing):
        raise GeometryError(
            f"oriel: {n_oriels} oriels {oriel_width:g} m wide do not fit side by side on a "
            f"{width:g} m front wall"
        )
    solids = [body.solids[0]]
    inset = 0.3  # the box reaches this far into the wall (hidden)
    z0, z1 = depth / 2 - inset, depth / 2 + oriel_depth
    for i in range(n_oriels):
        xc = -width / 2 + width * (i + 1) / (n_oriels + 1)
        x0, x1 = xc - oriel_width / 2, xc + oriel_width / 2
        y0, y1 = oriel_bottom, oriel_top
        pre = f"body.oriels[{i}]"
        faces = [
            (
                f"{pre}.front",
                "Wall",
                "oriel",
                np.array([[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]]),
            ),
            (
                f"{pre}.back",
                "Wall",
                "oriel",
                np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0]]),
            ),
            (
                f"{pre}.left",
                "Wall",
                "oriel",
                np.array([[x0, y0, z0], [x0, y0, z1], [x0, y1, z1], [x0, y1, z0]]),
            ),
            (
                f"{pre}.right",
                "Wall",
                "oriel",
                np.array([[x1, y0, z0], [x1, y0, z1], [x1, y1, z1], [x1, y1, z0]]),
            ),
            (
                f"{pre}.top",
                "RoofPlane",
                "flatroof",
                np.array([[x0, y1, z0], [x1, y1, z0], [x1, y1, z1], [x0, y1, z1]]),
            ),
            (
                f"{pre}.bottom",
                "Floor",
                "soffit",
                np.array([[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]]),
            ),
        ]
        inside = np.array([xc, (y0 + y1) / 2, (z0 + z1) / 2])
        solid = _solid(f"oriel{i}", inside, faces)
        solid = Solid(
            solid.name,
            tuple(
                replace(f, params={"floors": 1.0, "floor_h": y1 - y0, "y0": y0})
                if f.role.endswith((".front", ".left", ".right"))
                else f
                for f in solid.faces
            ),
        )
        solids.append(solid)
    params = dict(body.parameters)
    params.update({"n_oriels": n_oriels, "oriel_width": oriel_width, "oriel_depth": oriel_depth})
    return Model("House", tuple(solids), params)


def reference_box(
    width: float = 0.40, depth: float = 0.30, height: float = 0.25, lift: float = 0.0
) -> Model:
    """A textured reference box standing on the ground, centred on the vertical y axis."""
    w, d = width / 2, depth / 2
    y0, y1 = lift, lift + height
    c = [np.array(p, dtype=float) for p in [(-w, y0, d), (w, y0, d), (w, y0, -d), (-w, y0, -d)]]

    def up(p: FloatArray) -> FloatArray:
        return np.array([p[0], y1, p[2]])

    faces = [
        ("box.front", "BoxFace", "box", np.array([c[0], c[1], up(c[1]), up(c[0])])),
        ("box.right", "BoxFace", "box", np.array([c[1], c[2], up(c[2]), up(c[1])])),
        ("box.back", "BoxFace", "box", np.array([c[2], c[3], up(c[3]), up(c[2])])),
        ("box.left", "BoxFace", "box", np.array([c[3], c[0], up(c[0]), up(c[3])])),
        ("box.top", "BoxFace", "box", np.array([up(p) for p in c])),
        ("box.bottom", "Floor", "floor", np.array(c)),
    ]
    solid = _solid("box", np.array([0.0, (y0 + y1) / 2, 0.0]), faces)
    return Model("ReferenceObject", (solid,), {"width": width, "depth": depth, "height": height})


def signed_volume(solid: Solid) -> float:
    """Volume of a closed solid from its outward-oriented faces (positive if closed and outward)."""
    vol = 0.0
    for f in solid.faces:
        p = f.polygon
        for i in range(1, len(p) - 1):
            vol += float(np.dot(p[0], np.cross(p[i], p[i + 1]))) / 6.0
    return vol


def tower(
    side: float = 6.0,
    height: float = 14.0,
    pitch_deg: float = 50.0,
    wall_material: str = "brick",
    roof_material: str = "tiles",
    floors: int = 4,
) -> Model:
    """A square tower with a pyramid roof (kb/tower.kb), centred on the y axis (site frame).

    side : the shaft's side, height : its eaves height, metres; pitch_deg : the slope of each
    of the four roof planes, degrees. Roles: ``shaft.north`` faces +z, ``shaft.east`` +x,
    ``shaft.south`` -z, ``shaft.west`` -x, ``shaft.base`` the ground, ``shaft.cap.*`` the
    roof's slopes above the walls of the same name (the renderer names the parts it renders).
    """
    if min(side, height) <= 0:
        raise GeometryError("tower: side and height must be positive")
    if not 0 < pitch_deg < 80:
        raise GeometryError("tower: the roof's pitch must be in (0, 80) degrees")
    s = side / 2
    apex = np.array([0.0, height + s * math.tan(math.radians(pitch_deg)), 0.0])
    F = [np.array(p) for p in ([-s, 0, s], [s, 0, s], [s, 0, -s], [-s, 0, -s])]
    E = [np.array([p[0], height, p[2]]) for p in F]
    # wall k runs from corner k to corner k + 1: north (+z), east (+x), south (-z), west (-x)
    faces: list[tuple[str, str, str, FloatArray]] = [("shaft.base", "Ground", "floor", np.array(F))]
    for k, name in enumerate(("north", "east", "south", "west")):
        a, b = k, (k + 1) % 4
        faces.append(
            (f"shaft.{name}", "Masonry", wall_material, np.array([F[a], F[b], E[b], E[a]]))
        )
        faces.append((f"shaft.cap.{name}", "Slope", roof_material, np.array([E[a], E[b], apex])))
    solid = _solid("shaft", np.array([0.0, height / 2, 0.0]), faces)
    walls = tuple(
        replace(f, params={"floors": float(floors), "floor_h": height / max(floors, 1)})
        if f.concept == "Masonry"
        else f
        for f in solid.faces
    )
    params: dict[str, float | str | bool] = {
        "side": side,
        "height": height,
        "pitch_deg": pitch_deg,
        "floors": floors,
    }
    return Model("Tower", (Solid("shaft", walls),), params)
