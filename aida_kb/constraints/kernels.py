"""Vectorised residual kernels of the paper's constraints (eqs. 1-4) with analytic Jacobians.

Every kernel evaluates all M constraints of one kind in one numpy call over index arrays.
Inputs are the current planes of all parts, ``normals`` (P, 3) unit vectors and ``offsets``
(P,) metres, world frame. Outputs are the *unweighted* residuals ``r`` (M, k) in the
constraint's unit and their Jacobian ``J`` (M, k, a, 4), the derivative of ``r[m, i]`` with
respect to ``(n, d)`` of the constraint's ``a``-th plane: ``J[..., :3]`` by the normal,
``J[..., 3]`` by the offset. The caller chains ``J`` with the part parametrisation
(`aida_kb.geometry.frames`) and applies weights.

Angles follow one convention: ``angle(a, b)`` is the angle at which the planes meet, measured
inside the solid, ``pi - acos(n_a·n_b)`` in [0, pi]: two perpendicular walls meet at pi/2, a
wing whose front wall is turned 45 degrees from the body's front wall meets it at 3·pi/4.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aida_kb.geometry.rotation import skew

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

_SMALL = 1e-3  # below this |a x b| the rotation-vector factors use their series expansions


def cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """Row-wise cross product of (..., 3) arrays (``np.cross`` without its overhead)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def dot(a: FloatArray, b: FloatArray) -> FloatArray:
    """Row-wise dot product of (..., 3) arrays."""
    out: FloatArray = a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]
    return out


