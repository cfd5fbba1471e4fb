"""Fuzzing every reader against its contract (issue 16); `tests/test_fuzz.py` runs a short budget.

Run: .venv/bin/python benchmarks/fuzz.py [--cases N] [--seed S]

Targets: ``.kb`` (compile_path), ``scene.yaml`` (read_scene), ``calib.yaml`` (read_calib),
``image`` (read_image), ``labels`` (read_labels), ``depth`` (read_depth), ``evidence``
(read_evidence), ``model`` (read_model), ``interpretation`` (read_interpretation) and
``truth`` (read_scene with truth.json). Each case takes a valid seed file of the target and
applies one to three mutations (byte flips, deletions, duplications, truncation, inserted
hostile tokens such as ``1e999``, ``NaN``, 5,000 nested brackets or a 5,000-digit number;
for JSON and YAML a structured mutation that replaces one value of the parsed document; for
PNG files a header claiming another size), writes it where the reader expects it and reads it.

The contract: the reader returns a result, or raises an `AidaError` whose message is one line
naming the file (its path, or the scene directory for a scene's files); never another
exception; no NaN or infinity anywhere in a result. For ``.kb`` files: compiling never raises,
never reports an internal parser error (KB099), and a clean result's model holds only finite
numbers. Ends with ONE line of JSON: runs and clean errors per target, contract violations
(and the first few, described).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import math
import random
import shutil
import struct
import sys
import tempfile
import time
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml
from pydantic import BaseModel

from aida_kb.errors import AidaError
from aida_kb.interpret.result import (
    ConstraintResidual,
    HypothesisTrace,
    Instance,
    Interpretation,
    read_interpretation,
    write_interpretation,
)
from aida_kb.io.evidence import read_evidence
from aida_kb.io.model import ModelPart, ReconstructedModel, read_model, write_model
from aida_kb.io.scene import (
    PartTruth,
    PoseTruth,
    SceneTruth,
    StereoCalib,
    ViewData,
    read_calib,
    read_depth,
    read_image,
    read_labels,
    read_scene,
    write_scene,
)
from aida_kb.kb import compile_path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_CASES = 2400

#: Hostile fragments inserted by the byte-level mutations.
HOSTILE: tuple[bytes, ...] = (
    b"1e999",
    b"-1e999",
    b"NaN",
    b"Infinity",
    b"-0",
    b"0",
    b"-1",
    b"1e-300",
    b"9" * 5000,
    b"[" * 5000,
    b"{" * 2000,
    b"(" * 900,
    b"f(" * 900,
    b"\x00",
    b"\xff\xfe",
    b"\xc3\x28",
    b'"',
    b"'",
    b"\n",
    b"&a [*a, *a]",
    b"../../../../etc/passwd",
    b"/dev/zero",
    b"%YAML:1.0",
    b"<a>" * 200,
    b"  " * 300,
)
#: Replacement values of the structured (JSON/YAML) mutations.
VALUES: tuple[Any, ...] = (
    None,
    True,
    0,
    -1,
    1e308,
    -1e308,
    1e-320,
    2**64,
    "",
    "x" * 10000,
    "../outside.png",
    "/etc/passwd",
    [],
    {},
    [[[[[]]]]],
    [0.0] * 9,
    [1.0, 2.0],
    {"a": 1},
)


@dataclasses.dataclass
class Target:
    """One reader: the seed files, where a case's file goes, and the read."""

    name: str
    seeds: list[bytes]
    #: writes `data` where the reader looks; returns (file, the directory named in messages)
    place: Callable[[bytes], tuple[Path, Path]]
    read: Callable[[Path], Any]
    kind: str  # "json", "yaml", "kb", "image", "npy", "calib"


# ---- seeds ----------------------------------------------------------------------------------


