"""Lint time of a generated knowledge base of 10,000 concepts against its raw Lark parse time.

Run: .venv/bin/python benchmarks/lint.py
Prints one line of JSON with these figures (CPU seconds, process time):

- ``parse_s``: Lark's LALR parse (contextual lexer) of the text with the grammar alone - no
  transformer, a plain parse tree: the floor any Lark-based front end pays.
- ``lint_s``: what ``aida-kb lint`` does short of printing: aida-kb's own parse (the AST with
  spans and the syntax diagnostics), loading, resolution and every semantic check
  (`compile_text`).
- ``lint_over_parse``: ``lint_s / parse_s``, the headline (target <= 1.5). Both are timed under
  the same conditions: aida-kb parses and compiles with Python's cyclic garbage collector
  switched off (`aida_kb.dsl.parse` and `compile_text` do so themselves: their trees have no
  reference cycles), so the raw parse is timed with the collector off too. Before each timed
  call the previous call's garbage is collected, outside the timing.
- ``aida_parse_s``: aida-kb's parse alone (`aida_kb.dsl.parse`), the first part of ``lint_s``;
  ``check_s`` = ``lint_s - aida_parse_s`` is the rest (loading, resolution, checks).
- ``build_s``: the further cost of the pydantic model (``CompileResult.kb``), which linting
  does not need.
- ``lint_over_parse_median``: the same ratio from the medians instead of the best runs.
- ``parse_gc_on_s``: the raw parse with the collector on, for reference only (Python's default;
  the collector then rescans the growing tree again and again).

The timed calls are interleaved (raw parse, aida-kb parse, lint, raw parse with the collector
on, repeated ``RUNS`` times), so that every figure sees the same machine load; the best run
of each is reported, the medians give a second view on a busy machine.
"""

from __future__ import annotations

import gc
import json
import statistics
import time
from collections.abc import Callable
from pathlib import Path

from lark import Lark

from aida_kb.dsl import grammar_path, parse
from aida_kb.kb import compile_text

CONCEPTS = 10_000
RUNS = 5

_COMMON = """layers scene > world > image

template perpendicular(a: Plane, b: Plane, tol: angle = 1 deg) {
    "Two planes meet at a right angle."
    angle(a, b) == 90 deg +- tol
}
template parallel_planes(a: Plane, b: Plane, tol: angle = 0.5 deg) { parallel(a, b) +- tol }
template parallel_edges(a: Plane, b: Plane, c: Plane, d: Plane, tol: angle = 0.5 deg) {
    parallel(edge(a, b), edge(c, d)) +- tol
}
template symmetric(a: Plane, b: Plane, c: Plane, d: Plane, tol: angle = 0.5 deg) {
    angle(a, b) == angle(c, d) +- tol
}

concept Region in image {
    "A segmented image region."
    part contours: Contour [0..*]
    measure position(self) +- 1 px reject above 4 px
}
concept Contour in image { measure edge(self) +- 1 px reject above 3 px }
abstract concept Plane in world { con-of region: Region [0..1] }
concept RoofPlane is-a Plane { attribute pitch: angle in [0 deg, 65 deg] }
concept Floor is-a Plane { }
"""

_GROUP = """
concept Wall{i} is-a Plane {{
    "A wall of house {i}."
    attribute tilt: angle in [85 deg, 95 deg] = 90 deg
    attribute height: length in [2 m, 30 m]
}}
concept Roof{i} in world {{
    part front, back: RoofPlane
    adjacent pairs((front, back))
}}
concept Oriel{i} in world {{
    part front, left, right: Wall{i}
    adjacent ring(front, right, left)
    constraint perpendicular(front, left)
}}
concept Body{i} in world {{
    part front, back, left, right: Wall{i}
    part floor: Floor
    part roof: Roof{i}
    optional part oriels: Oriel{i} [0..*]
    adjacent ring(front, right, back, left)
    adjacent pairs((front, floor), (back, floor), (front, roof.front), (back, roof.back))
    constraint corner: perpendicular(front, left)
    constraint opposite: parallel_planes(front, back)
    constraint eaves: parallel_edges(front, roof.front, back, roof.back)
    constraint slopes: symmetric(front, roof.front, back, roof.back)
    constraint angle(front, floor) == 90 deg weight 10
    measure edge(edge(front, roof.front)) +- 1 px
}}
concept House{i} in scene {{ "House number {i}." con-of body: Body{i} }}
"""


def generate(concepts: int = CONCEPTS) -> str:
    """A knowledge base of exactly ``concepts`` concepts (5 shared, then groups of 5)."""
    groups, rest = divmod(concepts - 5, 5)
    assert rest == 0, "the generator makes 5 shared concepts and groups of 5"
    return _COMMON + "".join(_GROUP.format(i=i) for i in range(groups))


def _cpu(fn: Callable[[], object], *, collector: bool = False) -> float:
    """CPU seconds of one call (process time: fairer than wall time on a busy machine).

    The garbage left by the previous call is collected first, outside the timing, so that no
    call pays for another's; the call runs with the cyclic collector off unless ``collector``.
    """
    gc.collect()
    if not collector:
        gc.disable()
    try:
        start = time.process_time()
        fn()
        return time.process_time() - start
    finally:
        gc.enable()


def main() -> None:
    text = generate()
    raw = Lark(Path(grammar_path()).read_text(encoding="utf-8"), parser="lalr")
    parse(text, "generated.kb")  # build (or load) the product's parser outside the timings

    def aida_parse() -> None:
        result = parse(text, "generated.kb")
        assert result.ok, result.diagnostics[:3]

    def lint() -> None:
        result = compile_text(text, "generated.kb")
        assert not any(d.is_error for d in result.diagnostics), result.diagnostics[:3]

    times: dict[str, list[float]] = {"parse": [], "aida_parse": [], "lint": [], "parse_gc": []}
    for _ in range(RUNS):  # interleaved: every figure sees the same machine load
        times["parse"].append(_cpu(lambda: raw.parse(text)))
        times["aida_parse"].append(_cpu(aida_parse))
        times["lint"].append(_cpu(lint))
        times["parse_gc"].append(_cpu(lambda: raw.parse(text), collector=True))
    best = {k: min(v) for k, v in times.items()}
    median = {k: statistics.median(v) for k, v in times.items()}
    result = compile_text(text, "generated.kb")
    build_s = _cpu(lambda: result.kb)
    n = len(result.kb.concepts) if result.kb is not None else 0
    assert n == CONCEPTS, n
    print(
        json.dumps(
            {
                "concepts": n,
                "parse_s": round(best["parse"], 4),
                "lint_s": round(best["lint"], 4),
                "lint_over_parse": round(best["lint"] / best["parse"], 3),
                "aida_parse_s": round(best["aida_parse"], 4),
                "check_s": round(best["lint"] - best["aida_parse"], 4),
                "build_s": round(build_s, 4),
                "lint_over_parse_median": round(median["lint"] / median["parse"], 3),
                "parse_gc_on_s": round(best["parse_gc"], 4),
                "runs": RUNS,
            }
        )
    )


if __name__ == "__main__":
    main()
