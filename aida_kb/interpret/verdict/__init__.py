"""The verdict on an accepted interpretation: verified, doubtful (with the reasons) or nothing.

The search accepts the best hypothesis whose constraints stay under their thresholds. That
alone lets a wrong model through when the evidence it fails to use is simply ignored (a roof
"inserted from knowledge" while a roof region fills a third of the image). An interpretation
is **verified** only when it also

(a) keeps every instantiated constraint under its threshold (the residual report; the
    evidence factors a multi-view adjustment adds by code — rule ``evidence`` — are judged by
    (b) and (c) instead: an outlier among them is no contradiction of the knowledge);
(b) explains the evidence: of the certainty weight of the regions that lie inside the model's
    projection (the ray through a region's centre meets a model face), most lies on a model
    face (the region's plane within `DEPTH_TOLERANCE` of the face and its normal within
    `NORMAL_TOLERANCE_DEG` — or `REGION_NORMAL_SIGMAS` of its own plane fit's sigma where that
    is wider: a region with little depth does not tell its orientation —, its centre inside
    the face's polygon, or OUTLINE_ON_MIN of its outline inside the faces of its plane: a
    region joining two oriels' fronts has its centre on the wall between them). A region the
    model covers but does not explain contradicts it: seen *through* the model (beyond the
    face the ray meets) or on a face at another orientation (a region whose plane fit kept
    at least PLANE_INLIER_SHARE of its pixels: a fit that kept fewer does not tell its
    orientation). A region in front of the model may be
    something standing before it (a tree) and counts neither way — unless it stands close
    before a face and parallel to it: such regions may carry STANDING_OUT_SHARE_MAX of the
    weight together (an oriel the model lacks);
(c) agrees with every registered view: the same test in each view, at the camera the
    reconstruction gave it; a view that does not explain its evidence is named, and so is a
    view where the model covers none of its regions or shows none of its edges (nothing
    there confirms the camera: a registration 100 degrees off passes every test for want
    of evidence), a view a reconstruction left without a camera (not registered: the
    result does not say where it was taken from; `judge(..., all_views=True)`), and a
    registered view (not the first, which sets the world frame) whose camera the
    adjustment fixes only to more than CAMERA_ANGLE_SD_MAX_DEG or CAMERA_CENTRE_SD_MAX of
    its distance (at two standard deviations, CAMERA_SD_CONFIDENCE, from the adjustment's
    covariance at the scatter its measurements show, `aida_kb.interpret.uncertainty`:
    segments and regions of every view, the model's planes unknowns too);
(d) meets the knowledge's attribute ranges: every attribute of an instantiated concept that
    stands for a geometric measure (`is slope(self)`, `height(self)`, ...; docs/language.md
    3.10) is measured on the model and must lie in its range; and every part the knowledge
    orients at a fixed slope (`orient top: upward`, 3.9) has it. "Up" is the direction of a
    part the knowledge orients upward or downward (the floor);
(e) measures every part (inserted from knowledge, or bound to regions none of which lies
    on it): a region of some view lies on it, the outlines of regions on the model reach
    its plane over an area inside its face (spanning OUTLINE_SPAN of it), or two of its
    edges are measured — seen (segments along half the edge) in two views, or in one view
    along a neighbour a region measures; one such edge suffices when the knowledge orients
    the part parallel or square to parts regions measure — unless that orientation is the
    choice among alternatives the evidence has not told apart (a flat roof's level top
    through its front eave: a shed's sloping top has that eave too; and the regions on such
    a part lie within CONTESTED_NORMAL_DEG of it, not only within (b)'s tolerance). A part
    not measured is where the knowledge's placement put it (a back wall mirrored about the
    ridge: the house's depth a guess; a roof's hidden back as steep as its front: a shed
    taken for a gable; a floor square to the walls), not where the scene has it. A part
    placed by its edges is placed to POSITION_TOLERANCE of the model's size (one standard
    deviation of its offset, from how far a pixel across each edge moves it in the views
    that see it, or the adjustment's covariance if larger: a wing's end from one edge seen
    at a grazing angle is not);
(f) lacks no surface joined to the object: a region outside the model's projection or in
    front of it, of at least ADJOINING_MIN_SHARE of the view's region pixels, whose outline
    meets a model face in 3-D along a quarter of the model's size, and which continues no
    face's plane (the ground continues the floor), is a part the model lacks (a hip roof's
    slopes above walls taken for a flat roof's); a tree before the house does not meet it;
(g) explains the surfaces near it: of the weight of the regions on the model and of those
    outside its projection or in front of it whose centres lie within NEAR_MARGIN of its
    size of its bounding box (and continue no face's plane), the model explains at least
    NEAR_EXPLAINED_MIN (an L-shaped house taken for its body leaves the wing's walls and
    roof there; an occluder covers at most a third of an object);
(i) has every part a region measures fixed by the adjustment to the normal accuracy asked of
    it: at NORMAL_SD_CONFIDENCE standard deviations (the adjustment's covariance, each region
    weighed by its own plane fit) within NORMAL_SD_MAX_DEG (`verdict.normals`; the evidence
    checks hold a model only to their few degrees: a street house 0.63 deg off passed them);
(j) is there where each view sees it, and ends where the surfaces end (`verdict.filled`): the
    faces are rasterised at the view's model camera (a depth buffer: only what the view sees
    of each face) and so are the regions, from their outlines; a region's plane along a
    face's pixel lies at the face's depth, clearly beyond it (FILL_BEYOND_DEPTH of its depth
    and FILL_BEYOND_SIZE of the model's size: seen *through* the model) or before it (an
    occluder: neither way). A face judged on FILL_MIN_SHARE of the image (FILL_EDGE_PX inside
    its outline, occluders taken off) of which more than FILL_CONTRADICTED_MAX shows the
    surface beyond is not there; a region (b) explains that lies at a face's depth over
    FILL_MIN_SHARE of the image, its plane on that face's, with more than SPILL_MAX of its
    pixels outside the model's projection goes on where the model has no surface (a gable's
    whole end wall beside the half a shed has: held-out 61325, 21 % off, passed (a)-(i));
    its pixels without a depth are taken off those outside (a segmented region leaks into
    the textureless sky through a gap in its outline; its surface has a depth).
    Regions whose plane fit kept fewer than PLANE_INLIER_SHARE of their pixels do not tell
    their depth and judge nothing.

Otherwise the interpretation is **doubtful**, and the reasons say which check failed and
where. An interpretation that found no object is **nothing**; so is one whose sizes (the
attributes in metres) lie outside the knowledge's ranges: what was found is not the goal (a
0.3 m box is no house), and the reasons say which sizes — among them an ``elevation`` above
the surfaces the reference view sees beneath the part (`attributes.evidence_ground`: a tree's
crown over its trunk floats; the ground region's plane is the search's, not the verdict's);
and so is a reconstruction that no other view of the scene confirms (`unconfirmed`: it
registered none of them, or the model, at the cameras it gave them, covers none of their
regions or shows none of their edges; a tree's box-shaped crown taken for a small house in
one view). The summary line says the
reasons once for several parts (`summary_reasons`). Everything is read from the
compiled knowledge base and the files: no concept or attribute of a particular .kb is named.


The package, one module per concern: `tolerances` (the named thresholds), `outcome`
(`Verdict`, `ViewCheck`), `geometry` (faces, projection, region outlines), `views` ((b), (f),
(g) in one view), `edges` (segments along model edges; (c), and (e)'s edge placement),
`measured` ((e)), `attributes` ((d)), `cameras` ((c) for registered cameras; standard
deviations in the model), `normals` ((i)), `filled` ((j)), `judge` (the verdict) and
`summary` (the verdict in the result).
"""

