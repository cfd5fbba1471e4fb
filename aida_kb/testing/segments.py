"""Simulated line-segment evidence of a known model, for the tests and benchmarks/registration.py.

`simulated_segments` projects the edges a camera sees, breaks some into pieces, drops a few,
adds Gaussian noise to the edge points, fits the segments to them and scatters clutter
segments over the image — what a
line detector gives of a clean object in a busy scene. Not part of registration itself.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.register.model import RigidModel

FloatArray = npt.NDArray[np.float64]

__all__ = ["simulated_segments"]


def simulated_segments(
    model: RigidModel,
    camera: PinholeCamera,
    rng: np.random.Generator,
    *,
    noise_px: float = 0.5,
    clutter: int = 40,
    split_fraction: float = 0.3,
    drop_fraction: float = 0.1,
    fit_points: bool = True,
) -> tuple[FloatArray, FloatArray]:
    """Segments (p1, p2), each (S, 2) pixels, that `camera` would detect of `model`'s edges.

    Parameters
    ----------
    noise_px : standard deviation of the Gaussian image noise, pixels: of every edge point
        (one per pixel along an edge, in x and y) to which a segment is then fitted by total
        least squares (``fit_points``, what a line detector does), or of the end points
        themselves (``fit_points=False``, and always for the clutter).
    clutter : number of random segments (10..80 px, any direction) added over the image.
    split_fraction : fraction of edges broken into two pieces with a gap between them.
    drop_fraction : fraction of edges not detected at all.
    """
    vis = model.visible_edges(camera, margin_px=2.0)
    a, b = vis.a, vis.b
    n = a.shape[0]
    keep = rng.random(n) >= drop_fraction
    split = rng.random(n) < split_fraction
    pieces_a: list[FloatArray] = [a[keep & ~split], ((a + b) / 2 + 0.03 * (b - a))[keep & split]]
    pieces_b: list[FloatArray] = [b[keep & ~split], b[keep & split]]
    pieces_a.append(a[keep & split])
    pieces_b.append(((a + b) / 2 - 0.03 * (b - a))[keep & split])
    # detectors shorten edges at corners a little
    p1 = np.concatenate(pieces_a)
    p2 = np.concatenate(pieces_b)
    d = p2 - p1
    p1 = p1 + 0.02 * d
    p2 = p2 - 0.02 * d
    if fit_points:
        p1, p2 = _fitted(p1, p2, noise_px, rng)
    else:
        p1 = p1 + rng.normal(scale=noise_px, size=p1.shape)
        p2 = p2 + rng.normal(scale=noise_px, size=p2.shape)
    size = np.array([camera.width, camera.height], dtype=np.float64)
    centres = rng.random((clutter, 2)) * size
    angle = rng.random(clutter) * np.pi
    half = (10.0 + 70.0 * rng.random(clutter)) / 2
    dirs = np.stack([np.cos(angle), np.sin(angle)], axis=1) * half[:, None]
    c1 = centres - dirs + rng.normal(scale=noise_px, size=centres.shape)
    c2 = centres + dirs + rng.normal(scale=noise_px, size=centres.shape)
    p1 = np.concatenate([p1, c1])
    p2 = np.concatenate([p2, c2])
    order = rng.permutation(p1.shape[0])
    return p1[order], p2[order]


def _fitted(
    p1: FloatArray, p2: FloatArray, noise_px: float, rng: np.random.Generator
) -> tuple[FloatArray, FloatArray]:
    """Segments fitted (total least squares) to edge points one pixel apart with 2-D noise."""
    if p1.shape[0] == 0:
        return p1, p2
    length = np.linalg.norm(p2 - p1, axis=1)
    n = np.maximum(np.ceil(length).astype(np.intp), 2)
    ids = np.repeat(np.arange(n.size), n)
    first = np.concatenate([[0], np.cumsum(n)[:-1]])
    s = (np.arange(ids.size) - first[ids]) / (n[ids] - 1)
    pts = p1[ids] + s[:, None] * (p2 - p1)[ids]
    pts = pts + rng.normal(scale=noise_px, size=pts.shape)
    count = n.astype(np.float64)
    mean = np.stack(
        [np.bincount(ids, pts[:, k], minlength=n.size) / count for k in range(2)], axis=1
    )
    r = pts - mean[ids]
    cxx = np.bincount(ids, r[:, 0] * r[:, 0], minlength=n.size)
    cxy = np.bincount(ids, r[:, 0] * r[:, 1], minlength=n.size)
    cyy = np.bincount(ids, r[:, 1] * r[:, 1], minlength=n.size)
    theta = 0.5 * np.arctan2(2.0 * cxy, cxx - cyy)
    u = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    t_first = np.einsum("ij,ij->i", pts[first] - mean, u)
    t_last = np.einsum("ij,ij->i", pts[first + n - 1] - mean, u)
    return mean + t_first[:, None] * u, mean + t_last[:, None] * u
