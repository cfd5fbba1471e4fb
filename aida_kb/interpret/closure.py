"""Closed solids from the planes of a verified structure (`aida_kb.geometry.polyhedron`).

Every structure of an interpretation — a house body, a wing, an oriel box — is one closed
polyhedron: its planar parts are its faces, and which of them meet along an edge is the
knowledge base's adjacency (`Structure.adjacency`). `Polyhedron.from_adjacency` turns that into
faces with shared vertices, so every edge belongs to exactly two faces; it needs no convexity
(the walls of a wing may run into its body), and it refuses degenerate solids with a
`GeometryError` naming the faces (a face that does not close, planes that cross over).

A structure the knowledge gives fewer faces than a closed solid needs is closed by the planes
of the verified level it belongs to (`closing_faces`), as its whole's ``attach`` declaration
says (docs/language.md §3.12): a wing standing on the ground by its whole's floor, an oriel
standing out of a wall by that wall (its open back facing into the body). Several structures
together (a body with wings) form a union of closed solids.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.errors import GeometryError
from aida_kb.geometry.polyhedron import Polyhedron
from aida_kb.interpret.hypotheses import HORIZONTAL, Frame, PlanarPart
from aida_kb.interpret.party import one_plane
from aida_kb.kb.paths import RolePath, Step

if TYPE_CHECKING:
    from aida_kb.constraints import Constraint
    from aida_kb.interpret.knowledge import Knowledge
    from aida_kb.interpret.result import Interpretation
    from aida_kb.kb.model import AttachmentModel

FloatArray = npt.NDArray[np.float64]

MIN_FACE_FRACTION = 0.01  # a face smaller than this fraction of the largest one is missing
# where more than three faces meet, planes that miss a common point by up to this fraction of
# the solid's size are moved until they meet (`Polyhedron.concurrent`: rounding, millimetres);
# further apart (1-2.4 m on 20 m houses) the verified planes do not form this solid at all
CONCURRENT_MAX_REL = 0.005
# the whole's plane that closes an open face must be this parallel to it (cosine of the angle)
MIN_CLOSING_ALIGNMENT = 0.9
_OPPOSITE = {
    "forward": "backward",
    "backward": "forward",
    "leftward": "rightward",
    "rightward": "leftward",
    "upward": "downward",
    "downward": "upward",
}


@dataclass(frozen=True)
class ClosingFace:
    """A face that closes a structure: role path, concept, plane (unit n, d) and neighbours.

    ``source`` is the verified part whose plane it lies in (``body.floor``, ``body.front``):
    the structure's parts meet that part along the closing face's edges.
    """

    role: str
    concept: str
    normal: FloatArray  # (3,) unit, out of the structure's solid
    offset_m: float
    neighbours: tuple[str, ...]  # role paths of the structure's parts it meets
    source: str


def closing_faces(
    root: str,
    leaves: Sequence[PlanarPart],
    frame: Frame,
    fixed: Mapping[str, tuple[FloatArray, float]],
    attachment: AttachmentModel | None,
    concepts: Mapping[str, str],
) -> list[ClosingFace]:
    """The face a structure lacks for a closed solid, from the planes of verified levels.

    Parameters
    ----------
    root : the structure's role path (``body.wings[0]``).
    leaves : its planar parts (with the directions they face).
    frame : the structure's frame (unit vectors, world frame).
    fixed : role path -> (unit normal (3,), offset m) of the verified levels' planes.
    attachment : how the structure attaches to its whole (its whole's ``attach``), or None.
    concepts : role path -> concept of the fixed planes.

    The open face faces ``attachment.face`` in the structure's frame and lies in the one of the
    whole's planes ``attachment.planes`` whose outward normal is nearest that direction
    (``in``: the face continues the plane) or its opposite (``against``: the face lies against
    the plane, facing into the whole), the cosine at least `MIN_CLOSING_ALIGNMENT`; it meets
    the structure's parts that neither face the same way nor
    the opposite way (for a vertical face: those that face a side untilted). Nothing is added
    without an attachment, when a part of the structure already faces that way, or when no
    fixed plane fits.
    """
    if attachment is None or "." not in root:
        return []
    if any(leaf.direction == attachment.face for leaf in leaves):
        return []
    whole = root.rsplit(".", 1)[0]
    sense = 1.0 if attachment.contact == "in" else -1.0
    direction = frame.direction(attachment.face)
    best: tuple[float, str] | None = None
    for plane in attachment.planes:
        role = f"{whole}.{plane}" if whole else plane
        if role not in fixed:
            continue
        score = sense * float(np.asarray(fixed[role][0]) @ direction)
        if best is None or score > best[0]:
            best = (score, role)
    if best is None or best[0] < MIN_CLOSING_ALIGNMENT:
        return []
    source = best[1]
    n, d = fixed[source]
    sign = sense
    opposite = _OPPOSITE[attachment.face]
    if attachment.face in HORIZONTAL:
        around = tuple(leaf.role for leaf in leaves if leaf.direction != opposite)
    else:
        around = tuple(
            leaf.role for leaf in leaves if leaf.direction in HORIZONTAL and not leaf.pitched
        )
    return [
        ClosingFace(
            f"{root}.{attachment.name}",
            concepts.get(source, ""),
            sign * np.asarray(n, dtype=np.float64),
            sign * float(d),
            around,
            source,
        )
    ]


def closing_ties(
    knowledge: Knowledge, interp: Interpretation, names: Sequence[str]
) -> list[Constraint]:
    """The priors holding each closing face of the interpretation's model on the plane of its
    whole that closed it (`closing_faces`: an oriel's back against the wall it stands out of,
    a wing's floor in the body's floor), for an adjustment whose parts are `names`.

    The first view's model copies the whole's plane into the closing face; an adjustment that
    frees every part's plane (the views' joint adjustment) would otherwise let the face drift
    with nothing but its own edges to hold it: on the kept dev runs 65000-70035 oriels' backs
    and wings' floors lay up to 2.6 deg and 1.3 m off their walls and floors (70014, 70025),
    while the knowledge's ``attach`` says they lie in them. Each tie is a `party.one_plane`
    (facing alike for ``in``, opposite for ``against``). A model part is a closing face when
    no instance of the interpretation fills its role and its structure's whole ``attach``es
    that structure by a face of that name; its plane is the one of the attachment's planes
    whose normal lies nearest (`MIN_CLOSING_ALIGNMENT`), as `closing_faces` chose it. No
    model: no tie.
    """
    if interp.model is None:
        return []
    index = {name: i for i, name in enumerate(names)}
    normals = {p.role: np.asarray(p.normal, dtype=np.float64) for p in interp.model.parts}
    fillers = {inst.role: inst.concept for inst in interp.instances}
    out: list[Constraint] = []
    for name in names:
        try:
            path = RolePath.parse(name)
        except ValueError:
            continue
        if len(path) < 3 or name in fillers or name not in normals:
            continue
        whole = path.parent.parent
        concept = fillers.get(str(whole))
        if concept is None or concept not in knowledge.concepts:
            continue
        attachment = knowledge.concept(concept).attachments.get(path.parent.last.role)
        if attachment is None or path.last != Step(attachment.name):
            continue
        sense = 1 if attachment.contact == "in" else -1
        best: tuple[float, str] | None = None
        for plane in attachment.planes:
            role = str(whole.join(RolePath.parse(plane)))
            if role not in index or role not in normals:
                continue
            score = sense * float(normals[role] @ normals[name])
            if best is None or score > best[0]:
                best = (score, role)
        if best is None or best[0] < MIN_CLOSING_ALIGNMENT:
            continue
        out.append(one_plane(index[name], index[best[1]], sense, f"in plane({name}, {best[1]})"))
    return out


def close(
    faces: Sequence[tuple[str, FloatArray, float]],
    adjacency: Iterable[tuple[str, str]],
) -> dict[str, FloatArray]:
    """The closed solid of the faces (role path, unit normal (3,), offset m): every polygon.

    Returns role path -> polygon (K, 3), metres, world frame, counter-clockwise seen from
    outside, planar; every edge is shared by exactly two polygons. Where more than three
    planes meet and are not concurrent, the planes are first moved until they are
    (`Polyhedron.concurrent`): the polygons' planes then differ from the given ones by millimetres.

    Raises
    ------
    GeometryError
        Naming the faces: the adjacency does not close a solid, the planes cross over, a
        face is vanishingly small (below `MIN_FACE_FRACTION` of the largest), or more than
        three faces meet at a vertex whose planes miss a common point by more than
        `CONCURRENT_MAX_REL` of the solid's size (`check_concurrent`).
    """
    names = [r for r, _, _ in faces]
    known = set(names)
    pairs = {(min(a, b), max(a, b)) for a, b in adjacency if a in known and b in known}
    solid = Polyhedron.from_adjacency(
        names,
        np.array([n for _, n, _ in faces], dtype=np.float64),
        np.array([d for _, _, d in faces], dtype=np.float64),
        sorted(pairs),
    )
    check_concurrent(solid)
    areas = solid.face_areas()
    biggest = float(areas.max())
    for name, area in zip(names, areas, strict=True):
        if area < MIN_FACE_FRACTION * biggest:
            raise GeometryError(
                f"{name} has no face in the closed model ({area:.2g} m² of {biggest:.3g} m²)"
            )
    return solid.concurrent().polygons()


# a plane placed by the knowledge weighs this little against a measured one where more than
# three faces meet: the common point is the measured planes', the placed plane moves to it
UNSEEN_WEIGHT = 1e-3
# rounds of settling placed planes one by one (each: common points, then the placed planes'
# offsets); stops earlier when no offset moves by more than SETTLE_TOLERANCE_M
MAX_SETTLE_ROUNDS = 200
SETTLE_TOLERANCE_M = 1e-6
# how much a placed plane's offset holds to its placement when all are settled together,
# against the misfit at the corners (per metre of offset, relative to UNSEEN_WEIGHT): just
# enough to choose, among offsets that all close the solid, the ones nearest the placements
# (a hip's placed planes have one offset more than its corners fix)
SETTLE_HOLD = 1e-6


def settle_unseen(
    faces: Sequence[tuple[str, FloatArray, float]],
    adjacency: Iterable[tuple[str, str]],
    unseen: Iterable[str],
) -> dict[str, float]:
    """Offsets that make the planes no view shows meet the others where more than three faces
    meet (the eaves corners of a hip roof, a pyramid's apex): role path -> offset, metres.

    The planes the knowledge placed (``unseen``: their normals from the knowledge, their
    offsets from `unseen` placements) have no evidence of their own. First each is moved on
    its own: where four faces meet their common point is the measured planes' (weighted
    least squares, the placed planes weighing `UNSEEN_WEIGHT`) and each placed plane is moved
    along its normal to the mean of its vertices, until no offset changes by
    `SETTLE_TOLERANCE_M`. Where that leaves a corner open by more than `close` accepts — a
    hip roof's back corner, where the back wall, the side wall and both back slopes are all
    placed and each answers to two such corners (0.24 m open on a street's hip) — they are
    settled together (`_settled_together`). Normals are kept. Where only three faces meet,
    the vertex lies on all three at any offset: nothing moves. Returns the given offsets when
    the faces do not close a solid (`close` then says why).
    """
    names = [r for r, _, _ in faces]
    known = set(names)
    hidden = set(unseen)
    movable = [i for i, r in enumerate(names) if r in hidden]
    offsets = np.array([d for _, _, d in faces], dtype=np.float64)
    if not movable:
        return {}
    pairs = sorted({(min(a, b), max(a, b)) for a, b in adjacency if a in known and b in known})
    normals = np.array([n for _, n, _ in faces], dtype=np.float64)
    given = {names[i]: float(offsets[i]) for i in movable}
    try:
        solid = Polyhedron.from_adjacency(names, normals, offsets, pairs)
    except GeometryError:
        return given
    if all(len(v) <= 3 for v in solid.vertex_faces):
        return given
    weight = np.ones(len(names))
    weight[movable] = UNSEEN_WEIGHT
    one_by_one = _settled_one_by_one(solid, normals, offsets, weight, movable)
    try:
        check_concurrent(Polyhedron.from_adjacency(names, normals, one_by_one, pairs))
    except GeometryError:
        together = _settled_together(solid, normals, offsets, weight, movable)
        if _keeps_measured_faces(solid, names, normals, together, pairs, movable):
            return {names[i]: float(together[i]) for i in movable}
    return {names[i]: float(one_by_one[i]) for i in movable}


def _settled_one_by_one(
    solid: Polyhedron,
    normals: FloatArray,
    offsets: FloatArray,
    weight: FloatArray,
    movable: list[int],
) -> FloatArray:
    """Every face's offset ((F,) metres) with each placed one (`movable`) moved to the mean of
    its vertices' common points (weighted by `weight` (F,)), repeated until none moves."""
    offsets = offsets.copy()
    # incidences (vertex, face), and each face's vertices
    vi = np.array([v for v, fs in enumerate(solid.vertex_faces) for _ in fs], dtype=np.intp)
    fi = np.array([f for fs in solid.vertex_faces for f in fs], dtype=np.intp)
    w = weight[fi]
    nn = normals[fi][:, :, None] * normals[fi][:, None, :] * w[:, None, None]  # (I, 3, 3)
    A = np.zeros((len(solid.vertex_faces), 3, 3))
    np.add.at(A, vi, nn)
    mask = np.isin(fi, movable)
    counts = np.bincount(fi[mask], minlength=len(offsets)).astype(np.float64)
    for _ in range(MAX_SETTLE_ROUNDS):
        b = np.zeros((len(solid.vertex_faces), 3))
        np.add.at(b, vi, normals[fi] * (w * offsets[fi])[:, None])
        x = np.linalg.solve(A, b[:, :, None])[:, :, 0]  # (V, 3) common points
        along = np.einsum("ij,ij->i", normals[fi[mask]], x[vi[mask]])
        sums = np.bincount(fi[mask], weights=along, minlength=len(offsets))
        new = offsets.copy()
        new[movable] = sums[movable] / np.maximum(counts[movable], 1.0)
        moved = float(np.max(np.abs(new - offsets)))
        offsets = new
        if moved < SETTLE_TOLERANCE_M:
            break
    return offsets


def _settled_together(
    solid: Polyhedron,
    normals: FloatArray,
    offsets: FloatArray,
    weight: FloatArray,
    movable: list[int],
) -> FloatArray:
    """Every face's offset ((F,) metres) with the placed ones (`movable`) and every vertex's
    point found together as one linear least-squares problem: each face's distance from each
    of its vertices' points a residual (weighted by `weight` (F,)), each placed offset held to
    its placement by `SETTLE_HOLD`. Where four faces meet, the offsets make them concurrent."""
    column = {f: k for k, f in enumerate(movable)}
    vi = np.array([v for v, fs in enumerate(solid.vertex_faces) for _ in fs], dtype=np.intp)
    fi = np.array([f for fs in solid.vertex_faces for f in fs], dtype=np.intp)
    n_points = 3 * len(solid.vertex_faces)
    rows = len(vi) + len(movable)
    A = np.zeros((rows, n_points + len(movable)))
    b = np.zeros(rows)
    root = np.sqrt(weight[fi])
    incidence = np.arange(len(vi))
    for axis in range(3):
        A[incidence, 3 * vi + axis] = root * normals[fi, axis]
    placed = np.isin(fi, movable)
    A[incidence[placed], n_points + np.array([column[int(f)] for f in fi[placed]])] = -root[placed]
    b[: len(vi)] = root * offsets[fi]
    hold = np.sqrt(UNSEEN_WEIGHT * SETTLE_HOLD)
    A[len(vi) + np.arange(len(movable)), n_points + np.arange(len(movable))] = hold
    solution = np.linalg.lstsq(A, b, rcond=None)[0]
    settled = offsets.copy()
    settled[movable] += solution[n_points:]
    return settled


# settled placed planes must leave every measured face at least this share of its area: the
# region that measured it lies on it. Placed normals that cannot form the solid (a hip's
# placed slope pitched 8 degrees off its measured twin) close it only by collapsing it (dev
# street seed 7: the back wall moved 7.7 m onto the front, the walls left 0.3 m²)
SETTLE_KEEP_AREA = 0.5


def _keeps_measured_faces(
    before: Polyhedron,
    names: list[str],
    normals: FloatArray,
    offsets: FloatArray,
    pairs: list[tuple[str, str]],
    movable: list[int],
) -> bool:
    """True if the solid with the settled `offsets` ((F,) metres) closes and keeps every face
    not in `movable` at SETTLE_KEEP_AREA of its area in `before`."""
    try:
        after = Polyhedron.from_adjacency(names, normals, offsets, pairs)
    except GeometryError:
        return False
    measured = np.ones(len(names), dtype=bool)
    measured[movable] = False
    return bool(
        np.all(after.face_areas()[measured] >= SETTLE_KEEP_AREA * before.face_areas()[measured])
    )


def check_concurrent(solid: Polyhedron) -> None:
    """Raise GeometryError naming the faces of the worst vertex where more than three faces
    meet whose planes miss a common point by more than `CONCURRENT_MAX_REL` of the solid's
    size: moving them until they meet would change the verified planes, not round them."""
    worst = int(np.argmax(solid.vertex_residuals)) if solid.vertex_residuals.size else 0
    if solid.vertex_residuals.size and float(
        solid.vertex_residuals[worst]
    ) > CONCURRENT_MAX_REL * max(solid.size, 1e-300):
        faces = ", ".join(solid.names[f] for f in solid.vertex_faces[worst])
        raise GeometryError(
            f"the planes of {faces} do not meet in one point "
            f"({float(solid.vertex_residuals[worst]):.2g} m apart)"
        )


def inside_face(face: FloatArray, point_m: FloatArray, margin: float = 0.0) -> bool:
    """True if `point_m` (3,), projected onto a convex face's plane, lies inside the face.

    The face (N, 3) is a convex polygon; `margin` widens it by that fraction of its size
    (the diagonal of its bounding box) on every side.
    """
    centre = face.mean(axis=0)
    normal = np.cross(face[1] - face[0], face[2] - face[0])
    for i in range(3, len(face)):
        if np.linalg.norm(normal) > 1e-12:
            break
        normal = np.cross(face[1] - face[0], face[i] - face[0])
    normal = normal / max(float(np.linalg.norm(normal)), 1e-12)
    p = point_m - float((point_m - centre) @ normal) * normal
    size = float(np.linalg.norm(face.max(axis=0) - face.min(axis=0)))
    slack = margin * size
    for a, b in zip(face, np.roll(face, -1, axis=0), strict=True):
        edge = b - a
        outward = np.cross(edge, normal)
        if float(np.linalg.norm(outward)) < 1e-12:
            continue
        outward = outward / float(np.linalg.norm(outward))
        if float(np.dot(outward, centre - a)) > 0:
            outward = -outward
        if float(np.dot(outward, p - a)) > slack:
            return False
    return True
