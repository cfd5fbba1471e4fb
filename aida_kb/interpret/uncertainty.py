"""How well the evidence fixes a model and its cameras: standard deviations from the adjustment.

The model of a reconstruction is the solution of a least-squares adjustment of its planes
and its later views' poses (`aida_kb.interpret.joint.joint_problem`: every view's
segments on the model's edges, its regions on the parts, the knowledge's constraints among
the parts and the first shape's angles, loosely). At that solution, with J the Jacobian of
the whitened (and robustly weighted) residuals, the covariance of the unknowns is

    cov = (Σ_g J_gᵀ J_g / s_g² + J_kᵀ J_k)⁻¹,    s_g² = |r_g|² / Σ_{i in g} (1 - h_ii),

J_g the rows of one group of measurements (segments on edges, model edges fitted to the
images, regions on parts) and J_k the knowledge's and the priors' rows (not measured, so not
rescaled). s_g² is that group's variance factor: its noise model (`JOINT_EDGE_SIGMA_PX` across
an edge, a fit's own, a region's fit) scaled to the scatter its residuals show, over the
group's redundancy — the sum of its rows' redundancy numbers ``1 - h_ii``, h the hat matrix of
the measurements' rows alone (`redundancy_numbers`): the share of their own errors its
residuals keep, by each row's leverage (variance-component estimation, Förstner's; a row
alone on an edge keeps none, a direction no measurement reaches takes none). With fewer than
MIN_REDUNDANCY more measurements than unknowns the noise models stand as they are. A model
edge fitted in both images of a view is one edge seen twice (its two fits' errors correlate):
the pair's rows keep the redundancy of one measurement, not two (`paired_redundancy`). A
direction the evidence and the knowledge leave open (a part no factor reaches, a camera seeing
one edge) has an infinite deviation.

The knowledge lends no redundancy. Its constraints take unknowns away, so counted in h they
would leave the measurements more redundancy and smaller factors; but they are the
hypothesis under test, and a wrong one would certify itself: the tree crown of
tests/interpret/test_verdict.py (26 measurements, 18 unknowns, redundancy 8 alone, 14.4 with
the knowledge) got factors 0.06 / 0.006 instead of 1, and was verified as a house.

Calibration. On a synthetic joint adjustment with known noise (a box seen in three views,
segments with 0.5 px noise against the 4 px noise model, the meeting angles as priors:
``tests/interpret/test_calibration.py``) the cameras' mean squared error over their squared
deviation is 0.76 over 30 noise draws (the exact priors' redundancy not counted: 0.97 if it
were; 0.72 with the redundancy m - n shared by row count, as before). On rendered scenes, over
the registered cameras of right models (benchmark presets and dev seeds), the error over the
deviation has a median of 0.6 and a 90th percentile of 1.4 (a calibrated deviation of a 3-D
rotation: 0.7-0.9 and 1.4-1.6): the deviation of the cameras is mostly the model's orientation
in the first view's frame (house preset seed 0: 0.09 deg; 0.012 deg given the model).
Session 16, the image rounds' covariance recomputed at the kept right models of three dev sets
(kept runs of main 944ee2c and two older mains; error over deviation, median; within two
deviations): 61600-61635 12 cameras 0.53, 1.00; 61500-61535 15 cameras 0.82, 0.93; 61400-61435
11 cameras 0.97, 0.91 — about the vertical 0.31, 0.62, 1.07 (one axis, honest 0.67), in tilt
0.85, 0.64, 0.97 (two axes, 0.83). The deviations are honest: a right model's camera doubted at
0.06-0.09 deg (61606, 61620, 61622) is off by that much (61620: 0.06 deg, of which 0.04 is the
model's turn in the first view's frame) or may be, and no measurement group dominates them
(leaving out any one view's fits, regions, the knowledge or the first shape's angles moves them
by 5-20 %). A common ground plane measured by every view's stereo ground region (0.026 deg off
in the median) would shrink them by under 10 % where two views see the ground. The image rounds'
own covariance fixes the parts a region measures to 0.02-0.1 deg (error over deviation: median
0.55 on the right models of 61600-61635; the segments' problem here: 0.2-0.6 deg, median 0.22
over 160 parts), but check (i) keeps the segments' deviations: with the image rounds', two wrong
models of the dev sets (61525, 0.91 deg off; 61417, its floor 1.69 deg off) would pass every
check but the cameras'.

Session 20, the image rounds' covariance recomputed at the kept right models of every kept
closing set (61400-61935, 66 cameras; 63000-63035, 9), error over deviation: with each edge's
left and right fits counted as two independent rows the fits' variance factor was about half
what their residuals show (`paired_redundancy`; on the dev sets median 0.83, 90th percentile
1.62, 0.970 within two deviations, largest 2.82; 63000-63035 1.33, 3.08, 0.778, 3.11); with
each pair's rows as one measurement 0.72, 1.35, 0.985, 2.36 and 1.07, 2.77, 0.778, 2.82. The
fits' errors against the true edges (1,769 fits of those models) correlate between a view's
left and right images by more than `aida_kb.interpret.joint.STEREO_FIT_CORRELATION` says
(mean offsets 0.91, whitened 0.82; slopes 0.62): the same edge, the same shading beside it.

Session 21: the parts' deviations were too small for a few parts placed by one or two edges
(a floor seen at a grazing angle 1.1 deg off, 12 of its deviations): every measurement of one
edge, in every view and image, lies on the same boundary beside the true edge, a bias no count
of measurements averages away. Each edge now carries one shared bias (`EDGE_BIAS_PX`,
`edge_bias_information`) in the parts' covariance; the cameras' keep theirs without it.

The deviations, one per part (its normal, degrees; its offset at its centre, metres) and
one per camera of a view the adjustment moves (its rotation, degrees; its centre, metres),
go into ``model.json`` (`aida_kb.io.model.PartSd`, `CameraSd`) and are what the verdict's
checks (c) and (e) hold against the accuracy asked of them. The first view sets the world
frame: its camera has none.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.errors import AidaError

if TYPE_CHECKING:
    from aida_kb.constraints import Constraint
    from aida_kb.geometry.camera import PinholeCamera
    from aida_kb.interpret.result import Interpretation
    from aida_kb.io.evidence import Evidence
    from aida_kb.io.model import ReconstructedModel
    from aida_kb.kb.model import KnowledgeBase
    from aida_kb.solve.problem import Problem

FloatArray = npt.NDArray[np.float64]

NULL_EIGEN_REL = 1e-12  # eigenvalues of the information below this share of the largest are
# directions the adjustment leaves open (rounding level of a dense 64-bit normal matrix)
NULL_LOADING = 1e-6  # an unknown loading an open direction by more than this (squared
# component of the unit eigenvector) is not fixed: its deviation is infinite
MIN_REDUNDANCY = 10  # the residuals' scatter estimates a variance factor from at least ten
# more measurements than unknowns (with fewer its own standard error exceeds 30 %)
FACTOR_FLOOR = 1e-4  # a variance factor is never taken below this (residuals at rounding
# level on exact synthetic evidence would claim a model fixed to nothing)
ROTATION_STEP_RAD = 1e-6  # numerical derivative of a rotation's angle by its rotation vector


@dataclass(frozen=True)
class Uncertainty:
    """Standard deviations of an adjusted model's parts and cameras.

    parts : role -> (normal, degrees; offset at its centre, metres); inf: not fixed.
    cameras : view id -> (rotation, degrees; centre, metres) of the views the adjustment
        moves (not the first, which sets the world frame).
    variance_factor : s², the measurements' residual scatter over their noise model (the
        mean over their rows of each kind's factor).
    factors : each kind of measurement's variance factor (``edge``, ``camera_position``).
    edge_scatter_px : the scatter across an edge the segments show, pixels (the joint
        adjustment's edge sigma times the root of the edges' own variance factor).
    measurements, unknowns : rows of measurements (segments' and regions' residuals) and
        unknowns of the adjustment.
    on_regions : the parts a region of some view lies on (their normals are measured).
    """

    parts: dict[str, tuple[float, float]] = field(default_factory=dict)
    cameras: dict[str, tuple[float, float]] = field(default_factory=dict)
    variance_factor: float = 1.0
    factors: dict[str, float] = field(default_factory=dict)
    edge_scatter_px: float = math.nan
    measurements: int = 0
    unknowns: int = 0
    on_regions: frozenset[str] = frozenset()


def rotation_jacobian(rvec: FloatArray) -> FloatArray:
    """(3, 3): d(rotation vector of R(rvec + d)·R(rvec)ᵀ)/d(d) at d = 0 — how a step of the
    rotation vector turns the camera (radians per radian; the identity at rvec = 0)."""
    from scipy.spatial.transform import Rotation

    base = Rotation.from_rotvec(rvec)
    cols = [
        (Rotation.from_rotvec(rvec + ROTATION_STEP_RAD * e) * base.inv()).as_rotvec()
        / ROTATION_STEP_RAD
        for e in np.eye(3)
    ]
    return np.stack(cols, axis=1)


def covariance_of(info: FloatArray) -> FloatArray:
    """The inverse of a symmetric information matrix (n, n) on the directions it fixes;
    the variances of unknowns that load an open direction are infinite."""
    n = info.shape[0]
    if n == 0:
        return np.zeros((0, 0))
    w, V = np.linalg.eigh(info)
    top = float(w.max()) if w.size else 0.0
    if top <= 0:
        return np.full((n, n), np.inf)
    null = w <= NULL_EIGEN_REL * top
    keep = ~null
    cov: FloatArray = (V[:, keep] / w[keep]) @ V[:, keep].T
    open_ = (V[:, null] ** 2).sum(axis=1) > NULL_LOADING
    cov[open_, :] = np.inf
    cov[:, open_] = np.inf
    return cov


def adjustment_uncertainty(
    kb: KnowledgeBase, interp: Interpretation, evidence: Evidence
) -> Uncertainty | None:
    """The standard deviations of `interp`'s model and cameras (module docstring); None
    when there is no model, the first view has no camera or the problem cannot be built."""
    from aida_kb.interpret.joint import JointInputs, joint_problem, kb_constraints, meeting_angles
    from aida_kb.register import RigidModel
    from aida_kb.register.evidence import camera_of, measurements_of

    model = interp.model
    if model is None or not evidence.views:
        return None
    by_id = {v.id: v for v in evidence.views}
    reference = evidence.views[0].id
    cams_by_view = {c.view: c for c in model.cameras if c.view in by_id}
    if reference not in cams_by_view:
        return None
    order = [reference] + [v for v in cams_by_view if v != reference]
    try:
        rigid = RigidModel.from_model(model)
        cams = [camera_of(cams_by_view[v]) for v in order]
        views = [measurements_of(by_id[v]) for v in order]
        held = ground_held(model)
        free = [i for i in range(1, len(order)) if order[i] not in held]
        problem = joint_problem(
            rigid,
            cams,
            views,
            free,
            JointInputs(
                meeting_angles(rigid), kb_constraints(kb, interp, rigid.names), up=model.up
            ),
        )
    except AidaError:
        return None
    ids = [order[i] for i in free]
    unc = problem_uncertainty(problem, rigid.names, cams, free, ids, EDGE_BIAS_PX)
    if unc is None:
        return None
    own = image_edge_deviations(model)
    if not own:
        return unc
    cameras = {v: own.get(v, sd) for v, sd in unc.cameras.items()}
    cameras.update({v: own[v] for v in held if v in own})
    return replace(unc, cameras=cameras)


GROUND_TEXTURE_VARIANCE_INFLATION = 9.0
"""In the deviations of the later cameras from the adjustment with the ground's texture
(`aida_kb.interpret.groundtexture`; model.json ``sd`` with ``measurements`` "ground texture"),
the texture patches' variance factor is taken this many times what their scatter gives: three
times their noise. Their scatter is that of independent grey levels, but their error is not:
the ground's plane, which the first view's stereo pair fixes from hundreds of patches, comes
out 0.02-0.05 deg off (2-6 of its deviations; dev 71018, 71019, 72012, 72027), and the grazing
ground passes that on to the cameras' swing. Clustering the patches' residuals (per patch, per
60-240 px block of the image: a sandwich covariance) changes the deviations by under 20 %, so
the error is one the patches share, not their scatter.
Session 27 calibrated twice the cameras' whole deviation on the ground-texture cameras of the
right models (every normal within 0.5 deg, the right kind) of the kept dev runs: chosen on
70000-70035 and 71000-71035 (15 cameras; error over deviation median 1.51 and 10 of 15 within
two deviations as computed, 15 of 15 doubled), checked on 72000-72035 (6 cameras: 3 within two
deviations as computed, 5 doubled). The doubt belongs to the patches, not to the whole camera:
inflating the patches' noise, a camera the ground alone fixes keeps about that doubled
deviation, while one that the model's edges and its own regions fix as well keeps their share
undoubled. Session 31, 30 later cameras of 17 dev scenes (69004-69032, 71001-72027,
74002-74014): a camera's deviation over the doubled one is 0.55-1.31, median 0.90, at three
times the patches' noise (0.52-0.93, median 0.74, at twice: the cameras the ground fixes
would lose a quarter of the calibrated doubt; 72012 view 01, 0.158 deg off, keeps its 0.048).
Rejudged on one run each, the camera doubt leaves dev 74002 (a flat roof 0.012 deg off, 0.058
-> 0.047 deg: verified and correct) and 69018 view 02 (0.042 deg off, 0.061 -> 0.047); every
camera more than 0.1 deg off keeps its doubt but 72012's view 01 (doubted before for its
vertices, as now), and none is verified wrong."""


HELD_CAMERA_SD_DEG = 0.05
"""A later camera the reconstruction's adjustment with the ground's texture fixed to within
this (one sd of its rotation, model.json ``sd.measurements`` "ground texture", the patches'
noise tripled, `GROUND_TEXTURE_VARIANCE_INFLATION`; half the verdict's camera limit at 2 sd)
is held where it is in the verdict's problem: the parts' deviations are then those of the
model seen from known cameras. Its own deviation adds at most
this much (in quadrature, through the turn it gives the model) to a part's, whose limit is a
quarter of a degree at one sd (`aida_kb.interpret.verdict.tolerances`): 4 % of that variance.
Free, the camera's swing about the object, which the segments' problem alone leaves open to
0.06-0.23 deg, turns the model with it, and the parts' deviations are the swing's (dev 69009:
0.44-0.48 deg with the cameras 0.01-0.03 deg off)."""


def ground_held(model: ReconstructedModel) -> frozenset[str]:
    """The views whose cameras the verdict's problem holds (`HELD_CAMERA_SD_DEG`)."""
    return frozenset(
        c.view
        for c in model.cameras
        if c.sd is not None
        and c.sd.measurements == "ground texture"
        and c.sd.rotation_deg is not None
        and c.sd.rotation_deg <= HELD_CAMERA_SD_DEG
    )


RECONSTRUCTION_MEASUREMENTS = frozenset({"image edges", "ground texture"})
"""The ``measurements`` of a model camera's ``sd`` that the reconstruction's own last
adjustment gave (the images' edges, and the ground's texture where it was used): measurements
the verdict's segments' problem does not hold, so those deviations stand."""


def image_edge_deviations(model: ReconstructedModel) -> dict[str, tuple[float, float]]:
    """The cameras whose deviations the reconstruction's own last adjustment gave (model.json
    ``sd`` with ``measurements`` "image edges": `aida_kb.interpret.multiview.IMAGE_ROUNDS`, the
    model's edges fitted along the images, measurements the segments' problem here does not
    hold): view id -> (rotation, degrees; centre, metres). Those keep them."""
    return {
        c.view: (c.sd.rotation_deg, c.sd.centre_m)
        for c in model.cameras
        if c.sd is not None
        and c.sd.measurements in RECONSTRUCTION_MEASUREMENTS
        and c.sd.rotation_deg is not None
        and c.sd.centre_m is not None
    }


IMAGE_EDGE_LABEL = "image edge"
"""The label's start of an edge factor of a model edge fitted to an image (`aida_kb.interpret.
multiview.IMAGE_ROUNDS`): its noise model is the fit's own (`aida_kb.register.pose.
point_sigma`), not a segment's loose `JOINT_EDGE_SIGMA_PX`, so it gets its own variance
factor — pooled with the segments', whose scatter is a tenth of their 4 px, the fits' deviations
shrank fivefold (dev seed 58005: edge factor 0.05)."""


IMAGE_EDGE_MIN_FACTOR = 0.1
"""The fitted image edges' variance factor is never taken below this: an edge is fitted within
a few pixels of the model's own projection, so the fits follow the model they are fitted at and
their residuals from it understate their error. Against the TRUE model and cameras the dev
seeds' fits scatter by 0.4-1.3 of their noise model (whitened RMS), at the adjusted model by
0.1-0.5 (factors 0.01-0.3). With the fits the view's own segments contradict left out
(`aida_kb.interpret.imagefit.corroborated`) and an edge's left and right fits counted as one
seen twice (`aida_kb.interpret.joint.STEREO_FIT_CORRELATION`), the cameras' errors over
their deviations on 14 registered cameras of 10 dev scenes (58002-58023, image rounds on):
floor 1e-4 (none): median 0.94, 12 of 14 within 2 sd; 0.1: 0.94, 13 of 14; 0.25: 0.75, 13 of
14; 0.5: 0.67, 13 of 14; 1: 0.57, 13 of 14 (the one beyond: 58015's view 02, 0.48 deg off with
every fit within 0.3 px of the true edge — the model's own error, 0.36 deg). At 0.1 a camera
0.021 deg off (58006) is fixed to 0.047 deg (0.058 at 0.5, 0.063 at 1); without the two
corrections above, raw factors put 58005's camera, 0.032 deg off, at 0.014."""


def measurement_group(c: Constraint) -> str:
    """The group whose variance factor a factor takes: its kind, the fitted image edges apart
    from the segments; "" for a factor of the knowledge or a prior (not rescaled)."""
    if not c.measurement:
        return ""
    if c.kind == "edge" and c.label.startswith(IMAGE_EDGE_LABEL):
        return IMAGE_EDGE_LABEL
    return c.kind


def range_basis(J: FloatArray) -> FloatArray:
    """(m, rank) orthonormal columns spanning the range of J (m, n): the hat matrix of J is
    ``B Bᵀ``; directions J leaves open take none (as the pseudo-inverse)."""
    if J.shape[1] == 0:
        return np.zeros((J.shape[0], 0))
    w, V = np.linalg.eigh(J.T @ J)
    keep = w > NULL_EIGEN_REL * max(float(w.max()), 0.0)
    basis: FloatArray = J @ (V[:, keep] / np.sqrt(w[keep]))
    return basis


def redundancy_numbers(J: FloatArray) -> FloatArray:
    """(m,) each row's redundancy number ``1 - h_ii``, h the hat matrix ``J (JᵀJ)⁺ Jᵀ`` of the
    whitened Jacobian J (m, n): the share of its own error a row's residual keeps at the
    solution (the rest the unknowns absorb). They sum to m - rank(J); directions J leaves open
    take none (the pseudo-inverse)."""
    basis = range_basis(J)
    out: FloatArray = np.clip(1.0 - (basis * basis).sum(axis=1), 0.0, 1.0)
    return out


SNOOP_ALPHA = 1e-5
"""`outlying_measurement`: a factor's test (this share of a good factor's statistic lies
beyond the critical value, were the residuals Gaussian). Far in the tail on purpose: about 40
fitted image edges are tested in an adjustment, and the fits' residuals are not Gaussian (they
follow the model they are fitted at; an edge's left and right fits correlate). At 1e-3 a right
model's fits of no effect were dropped (dev 61534: in 2 of its 4 image rounds). A fit on the
wrong image line lies far beyond even 1e-9 (dev street 62402: view 00's ridge fitted off the
roof's edge, 8.3 of its squared noise model where the other fits show 0.26 in the mean, moved
view 01's camera 0.07 deg)."""
SNOOP_MIN_REDUNDANCY = 0.05
"""... and a factor whose residual keeps less than this share of its own error (the smallest
eigenvalue of its block of the residuals' cofactor matrix) is not tested: the unknowns absorb
its error, its residual shows none of it."""


def outlying_measurement(
    problem: Problem,
    names: Sequence[str],
    cameras: Sequence[PinholeCamera],
    free: Sequence[int],
    group: str,
) -> int | None:
    """The factor of measurement `group` (`measurement_group`) that the adjustment at the
    solution `problem` starts from explains worst, if it is an outlier (Baarda's data
    snooping): its whitened residual block r_b (k rows) against the residuals' cofactor block
    ``Q_b = I - B_b B_bᵀ`` (`range_basis` of the measurements' Jacobian), ``t = r_bᵀ Q_b⁻¹ r_b``,
    over the group's variance factor without it, ``s² = (Σ_g r² - t) / (redundancy_g - k)``;
    an outlier when ``t / s²`` exceeds k times the F(k, redundancy_g - k) quantile at
    1 - SNOOP_ALPHA. Returns its index in ``problem.constraints``; None when no factor is
    beyond, the group has fewer than MIN_REDUNDANCY more rows than its factors absorb, or the
    problem cannot be evaluated. Every part free, the cameras `free` (as
    `problem_uncertainty`); the residuals unweighted by the robust loss (the test is of the
    factor as measured)."""
    from scipy.stats import f as f_distribution

    linear = _linearised(problem, len(names), cameras, free, robust=False)
    if linear is None:
        return None
    r, J, of_row = linear
    measured = np.array([problem.constraints[int(c)].measurement for c in of_row], dtype=bool)
    basis = range_basis(J[measured])
    rm, cm = r[measured], of_row[measured]
    in_group = np.array([measurement_group(problem.constraints[int(c)]) == group for c in cm])
    if not in_group.any():
        return None
    B, rg = basis[in_group], rm[in_group]
    redundancy = float(np.clip(1.0 - (B * B).sum(axis=1), 0.0, 1.0).sum())
    total = float(rg @ rg)
    worst: tuple[float, int] | None = None
    for c in np.unique(cm[in_group]):
        rows = cm[in_group] == c
        k = int(rows.sum())
        if redundancy - k < MIN_REDUNDANCY:
            return None
        Q = np.eye(k) - B[rows] @ B[rows].T
        if float(np.linalg.eigvalsh(Q).min()) < SNOOP_MIN_REDUNDANCY:
            continue
        t = float(rg[rows] @ np.linalg.solve(Q, rg[rows]))
        s2 = max(total - t, 0.0) / (redundancy - k)
        critical = k * float(f_distribution.ppf(1.0 - SNOOP_ALPHA, k, redundancy - k))
        excess = t / max(s2, FACTOR_FLOOR) / critical
        if excess > 1.0 and (worst is None or excess > worst[0]):
            worst = (excess, int(c))
    return None if worst is None else worst[1]


def paired_redundancy(
    red: FloatArray, pairs: npt.NDArray[np.intp], correlation: float
) -> FloatArray:
    """(m,) the redundancy numbers `red` (m,) with the rows `pairs` (k, 2) (indices into `red`)
    taken as two measurements of one quantity whose errors correlate by `correlation` (rho),
    each weighed as one of their mean (sigma widened by ``sqrt(1 + rho)``: `aida_kb.interpret.
    joint.STEREO_FIT_CORRELATION`). Such a pair's residuals keep, in expectation, the
    share ``1 - h_a - h_b`` of their mean's error and ``(1 - rho) / (1 + rho)`` of their
    difference's, not ``(1 - h_a) + (1 - h_b)``: counted as two independent rows, a pair
    would claim a whole row's redundancy more than its residuals can show, and a group of
    such pairs about half the variance factor it has (less where one edge alone places a
    plane: its residuals keep nothing, the rows claim one). Each row of a pair gets half of
    the pair's redundancy (never below zero)."""
    out = red.copy()
    if pairs.size == 0:
        return out
    a, b = pairs[:, 0], pairs[:, 1]
    share = (1.0 - correlation) / (1.0 + correlation)
    pair = np.maximum(red[a] + red[b] - 1.0 + share, 0.0)
    out[a] = out[b] = 0.5 * pair
    return out


def variance_factors(
    r: FloatArray,
    J: FloatArray,
    groups: npt.NDArray[np.str_],
    measured: npt.NDArray[np.bool_],
    pairs: npt.NDArray[np.intp] | None = None,
    correlation: float = 0.0,
) -> dict[str, float]:
    """Each group of measurements' variance factor: its whitened residuals' sum of squares over
    its rows' redundancy numbers (`redundancy_numbers`; r (m,) and J (m, n) of every row,
    knowledge and priors too, `groups` (m,) each row's group, `measured` (m,) which rows are
    measurements). The rows `pairs` (k, 2) (indices of measured rows, into r) are two
    measurements of one quantity correlated by `correlation` (`paired_redundancy`). 1 for
    every group when the measurements outnumber the unknowns by fewer than MIN_REDUNDANCY;
    the fitted image edges' never under IMAGE_EDGE_MIN_FACTOR."""
    kinds = sorted(set(groups[measured].tolist()))
    if int(measured.sum()) - J.shape[1] < MIN_REDUNDANCY:
        return dict.fromkeys(kinds, 1.0)
    red_all = np.zeros(r.shape[0])
    red_all[measured] = redundancy_numbers(J[measured])
    if pairs is not None:
        red_all = paired_redundancy(red_all, pairs, correlation)
    red = red_all[measured]
    rm, gm = r[measured], groups[measured]
    factors = {}
    for kind in kinds:
        sel = gm == kind
        share = float(red[sel].sum())
        factors[kind] = max(float(rm[sel] @ rm[sel]) / share, FACTOR_FLOOR) if share > 0 else 1.0
        if kind == IMAGE_EDGE_LABEL:  # fitted around the model's own edges: see the constant
            factors[kind] = max(factors[kind], IMAGE_EDGE_MIN_FACTOR)
    return factors


EDGE_BIAS_PX = 1.0
"""A model edge's image line is known no better than this, pixels, however many segments and
fits measure it: each 3-D edge carries one systematic error shared by all its measurements in
every view and image (`edge_bias_information`). The image's line is the boundary the edge
shows (a wall's bottom against grass, a shadow, texture beside the corner), not the edge
itself, and every view sees the same boundary: on the kept dev models all fits of one floor
edge (both images of two views) lay on one wrong line, and a floor seen at a grazing angle was
placed 1.1 deg off with a deviation of 0.09 deg (64019: its two edges 1-3 px below the true
ones in view 00, the two edges' directions, not their positions, set the floor's normal).

The parts' normals, error over deviation at the kept models of the truth's form (right
specialisations, no part missing or extra, every normal within 5 deg; the verdict's segments'
problem; median, within two deviations, largest; and the parts whose two deviations are 0.5
deg or less yet are more than 0.5 deg off), by what places the part. Chosen on the closing sets
61400-61935 (1 px is the least of 0.25, 0.5, 0.75, 1 that leaves no such part: at 0.75
61522's floor, 0.97 deg off, had two deviations of 0.48 deg), checked on 63000-63035 and
64000-64035:

| parts | bias | median | within 2 sd | largest | 2 sd <= 0.5 and > 0.5 deg off |
|---|---|---|---|---|---|
| dev, on regions (390) | none | 0.39 | 0.941 | 6.8 | 3 (61402 two, 61623) |
| | 1 px | 0.26 | 0.959 | 3.4 | 0 |
| dev, by edges (385) | none | 0.26 | 0.956 | 7.4 | 2 (61517, 61522 floors) |
| | 1 px | 0.16 | 0.979 | 3.4 | 0 |
| check, on regions (159) | none | 0.39 | 0.962 | 3.9 | 2 (64023, 64035) |
| | 1 px | 0.25 | 1.000 | 1.7 | 0 |
| check, by edges (134) | none | 0.29 | 0.955 | 11.8 | 3 (63028, 63035, 64019 floors) |
| | 1 px | 0.19 | 0.993 | 2.9 | 0 |

(parts the knowledge alone places: 0.17-0.18 and 1.000 either way.) The medians stay under the
0.7-0.9 of a Gaussian error: most edges lie on their image lines to a fraction of a pixel, a
few are a pixel or more off, and one deviation cannot be both. The cameras' deviations take no
bias: recomputed at the same models (image rounds), the cameras' error over deviation had a
median of 0.78 and 0.929 within two deviations without it (56 dev cameras; 0.82 and 0.894 on
47 checked), and 0.48 and 0.982 with it (0.41 and 0.979), every camera then doubted at two
deviations: the image rounds' cameras are already as honest as they were calibrated to be
(`aida_kb.interpret.joint.IMAGE_SCATTER_BIAS`), and one bias seen alike in every view
leaves the views' poses relative to one another as the edges fix them."""


def edge_bias_information(
    problem: Problem,
    constraint_of_row: npt.NDArray[np.intp],
    J: FloatArray,
    Jw: FloatArray,
    bias_px: float,
) -> FloatArray:
    """(n, n) the information the model edges' shared biases take from the adjustment's.

    Each 3-D edge between parts a and b measured by image lines (``edge`` factors in pixels:
    segments and fitted edges, every view and image) is taken as displaced by one unknown
    error common to all of them: a step θ of its two planes' parameters (offsets and tilts,
    six; only how it moves the edge's line matters) with the covariance ``Σ = bias_px² N /
    rank (GᵀG)⁺``, G (N, 6) the image displacement of the factors' N end points by θ, pixels:
    in the mean over its measurements each end point of the edge's image lines is displaced
    by `bias_px` (one standard deviation), along every way the line can move in the views
    that see it, however many segments or fits there are. Marginalised, the edge's rows carry
    the covariance ``I + U Σ Uᵀ`` (U their whitened derivatives by θ), and the information
    ``JᵀJ`` of its rows loses ``Jᵀ U L (I + Lᵀ UᵀU L)⁻¹ Lᵀ Uᵀ J`` (Σ = L Lᵀ; the Schur
    complement of θ): many segments on one edge fix it no better than its bias, a part placed
    by one or two edges keeps the bias in its deviation.

    Parameters
    ----------
    problem : the adjustment's problem (every part free: part i's offset and tilts are
        columns 3i..3i+2).
    constraint_of_row : (m,) each residual row's constraint.
    J : (m, n) the rows' Jacobian whitened by their noise models (per pixel of their sigma).
    Jw : (m, n) ``J`` with each measurement row rescaled by its group's variance factor.
    bias_px : the edges' bias, pixels (one standard deviation).
    """
    n = J.shape[1]
    out = np.zeros((n, n))
    if bias_px <= 0:
        return out
    # the edge factors (K) and their edges' part pairs; the factors' rows follow with numpy
    factors, pairs = [], []
    for ci, c in enumerate(problem.constraints):
        whitened = c.sqrt_information is not None and len(c.sqrt_information) == 2
        if c.kind == "edge" and c.measurement and c.unit == "px" and whitened and len(c.parts) == 2:
            factors.append(ci)
            pairs.append((min(c.parts), max(c.parts)))
    order = np.argsort(constraint_of_row, kind="stable")
    starts = np.searchsorted(constraint_of_row[order], np.arange(len(problem.constraints) + 1))
    ci_all = np.asarray(factors, dtype=np.intp)
    two = (starts[ci_all + 1] - starts[ci_all]) == 2 if factors else np.zeros(0, dtype=bool)
    if not two.any():
        return out
    ci_all = ci_all[two]
    # the edges (P of them) and each factor's edge
    edge_pairs, edge_of = np.unique(np.asarray(pairs)[two], axis=0, return_inverse=True)
    edge_of = edge_of.reshape(-1)
    P = len(edge_pairs)
    cols = np.hstack([3 * edge_pairs[:, :1] + np.arange(3), 3 * edge_pairs[:, 1:] + np.arange(3)])
    rows = order[starts[ci_all][:, None] + np.arange(2)]  # (K, 2) each factor's two rows
    S = np.asarray([problem.constraints[ci].sqrt_information for ci in ci_all], dtype=np.float64)
    fcols = cols[edge_of]  # (K, 6)
    # each factor's end points' displacements by its edge's step, pixels: whitening undone
    G = np.linalg.solve(S, J[rows[:, :, None], fcols[:, None, :]])  # (K, 2, 6)
    GtG = np.zeros((P, 6, 6))
    np.add.at(GtG, edge_of, np.einsum("kri,krj->kij", G, G))
    w, V = np.linalg.eigh(GtG)  # (P, 6), (P, 6, 6)
    keep = w > NULL_EIGEN_REL * np.maximum(w.max(axis=1, keepdims=True), 0.0)
    rank = keep.sum(axis=1)
    count = np.bincount(edge_of, minlength=P) * 2  # end points per edge
    scale = (
        bias_px * np.sqrt(count / np.maximum(rank, 1))[:, None] / np.sqrt(np.where(keep, w, 1.0))
    )
    L = V * np.where(keep, scale, 0.0)[:, None, :]  # (P, 6, 6); columns of dropped directions 0
    row_edge = np.repeat(edge_of, 2)
    flat_rows = rows.reshape(-1)
    Jr = Jw[flat_rows]  # (R, n)
    Uz = np.einsum(
        "ri,rij->rj", Jr[np.arange(len(flat_rows))[:, None], cols[row_edge]], L[row_edge]
    )
    M = np.zeros((P, n, 6))
    np.add.at(M, row_edge, Jr[:, :, None] * Uz[:, None, :])
    UtU = np.zeros((P, 6, 6))
    np.add.at(UtU, row_edge, Uz[:, :, None] * Uz[:, None, :])
    X = np.linalg.solve(np.eye(6)[None] + UtU, M.transpose(0, 2, 1))  # (P, 6, n)
    out += np.einsum("pna,pam->nm", M, X)
    return out


def stereo_fit_pairs(
    problem: Problem, constraint_of_row: npt.NDArray[np.intp]
) -> npt.NDArray[np.intp]:
    """(k, 2) the residual rows (indices; `constraint_of_row` (m,) each row's constraint) of the
    model edges fitted in both images of one view (`aida_kb.interpret.imagefit.fitted_edges`),
    row by row: the left image's fit's and the right image's (a camera derived from the
    view's, `aida_kb.solve.problem.Problem.derived`), paired by edge and view."""
    sides: dict[tuple[int, int, int], dict[bool, int]] = {}
    for ci, c in enumerate(problem.constraints):
        if measurement_group(c) != IMAGE_EDGE_LABEL or c.edge is None or len(c.parts) != 2:
            continue
        base = problem.base_camera(c.edge.camera)
        a, b = c.parts
        sides.setdefault((base, min(a, b), max(a, b)), {})[base != c.edge.camera] = ci
    out = []
    for both in sides.values():
        if len(both) != 2:
            continue
        left = np.flatnonzero(constraint_of_row == both[False])
        right = np.flatnonzero(constraint_of_row == both[True])
        if left.size == right.size:
            out.append(np.stack([left, right], axis=1))
    return np.vstack(out) if out else np.zeros((0, 2), dtype=np.intp)


@dataclass(frozen=True)
class Information:
    """An adjustment's measurements and knowledge linearised at its solution, whitened.

    J : (m, n) every residual row's derivatives by the unknowns (each part's offset and two
        tilts, 3 a part, then each free camera's rotation vector and centre, 6 a camera),
        per sigma of its noise model; Jw : J with each measurement row rescaled by its
        group's variance factor (`variance_factors`), the rows the covariance is made of.
    rows : (m,) each row's constraint index into the problem's constraints.
    groups : (m,) each row's group (`measurement_group`); measured : (m,) whether it is a
        measurement (the knowledge's and the priors' rows are not).
    factors : each group's variance factor.
    """

    J: FloatArray
    Jw: FloatArray
    rows: npt.NDArray[np.intp]
    groups: npt.NDArray[np.str_]
    measured: npt.NDArray[np.bool_]
    factors: dict[str, float]


def _linearised(
    problem: Problem,
    parts: int,
    cameras: Sequence[PinholeCamera],
    free: Sequence[int],
    *,
    robust: bool,
) -> tuple[FloatArray, FloatArray, npt.NDArray[np.intp]] | None:
    """`problem` linearised at the solution it starts from, its `parts` parts all free and the
    cameras `free` (indices into `cameras`): the residuals r (m,), their derivatives J (m, n)
    and each row's constraint index (m,); weighted by the joint adjustment's robust loss when
    `robust`. None when the problem cannot be evaluated or a value is not finite."""
    from aida_kb.interpret.joint import JOINT_F_SCALE, JOINT_LOSS
    from aida_kb.solve import Evaluation

    try:
        ev = Evaluation(
            problem,
            np.arange(parts, dtype=np.intp),
            free_cameras=np.asarray(free, dtype=np.intp),
            loss=JOINT_LOSS if robust else "linear",
            f_scale=JOINT_F_SCALE if robust else 1.0,
        )
        r, J = ev.residuals_and_dense_jacobian(ev.x_from(np.zeros((parts, 3)), list(cameras)))
    except AidaError:
        return None
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(J))):
        return None
    return r, J, np.asarray(ev.constraint_of_row, dtype=np.intp)