from __future__ import annotations

from aida_kb.interpret.verdict.attributes import (
    check_attributes,
    check_orientations,
    measured_attributes,
)
from aida_kb.interpret.verdict.cameras import (
    camera_doubts,
    with_deviations,
)
from aida_kb.interpret.verdict.edges import (
    edge_cover,
    edge_coverage,
    line_offset_sd,
    seen_edges,
)
from aida_kb.interpret.verdict.filled import (
    FaceFill,
    Spill,
    face_fills,
    fill_maps,
    spills,
    unfilled,
)
from aida_kb.interpret.verdict.geometry import (
    inside_polygon,
    model_faces,
    model_size,
    outline_points,
    project,
)
from aida_kb.interpret.verdict.judge import (
    judge,
    unconfirmed,
    undecided,
)
from aida_kb.interpret.verdict.measured import (
    BOUND_TO_NOTHING,
    NOT_MEASURED,
    PLACED_BY_KNOWLEDGE,
    contested,
    spread,
    unmeasured_roles,
)
from aida_kb.interpret.verdict.normals import (
    NORMAL_SD_CONFIDENCE,
    NORMAL_SD_MAX_DEG,
    loose_normals,
)
from aida_kb.interpret.verdict.outcome import (
    DOUBTFUL,
    NOTHING,
    VERIFIED,
    Verdict,
    ViewCheck,
)
from aida_kb.interpret.verdict.summary import (
    summary_reasons,
    with_verdict,
)
from aida_kb.interpret.verdict.tolerances import (
    ADJOINING_MIN_SHARE,
    ADJOINING_SPAN,
    CAMERA_ANGLE_SD_MAX_DEG,
    CAMERA_CENTRE_SD_MAX,
    CAMERA_SD_CONFIDENCE,
    CONTESTED_NORMAL_DEG,
    CONTRADICTION_MAX,
    COS_PARALLEL,
    DEPTH_TOLERANCE,
    DEPTH_TOLERANCE_MIN_M,
    EDGE_ANGLE_DEG,
    EDGE_COVER_MIN,
    EDGE_MIN_LENGTH_PX,
    EDGE_SEEN_SHARE,
    EDGE_SIGMA_PX,
    EDGE_STEP_MIN,
    EDGE_STEP_Z,
    EDGE_TOLERANCE_PX,
    EXACT_DEG,
    EXPLAINED_MIN,
    FILL_BEYOND_DEPTH,
    FILL_BEYOND_SIZE,
    FILL_CONTRADICTED_MAX,
    FILL_EDGE_PX,
    FILL_MIN_SHARE,
    FILL_NEAR_Z,
    INSIDE_MARGIN,
    MEASURED_LINES,
    MEASURING_SHARE,
    MIN_WEIGHT_SHARE,
    NEAR_EXPLAINED_MIN,
    NEAR_MARGIN,
    NORMAL_TOLERANCE_DEG,
    ORIENTATION_TOLERANCE_DEG,
    OUTLINE_AREA_RATIO,
    OUTLINE_INSIDE_MIN,
    OUTLINE_ON_MIN,
    OUTLINE_SPAN,
    OUTLINE_STEP_PX,
    OUTLINE_TOLERANCE_PX,
    PLANE_INLIER_SHARE,
    POSITION_TOLERANCE,
    RANGE_SLACK_REL,
    REGION_NORMAL_SIGMAS,
    SEEN_EDGE_COVER_MIN,
    SIN_SQUARE,
    SIZE_UNIT,
    SPILL_MAX,
    STANDING_OUT_MAX,
    STANDING_OUT_SHARE_MAX,
)
from aida_kb.interpret.verdict.views import (
    adjoining,
    check_view,
    unexplained_near,
)