def _calib() -> StereoCalib:
    K = np.array([[60.0, 0.0, 31.5], [0.0, 60.0, 23.5], [0.0, 0.0, 1.0]])
    return StereoCalib(K, np.zeros(5), K, np.zeros(5), np.eye(3), np.array([-0.3, 0, 0]), (64, 48))


def _truth() -> SceneTruth:
    return SceneTruth(
        object="House",
        parts=[
            PartTruth(
                role="body.front",
                concept="Wall",
                label=1,
                normal=(0.0, 0.0, -1.0),
                d=-10.0,
                polygon=[(-1.0, -1.0, 10.0), (1.0, -1.0, 10.0), (1.0, 1.0, 10.0)],
            )
        ],
        views=[
            PoseTruth(
                view="00",
                K=((60, 0, 31.5), (0, 60, 23.5), (0, 0, 1)),
                R=((1, 0, 0), (0, 1, 0), (0, 0, 1)),
                t=(0, 0, 0),
            )
        ],
    )


def _cube() -> ReconstructedModel:
    s = 2.0
    corners = {(i, j, k): (i * s, j * s, k * s) for i in (0, 1) for j in (0, 1) for k in (0, 1)}
    faces = {
        "x0": ((-1, 0, 0), 0.0, [(0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0)]),
        "x1": ((1, 0, 0), s, [(1, 0, 0), (1, 1, 0), (1, 1, 1), (1, 0, 1)]),
        "y0": ((0, -1, 0), 0.0, [(0, 0, 0), (1, 0, 0), (1, 0, 1), (0, 0, 1)]),
        "y1": ((0, 1, 0), s, [(0, 1, 0), (0, 1, 1), (1, 1, 1), (1, 1, 0)]),
        "z0": ((0, 0, -1), 0.0, [(0, 0, 0), (0, 1, 0), (1, 1, 0), (1, 0, 0)]),
        "z1": ((0, 0, 1), s, [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]),
    }
    return ReconstructedModel(
        parts=[
            ModelPart(
                role=f"box.{name}",
                concept="Plane",
                normal=(float(n[0]), float(n[1]), float(n[2])),
                offset_m=d,
                polygon=[corners[c] for c in poly],
            )
            for name, (n, d, poly) in faces.items()
        ]
    )


def _interpretation() -> Interpretation:
    return Interpretation(
        goal="House",
        accepted=True,
        message="a box",
        instances=[
            Instance(role="", concept="Box", instance_of="Box", parent=None, link="goal"),
            Instance(
                role="x0",
                concept="Plane",
                instance_of="Plane",
                parent="",
                link="part-of",
                bindings=["00/1"],
            ),
        ],
        model=_cube(),
        residuals=[
            ConstraintResidual(
                label="square",
                kind="angle",
                concept="Box",
                owner="",
                parts=["x0", "y0"],
                residual=0.01,
                unit="rad",
                sigma=0.02,
                normalised_cost=0.25,
                threshold=10.8,
                reject_above=None,
                rejected=False,
            )
        ],
        trace=[
            HypothesisTrace(id=0, parent=None, concept="Box", role="", status="verified", step=0),
            HypothesisTrace(
                id=1,
                parent=0,
                concept="Plane",
                role="x0",
                status="rejected",
                step=1,
                constraint="square",
                cost=12.5,
            ),
        ],
        expanded=2,
        cost=0.25,
    )


def _png(image: np.ndarray[Any, Any]) -> bytes:
    ok, data = cv2.imencode(".png", image)
    assert ok
    return data.tobytes()


