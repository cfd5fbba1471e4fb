"""What limits a later view's camera (not a test). Prints a line per registered view, then ONE
line of JSON.

For each kept robustness scene (``scene-SEED/`` with its truth, ``out-SEED/`` with the
interpretation, evidence and model, as ``benchmarks/robustness.py --keep DIR`` leaves them)
whose model has the truth's parts, the image rounds' last problem is built again at the kept
model and cameras (`aida_kb.interpret.joint.joint_problem`: the model's edges fitted to every
view's left and right images, `aida_kb.interpret.imagefit.fitted_edges`, later-round fits
more than `IMAGE_REJECT_SIGMAS` off left out; the regions; the segments of edges without a
clean fit; the knowledge's constraints; the model's own angles standing for the first
shape's; the fits the snooping left out are not known here) and its covariance taken as the
reconstruction takes it (`aida_kb.interpret.uncertainty.problem_information`). Each later
camera's rotation is split about its own axes (x right: tilt; y down: the turn about the
vertical, "pan"; z forward: roll), and its deviation is given

- as the reconstruction gives it (``sd``), and by axis;
- given the model (``given_model``: the camera's own block of the information, the model's
  planes and the other cameras held; what the view fixes of its pose against the model);
- without the right images' fits, without the regions, without the segments (which group
  of measurements carries it);
- at the TRUTH (``truth_sd``): the same problem with the true model and cameras, the edges
  fitted there (what the evidence gives where nothing is off: data-limited if it is no
  smaller).

and its error against the truth by axis with the centre's error in the camera's axes (a
turn about the vertical with a sideways shift of the centre by the turn times the
distance is the camera orbiting the object: the object's turn as the view sees it).

JSON: ``cameras``; medians of ``sd_deg``, ``given_model_deg``, ``truth_sd_deg``,
``no_right_deg``, ``no_regions_deg``, ``no_segments_deg``; ``model_share`` (median of 1 -
given_model² / sd²: the share of the variance that is the model's, mostly its turn in the first
view's frame); ``pan_share_sd`` and ``pan_share_err`` (medians of the pan's share of the
variance and of the squared error); ``orbit_m_per_deg`` (median of the centre's sideways error
over the pan error, metres per degree, against ``distance_m_per_deg``, the sideways shift of
an orbit about the model's centre: the camera's distance from it times pi / 180).

Run: ``python benchmarks/camera_limits.py KEEP [KEEP ...]`` (``--seeds A-B`` to restrict).

Measured on the kept runs of main a0bedb4 (session 23; the registered views of models with
the truth's parts, medians; dev 66000-66035 then 65000-65035, 34 and 35 views): sd 0.103 /
0.131 deg, given the model 0.043 / 0.058, at the truth 0.138 / 0.146, without the regions
0.171 / 0.214, without the right images' fits 0.128 / 0.161, without the segments 0.121 /
0.149; model_share 0.83 / 0.82; pan_share_err 0.67 / 0.61, pan_share_sd 0.58 / 0.54;
orbit_m_per_deg 0.82 / 0.90 against distance_m_per_deg 0.76 / 0.95. The errors are the swing
about the object, the regions' normals fix it, and at the truth the evidence fixes the
cameras no better: data-limited (docs/architecture.md, after the tie points).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from aida_kb.constraints import Constraint
    from aida_kb.geometry.camera import PinholeCamera
    from aida_kb.interpret.result import Interpretation
    from aida_kb.io.evidence import Evidence
    from aida_kb.io.model import ModelCamera, ReconstructedModel
    from aida_kb.io.scene import Scene
    from aida_kb.io.truth import PoseTruth, SceneTruth
    from aida_kb.kb.model import KnowledgeBase
    from aida_kb.register import RigidModel
    from aida_kb.solve.problem import Problem

FloatArray = npt.NDArray[np.float64]
RowFilter = Callable[["Constraint", "Problem"], bool]

FAR_DEG = 2.0
"""A camera more than this far off the truth was registered to a wrong pose (a twin): its
error is no measurement noise, and the view is left out."""


def _right_fit(c: Constraint, problem: Problem) -> bool:
    """A row of a model edge fitted in a right image (a camera derived from a view's)."""
    from aida_kb.interpret.uncertainty import IMAGE_EDGE_LABEL, measurement_group

    if measurement_group(c) != IMAGE_EDGE_LABEL or c.edge is None:
        return False
    return problem.base_camera(c.edge.camera) != c.edge.camera


def _region(c: Constraint, problem: Problem) -> bool:
    return c.kind == "camera_position" and c.measurement


def _segment(c: Constraint, problem: Problem) -> bool:
    from aida_kb.interpret.uncertainty import measurement_group

    return measurement_group(c) == "edge"


WITHOUT: dict[str, RowFilter] = {
    "no_right": _right_fit,
    "no_regions": _region,
    "no_segments": _segment,
}
"""The groups of rows left out, one at a time, to see which carries a camera."""


def _problem(
    kb: KnowledgeBase,
    interp: Interpretation,
    evidence: Evidence,
    scene: Scene,
    rigid: RigidModel,
    cameras: list[PinholeCamera],
    order: list[str],
) -> tuple[Problem, list[int]]:
    """The image rounds' problem at `rigid` and `cameras` (views `order`, the first fixed):
    the problem and each view's count of left-image fits."""
    from aida_kb.interpret.imagefit import fitted_edges, right_images, view_images
    from aida_kb.interpret.joint import JointInputs, joint_problem, kb_constraints, meeting_angles
    from aida_kb.interpret.multiview import IMAGE_REJECT_SIGMAS
    from aida_kb.register.evidence import measurements_of

    model = interp.model
    assert model is not None
    by_id = {v.id: v for v in evidence.views}
    views = [measurements_of(by_id[v]) for v in order]
    greys = view_images(scene, evidence, views)
    rights = right_images(scene, order)
    fl, fr = fitted_edges(rigid, cameras, greys, rights, IMAGE_REJECT_SIGMAS, views, model.up)
    inputs = JointInputs(
        meeting_angles(rigid),
        kb_constraints(kb, interp, rigid.names),
        [None] * len(order),
        fl,
        fr,
        model.up,
    )
    free = list(range(1, len(order)))
    problem = joint_problem(rigid, cameras, views, free, inputs)
    return problem, [0 if f is None else f.size for f in fl]


def _covariance(
    problem: Problem,
    parts: int,
    cameras: list[PinholeCamera],
    drop: RowFilter | None = None,
) -> FloatArray | None:
    """The unknowns' covariance (`problem_information`), with the rows `drop` names left out."""
    from aida_kb.interpret.uncertainty import covariance_of, problem_information

    info = problem_information(problem, parts, cameras, list(range(1, len(cameras))))
    if info is None:
        return None
    Jw = info.Jw
    if drop is not None:
        keep = np.array([not drop(problem.constraints[int(i)], problem) for i in info.rows])
        Jw = Jw[keep]
    return covariance_of(Jw.T @ Jw)


def _given_model(
    problem: Problem, parts: int, cameras: list[PinholeCamera], k: int
) -> FloatArray | None:
    """(3, 3) the k-th free camera's rotation covariance (its axes, rad²) with the model and
    the other cameras held: the inverse of its own rotation-and-centre block."""
    from aida_kb.interpret.uncertainty import problem_information, rotation_jacobian

    info = problem_information(problem, parts, cameras, list(range(1, len(cameras))))
    if info is None:
        return None
    col = 3 * parts + 6 * k
    block = info.Jw[:, col : col + 6]
    try:
        inv = np.linalg.inv(block.T @ block)
    except np.linalg.LinAlgError:
        return None
    G = rotation_jacobian(cameras[k + 1].pose[:3])
    out: FloatArray = G @ inv[:3, :3] @ G.T
    return out


def _deg(cov: FloatArray | None) -> float:
    """A rotation's deviation, degrees, from its covariance (rad²); inf when not fixed."""
    if cov is None or not np.all(np.isfinite(cov)):
        return math.inf
    return math.degrees(math.sqrt(max(float(np.trace(cov)), 0.0)))


def registered_views(
    evidence: Evidence, model: ReconstructedModel, truth: SceneTruth
) -> tuple[list[str], dict[str, ModelCamera], dict[str, PoseTruth]]:
    """The views whose cameras a kept model placed and the truth knows, the evidence's first
    view leading (none unless it and a later view are there), with the model's and the
    truth's cameras by view."""
    ids = {v.id for v in evidence.views}
    placed = {c.view: c for c in model.cameras if c.view in ids}
    true_poses = {v.view: v for v in truth.views}
    first = evidence.views[0].id
    order = [first] + [v for v in placed if v != first and v in true_poses]
    if len(order) < 2 or first not in placed:
        order = []
    return order, placed, true_poses


def scene_views(
    keep: Path, seed: int, kb_of: Callable[[str], KnowledgeBase]
) -> list[dict[str, object]]:
    """One record per registered later view of the kept scene `seed` in `keep` whose model
    has the truth's parts (none otherwise): its figures (module docstring)."""
    from scipy.spatial.transform import Rotation

    from aida_kb.errors import AidaError
    from aida_kb.geometry.camera import PinholeCamera
    from aida_kb.interpret.result import read_interpretation
    from aida_kb.interpret.uncertainty import camera_rotation_covariance
    from aida_kb.io.evidence import read_evidence
    from aida_kb.io.scene import read_scene
    from aida_kb.register import RigidModel
    from aida_kb.register.evidence import camera_of

    out_dir = keep / f"out-{seed}"
    if not (out_dir / "interpretation.json").is_file():
        return []
    scene = read_scene(keep / f"scene-{seed}")
    truth = scene.truth
    interp = read_interpretation(out_dir / "interpretation.json")
    evidence = read_evidence(out_dir / "evidence.json")
    model = interp.model
    if truth is None or not truth.parts or model is None or len(model.cameras) < 2:
        return []
    true_parts = {p.role: p for p in truth.parts}
    if sorted(true_parts) != sorted(p.role for p in model.parts):
        return []
    order, placed, true_poses = registered_views(evidence, model, truth)
    if not order:
        return []
    kb = kb_of(str(truth.parameters.get("knowledge", "buildings.kb")))
    try:
        rigid = RigidModel.from_model(model)
        ps = [true_parts[n] for n in rigid.names]
        true_rigid = RigidModel.from_polygons(
            list(rigid.names),
            np.array([p.normal for p in ps], dtype=np.float64),
            np.array([p.d for p in ps], dtype=np.float64),
            [np.asarray(p.polygon, dtype=np.float64) for p in ps],
        )
        cams = [camera_of(placed[v]) for v in order]
        true_cams = [
            PinholeCamera(
                np.asarray(true_poses[v].K, dtype=np.float64),
                np.asarray(true_poses[v].R, dtype=np.float64),
                np.asarray(true_poses[v].t, dtype=np.float64),
                c.width,
                c.height,
            )
            for v, c in zip(order, cams, strict=True)
        ]
        problem, fits = _problem(kb, interp, evidence, scene, rigid, cams, order)
        true_problem, true_fits = _problem(
            kb, interp, evidence, scene, true_rigid, true_cams, order
        )
    except AidaError as exc:
        print(f"seed {seed}: {exc}", file=sys.stderr)
        return []
    P = len(rigid.names)
    cov = _covariance(problem, P, cams)
    true_cov = _covariance(true_problem, P, true_cams)
    without = {name: _covariance(problem, P, cams, drop) for name, drop in WITHOUT.items()}
    centre = np.vstack([np.asarray(p.polygon, dtype=np.float64) for p in model.parts]).mean(axis=0)
    records: list[dict[str, object]] = []
    for k, view in enumerate(order[1:]):
        cam, true_cam = cams[k + 1], true_cams[k + 1]
        error = np.degrees(
            Rotation.from_matrix(cam.R_cam_world @ true_cam.R_cam_world.T).as_rotvec()
        )
        if float(np.linalg.norm(error)) > FAR_DEG or cov is None:
            continue
        shift = true_cam.R_cam_world @ (cam.centre - true_cam.centre)
        rot = camera_rotation_covariance(cov, P, k, cam)
        axes = np.degrees(np.sqrt(np.maximum(np.diag(rot), 0.0)))
        rec: dict[str, object] = {
            "seed": seed,
            "view": view,
            "error_deg": round(float(np.linalg.norm(error)), 4),
            "error_xyz_deg": [round(float(e), 4) for e in error],
            "centre_error_xyz_m": [round(float(e), 4) for e in shift],
            "distance_m": round(float(np.linalg.norm(cam.centre - centre)), 2),
            "sd_deg": round(_deg(rot), 4),
            "sd_xyz_deg": [round(float(a), 4) for a in axes],
            "given_model_deg": round(_deg(_given_model(problem, P, cams, k)), 4),
            "truth_sd_deg": round(
                _deg(
                    None
                    if true_cov is None
                    else camera_rotation_covariance(true_cov, P, k, true_cam)
                ),
                4,
            ),
            "fits_left": fits[k + 1],
            "truth_fits_left": true_fits[k + 1],
        }
        for name, c in without.items():
            rec[f"{name}_deg"] = round(
                _deg(None if c is None else camera_rotation_covariance(c, P, k, cam)), 4
            )
        records.append(rec)
    return records


def _median(values: list[float]) -> float | None:
    finite = [v for v in values if math.isfinite(v)]
    return round(float(np.median(finite)), 4) if finite else None


def _number(record: dict[str, object], name: str) -> float:
    """A record's figure as a float (NaN when it is not a number)."""
    value = record.get(name)
    return float(value) if isinstance(value, (int, float)) else math.nan


def summary(records: list[dict[str, object]]) -> dict[str, object]:
    """The JSON line's figures over the views' records (module docstring)."""

    def col(name: str) -> list[float]:
        return [_number(r, name) for r in records]

    model_share, pan_sd, pan_err, orbit, distance = [], [], [], [], []
    for r in records:
        sd, given = _number(r, "sd_deg"), _number(r, "given_model_deg")
        axes = np.asarray(r["sd_xyz_deg"], dtype=np.float64)
        error = np.asarray(r["error_xyz_deg"], dtype=np.float64)
        shift = np.asarray(r["centre_error_xyz_m"], dtype=np.float64)
        if math.isfinite(sd) and sd > 0 and math.isfinite(given):
            model_share.append(max(1.0 - (given / sd) ** 2, 0.0))
        if float(np.sum(axes**2)) > 0:
            pan_sd.append(float(axes[1] ** 2 / np.sum(axes**2)))
        if float(np.sum(error**2)) > 0:
            pan_err.append(float(error[1] ** 2 / np.sum(error**2)))
        if abs(error[1]) > 0.02:  # a pan error that is more than noise in the centre's shift
            orbit.append(float(shift[0] / error[1]))
            distance.append(_number(r, "distance_m") * math.pi / 180.0)
    return {
        "cameras": len(records),
        **{f"median_{name}": _median(col(name)) for name in ("error_deg", "sd_deg")},
        **{
            f"median_{name}": _median(col(name))
            for name in ("given_model_deg", "truth_sd_deg", *(f"{n}_deg" for n in WITHOUT))
        },
        "model_share": _median(model_share),
        "pan_share_sd": _median(pan_sd),
        "pan_share_err": _median(pan_err),
        "orbit_m_per_deg": _median(orbit),
        "distance_m_per_deg": _median(distance),
    }


def knowledge_bases() -> Callable[[str], KnowledgeBase]:
    """A loader of the repository's ``kb/NAME`` files, each compiled once (SystemExit when
    one does not compile)."""
    from aida_kb.kb import compile_path

    kbs: dict[str, KnowledgeBase] = {}
    root = Path(__file__).resolve().parent.parent / "kb"

    def kb_of(name: str) -> KnowledgeBase:
        if name not in kbs:
            compiled = compile_path(root / name)
            if compiled.kb is None:
                raise SystemExit(f"kb/{name}: does not compile")
            kbs[name] = compiled.kb
        return kbs[name]

    return kb_of


def kept_seeds(keep: Path, seeds: str) -> list[int]:
    """The seeds of the ``scene-SEED`` folders in `keep`, within ``seeds`` ("A-B" inclusive,
    "A", or "" for all), in order."""
    lo, _, hi = seeds.partition("-")
    out = []
    for folder in sorted(keep.glob("scene-*")):
        seed = int(folder.name.split("-", 1)[1])
        if not lo or int(lo) <= seed <= int(hi or lo):
            out.append(seed)
    return out


def main(argv: list[str] | None = None) -> None:
    """Read the kept scenes, print a line per view and the JSON summary."""
    parser = argparse.ArgumentParser(description="What limits the later views' cameras.")
    parser.add_argument("keep", nargs="+", type=Path, help="robustness --keep folders")
    parser.add_argument("--seeds", default="", help="only these seeds: A-B (inclusive)")
    args = parser.parse_args(argv)
    kb_of = knowledge_bases()
    records: list[dict[str, object]] = []
    for keep in args.keep:
        for seed in kept_seeds(keep, args.seeds):
            for r in scene_views(keep, seed, kb_of):
                print(json.dumps(r), file=sys.stderr)
                records.append(r)
    print(json.dumps(summary(records)))


if __name__ == "__main__":
    main()
