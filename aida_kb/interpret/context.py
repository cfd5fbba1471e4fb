"""What every step of one interpretation run shares: the knowledge, the reference view's
evidence, the estimated vertical and the world-layer body that realises the goal.

Built once per run (`Context.build`) and passed to the modules of the interpreter (search
control `interpreter`, region assignment `assign`, placement of unseen parts `unseen`,
adjustment `adjust`, plausibility `plausibility`, blame `blame`, trace `trace`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.errors import InterpretError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.interpret.ground import ground_region
from aida_kb.interpret.knowledge import Knowledge, Node
from aida_kb.interpret.observe import EvidenceView, RegionView, SegmentView, estimate_up

FloatArray = npt.NDArray[np.float64]

MIN_WALL_WEIGHT_FRACTION = 0.02  # a region lighter than this fraction of the total is clutter
# ... unless it is evidence for a smaller part (an oriel's side) beside a verified body
MIN_PART_WEIGHT_FRACTION = 0.01
# ... or it is large in the image: at least this fraction of the reference view's region
# pixels, however little certainty it carries (a dark roof, a wall seen at a grazing angle:
# few pixels with depth; development scene 2014, a shed's dark roof: 9 % of the pixels, 0.1 %
# of the weight, its plane 3 deg off). Left out, such a part is inserted although it faces
# the camera, and the hypothesis falls (`unseen.initial_planes`): nothing is found.
MIN_PART_AREA_FRACTION = 0.03


@dataclass(frozen=True)
class BodySlot:
    """The world-layer body realising the goal: its role ('' when the goal is the body itself),
    its concept, and the goal's own node (None when the goal is the body)."""

    role: str
    concept: str
    goal_node: Node | None


def body_slot(knowledge: Knowledge, goal: str) -> BodySlot:
    """The world-layer body realising `goal` (along con-of), or the goal itself.

    Raises InterpretError when the goal is abstract or has no parts to interpret.
    """
    concept = knowledge.concept(goal)
    if concept.abstract:
        raise InterpretError(f"goal {goal!r} is abstract; name a concrete concept")
    real = knowledge.realisation(goal)
    if real is None or knowledge.is_planar(real.concept):
        if knowledge.is_planar(goal):
            raise InterpretError(f"goal {goal!r} has no parts to interpret")
        return BodySlot("", goal, None)
    return BodySlot(real.role, real.concept, Node("", goal, goal, None, "goal"))


def object_reference_weight(
    regions: tuple[RegionView, ...], up: FloatArray, total_weight: float
) -> float:
    """The weight a region's significance is judged against where no scene gives one: the
    view's `total_weight` less its ground's (`ground.ground_region`; 0: the total where it
    has none, or nothing else).

    The ground is no part of the object and no hypothesis explains it, yet it may carry most
    of a view's weight: 84 % in dev seed 61526, where each of three oriels' fronts then
    carried 0.6-0.8 % of the total, under `MIN_PART_WEIGHT_FRACTION`, and no oriel was
    looked for. Judged against the rest, the object's regions count by their share of what
    an object may explain. regions : one view's regions (world frame); up : (3,) unit.
    """
    ground = ground_region(regions, up)
    if ground is None:
        return 0.0
    rest = total_weight - ground.weight
    return rest if rest > 0.0 else 0.0