def build_targets(work: Path) -> dict[str, Target]:
    """Every target with its seeds, each writing into its own folder below `work`."""
    rng = np.random.default_rng(0)
    img = rng.integers(0, 255, (48, 64, 3), dtype=np.uint8)
    labels = np.zeros((48, 64), np.uint16)
    labels[10:30, 5:40] = 1
    depth = np.full((48, 64), 10.0, np.float32)
    depth[:5] = np.nan
    seed_scene = write_scene(
        work / "seed-scene",
        _calib(),
        [ViewData(img, img.copy(), labels=labels, depth_left=depth)],
        truth=_truth(),
    )
    seed_files = {p.name: p.read_bytes() for p in seed_scene.rglob("*") if p.is_file()}
    write_model(work / "seed-model.json", _cube())
    write_interpretation(work / "seed-interpretation.json", _interpretation())
    kb_seeds = [(ROOT / "kb" / "buildings.kb").read_bytes()]
    kb_seeds += [p.read_bytes() for p in sorted((ROOT / "kb" / "examples").glob("*.kb"))[:4]]
    evidence_seeds = [
        (ROOT / "tests" / "fixtures" / n).read_bytes() for n in ("house_correct.json", "oriel.json")
    ]
    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    ok, jpeg = cv2.imencode(".jpg", img)
    assert ok

    def scene_place(name: str, folder: str) -> Callable[[bytes], tuple[Path, Path]]:
        scene = work / folder
        shutil.copytree(seed_scene, scene)
        rel = next(p for p in seed_scene.rglob(name)).relative_to(seed_scene)

        def place(data: bytes) -> tuple[Path, Path]:
            (scene / rel).write_bytes(data)
            return scene / rel, scene

        return place

    def file_place(name: str) -> Callable[[bytes], tuple[Path, Path]]:
        folder = work / f"t-{name}"
        folder.mkdir()

        def place(data: bytes) -> tuple[Path, Path]:
            (folder / name).write_bytes(data)
            return folder / name, folder / name

        return place

    return {
        "kb": Target("kb", kb_seeds, file_place("fuzz.kb"), compile_path, "kb"),
        "scene_yaml": Target(
            "scene_yaml",
            [seed_files["scene.yaml"]],
            scene_place("scene.yaml", "t-scene"),
            lambda p: read_scene(p.parent),
            "yaml",
        ),
        "calib_yaml": Target(
            "calib_yaml", [seed_files["calib.yaml"]], file_place("calib.yaml"), read_calib, "calib"
        ),
        "image": Target(
            "image",
            [seed_files["left.png"], _png(grey), jpeg.tobytes()],
            file_place("left.png"),
            read_image,
            "image",
        ),
        "labels": Target(
            "labels", [seed_files["labels.png"]], file_place("labels.png"), read_labels, "image"
        ),
        "depth": Target(
            "depth", [seed_files["depth_left.npy"]], file_place("depth.npy"), read_depth, "npy"
        ),
        "evidence": Target(
            "evidence", evidence_seeds, file_place("evidence.json"), read_evidence, "json"
        ),
        "model": Target(
            "model",
            [(work / "seed-model.json").read_bytes()],
            file_place("model.json"),
            read_model,
            "json",
        ),
        "interpretation": Target(
            "interpretation",
            [(work / "seed-interpretation.json").read_bytes()],
            file_place("interpretation.json"),
            read_interpretation,
            "json",
        ),
        "truth": Target(
            "truth",
            [seed_files["truth.json"]],
            scene_place("truth.json", "t-truth"),
            lambda p: read_scene(p.parent, with_truth=True),
            "json",
        ),
    }


# ---- mutations -------------------------------------------------------------------------------


def _byte_mutation(data: bytes, rnd: random.Random) -> bytes:
    n = len(data)
    op = rnd.randrange(7)
    i = rnd.randrange(n + 1)
    j = min(n, i + rnd.randrange(1, 64))
    if op == 0 and n:  # flip one byte
        k = rnd.randrange(n)
        return data[:k] + bytes([data[k] ^ (1 << rnd.randrange(8))]) + data[k + 1 :]
    if op == 1:  # delete a range
        return data[:i] + data[j:]
    if op == 2:  # duplicate a range
        return data[:j] + data[i:j] * rnd.randrange(1, 4) + data[j:]
    if op == 3:  # truncate
        return data[:i]
    if op == 4:  # random bytes
        return data[:i] + rnd.randbytes(rnd.randrange(1, 16)) + data[i:]
    if op == 5:  # replace a number with a hostile one
        digits = [k for k in range(n) if 48 <= data[k] <= 57]
        if digits:
            k = rnd.choice(digits)
            end = k
            while end < n and (48 <= data[end] <= 57 or data[end] in b".eE+-"):
                end += 1
            return data[:k] + rnd.choice(HOSTILE[:9]) + data[end:]
    return data[:i] + rnd.choice(HOSTILE) + data[i:]


