"""Every object of a batch in one CityJSON Text Sequence: ``city.jsonl`` (CityJSONSeq 2.0).

A CityJSONSeq is newline-delimited JSON: the first line a ``CityJSON`` object holding what
the features share (``transform``, ``metadata``) with empty ``CityObjects`` and
``vertices``, then one ``CityJSONFeature`` per line, each with its own ``CityObjects`` and
``vertices`` (integers, quantised by the first line's transform). A consumer can stream it a
building at a time, and a batch can append to it without holding the city in memory.

Each accepted scene's ``model.city.json`` (written by ``reconstruct``) becomes one feature:
its Building (and BuildingParts) with identifiers prefixed by the scene's key, so that they
are unique in the sequence, its vertices re-quantised onto the sequence's transform (exact:
both use `CITYJSON_SCALE_M`), and its texture paths made relative to the batch folder. The
scene's verdict is an attribute of its Building. Scenes are not placed on a map unless they
were georeferenced: without that, every model stays in its own scene's frame (the
``+aida-kb`` member of each feature records it).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from aida_kb.batch.outcome import SummaryRow
from aida_kb.batch.work import SCENES_DIR
from aida_kb.errors import FormatError
from aida_kb.io.atomic import write_text_atomic
from aida_kb.io.export import CITYJSON_SCALE_M

CITYSEQ_FILE = "city.jsonl"
SCENE_MODEL = "model.city.json"
# the id of an object in the sequence: the scene's key, then its id in the scene's document
ID_SEPARATOR = "/"


def _read(path: Path) -> dict[str, Any]:
    """A scene's CityJSON document; FormatError naming the file if it is not one."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise FormatError(f"{path}: cannot read the scene's CityJSON ({exc})") from None
    if not isinstance(doc, dict) or doc.get("type") != "CityJSON":
        raise FormatError(f"{path}: not a CityJSON document")
    return doc


def _world_vertices(doc: dict[str, Any], path: Path) -> np.ndarray[Any, np.dtype[np.float64]]:
    """The document's vertices in metres, (N, 3) float."""
    try:
        vertices = np.asarray(doc["vertices"], dtype=np.int64).reshape(-1, 3)
        scale = np.asarray(doc["transform"]["scale"], dtype=np.float64).reshape(3)
        translate = np.asarray(doc["transform"]["translate"], dtype=np.float64).reshape(3)
    except (KeyError, TypeError, ValueError) as exc:
        raise FormatError(f"{path}: vertices or transform malformed ({exc})") from None
    return vertices * scale + translate


def _renamed(key: str, objects: dict[str, Any], extra: dict[str, Any]) -> dict[str, Any]:
    """The city objects with ids prefixed by the scene key; `extra` attributes on the roots."""

    def rename(name: str) -> str:
        return f"{key}{ID_SEPARATOR}{name}"

    out: dict[str, Any] = {}
    for name, obj in objects.items():
        obj = dict(obj)
        for link in ("children", "parents"):
            if link in obj:
                obj[link] = [rename(n) for n in obj[link]]
        if "parents" not in obj:  # an object's own verdict (several per scene) stays
            obj["attributes"] = {**extra, **obj.get("attributes", {})}
        out[rename(name)] = obj
    return out


def _appearance(key: str, appearance: dict[str, Any] | None) -> dict[str, Any] | None:
    """The scene's appearance with texture images relative to the batch folder."""
    if not appearance:
        return None
    appearance = dict(appearance)
    if "textures" in appearance:
        appearance["textures"] = [
            {**t, "image": f"{SCENES_DIR}/{key}/{t['image']}"} for t in appearance["textures"]
        ]
    return appearance


def _renumber(node: Any, used: dict[int, int]) -> Any:
    """Boundaries (nested lists of vertex indices) with each index replaced by its place in
    `used` (old -> new, extended in the order met)."""
    if isinstance(node, list):
        return [_renumber(x, used) for x in node]
    if isinstance(node, int) and not isinstance(node, bool):
        return used.setdefault(node, len(used))
    return node