def problem_information(
    problem: Problem,
    parts: int,
    cameras: Sequence[PinholeCamera],
    free: Sequence[int],
    inflation: Mapping[str, float] | None = None,
) -> Information | None:
    """The whitened rows of `problem` (`Information`) at the solution it starts from: its
    `parts` parts all free and the cameras `free` (indices into `cameras`, the problem's
    first cameras). `inflation` : group (`measurement_group`) -> a multiplier of its variance
    factor (errors its rows share, which their scatter does not show). None when a residual
    or derivative is not finite or the problem cannot be evaluated."""
    from aida_kb.interpret.joint import STEREO_FIT_CORRELATION

    linear = _linearised(problem, parts, cameras, free, robust=True)
    if linear is None:
        return None
    r, J, of_row = linear
    rows = [problem.constraints[int(c)] for c in of_row]
    measured = np.array([c.measurement for c in rows], dtype=bool)
    groups = np.array([measurement_group(c) for c in rows])
    pairs = stereo_fit_pairs(problem, of_row)
    factors = variance_factors(r, J, groups, measured, pairs, STEREO_FIT_CORRELATION)
    for kind, times in (inflation or {}).items():
        if kind in factors:
            factors[kind] *= times
    scale = np.ones(r.shape[0])
    for kind, fk in factors.items():
        scale[groups == kind] = 1.0 / math.sqrt(fk)
    return Information(J, J * scale[:, None], of_row, groups, measured, factors)