__all__ = [
    "ADJOINING_MIN_SHARE",
    "ADJOINING_SPAN",
    "BOUND_TO_NOTHING",
    "CAMERA_ANGLE_SD_MAX_DEG",
    "CAMERA_CENTRE_SD_MAX",
    "CAMERA_SD_CONFIDENCE",
    "CONTESTED_NORMAL_DEG",
    "CONTRADICTION_MAX",
    "COS_PARALLEL",
    "DEPTH_TOLERANCE",
    "DEPTH_TOLERANCE_MIN_M",
    "DOUBTFUL",
    "EDGE_ANGLE_DEG",
    "EDGE_COVER_MIN",
    "EDGE_MIN_LENGTH_PX",
    "EDGE_SEEN_SHARE",
    "EDGE_SIGMA_PX",
    "EDGE_STEP_MIN",
    "EDGE_STEP_Z",
    "EDGE_TOLERANCE_PX",
    "EXACT_DEG",
    "EXPLAINED_MIN",
    "FILL_BEYOND_DEPTH",
    "FILL_BEYOND_SIZE",
    "FILL_CONTRADICTED_MAX",
    "FILL_EDGE_PX",
    "FILL_MIN_SHARE",
    "FILL_NEAR_Z",
    "INSIDE_MARGIN",
    "MEASURED_LINES",
    "MEASURING_SHARE",
    "MIN_WEIGHT_SHARE",
    "NEAR_EXPLAINED_MIN",
    "NEAR_MARGIN",
    "NORMAL_SD_CONFIDENCE",
    "NORMAL_SD_MAX_DEG",
    "NORMAL_TOLERANCE_DEG",
    "NOTHING",
    "NOT_MEASURED",
    "ORIENTATION_TOLERANCE_DEG",
    "OUTLINE_AREA_RATIO",
    "OUTLINE_INSIDE_MIN",
    "OUTLINE_ON_MIN",
    "OUTLINE_SPAN",
    "OUTLINE_STEP_PX",
    "OUTLINE_TOLERANCE_PX",
    "PLACED_BY_KNOWLEDGE",
    "PLANE_INLIER_SHARE",
    "POSITION_TOLERANCE",
    "RANGE_SLACK_REL",
    "REGION_NORMAL_SIGMAS",
    "SEEN_EDGE_COVER_MIN",
    "SIN_SQUARE",
    "SIZE_UNIT",
    "SPILL_MAX",
    "STANDING_OUT_MAX",
    "STANDING_OUT_SHARE_MAX",
    "VERIFIED",
    "FaceFill",
    "Spill",
    "Verdict",
    "ViewCheck",
    "adjoining",
    "camera_doubts",
    "check_attributes",
    "check_orientations",
    "check_view",
    "contested",
    "edge_cover",
    "edge_coverage",
    "face_fills",
    "fill_maps",
    "inside_polygon",
    "judge",
    "line_offset_sd",
    "loose_normals",
    "measured_attributes",
    "model_faces",
    "model_size",
    "outline_points",
    "project",
    "seen_edges",
    "spills",
    "spread",
    "summary_reasons",
    "unconfirmed",
    "undecided",
    "unexplained_near",
    "unfilled",
    "unmeasured_roles",
    "with_deviations",
    "with_verdict",
]