@dataclass(frozen=True)
class Context:
    """One interpretation run's shared, read-only inputs.

    Attributes
    ----------
    knowledge : the compiled knowledge base as the interpreter sees it
    evidence : all views' evidence
    goal : the goal concept
    body : the world-layer body realising the goal
    regions : the reference view's regions
    total_weight : their summed weight (1.0 when there are none)
    up : (3,) unit vector, world frame: the estimated vertical
    segments : the reference view's line segments
    views : the views' names, sorted (a segment's camera index is its view's place here)
    pinholes : the views' cameras, in the order of `views`
    """

    knowledge: Knowledge
    evidence: EvidenceView
    goal: str
    body: BodySlot
    regions: tuple[RegionView, ...]
    total_weight: float
    up: FloatArray
    segments: tuple[SegmentView, ...]
    views: tuple[str, ...]
    pinholes: tuple[PinholeCamera, ...]
    # the weight `significant` judges against when not the total (`interpret.scene`; a
    # view's weight less its ground's, `object_reference_weight`)
    reference_weight: float = 0.0
    # other objects' regions (`interpret.scene`): they may hide this object's parts
    foreign: frozenset[str] = frozenset()
    # the reference view's regions' summed area, pixels (0: the sum of `regions`' areas)
    total_area_px: float = 0.0

    @classmethod
    def build(
        cls,
        knowledge: Knowledge,
        evidence: EvidenceView,
        goal: str,
        explained: frozenset[str] = frozenset(),
        reference_weight: float = 0.0,
        foreign: frozenset[str] = frozenset(),
    ) -> Context:
        """The context of interpreting `evidence` for `goal` (raises InterpretError for a goal
        that cannot be interpreted, `body_slot`).

        explained : region ids another object of the scene explains (`interpret.scene`):
        no part binds them and no segment bordering only them measures an edge; the vertical
        and the weight they are judged against (`significant`) stay those of all regions.
        reference_weight : the weight `significant` judges against (0: the view's weight
        less its ground's, `object_reference_weight`).
        foreign : region ids of other objects (`interpret.scene`): a segment bordering one
        measures no edge here (where another object occludes this one, the border is not
        this object's edge).
        """
        camera = evidence.camera
        views = tuple(sorted(evidence.cameras))
        seen = tuple(r for r in evidence.regions.values() if r.view == evidence.reference_view)
        regions = tuple(r for r in seen if r.id not in explained)
        total = sum(r.weight for r in seen) or 1.0
        up = estimate_up(
            list(seen),
            camera,
            segments_px=evidence.lines_px.get(camera.view),
            level=knowledge.orients_level(),
        )
        if reference_weight <= 0.0:
            reference_weight = object_reference_weight(seen, up, total)
        return cls(
            knowledge=knowledge,
            evidence=evidence,
            goal=goal,
            body=body_slot(knowledge, goal),
            regions=regions,
            total_weight=total,
            up=up,
            segments=tuple(
                s
                for s in evidence.segments
                if s.view == camera.view
                and not (s.regions and set(s.regions) <= explained)
                and not foreign.intersection(s.regions)
            ),
            views=views,
            pinholes=tuple(evidence.cameras[v].pinhole for v in views),
            reference_weight=reference_weight,
            foreign=foreign,
            total_area_px=sum(r.area_px for r in seen),
        )

    def share(self, region: RegionView) -> float:
        """The share of the reference view's evidence `region` carries, in [0, 1]: the
        larger of its share of the regions' weight (`total_weight`) and of their pixels
        (`total_area_px`). A dark, low-texture face in view carries little certainty but
        covers its pixels all the same (dev seed 61907, a hip roof's slopes: 5.5 % of the
        weight, 12.8 % of the pixels)."""
        area = self.total_area_px or sum(r.area_px for r in self.regions)
        pixels = region.area_px / area if area > 0.0 else 0.0
        return max(region.weight / self.total_weight, pixels)

    def significant(self, region: RegionView, fraction: float = MIN_WALL_WEIGHT_FRACTION) -> bool:
        """True if `region` carries at least `fraction` of the reference view's evidence."""
        return region.weight >= fraction * (self.reference_weight or self.total_weight)

    def large(self, region: RegionView) -> bool:
        """True if `region` covers at least MIN_PART_AREA_FRACTION of the reference view's
        region pixels."""
        area = sum(r.area_px for r in self.regions) or 1.0
        return region.area_px >= MIN_PART_AREA_FRACTION * area

    def must_explain(self, region: RegionView) -> bool:
        """True if `region` is evidence an interpretation must explain or pay for leaving
        out (`plausibility.unexplained`): significant by its weight, or large in the image
        (`large`: a dark roof slope, little certainty over many pixels, may be a part's
        evidence, `generate.best_bindings`, and so counts when no part binds it)."""
        return self.significant(region) or self.large(region)

    def hidden_by_others(self, point_m: FloatArray) -> bool:
        """True if another object's region (`foreign`) hides `point_m` ((3,), world frame,
        metres) from the reference camera: the point's pixel lies inside the region's outline
        and the region's plane crosses the viewing ray before the point."""
        if not self.foreign:
            return False
        camera = self.evidence.camera
        centre = camera.centre_m
        pixel = camera.pinhole.project(point_m.reshape(1, 3))[0]
        ray = camera.rays_world(pixel.reshape(1, 2))[0]
        depth = float(ray @ (point_m - centre))
        for rid in sorted(self.foreign):
            region = self.evidence.regions.get(rid)
            if region is None or region.view != camera.view:
                continue
            if not any(_inside_px(pixel, o) for o in self.evidence.outlines.get(rid, ())):
                continue
            along = float(region.normal @ ray)
            if abs(along) < 1e-9:
                continue
            t = (region.offset_m - float(region.normal @ centre)) / along
            if 0.0 < t < depth:
                return True
        return False


def _inside_px(pixel: FloatArray, polygon: FloatArray) -> bool:
    """Even-odd test of a pixel (2,) against a closed polygon (M, 2), pixels."""
    if len(polygon) < 3:
        return False
    x, y = float(pixel[0]), float(pixel[1])
    a = polygon
    b = np.roll(polygon, -1, axis=0)
    crosses = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        at = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return bool(np.count_nonzero(crosses & (x < at)) % 2)