def _features(
    objects: dict[str, Any], roots: list[str], quantised: np.ndarray[Any, np.dtype[np.int64]]
) -> list[tuple[str, dict[str, Any], list[list[int]]]]:
    """(id, city objects, vertices) of each building of a scene: a root and its children,
    with only the vertices their geometry uses, renumbered. One root or none: the scene's
    objects and vertices as they are."""
    if len(roots) <= 1:
        return [(roots[0] if roots else "", objects, quantised.tolist())]
    out = []
    for root in roots:
        names = [root, *objects[root].get("children", [])]
        members = {n: objects[n] for n in names if n in objects}
        used: dict[int, int] = {}
        renumbered = {}
        for name, obj in members.items():
            obj = dict(obj)
            obj["geometry"] = [
                {**g, "boundaries": _renumber(g["boundaries"], used)}
                for g in obj.get("geometry", [])
            ]
            renumbered[name] = obj
        order = sorted(used, key=lambda v: used[v])
        out.append((root, renumbered, quantised[order].tolist()))
    return out


def city_sequence(
    root: Path, rows: Sequence[SummaryRow], title: str
) -> tuple[list[dict[str, Any]], list[str]]:
    """The sequence's lines (header first) from the accepted scenes of `rows` below `root`.

    Returns (lines, problems): a scene whose ``model.city.json`` cannot be read is left out
    and named in `problems` (one line each).
    """
    docs: list[tuple[SummaryRow, dict[str, Any], np.ndarray[Any, np.dtype[np.float64]]]] = []
    problems: list[str] = []
    for row in rows:
        outcome = row.outcome
        if outcome.status != "accepted" or SCENE_MODEL not in outcome.files:
            continue
        path = root / SCENES_DIR / outcome.scene / SCENE_MODEL
        try:
            doc = _read(path)
            docs.append((row, doc, _world_vertices(doc, path)))
        except FormatError as exc:
            problems.append(str(exc))
    everything = [w for _, _, w in docs if len(w)]
    if everything:
        points = np.concatenate(everything)
        lowest, highest = points.min(axis=0), points.max(axis=0)
    else:
        lowest = highest = np.zeros(3)
    translate = np.floor(lowest / CITYJSON_SCALE_M) * CITYJSON_SCALE_M
    systems = {d.get("metadata", {}).get("referenceSystem") for _, d, _ in docs}
    metadata: dict[str, Any] = {
        "title": title,
        "geographicalExtent": [round(float(x), 6) for x in (*lowest, *highest)],
    }
    if len(systems) == 1 and None not in systems:
        metadata["referenceSystem"] = systems.pop()
    header = {
        "type": "CityJSON",
        "version": "2.0",
        "transform": {
            "scale": [CITYJSON_SCALE_M] * 3,
            "translate": [float(x) for x in translate],
        },
        "metadata": metadata,
        "CityObjects": {},
        "vertices": [],
    }
    lines: list[dict[str, Any]] = [header]
    for row, doc, world in docs:
        key = row.outcome.scene
        quantised = np.round((world - translate) / CITYJSON_SCALE_M).astype(np.int64)
        verdict = row.outcome.verdicts[0].verdict if row.outcome.verdicts else None
        extra = {"aida-kb:scene": key}
        if verdict is not None:
            extra["aida-kb:verdict"] = verdict
        objects = _renamed(key, doc.get("CityObjects", {}), extra)
        roots = [n for n, o in objects.items() if "parents" not in o]
        appearance = _appearance(key, doc.get("appearance"))
        # one feature per building (a scene of several objects has one per object)
        for building, members, vertices in _features(objects, roots, quantised):
            feature: dict[str, Any] = {
                "type": "CityJSONFeature",
                "id": building or f"{key}",
                "CityObjects": members,
                "vertices": vertices,
            }
            if appearance is not None:
                feature["appearance"] = appearance
            if "+aida-kb" in doc:
                feature["+aida-kb"] = doc["+aida-kb"]
            lines.append(feature)
    return lines, problems


def write_city_sequence(root: Path, rows: Sequence[SummaryRow]) -> tuple[Path, list[str]]:
    """Write ``root/city.jsonl`` atomically (a header line even with no object).

    Returns the path and the scenes left out (see `city_sequence`).
    """
    lines, problems = city_sequence(
        root, rows, "aida-kb batch: the accepted objects, one feature per scene"
    )
    text = "".join(json.dumps(line, separators=(",", ":")) + "\n" for line in lines)
    path = root / CITYSEQ_FILE
    write_text_atomic(path, text)
    return path, problems
