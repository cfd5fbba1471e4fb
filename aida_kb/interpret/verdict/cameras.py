"""Check (c) for a registered view's camera (the adjustment's covariance), and the standard
deviations written into the model."""

from __future__ import annotations

import math

import numpy as np

from aida_kb.interpret.uncertainty import Uncertainty, image_edge_deviations
from aida_kb.interpret.verdict.tolerances import (
    CAMERA_ANGLE_SD_MAX_DEG,
    CAMERA_CENTRE_SD_MAX,
    CAMERA_SD_CONFIDENCE,
)
from aida_kb.io.model import CameraSd, ModelCamera, PartSd, ReconstructedModel


def camera_doubts(view: str, model: ReconstructedModel, unc: Uncertainty | None) -> list[str]:
    """Check (c) for a registered view's camera (problems): the adjustment's covariance
    (`aida_kb.interpret.uncertainty`) fixes its rotation to CAMERA_ANGLE_SD_MAX_DEG and its
    centre to CAMERA_CENTRE_SD_MAX of its distance from the model's centre, both at
    CAMERA_SD_CONFIDENCE standard deviations."""
    camera = next((c for c in model.cameras if c.view == view), None)
    if camera is None:
        return []
    undecided = undecided_doubts(camera)
    if unc is None or view not in unc.cameras:
        return [*undecided, "camera: the adjustment's covariance could not be computed"]
    angle, centre_m = unc.cameras[view]
    corners = np.vstack([np.asarray(p.polygon, dtype=np.float64) for p in model.parts])
    R = np.asarray(camera.R, dtype=np.float64)
    C = -R.T @ np.asarray(camera.t, dtype=np.float64)
    distance = float(np.linalg.norm(C - corners.mean(axis=0)))
    centre = centre_m / max(distance, 1e-9)
    k = CAMERA_SD_CONFIDENCE
    if k * angle <= CAMERA_ANGLE_SD_MAX_DEG and k * centre <= CAMERA_CENTRE_SD_MAX:
        return undecided
    by = (
        "the model's edges fitted along the images"
        if camera.sd is not None and camera.sd.measurements == "image edges"
        else "the model's edges fitted along the images and the ground's texture"
        if camera.sd is not None and camera.sd.measurements == "ground texture"
        else f"{unc.measurements} measurements, their scatter "
        f"{unc.variance_factor**0.5:.2f} of their noise model"
    )
    # the figures said are those held against the limits: k sd (the sd itself in brackets);
    # an infinite sd is what the evidence leaves open, said in words (never "+-inf")
    rotation = f"+-{k * angle:.2f} deg" if math.isfinite(angle) else "nothing in its rotation"
    distance_text = (
        f"+-{100 * k * centre:.1f}% of its distance"
        if math.isfinite(centre)
        else "nothing in its distance"
    )
    sd = f"sd {angle:.3f} deg" if math.isfinite(angle) else "rotation sd not finite"
    return [
        *undecided,
        f"camera is fixed by the adjustment only to {rotation} and {distance_text} at {k:g} sd "
        f"(at most {CAMERA_ANGLE_SD_MAX_DEG:g} deg and {100 * CAMERA_CENTRE_SD_MAX:g}%; {sd}; "
        f"{by})",
    ]


def undecided_doubts(camera: ModelCamera) -> list[str]:
    """Check (c) for a registered view's pose choice (problems): a pose the registration took
    among rivals that nothing in the view rules out (`ModelCamera.undecided_turns_deg`: a
    symmetric model's twins whose faces look alike) is a choice, not a measurement: the view
    may be the model's twin, turned by as much, and the covariance, which is that of the
    pose taken, cannot show it."""
    if not camera.undecided_turns_deg:
        return []
    turns = ", ".join(f"{a:.1f}" for a in camera.undecided_turns_deg)
    return [
        f"camera pose is not decided: poses at turns of {turns} deg about the vertical "
        "(counted from the view it was registered against, not from the pose taken) fit its "
        "edges about as well "
        "and its images do not rule them out (a symmetric model's twins look alike)"
    ]


def _finite_pair(values: tuple[float, float] | None) -> tuple[float | None, float | None]:
    """Two standard deviations with the infinite ones (not fixed) as None."""
    if values is None:
        return None, None
    a, b = values
    return (a if math.isfinite(a) else None), (b if math.isfinite(b) else None)


def with_deviations(model: ReconstructedModel, unc: Uncertainty) -> ReconstructedModel:
    """`model` with the adjustment's standard deviations on its parts and cameras (model.json
    `sd`: normal degrees and offset metres of each part, rotation degrees and centre metres
    of each camera the adjustment moves; null where not fixed). A camera whose deviations
    the reconstruction's image-edge rounds gave keeps them (`image_edge_deviations`)."""
    own = image_edge_deviations(model)
    parts = [
        p.model_copy(update={"sd": PartSd(normal_deg=a, offset_m=b)}) if p.role in unc.parts else p
        for p, (a, b) in ((p, _finite_pair(unc.parts.get(p.role))) for p in model.parts)
    ]
    cameras = [
        c.model_copy(update={"sd": CameraSd(rotation_deg=a, centre_m=b)})
        if c.view in unc.cameras and c.view not in own
        else c
        for c, (a, b) in ((c, _finite_pair(unc.cameras.get(c.view))) for c in model.cameras)
    ]
    return model.model_copy(update={"parts": parts, "cameras": cameras})
