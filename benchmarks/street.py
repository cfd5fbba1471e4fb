"""Several houses per scene: the street presets reconstructed, every house judged.

Renders each street preset (aida_kb.synth.street: streets of 2-5 houses, a terrace of three
touching houses, a house half hidden behind another) with held-out seeds (never used while
developing: the development seeds are below 3000 — 0, 7 and 101 were used; 102 was measured
once, before the changes of session 7, and not debugged on; 102 and 30219 were reported in
session 7, and 30300-30303 with ``--random``), computes the evidence of its views (two by
default: the second from the other side of the row, `synth.street.view_angles`;
``--views 1`` for view 00 alone), reconstructs it against kb/street.kb as `aida-kb
reconstruct` does (goal Street: view 00 interpreted, `aida_kb.interpret.scene`; the other
views registered and the model refined with all, `interpret.multiview.reconstruct_views`;
every object judged on every view; an object's tie re-judged by the other views,
`interpret.scene.reconstruct_objects`) and pairs every true house with the reconstructed one
nearest it (`evaluate_scene`). Reported per
scene and in total: houses in the truth, found, correct (the verdict 'verified',
specialisation right, normals within 0.5 deg, vertices within 2 % of the house's size),
within_tolerance (specialisation, geometry and cameras right, whatever the verdict),
geometry_within_tolerance (specialisation and geometry right, whatever the verdict and the
cameras: the target of issue 19), wrong_verified
(verified but not correct: a wrong result reported as right), invented (no true house near)
and twice (a true house taken by two objects), the largest normal and vertex errors of the
houses found, and the time. Ends with one JSON line.

    .venv/bin/python benchmarks/street.py [--seeds 102,30219] [--quick] [--random 30300,30301]
        [--views N]

With ``--random SEEDS`` each seed is one randomised variant (`synth.street.random_street`: the
preset, the number of houses, view 00's angle, the distance and the noise drawn from it).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from aida_kb.interpret.party import stereo_depth
from aida_kb.interpret.scene import evaluate_scene, reconstruct_objects, scene_evidence_of
from aida_kb.interpret.sight import unseen_parts
from aida_kb.interpret.verdict import judge, with_verdict
from aida_kb.io.scene import read_scene
from aida_kb.kb.compiler import compile_path
from aida_kb.synth.scenes import preset, render_scene
from aida_kb.synth.street import random_street
from aida_kb.vision.evidence import scene_evidence

ROOT = Path(__file__).resolve().parents[1]
SCENES: tuple[tuple[str, dict[str, str]], ...] = (
    ("street", {"houses": "2"}),
    ("street", {"houses": "3"}),
    ("street", {"houses": "4"}),
    ("street", {"houses": "5"}),
    ("terrace", {}),
    ("occluded", {}),
)

# a house's geometry and specialisations are right (`evaluate`'s cause): verified, or doubtful
RIGHT = ("", "right but doubtful")
# ... and the target for a street (normals within 0.5 deg, vertices within 2 %): the
# house right whatever the cameras (`evaluate` names a camera of view 01 beyond 0.1 deg as the
# cause only after the house's own geometry passed)
GEOMETRY_RIGHT = (*RIGHT, "camera")


def _figure(row: dict[str, object], key: str) -> float:
    """A house's error figure (infinite when there is no comparison: no model to compare)."""
    value = row.get(key)
    return float(value) if isinstance(value, (int, float)) else float("inf")