def _replace_somewhere(node: Any, rnd: random.Random, value: Any, depth: int = 0) -> Any:
    """`node` with one randomly chosen value (at any depth) replaced by `value`."""
    if depth > 40:
        return value
    if isinstance(node, dict) and node and rnd.random() < 0.8:
        key = rnd.choice(list(node))
        return {**node, key: _replace_somewhere(node[key], rnd, value, depth + 1)}
    if isinstance(node, list) and node and rnd.random() < 0.8:
        k = rnd.randrange(len(node))
        return [*node[:k], _replace_somewhere(node[k], rnd, value, depth + 1), *node[k + 1 :]]
    return value


#: Numbers that keep a document's types: the values' own checks must refuse what is absurd.
NUMBERS: tuple[float, ...] = (1e308, -1e308, 1e-320, 0.0, -0.0, -5.5, 1e16, 3.0, 1e200)


def _numbers(node: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    if len(path) > 40:  # a seed made deep by an earlier mutation: leave its depths alone
        return []
    if isinstance(node, dict):
        return [q for k, v in node.items() for q in _numbers(v, (*path, k))]
    if isinstance(node, list):
        return [q for k, v in enumerate(node) for q in _numbers(v, (*path, k))]
    return [path] if isinstance(node, int | float) and not isinstance(node, bool) else []


def _set(node: Any, path: tuple[Any, ...], value: Any) -> None:
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value


def _structured(data: bytes, kind: str, rnd: random.Random) -> bytes | None:
    try:
        doc = json.loads(data) if kind == "json" else yaml.safe_load(data)
    except (ValueError, RecursionError, yaml.YAMLError):
        return None
    numbers = [p for p in _numbers(doc) if p]
    if numbers and rnd.random() < 0.5:  # a well-typed but absurd number
        for _ in range(rnd.randrange(1, 4)):
            _set(doc, rnd.choice(numbers), rnd.choice(NUMBERS))
        try:
            return json.dumps(doc).encode() if kind == "json" else yaml.safe_dump(doc).encode()
        except (ValueError, RecursionError, yaml.YAMLError):
            return None
    value = rnd.choice(VALUES)
    if rnd.random() < 0.15:  # a deep value
        value = [value]
        for _ in range(rnd.choice((10, 80, 600))):
            value = [value]
    mutated = _replace_somewhere(doc, rnd, value)
    try:
        if kind == "json":
            return json.dumps(mutated).encode()
        return yaml.safe_dump(mutated).encode()
    except (ValueError, RecursionError, yaml.YAMLError):
        return None


def _png_header(data: bytes, rnd: random.Random) -> bytes:
    if not data.startswith(b"\x89PNG") or len(data) < 33:
        return data
    width = rnd.choice((0, 1, 65535, 40000, 2**31 - 1, rnd.randrange(1, 5000)))
    height = rnd.choice((0, 1, 30000, 2**31 - 1, rnd.randrange(1, 5000)))
    ihdr = struct.pack(">II", width, height) + data[24:29]
    crc = struct.pack(">I", zlib.crc32(b"IHDR" + ihdr))
    return data[:16] + ihdr + crc + data[33:]


def mutate(target: Target, rnd: random.Random) -> bytes:
    """A seed of `target` after one to three mutations."""
    data = rnd.choice(target.seeds)
    for _ in range(rnd.randrange(1, 4)):
        choice = rnd.random()
        if target.kind in ("json", "yaml") and choice < 0.5:
            data = _structured(data, target.kind, rnd) or data
        elif target.kind == "image" and choice < 0.3:
            data = _png_header(data, rnd)
        else:
            data = _byte_mutation(data, rnd)
    return data


# ---- the contract ----------------------------------------------------------------------------


def nonfinite(value: Any, depth: int = 0) -> bool:
    """True when `value` holds a NaN or infinity anywhere (models, dataclasses, arrays)."""
    if depth > 200:
        return False
    if isinstance(value, float):
        return not math.isfinite(value)
    if isinstance(value, np.ndarray):
        return value.dtype.kind in "fc" and not bool(np.all(np.isfinite(value[~np.isnan(value)])))
    if isinstance(value, BaseModel):
        return nonfinite(value.model_dump(), depth + 1)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return any(nonfinite(getattr(value, f.name), depth + 1) for f in dataclasses.fields(value))
    if isinstance(value, dict):
        return any(nonfinite(v, depth + 1) for v in value.values())
    if isinstance(value, list | tuple):
        return any(nonfinite(v, depth + 1) for v in value)
    return False


def run_case(target: Target, data: bytes) -> str | None:
    """Read one mutated file; None if the contract held, else what broke it.

    The result's "clean error" or "result" is reported through `outcome` of `check`.
    """
    return check(target, data)[1]


def check(target: Target, data: bytes) -> tuple[str, str | None]:
    """("error" or "result", None) when the contract held, else ("violation", why)."""
    file, named = target.place(data)
    try:
        with contextlib.redirect_stdout(sys.stderr):
            result = target.read(file)
    except AidaError as exc:
        message = str(exc)
        if "\n" in message or not message.strip():
            return "violation", f"{target.name}: not one line: {message!r}"
        if str(named) not in message:
            return "violation", f"{target.name}: does not name the file: {message!r}"
        return "error", None
    except Exception as exc:  # the contract's point: nothing else may escape
        return "violation", f"{target.name}: {type(exc).__name__}: {str(exc)[:200]}"
    if target.kind == "kb":
        codes = {d.code for d in result.diagnostics}
        if "KB099" in codes:
            return "violation", f"kb: internal parser error: {result.diagnostics}"
        if result.ok and nonfinite(result.kb):
            return "violation", "kb: NaN or infinity in the compiled model"
        return ("result" if result.ok else "error"), None
    if target.kind == "npy":  # NaN is the format's "no surface"; infinity is not allowed
        if bool(np.any(np.isinf(result))):
            return "violation", "depth: infinity in the result"
        return "result", None
    if nonfinite(result):
        return "violation", f"{target.name}: NaN or infinity in the result"
    return "result", None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=DEFAULT_CASES, help="cases in all")
    parser.add_argument("--seed", type=int, default=16, help="random seed")
    args = parser.parse_args()
    rnd = random.Random(args.seed)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="aida-kb-fuzz-") as tmp:
        targets = build_targets(Path(tmp))
        stats = {name: {"runs": 0, "clean_errors": 0, "results": 0} for name in targets}
        violations: list[str] = []
        names = list(targets)
        for case in range(args.cases):
            target = targets[names[case % len(names)]]
            outcome, why = check(target, mutate(target, rnd))
            stats[target.name]["runs"] += 1
            if outcome == "error":
                stats[target.name]["clean_errors"] += 1
            elif outcome == "result":
                stats[target.name]["results"] += 1
            else:
                violations.append(str(why))
    print(
        json.dumps(
            {
                "cases": args.cases,
                "seed": args.seed,
                "targets": stats,
                "clean_errors": sum(s["clean_errors"] for s in stats.values()),
                "contract_violations": len(violations),
                "first_violations": violations[:5],
                "seconds": round(time.perf_counter() - start, 1),
            }
        )
    )


if __name__ == "__main__":
    main()
