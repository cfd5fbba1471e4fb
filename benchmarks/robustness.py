"""Robustness on randomised scenes (not a test). Prints a line per scene, then ONE line of JSON.

Each seed's scene (`aida_kb.synth.randomised.random_scene`: any building preset with random
sizes, an asymmetric gable, the turntable box, the tower, or no building at all; random
cameras, 1-8 views, light, shadows, occluders, distortion, exposure, ground and labels) is
rendered, reconstructed with the knowledge that describes its object (kb/buildings.kb; the
tower with kb/tower.kb, the turntable box with kb/reference_box.kb; the scenes without an
object with kb/buildings.kb) exactly as `aida-kb reconstruct` does, and judged by
`aida_kb.interpret.evaluate.evaluate`: correct = the right outcome (nothing where there is no
house), the right specialisations, normals within 0.5 deg, vertices within 2 % of the size,
every camera within 0.1 deg and 1 % of its distance.

Scenes with labels.png and without are reported apart. The seeds reported by default
(10000 ...) were never looked at while the code was developed (development used seeds below
3000). Figures: correct_rate, wrong_accepted_rate (verified but not correct), doubtful_rate,
nothing_rate (nothing found), error_rate, the correct rate per kind, nothing found in the
scenes without a house, the count of each failure cause, and how many scenes with a house
show every true part in some view (`aida_kb.interpret.sight`: a face of 200 px or half of an
edge; a part no view shows is the knowledge's guess whatever the interpretation) with the
correct ones among them (objects_fully_shown, correct_of_fully_shown).

Image width: the random scenes draw their own sizes (480, 640, 720 or 800 px wide);
``--max-width`` caps them. Keep the default 800 (the scenes' own sizes) for the figures: the
0.1 degree asked of every registered camera is out of reach at 480 px. Measured on
development seeds 2000-2019 (3 views): at 480 px the registered cameras of the scenes whose
specialisations were right were 0.05-0.65 deg off (median 0.27, 1 of 8 within 0.1 deg, every
one doubted by the adjustment's covariance, `aida_kb.interpret.uncertainty`: +-0.35-1.7 deg);
at the scenes' own 720 px, seeds 2001 and 2009: 0.10, 0.18 and 0.13 deg (+-0.12-0.26).
``--max-width 480`` is a fast screen for wrong_accepted_rate, not a measure of correct_rate.
The closing figures also give the registered cameras' median error, the share within 0.1
deg and the share within two of the adjustment's standard deviations (about 0.95 when those
are honest), and over the scenes whose model has the truth's form (right specialisations, no
part missing or extra; `aida_kb.interpret.robustness.sd_figures`) the median error over sd of
the cameras (camera_error_over_sd_median, 0.7-0.9 when honest) and of the parts' normals
(part_normal_error_over_sd_median) and the parts' share within two sd
(part_normals_within_2sd). On the kept dev closing sets 61600-63035 (main 01bbf29, rejudged):
part normals 0.25-0.40 in the median yet only 0.86-0.95 within two sd: the parts' deviations
are too large for most parts and too small for a few.

Streets (``--streets N``, its own section ``streets`` of the JSON line): N randomised street
variants (`aida_kb.synth.street.random_street_spec`: 2-5 free-standing houses of different
roofs, a terrace of 2-5 touching houses or a house half hidden behind another, view 00's
angle, the distance and the noise drawn; two views; labels.png half the time), seeds from
``--street-start`` (default 62000: never looked at while the code was developed; development
used 41200-41203 and the presets' 61031), reconstructed against kb/street.kb (goal Street) and
judged house by house (`aida_kb.interpret.scene.evaluate_scene`): per house correct,
wrong_verified (verified but not right: the worst), doubtful (found, not verified) and missed,
and within_tolerance (specialisations and geometry right, whatever the verdict);
per scene invented (an object near no house) and twice (a house taken by two objects); with
labels and without apart. The streets' seeds are a sequence of their own: the single-object
seeds draw the same kinds with or without streets (``--count 0 --streets N``: streets only).
Their images keep the presets' 1280 px (``--max-width`` caps the single objects only).

Run: ``.venv/bin/python benchmarks/robustness.py [--count 100] [--start 10000] [--jobs 1]
[--streets 10 --street-start 62000]`` (about half a minute per scene on one core).
``--keep DIR`` keeps every scene and result in DIR; ``--rejudge DIR`` judges the kept results
again with the current verdict (no rendering, no reconstruction: seconds each) and reports the
seeds of the range found there (streets too, with ``--streets``). The deviations the
reconstruction itself wrote (model.json ``sd`` of the cameras fixed by the images' edges or the
ground's texture) are those of the code that made the results: results kept by another version
are judged with that version's deviations (dev 71019, kept before the ground-texture cameras'
deviations were doubled: verified and 0.12 deg off when judged again, doubtful when run again),
so compare rejudged figures only with results of the same code. ``--without-camera-check``
(with ``--rejudge`` only) judges them with the cameras' accuracy check switched off (their
CAMERA_SD_CONFIDENCE taken as 0, in this process only): a stress test. Its wrong_accepted
results are the wrong models only the cameras' 2-sd check stops (held-out 61325 in session 12:
a gable taken for a shed, 21 % off, passed every other check); its figures are no result.
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
import tempfile
from collections import Counter, defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from aida_kb.interpret.robustness import (
    HOUSE_STATES,
    SceneOutcome,
    StreetOutcome,
    rejudge_scene,
    rejudge_street,
    run_random_scene,
    run_random_street,
    scene_rates,
)
from aida_kb.kb import compile_path
from aida_kb.kb.model import KnowledgeBase

KB_DIR = Path(__file__).resolve().parents[1] / "kb"


@functools.cache
def _knowledge(name: str = "buildings.kb") -> KnowledgeBase:
    """kb/NAME compiled (once per process); a clear one-line message (and exit 1) when it
    does not compile (edited while a long run goes on)."""
    path = KB_DIR / name
    result = compile_path(path)
    if result.kb is None:
        first = next((str(d) for d in result.diagnostics), "no diagnostics")
        raise SystemExit(f"{path}: does not compile: {first}")
    return result.kb


def _one(args: tuple[int, int, int, str]) -> SceneOutcome:
    seed, max_views, max_width, keep = args
    kb = _knowledge()
    if keep:
        return run_random_scene(
            kb, seed, keep, max_views=max_views, max_width=max_width, knowledge=_knowledge
        )
    with tempfile.TemporaryDirectory(prefix="aida-robust-") as tmp:
        return run_random_scene(
            kb, seed, tmp, max_views=max_views, max_width=max_width, knowledge=_knowledge
        )


# a house's evaluation cause when its specialisations and geometry are right: verified or not
WITHIN_TOLERANCE = ("", "right but doubtful")
STREET_KB = "street.kb"  # the knowledge of a street: one or more houses of buildings.kb


def _street(args: tuple[int, str]) -> StreetOutcome:
    seed, keep = args
    if keep:
        return run_random_street(_knowledge(STREET_KB), seed, keep)
    with tempfile.TemporaryDirectory(prefix="aida-street-") as tmp:
        return run_random_street(_knowledge(STREET_KB), seed, tmp)


def _street_line(r: StreetOutcome) -> str:
    states = " ".join(f"{s}={r.count(s)}" for s in HOUSE_STATES if r.count(s))
    causes = sorted({str(h["cause"]) for h in r.houses if h["state"] != "correct"})
    return (
        f"street {r.seed} {r.preset:<9} labels={int(r.labels)} views={r.views} "
        f"houses={len(r.houses)} {r.outcome:<8} {states} invented={r.invented} "
        f"twice={r.twice} ({r.seconds:.0f} s) {'; '.join(causes)} {r.message}"
    ).rstrip()


def _street_rates(rows: list[StreetOutcome]) -> dict[str, object]:
    """Per house: how many correct, wrong_verified, doubtful, missed (and their rates); per
    scene: invented and twice; correct houses per preset; the causes of the others."""
    houses = [h for r in rows for h in r.houses]
    n = len(houses)
    if not rows:
        return {"scenes": 0}
    out: dict[str, object] = {"scenes": len(rows), "houses": n}
    for state in HOUSE_STATES:
        k = sum(r.count(state) for r in rows)
        out[state] = k
        out[f"{state}_rate"] = round(k / n, 3) if n else None
    by_preset: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    for r in rows:
        by_preset[r.preset][0] += r.count("correct")
        by_preset[r.preset][1] += len(r.houses)
    out.update(
        {
            "invented": sum(r.invented for r in rows),
            "twice": sum(r.twice for r in rows),
            "errors": sum(r.outcome == "error" for r in rows),
            "scenes_all_correct": sum(r.count("correct") == len(r.houses) for r in rows),
            # the specialisations and geometry right, whatever the verdict (as
            # benchmarks/street.py's within_tolerance): what the verdict's doubts cost apart
            "within_tolerance": sum(1 for h in houses if h["cause"] in WITHIN_TOLERANCE),
            "correct_by_preset": {k: f"{c}/{t}" for k, (c, t) in sorted(by_preset.items())},
            "causes": dict(
                Counter(str(h["cause"]) for h in houses if h["state"] != "correct").most_common()
            ),
        }
    )
    return out


def _rejudged(folder: str, seeds: range) -> list[SceneOutcome]:
    kb = _knowledge()
    rows = [rejudge_scene(kb, s, folder, _knowledge) for s in seeds]
    return [r for r in rows if r is not None]


def _line(r: SceneOutcome) -> str:
    return (
        f"seed {r.seed} {r.kind:<17} labels={int(r.labels)} views={r.views} "
        f"{r.outcome:<8} {'correct' if r.correct else 'WRONG ' + r.cause} "
        f"({r.seconds:.0f} s) {json.dumps(r.figures)}"
    )


def main() -> None:
    """Run the scenes, print one line each (stderr) and the JSON summary (stdout)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=100, help="number of scenes (default 100)")
    ap.add_argument("--start", type=int, default=10000, help="first seed (default 10000)")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    ap.add_argument("--max-views", type=int, default=8, help="cap on the views (default 8)")
    ap.add_argument(
        "--max-width",
        type=int,
        default=800,
        help="cap on image width (800: the scenes' own sizes; at 480 no registered camera "
        "meets the 0.1 deg target, see the module docstring)",
    )
    ap.add_argument(
        "--streets", type=int, default=0, help="randomised streets too (default 0: none)"
    )
    ap.add_argument(
        "--street-start", type=int, default=62000, help="first street seed (default 62000)"
    )
    ap.add_argument("--keep", default="", help="keep scenes and results in this folder")
    ap.add_argument("--rejudge", default="", help="judge the results kept in this folder again")
    ap.add_argument(
        "--without-camera-check",
        action="store_true",
        help="with --rejudge: switch the cameras' accuracy check off (a stress test: which "
        "wrong results does only that check stop?)",
    )
    args = ap.parse_args()
    if args.without_camera_check:
        if not args.rejudge:
            ap.error("--without-camera-check needs --rejudge")
        from aida_kb.interpret.verdict import cameras

        # read at each call of cameras.camera_doubts
        cameras.CAMERA_SD_CONFIDENCE = 0.0  # type: ignore[attr-defined]
    rows: list[SceneOutcome] = []
    if args.rejudge:
        rows = _rejudged(args.rejudge, range(args.start, args.start + args.count))
        for r in rows:
            print(_line(r), file=sys.stderr, flush=True)
    else:
        if args.keep:
            Path(args.keep).mkdir(parents=True, exist_ok=True)
        seeds = [
            (s, args.max_views, args.max_width, args.keep)
            for s in range(args.start, args.start + args.count)
        ]
        with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            for r in pool.map(_one, seeds):
                rows.append(r)
                print(_line(r), file=sys.stderr, flush=True)
    streets: list[StreetOutcome] = []
    street_seeds = range(args.street_start, args.street_start + args.streets)
    if args.rejudge:
        kb = _knowledge(STREET_KB)
        found = [rejudge_street(kb, s, args.rejudge) for s in street_seeds]
        streets = [r for r in found if r is not None]
        for street in streets:
            print(_street_line(street), file=sys.stderr, flush=True)
    elif args.streets:
        with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            for street in pool.map(_street, [(s, args.keep) for s in street_seeds]):
                streets.append(street)
                print(_street_line(street), file=sys.stderr, flush=True)
    summary = {
        "benchmark": "robustness",
        "seeds": f"{args.start}..{args.start + args.count - 1}" if args.count else None,
        "rejudged": bool(args.rejudge),
        "camera_check": not args.without_camera_check,
        "max_views": args.max_views,
        "max_width": args.max_width,
        "all": scene_rates(rows),
        "with_labels": scene_rates([r for r in rows if r.labels]),
        "without_labels": scene_rates([r for r in rows if not r.labels]),
        "median_seconds": sorted(r.seconds for r in rows)[len(rows) // 2] if rows else None,
    }
    if args.streets:
        summary["streets"] = {
            "seeds": f"{args.street_start}..{args.street_start + args.streets - 1}",
            "all": _street_rates(streets),
            "with_labels": _street_rates([r for r in streets if r.labels]),
            "without_labels": _street_rates([r for r in streets if not r.labels]),
            "median_seconds": (
                sorted(r.seconds for r in streets)[len(streets) // 2] if streets else None
            ),
        }
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
