"""The registry of constraint kinds: one line per kind.

Every kind implements `aida_kb.constraints.kinds.base.Kind`. The registry is the only place
that knows which kinds exist; everything else asks it (``KINDS[name]``).
`tests/constraints/test_registry.py` checks that every kind here has a Jacobian test against
finite differences and a line in ``docs/architecture.md``.
"""

from __future__ import annotations

from aida_kb.constraints.kinds.angle import ANGLE
from aida_kb.constraints.kinds.base import Kind
from aida_kb.constraints.kinds.camera_position import CAMERA_POSITION
from aida_kb.constraints.kinds.coincident import COINCIDENT
from aida_kb.constraints.kinds.concurrent import CONCURRENT
from aida_kb.constraints.kinds.edge import EDGE
from aida_kb.constraints.kinds.parallel import PARALLEL
from aida_kb.constraints.kinds.parallel_edge import PARALLEL_EDGE
from aida_kb.constraints.kinds.position import POSITION
from aida_kb.constraints.kinds.symmetry import SYMMETRY
from aida_kb.constraints.kinds.texture import TEXTURE
from aida_kb.errors import SolveError

KINDS: dict[str, Kind] = {
    k.name: k
    for k in (
        ANGLE,  # eq. 1: the angle at which two planes meet
        PARALLEL,  # eq. 2: parallel planes
        PARALLEL_EDGE,  # §4.3: parallel edges
        SYMMETRY,  # eq. 3: two pairs meeting at the same angle
        POSITION,  # eq. 4: a plane against its region, world frame
        EDGE,  # eq. 5: an edge against an image segment
        CAMERA_POSITION,  # eq. 4 measured in a free camera's frame (registration)
        COINCIDENT,  # one plane of two parts (touching objects' shared wall)
        CONCURRENT,  # four planes through one point (a hip roof's eaves corner)
        TEXTURE,  # a patch of the first view's texture seen again by a later camera
    )
}

CHI2_999 = {1: 10.828, 2: 13.816, 3: 16.266, 14: 36.123}
"""99.9 % quantiles of chi-square with 1, 2, 3 and 14 (a texture patch) degrees of freedom:
the default rejection thresholds of the normalised cost when a constraint has no
``reject_above``."""


def kind_of(name: str, where: str = "constraint") -> Kind:
    """The kind called ``name``; `SolveError` naming ``where`` and the known kinds if none."""
    kind = KINDS.get(name)
    if kind is None:
        raise SolveError(f"{where}: unknown kind {name!r} (one of {', '.join(KINDS)})")
    return kind
