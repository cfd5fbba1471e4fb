"""The verdict in the result: the summary line and the doubts."""

from __future__ import annotations

import re

from aida_kb.interpret.result import Interpretation
from aida_kb.interpret.verdict.cameras import with_deviations
from aida_kb.interpret.verdict.measured import BOUND_TO_NOTHING, NOT_MEASURED, PLACED_BY_KNOWLEDGE
from aida_kb.interpret.verdict.outcome import DOUBTFUL, NOTHING, Verdict

_UNMEASURED = re.compile(
    rf"^(\S+) is ({re.escape(PLACED_BY_KNOWLEDGE)}|{re.escape(BOUND_TO_NOTHING)})"
    rf"{re.escape(NOT_MEASURED)}: "
)


def _roles_once(roles: list[str]) -> str:
    """Roles joined, each after the first written from its last dot when it shares the
    first's owner: ``body.back, .left, .floor``."""
    owner = roles[0].rsplit(".", 1)[0] + "." if "." in roles[0] else None
    rest = [
        r[len(owner) - 1 :]
        if owner is not None and r.startswith(owner) and "." not in r[len(owner) :]
        else r
        for r in roles[1:]
    ]
    return ", ".join([roles[0], *rest])


def summary_reasons(reasons: tuple[str, ...] | list[str]) -> list[str]:
    """The reasons as the summary line gives them: what (e) says of each part no evidence
    measures (placed by the knowledge, or bound to no region on it) said once for all those
    parts, where the first of them stood (``body.back, .left, .floor placed by the knowledge:
    no view measures them``); the other reasons as they are. `Verdict.reasons` (the result's
    doubts) keep each part's own reason, with its count of measured edges."""
    groups: dict[str, list[str]] = {}
    out: list[str] = []
    for reason in reasons:
        m = _UNMEASURED.match(reason)
        if m is None:
            out.append(reason)
            continue
        how = m.group(2)
        if how not in groups:
            groups[how] = []
            out.append("\0" + how)  # the group's place
        groups[how].append(m.group(1))
    said = []
    for reason in out:
        if not reason.startswith("\0"):
            said.append(reason)
            continue
        how = reason[1:]
        roles = groups[how]
        what = "them" if len(roles) > 1 else "it"
        said.append(f"{_roles_once(roles)} {how}: no view measures {what}")
    return said


def with_verdict(interp: Interpretation, verdict: Verdict) -> Interpretation:
    """`interp` carrying the verdict; a doubtful one's summary line says so first, with
    the reasons of `summary_reasons` (the doubts keep every reason in full)."""
    message = interp.message
    if verdict.verdict == DOUBTFUL:
        shown = "; ".join(summary_reasons(verdict.reasons))
        message = f"{interp.goal} doubtful: {shown} (was: {message})"
    elif verdict.verdict == NOTHING and verdict.reasons:
        message = f"no {interp.goal} found: {'; '.join(verdict.reasons)} (was: {message})"
    update: dict[str, object] = {
        "verdict": verdict.verdict,
        "doubts": list(verdict.reasons),
        "message": message,
    }
    if interp.model is not None and verdict.uncertainty is not None:
        update["model"] = with_deviations(interp.model, verdict.uncertainty)
    return interp.model_copy(update=update)