def _house(row: dict[str, object]) -> dict[str, object]:
    """One true house: the object paired with it, the verdict, the errors, the doubts."""
    return {
        "truth": row["truth"],
        "object": row["object"],
        "outcome": row.get("outcome", "missed"),
        "correct": bool(row.get("correct")),
        "normal_deg": round(_figure(row, "max_normal_error_deg"), 3),
        "vertex_pct": round(_figure(row, "max_vertex_error_pct"), 2),
        "cause": row.get("cause", "missed"),
        "cameras": row.get("cameras", []),
        "doubts": row.get("doubts", []),
        "unmeasurable": row.get("unmeasurable"),  # its parts no view shows (interpret.sight)
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="102", help="held-out seeds, comma-separated")
    parser.add_argument("--quick", action="store_true", help="only the first two scenes")
    parser.add_argument(
        "--random",
        default="",
        help="randomised street variants instead (synth.street.random_street), seeds "
        "comma-separated; development seeds below 3000",
    )
    parser.add_argument(
        "--views", type=int, default=0, help="views per scene (default: the preset's, two)"
    )
    args = parser.parse_args()
    kb = compile_path(ROOT / "kb" / "street.kb").kb
    assert kb is not None
    seeds = [int(s) for s in (args.random or args.seeds).split(",")]
    rows = []
    totals = {
        "houses": 0,
        "found": 0,
        "correct": 0,
        "within_tolerance": 0,
        "geometry_within_tolerance": 0,
        "wrong_verified": 0,
        "invented": 0,
        "twice": 0,
    }
    worst_normal = 0.0
    worst_vertex = 0.0
    total_seconds = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            scenes = SCENES[:2] if args.quick else SCENES
            if args.random:
                scenes = (random_street(seed),)
            for name, params in scenes:
                folder = Path(tmp) / f"{name}{params.get('houses', '')}-{seed}"
                views = args.views or None
                render_scene(preset(name, seed=seed, params=params, views=views), folder)
                start = time.perf_counter()
                scene = read_scene(folder, with_truth=False)
                raw, products = scene_evidence(scene)
                depth = stereo_depth(products, raw.views[0].id)
                evidence = scene_evidence_of(kb, raw, "Street", depth)
                interp = reconstruct_objects(kb, evidence, goal="Street", scene=scene)
                interp = with_verdict(interp, judge(kb, interp, evidence, all_views=True))
                seconds = time.perf_counter() - start
                total_seconds += seconds
                shown = read_scene(folder, with_truth=True)
                truth = shown.truth
                assert truth is not None
                judged = evaluate_scene(interp, truth, "houses", unseen_parts(shown))
                houses = [
                    r for r in judged if r.get("truth") and r["status"] in ("found", "missed")
                ]
                found = [r for r in houses if r["status"] == "found"]
                normals = [_figure(r, "max_normal_error_deg") for r in found]
                vertices = [_figure(r, "max_vertex_error_pct") for r in found]
                row = {
                    "scene": folder.name,
                    "houses": len(houses),
                    "found": len(found),
                    "correct": sum(1 for r in found if r.get("correct")),
                    "within_tolerance": sum(1 for r in found if r.get("cause") in RIGHT),
                    "geometry_within_tolerance": sum(
                        1 for r in found if r.get("cause") in GEOMETRY_RIGHT
                    ),
                    "wrong_verified": sum(
                        1 for r in found if r.get("outcome") == "verified" and not r.get("correct")
                    ),
                    "invented": sum(1 for r in judged if r["status"] == "invented"),
                    "twice": sum(1 for r in judged if r["status"] == "twice"),
                    "verdicts": [o.verdict for o in interp.objects],
                    "causes": [r.get("cause", "missed") for r in houses],
                    "per_house": [_house(r) for r in houses],
                    "max_normal_error_deg": round(max(normals, default=0.0), 3),
                    "max_vertex_error_pct": round(max(vertices, default=0.0), 2),
                    "seconds": round(seconds, 1),
                }
                print(json.dumps(row), flush=True)
                rows.append(row)
                for key in totals:
                    totals[key] += int(row[key])  # type: ignore[call-overload]
                worst_normal = max([worst_normal, *normals])
                worst_vertex = max([worst_vertex, *vertices])
    print(
        json.dumps(
            {
                "scenes": len(rows),
                "seeds": seeds,
                "random": bool(args.random),
                "views": args.views or len(scene.views),
                **totals,
                "max_normal_error_deg": round(worst_normal, 3),
                "max_vertex_error_pct": round(worst_vertex, 2),
                "seconds_per_scene": round(total_seconds / max(len(rows), 1), 1),
            }
        )
    )


if __name__ == "__main__":
    main()