def rotation_vector(a: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The rotation vector taking unit vector ``a`` to unit vector ``b``, and its Jacobians.

    ``r = theta · (a × b) / |a × b|`` with ``theta = atan2(|a × b|, a·b)``, so ``|r|`` is the
    angle between ``a`` and ``b`` (rad). Smooth at ``a = b`` (``r = 0``); singular only at
    ``a = -b``.

    Parameters
    ----------
    a, b : (M, 3) arrays, unit vectors.

    Returns
    -------
    r : (M, 3) rad; dr_da, dr_db : (M, 3, 3), ``dr_da[m, i, j] = d r_mi / d a_mj``.
    """
    x = cross(a, b)
    s = np.sqrt(dot(x, x))
    c = dot(a, b)
    q = s * s + c * c
    theta = np.arctan2(s, c)
    small = (s < _SMALL) & (c > 0)
    s_safe = np.where(small, 1.0, s)
    h = np.where(small, 1.0 / c - s * s / (3.0 * c**3), theta / s_safe)
    g = np.where(
        small,
        -2.0 / (3.0 * c**3) + 4.0 * s * s / (5.0 * c**5),
        (s_safe * c / q - theta) / s_safe**3,
    )
    hc = -1.0 / q
    r = h[:, None] * x
    dr_da = -h[:, None, None] * skew(b, check=False) + np.einsum(
        "mi,mj->mij", x, g[:, None] * cross(b, x) + hc[:, None] * b
    )
    dr_db = h[:, None, None] * skew(a, check=False) + np.einsum(
        "mi,mj->mij", x, g[:, None] * cross(x, a) + hc[:, None] * a
    )
    return r, dr_da, dr_db


def meeting_angle(a: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Angle at which planes with unit normals ``a``, ``b`` meet: ``pi - angle(a, b)``.

    Parameters
    ----------
    a, b : (M, 3) unit normals.

    Returns
    -------
    phi : (M,) rad in [0, pi]; dphi_da, dphi_db : (M, 3).
    """
    x = cross(a, b)
    s = np.sqrt(dot(x, x))
    c = dot(a, b)
    q = s * s + c * c
    phi = np.pi - np.arctan2(s, c)
    s_safe = np.maximum(s, 1e-15)
    dphi_da = -(c[:, None] * cross(b, x) / s_safe[:, None] - s[:, None] * b) / q[:, None]
    dphi_db = -(c[:, None] * cross(x, a) / s_safe[:, None] - s[:, None] * a) / q[:, None]
    return phi, dphi_da, dphi_db


def _normal_block(dr_dn: FloatArray) -> FloatArray:
    """(M, k, 3) derivative by a normal -> (M, k, 4) with zero derivative by the offset."""
    out = np.zeros((*dr_dn.shape[:-1], 4))
    out[..., :3] = dr_dn
    return out


def angle_kernel(
    normals: FloatArray, idx: IntArray, value: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Angle constraint (paper eq. 1): ``r = angle(a, b) - value`` (rad).

    idx : (M, 2) part indices (a, b); value : (M,) rad. Returns r (M, 1), J (M, 1, 2, 4).
    """
    phi, da, db = meeting_angle(normals[idx[:, 0]], normals[idx[:, 1]])
    r = (phi - value)[:, None]
    J = np.zeros((idx.shape[0], 1, 2, 4))
    J[:, 0, 0, :3] = da
    J[:, 0, 1, :3] = db
    return r, J


def _signs(a: FloatArray, b: FloatArray, sign: FloatArray) -> FloatArray:
    """Fixed signs where ``sign`` is +-1; where 0, the sign making ``a·(s·b) >= 0``."""
    auto = np.where(dot(a, b) >= 0.0, 1.0, -1.0)
    return np.where(sign == 0.0, auto, sign)


def parallel_kernel(
    normals: FloatArray, idx: IntArray, sign: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Parallel planes (paper eq. 2): the rotation vector from ``n_a`` to ``s·n_b`` (rad).

    ``|r|`` is the angle between the planes; ``s = +-1`` is fixed by ``sign`` (M,) where it is
    nonzero (same or opposite facing), else chosen so that the normals agree (``s·n_a·n_b >= 0``).
    Returns r (M, 3), J (M, 3, 2, 4).
    """
    a = normals[idx[:, 0]]
    b = normals[idx[:, 1]]
    s = _signs(a, b, sign)
    r, da, db = rotation_vector(a, s[:, None] * b)
    J = np.stack([_normal_block(da), _normal_block(db * s[:, None, None])], axis=2)
    return r, J


def _edge_directions(na: FloatArray, nb: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Unit directions ``e = (n_a × n_b)/|n_a × n_b|`` (M, 3) and de/dn_a, de/dn_b (M, 3, 3)."""
    x = cross(na, nb)
    length = np.maximum(np.sqrt(dot(x, x)), 1e-15)
    e = x / length[:, None]
    proj = (np.eye(3)[None] - np.einsum("mi,mj->mij", e, e)) / length[:, None, None]
    return e, proj @ -skew(nb, check=False), proj @ skew(na, check=False)


def parallel_edge_kernel(normals: FloatArray, idx: IntArray) -> tuple[FloatArray, FloatArray]:
    """Parallel edges (paper §4.3): the rotation vector between edge(a, b) and edge(c, d).

    idx : (M, 4) part indices (a, b, c, d); an edge's direction is ``n_a × n_b``, its sign is
    irrelevant (lines). Returns r (M, 3) rad, J (M, 3, 4, 4).
    """
    e1, de1_da, de1_db = _edge_directions(normals[idx[:, 0]], normals[idx[:, 1]])
    e2, de2_dc, de2_dd = _edge_directions(normals[idx[:, 2]], normals[idx[:, 3]])
    s = np.where(dot(e1, e2) >= 0.0, 1.0, -1.0)[:, None, None]
    r, dr_de1, dr_de2 = rotation_vector(e1, s[:, :, 0] * e2)
    dr_de2 = dr_de2 * s
    J = np.stack(
        [
            _normal_block(dr_de1 @ de1_da),
            _normal_block(dr_de1 @ de1_db),
            _normal_block(dr_de2 @ de2_dc),
            _normal_block(dr_de2 @ de2_dd),
        ],
        axis=2,
    )
    return r, J


def symmetry_kernel(normals: FloatArray, idx: IntArray) -> tuple[FloatArray, FloatArray]:
    """Symmetry (paper eq. 3): ``r = angle(a, b) - angle(c, d)`` (rad).

    idx : (M, 4) part indices. Returns r (M, 1), J (M, 1, 4, 4).
    """
    p1, da, db = meeting_angle(normals[idx[:, 0]], normals[idx[:, 1]])
    p2, dc, dd = meeting_angle(normals[idx[:, 2]], normals[idx[:, 3]])
    J = np.zeros((idx.shape[0], 1, 4, 4))
    J[:, 0, 0, :3] = da
    J[:, 0, 1, :3] = db
    J[:, 0, 2, :3] = -dc
    J[:, 0, 3, :3] = -dd
    return (p1 - p2)[:, None], J


def position_kernel(
    normals: FloatArray,
    offsets: FloatArray,
    idx: IntArray,
    n_init: FloatArray,
    c_init: FloatArray,
    scale_angle: FloatArray,
    scale_shift: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Position constraint (paper eq. 4) of parts ``idx`` (M, 1) against region evidence.

    The residual has four components: ``scale_angle · rotation_vector(n_init, n)`` (whose norm
    is the angle between the initial and the current normal) and ``scale_shift · shift``, where
    ``shift = ((c - c_init)·n_init)`` with ``c = c_init + (d - n·c_init)·n`` the region centre
    projected onto the current plane: the move of the centre along the initial normal (a move
    within the plane costs nothing).

    Parameters
    ----------
    n_init : (M, 3) unit normals, c_init : (M, 3) metres, world frame (plane fit of the region).
    scale_angle, scale_shift : (M,) factors taking rad and metres to the constraint's unit
        (1 and sqrt(w_n) in the paper's form).

    Returns
    -------
    r : (M, 4); J : (M, 4, 1, 4).
    """
    i = idx[:, 0]
    n = normals[i]
    d = offsets[i]
    rv, _, drv_dn = rotation_vector(n_init, n)
    cos = dot(n, n_init)
    dist = d - dot(n, c_init)
    shift = dist * cos
    r = np.empty((i.shape[0], 4))
    r[:, :3] = scale_angle[:, None] * rv
    r[:, 3] = scale_shift * shift
    J = np.zeros((i.shape[0], 4, 1, 4))
    J[:, :3, 0, :3] = scale_angle[:, None, None] * drv_dn
    J[:, 3, 0, :3] = scale_shift[:, None] * (dist[:, None] * n_init - cos[:, None] * c_init)
    J[:, 3, 0, 3] = scale_shift * cos
    return r, J