def camera_rotation_covariance(
    cov: FloatArray, parts: int, k: int, camera: PinholeCamera
) -> FloatArray:
    """(3, 3) the covariance of the `k`-th free camera's rotation (radians²) about its own
    axes (x right, y down, z forward: a turn R -> exp([w]) R, w in the camera frame), from the
    covariance `cov` (n, n) of an adjustment's unknowns with `parts` parts (`Information`)."""
    col = 3 * parts + 6 * k
    block = cov[col : col + 3, col : col + 3]
    if not np.all(np.isfinite(block)):  # a camera the evidence leaves open
        return np.full((3, 3), np.inf)
    G = rotation_jacobian(camera.pose[:3])
    out: FloatArray = G @ block @ G.T
    return out


def problem_uncertainty(
    problem: Problem,
    names: Sequence[str],
    cameras: Sequence[PinholeCamera],
    free: Sequence[int],
    views: Sequence[str],
    edge_bias_px: float = 0.0,
    inflation: Mapping[str, float] | None = None,
) -> Uncertainty | None:
    """The standard deviations (module docstring) at the solution `problem` starts from:
    every part free (`names`, in order) and the cameras `free` (indices into `cameras`, the
    problem's first cameras; `views` their ids, which key `Uncertainty.cameras`). The parts'
    with each model edge's shared bias of `edge_bias_px` pixels (`edge_bias_information`;
    `EDGE_BIAS_PX` in the verdict), the cameras' without it (`EDGE_BIAS_PX` says why).
    `inflation` : as for `problem_information` (`GROUND_TEXTURE_VARIANCE_INFLATION`). None
    when a residual or derivative is not finite or the problem cannot be evaluated."""
    from aida_kb.interpret.joint import JOINT_EDGE_SIGMA_PX

    P = len(names)
    info_rows = problem_information(problem, P, cameras, free, inflation)
    if info_rows is None:
        return None
    J, Jw, of_row = info_rows.J, info_rows.Jw, info_rows.rows
    kinds, factors = info_rows.groups, info_rows.factors
    m, n = int(info_rows.measured.sum()), J.shape[1]
    info = Jw.T @ Jw
    cov = covariance_of(info)
    biased = (
        covariance_of(info - edge_bias_information(problem, of_row, J, Jw, edge_bias_px))
        if edge_bias_px > 0
        else cov
    )
    total = sum(factors[k] * int((kinds == k).sum()) for k in factors)
    factor = total / m if m else 1.0
    var = np.diag(biased)
    parts = {}
    for i, name in enumerate(names):
        d, a, b = var[3 * i : 3 * i + 3]
        parts[name] = (math.degrees(math.sqrt(a + b)), math.sqrt(d))
    deviations = {}
    for k, view in enumerate(views):
        col = 3 * P + 6 * k
        rot = camera_rotation_covariance(cov, P, k, cameras[free[k]])
        if np.all(np.isfinite(rot)):
            angle = math.degrees(math.sqrt(max(float(np.trace(rot)), 0.0)))
        else:
            angle = math.inf
        centre = math.sqrt(max(float(np.trace(cov[col + 3 : col + 6, col + 3 : col + 6])), 0.0))
        deviations[view] = (angle, centre if math.isfinite(angle) else math.inf)
    edge = factors.get("edge")
    on_regions = frozenset(
        names[c.parts[0]]
        for c in problem.constraints
        if c.kind == "camera_position" and c.measurement and c.parts
    )
    return Uncertainty(
        parts,
        deviations,
        factor,
        factors,
        JOINT_EDGE_SIGMA_PX * math.sqrt(edge) if edge is not None else math.nan,
        m,
        n,
        on_regions,
    )
