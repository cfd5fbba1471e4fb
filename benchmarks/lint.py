"""Lint time of a generated knowledge base of 10,000 concepts against its raw Lark parse time.

Run: .venv/bin/python benchmarks/lint.py
Prints one line of JSON: {"concepts": 10000, "parse_s": ..., "lint_s": ..., "lint_over_parse": ...,
"build_s": ...}. ``parse_s`` is Lark's LALR parse of the same text with the grammar alone (no
transformer, a parse tree); ``lint_s`` is what ``aida-kb lint`` does: parse, load, resolve and
check (every diagnostic), no rendering; ``build_s`` is the further cost of the pydantic model
(``CompileResult.kb``), which linting does not need. aida-kb parses and compiles with
Python's cyclic garbage collector switched off (its trees have no cycles); ``parse_nogc_s``
and ``lint_over_parse_nogc`` compare against a raw parse with the collector off too. Each
figure is the best of several interleaved runs, in CPU seconds (process time).
"""

from __future__ import annotations

import gc
import json
import time
from collections.abc import Callable
from pathlib import Path

from lark import Lark

from aida_kb.dsl import grammar_path
from aida_kb.kb import compile_text

CONCEPTS = 10_000
RUNS = 3

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


def _cpu(fn: Callable[[], object]) -> float:
    """CPU seconds of one call (process time: fairer than wall time on a busy machine).

    The garbage left by the previous call is collected first, outside the timing, so that no
    call pays for another's.
    """
    gc.collect()
    start = time.process_time()
    fn()
    return time.process_time() - start


def main() -> None:
    text = generate()
    raw = Lark(Path(grammar_path()).read_text(encoding="utf-8"), parser="lalr")

    def lint() -> None:
        result = compile_text(text, "generated.kb")
        assert not any(d.is_error for d in result.diagnostics), result.diagnostics[:3]

    # interleaved, best of RUNS each: both figures see the same machine load
    parse_s = lint_s = parse_nogc_s = float("inf")
    for _ in range(RUNS):
        parse_s = min(parse_s, _cpu(lambda: raw.parse(text)))
        lint_s = min(lint_s, _cpu(lint))
        gc.disable()  # aida-kb parses and compiles with the cyclic collector off: compare so too
        try:
            parse_nogc_s = min(parse_nogc_s, _cpu(lambda: raw.parse(text)))
        finally:
            gc.enable()
    result = compile_text(text, "generated.kb")
    build_s = _cpu(lambda: result.kb)
    n = len(result.kb.concepts) if result.kb is not None else 0
    assert n == CONCEPTS, n
    print(
        json.dumps(
            {
                "concepts": n,
                "parse_s": round(parse_s, 4),
                "lint_s": round(lint_s, 4),
                "lint_over_parse": round(lint_s / parse_s, 3),
                "build_s": round(build_s, 4),
                "parse_nogc_s": round(parse_nogc_s, 4),
                "lint_over_parse_nogc": round(lint_s / parse_nogc_s, 3),
            }
        )
    )


if __name__ == "__main__":
    main()
