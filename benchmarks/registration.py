"""Benchmark of viewpoint registration on the turntable (paper §6.2, Table 1). Not a test.

The `turntable` preset is rendered (the reference box turned to 0, 85, 195 and 265 degrees);
its known geometry (truth.json — the benchmark may read it, the program never does) is the
fixed model, view 00 the reference camera. Figures, all in degrees of turn about the
turntable axis against the truth:

* ``max_error_deg``: views 85, 195 and 265 registered from simulated line segments at 0.5 px
  image noise in both images of each view's stereo pair (every edge point, one per pixel, gets
  2-D Gaussian noise of 0.5 px and the segment is fitted to them; 30 % of the edges broken in
  two, 10 % missing, 40 clutter segments per image), each with a rough initial turn 10 degrees
  off (the box is symmetric under a half turn, so 195 and 85 degrees from the front look
  alike: some guess is needed past 90), the 6 pose parameters of the left camera free (the
  right camera follows by the calibration). ``trials_max_error_deg`` /
  ``trials_median_error_deg``: the same over 10 noise draws (30 registrations);
  ``trials_table_within_0_02``: in how many of those draws all three turns are within 0.02;
  ``mono_*``: the same from the left images alone.
* ``pnp_max_error_deg``: the anchor: `cv2.solvePnP` (SQPnP, no guess) given the true 2-D/3-D
  correspondences of the visible box corners, the same 0.5 px noise on the corners.
* ``basin_deg``: the largest turn between two consecutive views (the reference and a view
  turned by 10, 15, ..., 90 degrees) up to which every registration with no initial guess
  lands within 0.1 degrees of the truth.
* ``rendered_max_error_deg``: views 85, 195, 265 registered from the rendered images' own
  evidence (`aida-kb evidence`: line detector on both images, stereo regions; each segment
  moved onto its edge by `refine_segments`, as `aida-kb register` does), initial turn
  10 degrees off; ``rendered_relative_errors_deg``: Table 1 from them — the error of the
  relative rotation between consecutive views (85, 110, 70 degrees), and whether all three
  are within 0.02 degrees.
* ``rendered_turn_sigma_deg``: each registered turn's standard deviation from the adjustment
  (`Registration.turn_sigma_deg`: the pose covariance of its final matches, each segment
  weighted by its own edge fit) — what the evidence itself says the turn is known to.
* ``held_out_relative_errors_deg`` / ``held_out_turn_sigma_deg``: the same on renders never
  used while developing (`HELD_OUT`: seed 11 with the paper's turns, seed 12 turned through
  7 views). Development used seed 0 and further seeds 1-3 (not in this benchmark).

Run: ``.venv/bin/python benchmarks/registration.py``. Prints details to stderr and ONE JSON
line to stdout.
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.io.scene import read_image, read_scene
from aida_kb.register import (
    Rig,
    RigidModel,
    StereoSegments,
    angle_about,
    register_view,
    turned,
)
from aida_kb.register.evidence import register_evidence_view, right_segments
from aida_kb.synth.scenes import preset, render_scene
from aida_kb.testing.segments import simulated_segments
from aida_kb.vision.evidence import scene_evidence

NOISE_PX = 0.5
ANGLES = (85.0, 195.0, 265.0)
GUESS_OFF_DEG = 10.0
TRIALS = 10
CONVERGED_DEG = 0.1


def _wrap(deg: float) -> float:
    return (deg + 180.0) % 360.0 - 180.0


def _pnp_error(
    model: RigidModel,
    cam0: PinholeCamera,
    cam: PinholeCamera,
    up: np.ndarray,
    rng: np.random.Generator,
) -> float:
    """Turn error of cv2.solvePnP from the visible corners with true correspondences."""
    vis = model.visible_edges(cam)
    ends = model.edge_ends[vis.index].reshape(-1, 3)
    keys = np.round(ends * 1e6).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    X = ends[np.sort(first)]
    x = cam.project(X) + rng.normal(scale=NOISE_PX, size=(X.shape[0], 2))
    ok, rvec, tvec = cv2.solvePnP(X, x, cam.K, None, flags=cv2.SOLVEPNP_SQPNP)
    if not ok:
        return math.inf
    R, _ = cv2.Rodrigues(rvec)
    est = PinholeCamera(cam.K, R, tvec.ravel(), cam.width, cam.height)
    return abs(_wrap(angle_about(cam0, est, up) - angle_about(cam0, cam, up)))


HELD_OUT = ((11, (0.0, 85.0, 195.0, 265.0)), (12, (0.0, 40.0, 95.0, 150.0, 190.0, 250.0, 300.0)))
"""Rendered turntables reported, never tuned on: (seed, turns of the table in degrees)."""


def _rendered_turns(
    model: RigidModel, reference: PinholeCamera, scene_dir: Path, angles: tuple[float, ...]
) -> tuple[list[float], list[float]]:
    """Each later view's turn (degrees) registered from the rendered images' evidence,
    starting 10 degrees off the truth, against the true box and the reference camera, and
    its standard deviation from the adjustment (degrees)."""
    blind = read_scene(scene_dir, with_truth=False)
    evidence, _ = scene_evidence(blind)
    turns = []
    sigmas = []
    for k, a in enumerate(angles[1:], start=1):
        reg = register_evidence_view(
            model,
            reference,
            evidence.views[k],
            init_angle_deg=a - GUESS_OFF_DEG,
            stereo=right_segments(blind, evidence.views[k].id),
            image=read_image(blind.view(evidence.views[k].id).left, grey=True),
        )
        turns.append(reg.angle_deg)
        sigmas.append(reg.turn_sigma_deg)
        print(
            f"{scene_dir.name}: rendered turn {a:.0f}: {reg.angle_deg % 360:.4f} deg "
            f"(sigma {reg.turn_sigma_deg:.4f}), {reg.rms_px:.3f} px RMS over {reg.n_edges} "
            f"segments and {reg.n_regions} regions",
            file=sys.stderr,
        )
    return turns, sigmas


def _relative_errors(turns: list[float], angles: tuple[float, ...]) -> list[float]:
    """|registered - true| relative rotation between consecutive views (Table 1), degrees."""
    measured = [0.0, *turns]
    return [
        abs(_wrap((measured[k] - measured[k - 1]) - (angles[k] - angles[k - 1])))
        for k in range(1, len(angles))
    ]


def main() -> None:
    """Render the turntable, run every part of the benchmark, print the JSON line."""
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        scene_dir = Path(tmp) / "turntable"
        render_scene(preset("turntable", seed=0), scene_dir)
        scene = read_scene(scene_dir)
        truth = scene.truth
        assert truth is not None
        model = RigidModel.from_polygons(
            [p.role for p in truth.parts],
            [p.normal for p in truth.parts],
            [p.d for p in truth.parts],
            [p.polygon for p in truth.parts],
        )
        w, h = scene.calib.image_size
        cams = [
            PinholeCamera(np.array(v.K), np.array(v.R), np.array(v.t), w, h) for v in truth.views
        ]
        up = -np.array(truth.part("box.top").normal)  # world y points down: the top's normal
        up = -up if float(up @ cams[0].R_cam_world[1]) > 0 else up
        pivot = model.centroid
        true_turn = [angle_about(cams[0], c, up) for c in cams[1:]]
        for a, t in zip(ANGLES, true_turn, strict=True):
            assert abs(_wrap(a - t)) < 1e-6, (a, t)

        c = scene.calib
        rig = Rig(c.K2, c.R, np.asarray(c.T).ravel(), w, h)

        # 1. Table 1 from simulated segments at 0.5 px, and over noise trials
        errors: list[list[float]] = []
        mono: list[list[float]] = []
        pnp: list[float] = []
        for trial in range(TRIALS):
            rng = np.random.default_rng(trial)
            row = []
            mono_row = []
            for k, a in enumerate(ANGLES, start=1):
                p1, p2 = simulated_segments(model, cams[k], rng, noise_px=NOISE_PX)
                r1, r2 = simulated_segments(model, rig.right_of(cams[k]), rng, noise_px=NOISE_PX)
                guess = a - GUESS_OFF_DEG
                reg = register_view(model, cams[0], p1, p2, init_angle_deg=guess)
                mono_row.append(abs(_wrap(reg.angle_deg - a)))
                reg = register_view(
                    model,
                    cams[0],
                    p1,
                    p2,
                    init_angle_deg=guess,
                    stereo=StereoSegments(rig, r1, r2),
                )
                row.append(abs(_wrap(reg.angle_deg - a)))
                if trial == 0:
                    print(
                        f"turn {a:.0f}: registered {reg.angle_deg % 360:.4f} deg "
                        f"(error {row[-1]:.4f}), {reg.rms_px:.3f} px RMS over {reg.n_edges} "
                        "segments",
                        file=sys.stderr,
                    )
                    pnp.append(_pnp_error(model, cams[0], cams[k], up, rng))
            errors.append(row)
            mono.append(mono_row)
        table = errors[0]
        flat = np.array(errors).ravel()
        mono_flat = np.array(mono).ravel()
        print(f"PnP anchor errors: {np.round(pnp, 4).tolist()}", file=sys.stderr)

        # 2. the convergence basin, no initial guess
        basin = 0.0
        rng = np.random.default_rng(100)
        for a in np.arange(10.0, 90.0 + 1e-9, 5.0):
            cam = turned(cams[0], up, pivot, math.radians(float(a)))
            p1, p2 = simulated_segments(model, cam, rng, noise_px=NOISE_PX)
            r1, r2 = simulated_segments(model, rig.right_of(cam), rng, noise_px=NOISE_PX)
            try:
                reg = register_view(model, cams[0], p1, p2, stereo=StereoSegments(rig, r1, r2))
                err = abs(_wrap(reg.angle_deg - float(a)))
            except Exception as exc:  # a failed registration is a failed convergence
                print(f"basin {a:.0f}: {exc}", file=sys.stderr)
                err = math.inf
            print(f"basin {a:.0f}: error {err:.4f} deg", file=sys.stderr)
            if err > CONVERGED_DEG:
                break
            basin = float(a)

        # 3. the rendered images' own evidence
        turns, sigmas = _rendered_turns(model, cams[0], scene_dir, (0.0, *ANGLES))
        rendered = [abs(_wrap(t - a)) for t, a in zip(turns, ANGLES, strict=True)]
        relative = _relative_errors(turns, (0.0, *ANGLES))
        # 4. Table 1 on renders never looked at while developing: the same box and angles
        # with other textures and noise, and a 7-view turn of the table (steps of 35-65 deg)
        held_out: list[float] = []
        held_sigmas: list[float] = []
        for seed, angles in HELD_OUT:
            out = Path(tmp) / f"held-{seed}"
            spec = preset(
                "turntable", seed=seed, params={"angles": ",".join(f"{a:g}" for a in angles)}
            )
            render_scene(spec, out)
            held, held_sd = _rendered_turns(model, cams[0], out, angles)
            held_out += _relative_errors(held, angles)
            held_sigmas += held_sd
    print(
        json.dumps(
            {
                "noise_px": NOISE_PX,
                "angles_deg": list(ANGLES),
                "errors_deg": [round(e, 4) for e in table],
                "max_error_deg": round(max(table), 4),
                "trials": TRIALS,
                "trials_max_error_deg": round(float(flat.max()), 4),
                "trials_median_error_deg": round(float(np.median(flat)), 4),
                "trials_table_within_0_02": int(np.sum(np.array(errors).max(axis=1) <= 0.02)),
                "mono_max_error_deg": round(max(mono[0]), 4),
                "mono_trials_max_error_deg": round(float(mono_flat.max()), 4),
                "mono_trials_median_error_deg": round(float(np.median(mono_flat)), 4),
                "pnp_max_error_deg": round(max(pnp), 4),
                "basin_deg": basin,
                "rendered_max_error_deg": round(max(rendered), 4),
                "rendered_relative_errors_deg": [round(e, 4) for e in relative],
                "rendered_table_within_0_02": bool(max(relative) <= 0.02),
                "rendered_turn_sigma_deg": [round(e, 4) for e in sigmas],
                "held_out_relative_errors_deg": [round(e, 4) for e in held_out],
                "held_out_within_0_02": f"{sum(e <= 0.02 for e in held_out)}/{len(held_out)}",
                "held_out_turn_sigma_deg": [round(e, 4) for e in held_sigmas],
                "seconds": round(time.perf_counter() - start, 1),
                "load_1min": round(os.getloadavg()[0], 2),
            }
        )
    )


if __name__ == "__main__":
    main()
