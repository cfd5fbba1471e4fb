"""Check (i): every part a region measures has its normal fixed to the accuracy asked of it.

The evidence checks (b), (c) and (f) hold a model against its regions within a few degrees
(`NORMAL_TOLERANCE_DEG`, the regions' own fits): a model whose faces are 0.5-1 degrees off
passes them all (a street house 0.63 deg off did, once the images' steps across its edges
counted as seen). This check asks what the adjustment itself says: the standard deviation of
each part's normal from its covariance (`aida_kb.interpret.uncertainty`; two tilt axes, the
root of their summed variances, degrees), at `NORMAL_SD_CONFIDENCE` of them, must be at most
`NORMAL_SD_MAX_DEG`.

Only the parts a region of some view lies on are held to it: a part no region measures is
placed by its edges and the knowledge (its normal's deviation is then the knowledge's own
tolerance, a floor square to the walls to the 2 degrees of the first shape's angles), and
whether it is measured at all is check (e)'s question (`verdict.measured`).

Nor are the parts placed by edges, now that their deviations hold each edge's shared bias
(`aida_kb.interpret.uncertainty.EDGE_BIAS_PX`: 0.979 of them within two deviations on the dev
closing sets, 0.993 on 63000-64035). Held to this check, every right model verified on the
kept closing sets 61400-64035 (8: 61416, 61604, 61634, 61733, 61801, 61827, 63021, 64004)
would be doubted, their floors fixed to 0.51-1.38 deg at two deviations (0.01-0.06 deg off);
the floors more than 0.5 deg off it would catch (61517, 61522, 63028, 63035, 64019: 0.57-1.10
deg) are in models doubted for other reasons.
"""

from __future__ import annotations

import math

from aida_kb.interpret.uncertainty import Uncertainty

NORMAL_SD_MAX_DEG = 0.5
"""Issue 14's accuracy of a part's normal, degrees: a correct result has every normal within
0.5 deg of the truth."""
NORMAL_SD_CONFIDENCE = 2.0
"""... held at this many standard deviations (as the cameras', `tolerances.CAMERA_SD_CONFIDENCE`:
a normal's error is two-dimensional, so two sd of the root summed variance keep it within the
limit about 86 % of the time when both axes are alike, 95 % when one dominates)."""


def loose_normals(uncertainty: Uncertainty | None) -> list[str]:
    """Check (i) (problems, one per part): the parts a region measures
    (`Uncertainty.on_regions`) whose normal the adjustment fixes only to more than
    NORMAL_SD_MAX_DEG at NORMAL_SD_CONFIDENCE standard deviations. None without the
    adjustment's covariance (check (c) names that for the cameras)."""
    if uncertainty is None:
        return []
    out = []
    k = NORMAL_SD_CONFIDENCE
    for role in sorted(uncertainty.on_regions):
        normal_deg, _ = uncertainty.parts.get(role, (math.inf, math.inf))
        if k * normal_deg <= NORMAL_SD_MAX_DEG:
            continue
        if not math.isfinite(normal_deg):
            out.append(
                f"{role}: the adjustment leaves its normal open (at most {NORMAL_SD_MAX_DEG:g} "
                f"deg at {k:g} sd)"
            )
            continue
        out.append(
            f"{role}: its normal is fixed by the adjustment only to +-{k * normal_deg:.2f} deg "
            f"at {k:g} sd (at most {NORMAL_SD_MAX_DEG:g} deg; sd {normal_deg:.3f} deg)"
        )
    return out
