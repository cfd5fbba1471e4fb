"""Part of an evidence file: the evidence without some regions (several objects per scene,
`aida_kb.interpret.scene`, judges each object without the regions the others explain)."""

from __future__ import annotations

from aida_kb.io.evidence import Evidence


def without_regions(evidence: Evidence, removed: set[str]) -> Evidence:
    """`evidence` without the regions `removed` ('VIEW/REGION') and their contours."""
    views = []
    for v in evidence.views:
        gone = {int(r.split("/", 1)[1]) for r in removed if r.split("/", 1)[0] == v.id}
        if not gone:
            views.append(v)
            continue
        views.append(
            v.model_copy(
                update={
                    "regions": [r for r in v.regions if r.id not in gone],
                    "contours": [c for c in v.contours if c.region not in gone],
                }
            )
        )
    return evidence.model_copy(update={"views": views})
