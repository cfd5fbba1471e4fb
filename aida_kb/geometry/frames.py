"""Local frames of planar parts (paper §3) and the map from part parameters to planes.

Every model part is a plane ``n·x = d`` (world frame, metres, ``n`` the unit normal pointing
out of the solid). It carries a local frame: origin ``t`` at the part's centre on the plane and
right-handed axes ``u, v, w`` with ``w = -n``. A part has three parameters relative to that
initial frame, ``p = (delta, alpha, beta)``:

* ``alpha`` (rad): rotation about the frame's ``u`` axis,
* ``beta`` (rad): rotation about the frame's ``v`` axis,
* ``delta`` (m): offset of the plane along its (rotated) normal.

The rotated axis ``w'`` is ``Rx(alpha)·Ry(beta)·e_z`` in frame coordinates, so

    w' = sin(beta)·u - sin(alpha)·cos(beta)·v + cos(alpha)·cos(beta)·w,
    n(p) = -w',    d(p) = n(p)·t + delta.

The centre moves to ``t + delta·n(p)`` (the orthogonal projection of ``t`` onto the moved
plane). ``p = 0`` reproduces the initial plane exactly; all functions are vectorised over P parts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.errors import GeometryError

FloatArray = npt.NDArray[np.float64]

#: World "up" in the OpenCV camera convention (y down); used to orient the u axis horizontally.
WORLD_UP = np.array([0.0, -1.0, 0.0])


def _check_finite(name: str, array: FloatArray) -> None:
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        raise GeometryError(f"{name}: non-finite value at index {tuple(int(i) for i in bad)}")


def frame_axes(normals: FloatArray) -> FloatArray:
    """Right-handed local axes for planes with unit ``normals``.

    Parameters
    ----------
    normals : (P, 3) array, unit normals, world frame.

    Returns
    -------
    axes : (P, 3, 3) array; ``axes[i, :, 0] = u``, ``axes[i, :, 1] = v``, ``axes[i, :, 2] = w``
        (columns, world frame), ``w = -n``, ``u`` horizontal (perpendicular to world up) where
        the plane is not horizontal, else the world x axis projected onto the plane.
    """
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    _check_finite("plane normals", n)
    if np.any(np.einsum("ij,ij->i", n, n) < 1e-24):
        raise GeometryError("plane normals: a normal is the zero vector")
    w = -n
    u = np.cross(WORLD_UP, w)
    norm = np.linalg.norm(u, axis=1)
    flat = norm < 1e-6
    if np.any(flat):
        x = np.array([1.0, 0.0, 0.0])
        alt = x - (w[flat] @ x)[:, None] * w[flat]
        u[flat] = alt
        norm[flat] = np.linalg.norm(alt, axis=1)
    u = u / norm[:, None]
    v = np.cross(w, u)
    return np.stack([u, v, w], axis=2)


@dataclass(frozen=True)
class PartFrames:
    """The initial local frames of P planar parts.

    Attributes
    ----------
    origin : (P, 3) array, metres, world frame: the frame origin ``t`` (the part's centre, on
        its initial plane).
    axes : (P, 3, 3) array, world frame: columns ``u, v, w`` (``w = -n``).
    """

    origin: FloatArray
    axes: FloatArray

    @property
    def n_parts(self) -> int:
        """Number of parts P."""
        return int(self.origin.shape[0])

    @classmethod
    def from_planes(
        cls,
        normals: FloatArray,
        offsets: FloatArray,
        centres: FloatArray | None = None,
    ) -> PartFrames:
        """Frames for planes ``n·x = d``; origins are ``centres`` projected onto the planes.

        Parameters
        ----------
        normals : (P, 3) array, world frame (normalised here; zero vectors are an error).
        offsets : (P,) array, metres.
        centres : (P, 3) array, metres, world frame, or None for the point ``d·n``.

        Raises
        ------
        GeometryError
            On non-finite input, a zero normal or mismatched shapes.
        """
        n = np.asarray(normals, dtype=np.float64)
        d = np.asarray(offsets, dtype=np.float64)
        if n.ndim != 2 or n.shape[1] != 3 or d.shape != (n.shape[0],):
            raise GeometryError(
                f"planes: normals (P, 3) and offsets (P,) expected, got {n.shape} and {d.shape}"
            )
        _check_finite("plane normals", n)
        _check_finite("plane offsets", d)
        length = np.linalg.norm(n, axis=1)
        if np.any(length < 1e-12):
            raise GeometryError(f"plane {int(np.argmin(length))}: zero normal vector")
        n = n / length[:, None]
        d = d / length
        if centres is None:
            c = d[:, None] * n
        else:
            c = np.asarray(centres, dtype=np.float64)
            if c.shape != n.shape:
                raise GeometryError(f"centres: shape {n.shape} expected, got {c.shape}")
            _check_finite("plane centres", c)
            c = c + (d - np.einsum("ij,ij->i", n, c))[:, None] * n
        return cls(origin=c, axes=frame_axes(n))

    def planes(self, params: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Planes for parameters ``params`` (P, 3) = (delta m, alpha rad, beta rad).

        Returns
        -------
        normals : (P, 3) unit normals, world frame.
        offsets : (P,) metres.
        """
        n, d, _, _ = self._evaluate(params, jacobian=False)
        return n, d

    def planes_and_jacobian(
        self, params: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Planes and their analytic derivatives with respect to the part parameters.

        Returns
        -------
        normals : (P, 3); offsets : (P,);
        dn_dp : (P, 3, 3) with ``dn_dp[i, :, k] = d n_i / d p_ik``;
        dd_dp : (P, 3) with ``dd_dp[i, k] = d d_i / d p_ik``.
        """
        n, d, dn, dd = self._evaluate(params, jacobian=True)
        assert dn is not None
        assert dd is not None
        return n, d, dn, dd

    def centres(self, params: FloatArray) -> FloatArray:
        """Part centres (P, 3), metres, world frame: ``t + delta·n(p)``."""
        p = self._params(params)
        n, _ = self.planes(p)
        out: FloatArray = self.origin + p[:, 0:1] * n
        return out

    def rebased(self, params: FloatArray) -> PartFrames:
        """New frames whose zero parameters are the planes of ``params`` (for a fresh solve)."""
        p = self._params(params)
        n, d = self.planes(p)
        return PartFrames.from_planes(n, d, self.centres(p))

    def _params(self, params: FloatArray) -> FloatArray:
        p = np.asarray(params, dtype=np.float64)
        if p.shape != (self.n_parts, 3):
            raise GeometryError(
                f"part parameters: shape ({self.n_parts}, 3) expected, got {p.shape}"
            )
        return p

    def _evaluate(
        self, params: FloatArray, *, jacobian: bool
    ) -> tuple[FloatArray, FloatArray, FloatArray | None, FloatArray | None]:
        p = self._params(params)
        delta, alpha, beta = p[:, 0], p[:, 1], p[:, 2]
        ca, sa, cb, sb = np.cos(alpha), np.sin(alpha), np.cos(beta), np.sin(beta)
        u, v, w = self.axes[:, :, 0], self.axes[:, :, 1], self.axes[:, :, 2]
        w_new = sb[:, None] * u - (sa * cb)[:, None] * v + (ca * cb)[:, None] * w
        n = -w_new
        d = np.einsum("ij,ij->i", n, self.origin) + delta
        if not jacobian:
            return n, d, None, None
        dn_da = (ca * cb)[:, None] * v + (sa * cb)[:, None] * w
        dn_db = -(cb[:, None] * u) - (sa * sb)[:, None] * v + (ca * sb)[:, None] * w
        dn = np.zeros((self.n_parts, 3, 3))
        dn[:, :, 1] = dn_da
        dn[:, :, 2] = dn_db
        dd = np.empty((self.n_parts, 3))
        dd[:, 0] = 1.0
        dd[:, 1] = np.einsum("ij,ij->i", dn_da, self.origin)
        dd[:, 2] = np.einsum("ij,ij->i", dn_db, self.origin)
        return n, d, dn, dd
