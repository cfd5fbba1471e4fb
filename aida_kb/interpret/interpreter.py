"""Hypothesis-verification interpretation (paper §2 and §5; ERNEST-style control).

The goal hypothesis (a scene concept) is expanded top-down: along con-of to its world-layer
realisation, along part-of into sub-hypotheses for the obligatory parts, and along is-a into
the alternatives of abstract parts. Planar parts are matched to evidence regions (orientation
and slope ranges in the instance frame, `assign`, `hypotheses`); parts the reference camera
cannot see are inserted from the knowledge (`unseen`). Each alternative is verified by one
adjustment with the project's solver (`alternative`, `adjust`, `verify`): if a constraint's
normalised cost in the residual report exceeds its threshold, or a part that the camera should
see has no evidence, the alternative is rejected (`plausibility`, `blame`) and the search goes
on with the others. Every hypothesis is recorded in the `trace`.

Hierarchy (paper §5): the main body (obligatory parts) is verified first; then optional
parts are hypothesised one at a time from the regions the body does not explain, adjusted
with the body's planes fixed. This module is the search control: `search.best_first` over
these levels, its cost the residual report's reduced normalised cost plus a penalty for
evidence left unexplained; it is deterministic and counts the hypotheses it expands.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from aida_kb.errors import AidaError
from aida_kb.interpret.alternative import Level, verify_alternative
from aida_kb.interpret.assign import forced_by, framings, ranked_fronts, vertical
from aida_kb.interpret.context import MIN_PART_WEIGHT_FRACTION, Context
from aida_kb.interpret.generate import BodyHypothesis, body_hypotheses
from aida_kb.interpret.ground import GROUND_LEVEL_DEG
from aida_kb.interpret.hypotheses import FloatArray, Frame
from aida_kb.interpret.knowledge import Knowledge, join
from aida_kb.interpret.observe import EvidenceView, RegionView, slope_deg
from aida_kb.interpret.plausibility import UNEXPLAINED_PENALTY, unexplained
from aida_kb.interpret.result import INSERTED, Instance
from aida_kb.interpret.search import best_first
from aida_kb.interpret.trace import Trace
from aida_kb.interpret.unseen import UnseenError, initial_planes
from aida_kb.kb.paths import RolePath

# at most this many hypotheses of the main body are verified (adjusted), best estimate first;
# the others are dropped (the trace says how many)
MAX_BODY_VERIFICATIONS = 30
# beyond one expansion for each generated hypothesis of the body, the search gives up (no
# interpretation) after expanding this many states for the optional parts: a handful each;
# more means they do not converge
MAX_OPTIONAL_EXPANSIONS = 40
# a verified body costs up to this much more for each part it inserts from the knowledge (no
# region shows it): of two alternatives that explain the same regions equally well, the one
# that guesses less is preferred (a gable and a hip roof over the same front slope and gable
# wall: their adjustments differ by noise, 1e-4). Small against the evidence: the penalty for
# leaving 1.25 % of the evidence weight unexplained (`plausibility.UNEXPLAINED_PENALTY`).
# An inserted part whose edges the reference image shows is not guessed: it costs only the
# share of its visible edges' length no segment lies along (`support.edge_support`; a part
# no camera sees costs it whole). A gable's roof planes over a dark roof with no region, its
# rakes and ridge seen, cost less than a flat roof's top, whose edges across the gable end
# wall are not seen.
INSERTED_PART_PENALTY = 0.05
# a body that inserts a part facing the camera (no region fits it; accepted only where the
# image's segments show its outline, `alternative.unseen_by_edges`) costs this much more for
# each: a face in view gives stereo a region far more often than not (a dark, low-texture
# roof is the exception)
FACING_INSERTED_PENALTY = 0.05
# a verified body explaining the same regions in the same frame as the accepted one, with
# other choices along is-a, is a tie when its cost is within this of the accepted body's:
# two guessed parts' worth (`INSERTED_PART_PENALTY`). A gable seen square to its front and a
# shed whose back wall stands under the ridge show the same edges; where the two differ only
# by where the knowledge placed unseen walls (their costs then scatter by a few hundredths),
# the evidence does not decide, and the result names the other (`Interpretation.ties`)
TIE_MARGIN = 2 * INSERTED_PART_PENALTY
# whether a body may insert a part facing the camera at all (False: rejected before any solve)
FACING_INSERTED = True

__all__ = ["Interpreter", "Level", "Pending", "State", "Trace"]


@dataclass(frozen=True)
class Pending:
    """An alternative of the main body waiting to be verified, with its optimistic cost."""

    hypothesis: BodyHypothesis
    # what optional parts may still explain of the evidence it leaves unbound (the penalty
    # for the free walls its estimate charges and one of them may bind, where the body's
    # concept has optional parts)
    optional: float = 0.0
    # the free significant regions an optional part may bind, walls and pitched roof planes
    # (region ids; `junction_regions`): a segment between one and the body is where a part
    # meets it, not an unexplained segment of the body (`adjust.adjust`, ``verified``)
    junctions: frozenset[str] = frozenset()
    # its parts that would be inserted facing the camera (`unseen.initial_planes`): verified
    # only where segments show them (`alternative.unseen_by_edges`); a rejection for want of
    # them does not count against `MAX_BODY_VERIFICATIONS`, as it did not when such bodies
    # were rejected before any solve
    facing: tuple[str, ...] = ()

    @property
    def estimate(self) -> float:
        """The penalty for the evidence it leaves unbound that no optional part may explain
        (`generate`): optimistic, a completed state with its optional parts costs at least
        that (an L-shape's wing taken for the body, its wing the body, completed cheaper than
        the true body's estimate of all it left unbound, which was then never verified)."""
        return self.hypothesis.estimate - self.optional


@dataclass(frozen=True)
class State:
    """A partial interpretation: the verified levels, and whether it is complete."""

    levels: tuple[Level, ...]
    done: bool
    cost: float
    pending: Pending | None = None


@dataclass
class Interpreter:
    """Interprets one evidence view against the knowledge, for one goal concept."""

    knowledge: Knowledge
    evidence: EvidenceView
    goal: str
    trace: Trace = field(default_factory=Trace)
    # regions other objects of the scene explain (`interpret.scene`): never bound here
    explained: frozenset[str] = frozenset()
    reference_weight: float = 0.0  # what `Context.significant` judges against (0: the total)
    anchors: frozenset[str] = frozenset()  # the regions the body may be anchored on (all)
    foreign: frozenset[str] = frozenset()  # other objects' regions: their borders measure nothing
    # choices along is-a the body must make (``(role path, concept)``; () : any): the other
    # views re-judge a tie by interpreting with each tied choice in turn (`rejudge`)
    choices: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        self.context = Context.build(
            self.knowledge,
            self.evidence,
            self.goal,
            self.explained,
            self.reference_weight,
            self.foreign,
        )
        # hypotheses of the body generated, verticals, frames, structures; verified so far
        self.generated: tuple[int, int, int, int] = (0, 0, 0, 0)
        self.verified_bodies = 0
        # every verified body with its cost (`ties`)
        self.bodies: list[tuple[Level, float]] = []
        # per body structure (by its choices): the parts a relation it asserts beyond a weaker
        # structure places (`Knowledge.beyond_weaker`; `alternative.outline_contradiction`)
        self.placed: dict[tuple[tuple[str, str], ...], frozenset[str]] = {}
        # the body's concept has optional parts (an oriel, a wing): the lighter walls they
        # may bind are evidence a complete state leaves unexplained (`left_unexplained`)
        self.optional = any(
            slot.link == "part-of" and not slot.obligatory
            for slot in self.knowledge.concept(self.context.body.concept).slots
        )

    def left_unexplained(self, levels: list[Level]) -> float:
        """The penalty a complete state of `levels` is charged for the evidence it leaves:
        the significant regions no level binds (`plausibility.unexplained`) and, where the
        body's concept has optional parts, the lighter walls one of them could have bound
        (`MIN_PART_WEIGHT_FRACTION`, vertical under the body's up, as `optional_alternatives`
        offers them). Without the latter a verified oriel whose front is lighter than a
        wall's share only added its misfit: the body without it was the cheaper complete
        state, by 0.0003 (dev seed 61509: an oriel verified at cost 0.015, dropped)."""
        ctx = self.context
        out = _unexplained(ctx, levels)
        if not self.optional or not levels:
            return out
        used = {r for lv in levels for r in lv.binding}
        lighter = [
            r
            for r in ctx.regions
            if r.id not in used
            and ctx.significant(r, MIN_PART_WEIGHT_FRACTION)
            and not ctx.must_explain(r)
        ]
        walls = vertical(lighter, levels[0].frame.up)
        return out + UNEXPLAINED_PENALTY * sum(ctx.share(r) for r in walls)

    # ---- level 0: the main body --------------------------------------------------------------
    def body_candidates(self, parent: int) -> list[Pending]:
        """The alternatives of the main body, not yet verified, with optimistic costs.

        Generated systematically (`generate.body_hypotheses`): every candidate vertical and
        frame, every specialisation, the best consistent bindings of regions to parts. The
        estimate is the penalty for the regions a binding leaves unexplained: its adjustment
        can only add to that (an admissible estimate).
        """
        ctx = self.context
        role, concept = ctx.body.role, ctx.body.concept
        structures = self.knowledge.structures(concept, role, None if not role else "", "con-of")
        framed = [s for s in structures if s.anchor is not None]
        self.placed = {s.choices: self.knowledge.beyond_weaker(s, framed) for s in framed}
        if not framed:
            hid = self.trace.create(concept, role, parent)
            self.trace.reject(
                hid, f"{concept} declares no frame ('frame from PART'): no part predicts the others"
            )
            return []
        # a scene's round anchors its object on given regions (interpret.scene)
        hypotheses, verticals, frames = body_hypotheses(ctx, framed, self.anchors)
        if self.choices:
            hypotheses = [h for h in hypotheses if _makes(h, self.choices)]
            framed = [s for s in framed if _makes_choices(s.choices, self.choices)]
            if not framed:
                hid = self.trace.create(concept, role, parent)
                wanted = ", ".join(f"{r}={c}" for r, c in self.choices)
                self.trace.reject(hid, f"no specialisation of {concept} makes {wanted}")
                return []
        self.generated = (len(hypotheses), verticals, frames, len(framed))
        if not hypotheses:
            hid = self.trace.create(concept, role, parent)
            anchor = framed[0].anchor_path
            leaf = next((x for x in framed[0].leaves if x.role == anchor), None)
            where = (
                f" ({leaf.concept}, oriented at {leaf.orient_span})"
                if leaf is not None and leaf.orient_span is not None
                else ""
            )
            self.trace.reject(
                hid,
                f"no evidence for {anchor}{where}: in {frames} frames under {verticals} "
                "verticals no significant region fits it",
            )
            return []
        out: list[Pending] = []
        for h in hypotheses:
            facing = self._facing(h)
            if not self.optional:
                out.append(Pending(h, facing=facing))
                continue
            free = [r for r in ctx.regions if r.id not in h.binding and ctx.significant(r)]
            # the walls an optional part may bind (`assign`: down to MIN_PART_WEIGHT_FRACTION)
            # among the evidence the estimate charges (`plausibility.unexplained`)
            charged = [
                r
                for r in ctx.regions
                if r.id not in h.binding
                and ctx.must_explain(r)
                and ctx.significant(r, MIN_PART_WEIGHT_FRACTION)
            ]
            walls = vertical(charged, h.frame.frame.up)
            out.append(
                Pending(
                    h,
                    UNEXPLAINED_PENALTY * sum(ctx.share(r) for r in walls),
                    junction_regions(free, h.frame.frame.up),
                    facing,
                )
            )
        return sorted(out, key=lambda p: p.estimate)  # stable: ties in the order generated

    def _facing(self, h: BodyHypothesis) -> tuple[str, ...]:
        """The parts `h` would insert facing the reference camera (cheap geometry, before any
        solve: `unseen.initial_planes` from the knowledge's placements); () when there are
        none or its planes cannot be placed (then `verify_body` says why)."""
        ctx = replace(self.context, up=h.frame.frame.up)
        try:
            initial = initial_planes(
                ctx, h.structure, h.frame.frame, h.binding, {}, {}, seen_by_edges=True
            )
        except AidaError:
            return ()
        return initial.visible

    def verify_body(self, pending: Pending, parent: int) -> tuple[Level, float] | None:
        """Verify one alternative of the main body; its level and cost, or None if rejected."""
        h = pending.hypothesis
        ctx = replace(self.context, up=h.frame.frame.up)
        bound = ", ".join(f"{role}={rid}" for rid, role in sorted(h.binding.items()))
        label = (
            f"vertical {h.frame.vertical}, frame from {'/'.join(sorted(h.frame.sources))}; "
            f"{bound or 'nothing bound'}"
        )
        try:
            # cheap, before any solve: a part it inserts would face the camera; such a body
            # is verified only where segments show that part (`FACING_INSERTED`)
            initial_planes(
                ctx, h.structure, h.frame.frame, h.binding, {}, {}, seen_by_edges=FACING_INSERTED
            )
        except UnseenError as exc:
            root = h.structure.nodes[0]
            what = "; ".join(x for x in (h.structure.describe(), label) if x)
            hid = self.trace.create(root.concept, root.role, parent, f"[{what}]")
            self.trace.reject(hid, f"[{what}] {exc}")
            return None
        self.verified_bodies += 1
        level = verify_alternative(
            ctx,
            self.trace,
            h.structure,
            h.frame.frame,
            parent,
            {},
            {},
            forced={},
            bindings=[h.binding],
            offered=h.offered,
            junctions=pending.junctions,
            label=label,
            seen_by_edges=FACING_INSERTED,
            placed=self.placed.get(h.structure.choices, frozenset()),
        )
        if level is None:
            if pending.facing:
                self.verified_bodies -= 1
            return None
        # its misfit counts in proportion to the evidence it explains, as an optional part's
        # does: which of two arms is taken for the body and which for its wing must not change
        # what the pair's misfits cost (counted whole, the arm binding more evidence, with
        # more residuals, was cheaper as the wing: the 135-degree L-shape's arms swapped)
        share = sum(self.evidence.regions[r].weight for r in level.binding)
        misfit = level.misfit * share / ctx.total_weight
        facing = FACING_INSERTED_PENALTY * len(level.visible)
        cost = misfit + h.prior + facing + body_evidence_cost(ctx, level)
        self.bodies.append((level, cost))
        return level, cost

    # ---- level 1..: optional parts ----------------------------------------------------------
    def optional_alternatives(self, state: State, parent: int) -> list[tuple[Level, float]]:
        """Verified alternatives for one more optional part of the body, with their costs."""
        ctx = replace(self.context, up=state.levels[0].frame.up)
        role, concept = ctx.body.role, ctx.body.concept
        used = {r for lv in state.levels for r in lv.binding}
        free = [
            r
            for r in ctx.regions
            if r.id not in used and ctx.significant(r, MIN_PART_WEIGHT_FRACTION)
        ]
        walls = vertical(free, ctx.up)
        if not walls:
            return []
        fixed_planes = {k: v for lv in state.levels for k, v in lv.outcome.planes.items()}
        guessed = frozenset(r for lv in state.levels for r in lv.inserted)
        choices = {r: c for lv in state.levels for r, c in lv.structure.choices}
        faces = {k: v for lv in state.levels for k, v in lv.polygons.items()}
        out: list[tuple[Level, float]] = []
        for slot in self.knowledge.concept(concept).slots:
            if slot.link != "part-of" or slot.obligatory:
                continue
            multi = RolePath.parse(join(role, slot.role))
            count = sum(
                1 for lv in state.levels[1:] if RolePath.parse(lv.structure.root).fills(multi)
            )
            if slot.max is not None and count >= slot.max:
                continue
            sub_role = str(multi.indexed(count))
            # the parts of one slot are added from left to right along the body's front: one
            # order of the same parts, not every permutation (and their indices do not depend
            # on which the search happened to verify first)
            rightward = state.levels[0].frame.direction("rightward")
            before = [
                float(_anchor_region(ctx, lv).centroid_m @ rightward)
                for lv in state.levels[1:]
                if RolePath.parse(lv.structure.root).fills(multi)
            ]
            for structure in self.knowledge.structures(slot.concept, sub_role, role, "part-of"):
                if structure.anchor is None:
                    continue
                for front in ranked_fronts(walls, self.evidence):
                    if before and float(front.centroid_m @ rightward) <= max(before):
                        continue
                    # the region as the anchor, or as another wall where the anchor faces
                    # away from the camera (`assign.framings`)
                    for part, frame in framings(structure, front, ctx.up, self.evidence.camera):
                        level = verify_alternative(
                            ctx,
                            self.trace,
                            structure,
                            frame,
                            parent,
                            fixed_planes,
                            choices,
                            forced=forced_by(structure, front, part),
                            exclude=used,
                            guessed=guessed,
                            faces=faces,
                        )
                        if level is None:
                            continue
                        # a verified smaller part costs its misfit in proportion to the
                        # evidence it explains, as the body does: whether to add it is
                        # decided by that evidence, not by its few constraints
                        share = sum(self.evidence.regions[r].weight for r in level.binding)
                        cost = state.cost + level.misfit * share / ctx.total_weight
                        # what the image contradicts it by counts as the body's does: its
                        # bound regions beyond their faces and its faces over no region
                        # (`contradicted`). Which arm of an L-shape is taken for the body and
                        # which for its wing must not change that (dev 73011, a 135-degree L:
                        # the wing taken for a shed body and the body for its wing cost 0.053
                        # less than the right pair, the gable end of the wing over the sky
                        # free). Its guessed parts are not charged: that prior chooses
                        # between the body's specialisations (`INSERTED_PART_PENALTY`)
                        cost += contradicted(ctx, level)
                        out.append((level, cost))
        return out

    # ---- the search --------------------------------------------------------------------------
    def run(self) -> tuple[State | None, int, int]:
        """Search; return the best complete state (or None), expansions, goal hypothesis id."""
        goal_id = self.trace.create(self.goal, "", None, "goal")
        start = State((), False, 0.0)
        pending = self.body_candidates(goal_id)

        def expand(state: State) -> list[tuple[State, float]]:
            self.trace.step += 1
            if state.pending is not None:
                if self.verified_bodies >= MAX_BODY_VERIFICATIONS:
                    return []
                verified = self.verify_body(state.pending, goal_id)
                if verified is None:
                    return []
                level, cost = verified
                return [(State((level,), False, cost), cost)]
            if not state.levels:
                return [(State((), False, p.estimate, p), p.estimate) for p in pending]
            # a partial state costs its levels' misfits (it can only grow along a path); the
            # evidence no level explains is charged when it is taken as complete, so that
            # every verified body gets its optional parts before a completed rival is taken
            # (a body and its wing, or the wing taken for the body and the body for its wing)
            done = state.cost + self.left_unexplained(list(state.levels))
            successors = [(State(state.levels, True, done), done)]
            for level, cost in self.optional_alternatives(state, state.levels[0].hid):
                successors.append((State((*state.levels, level), False, cost), cost))
            return successors

        # every hypothesis of the body may be taken from the open list (those beyond the
        # verification budget are dropped there): the budget of expansions counts them apart
        # from the optional parts', so that a verified body is still reached
        result = best_first(
            start,
            expand,
            lambda s: s.done,
            max_expansions=1 + len(pending) + MAX_OPTIONAL_EXPANSIONS,
        )
        generated, verticals, frames, structures = self.generated
        searched = (
            f"{generated} hypotheses of the body generated ({verticals} verticals, {frames} "
            f"frames, {structures} specialisations), {self.verified_bodies} verified "
            f"(at most {MAX_BODY_VERIFICATIONS}); {result.expanded} states expanded"
        )
        if result.best is None:
            self.trace.reject(
                goal_id, f"no alternative of its realisation was verified: {searched}"
            )
        else:
            self.trace.verify(goal_id, f"verified with cost {result.cost:.3g}: {searched}")
        return result.best, result.expanded, goal_id

    def ties(self, state: State) -> list[str]:
        """The other choices along is-a of the accepted body (``ROLE=CONCEPT``, sorted) that
        the evidence does not decide against: a verified body binding the same regions in
        the same frame, or every region the accepted one binds and more (in any frame: an
        L-shaped house's gable binding the roof region that the shed accepted left
        unexplained, dev seed 60008), its cost within `TIE_MARGIN` of the accepted body's —
        each with the penalty for the significant regions it leaves unexplained, as a
        complete state is charged —, that does not assert less than it (`Knowledge.weaker`:
        an asymmetric gable beside the symmetric one accepted is no rival)."""
        if not state.levels:
            return []
        body = state.levels[0]
        own = next((c for lv, c in self.bodies if lv is body), None)
        if own is None:
            return []
        chosen = dict(body.structure.choices)
        bound = set(body.binding)
        # each body as if taken alone: its cost and the penalty for the regions it leaves
        # unexplained (a rival binding more regions is not charged for those it explains)
        own += self.left_unexplained([body])
        out: set[str] = set()
        for level, cost in self.bodies:
            if level is body:
                continue
            same = set(level.binding) == bound and _same_frame(level.frame, body.frame)
            if not (same or set(level.binding) > bound):
                continue
            if cost + self.left_unexplained([level]) > own + TIE_MARGIN:
                continue
            if self.knowledge.weaker(level.structure, body.structure):
                # it fits no worse only by what it leaves out: the accepted one says more
                continue
            for role, concept in level.structure.choices:
                if chosen.get(role) != concept:
                    out.add(f"{role}={concept}")
        return sorted(out)

    def instances(self, state: State) -> list[Instance]:
        """The instance nodes of an accepted state (goal, body, parts, image-layer regions)."""
        goal_node = self.context.body.goal_node
        out: list[Instance] = []
        if goal_node is not None:
            out.append(
                Instance(
                    role="", concept=self.goal, instance_of=self.goal, parent=None, link="goal"
                )
            )
        for level in state.levels:
            bound = {r: rid for rid, r in level.binding.items()}
            for node in level.structure.nodes:
                bindings = [INSERTED] if node.role in level.inserted else []
                out.append(
                    Instance(
                        role=node.role,
                        concept=node.concept,
                        instance_of=node.instance_of,
                        parent=node.parent
                        if node.parent is not None
                        else ("" if goal_node is not None else None),
                        link=node.link if node.link != "goal" else "con-of",
                        bindings=bindings,
                    )
                )
                if node.role in bound:
                    real = self.knowledge.realisation(node.concept)
                    if real is not None:
                        out.append(
                            Instance(
                                role=join(node.role, real.role),
                                concept=real.concept,
                                instance_of=real.concept,
                                parent=node.role,
                                link="con-of",
                                bindings=[bound[node.role]],
                            )
                        )
        return out


def _makes_choices(made: tuple[tuple[str, str], ...], wanted: tuple[tuple[str, str], ...]) -> bool:
    """True if the is-a choices `made` include every one of `wanted`."""
    own = dict(made)
    return all(own.get(role) == concept for role, concept in wanted)


def junction_regions(free: list[RegionView], up: FloatArray) -> frozenset[str]:
    """The ids of the regions of `free` an optional part may bind where it meets the body:
    all but the level ones (`ground.GROUND_LEVEL_DEG` of `up`, (3,) unit, world frame: the
    ground, whose border with a wall is the body's own foot). A wing's walls and its roof's
    slopes alike: its roof runs into the body's roof along a segment that neither level's
    edges declare; charged to the body as loose (the wing, verified after it, is not charged
    for its segments to verified regions) it made the arm taken for the body pay its
    junction with the other's roof, and the 135-degree L-shape's arms came out swapped (dev
    63001: 16 px of roof junction, 0.10 of the true body's cost)."""
    return frozenset(r.id for r in free if slope_deg(r.normal, up) > GROUND_LEVEL_DEG)


def _makes(h: BodyHypothesis, wanted: tuple[tuple[str, str], ...]) -> bool:
    """True if hypothesis `h` of the body makes every choice of `wanted`."""
    return _makes_choices(h.structure.choices, wanted)


def guessed(level: Level) -> float:
    """How many of a level's inserted parts are guessed: each counts the share of its
    visible edges' length in the reference image that no segment lies along (1: none seen,
    or it has no visible edge; `support.EdgeSupport`)."""
    out = 0.0
    for role in level.inserted:
        seen = level.edges.share(frozenset((role,)))
        out += 1.0 if seen is None else 1.0 - seen
    return out


def body_evidence_cost(ctx: Context, level: Level) -> float:
    """What a verified body costs beyond its misfit: `INSERTED_PART_PENALTY` for each part
    it guesses (`guessed`), and what the image contradicts it by (`contradicted`)."""
    return INSERTED_PART_PENALTY * guessed(level) + contradicted(ctx, level)


def contradicted(ctx: Context, level: Level) -> float:
    """What the image contradicts a verified level (the body, or a smaller part of it) by:
    the evidence weight of its bound regions that lies outside their faces
    (`support.overflow`; a gable end wall's triangle above a flat roof's eave) at the rate of
    unexplained evidence (`plausibility.UNEXPLAINED_PENALTY`), as are the region pixels its
    bound faces cover where no region lies (`support.uncovered`: a shed's side wall rising
    past a gable wall's rake into the sky)."""
    return (
        UNEXPLAINED_PENALTY * level.overflow / ctx.total_weight
        + UNEXPLAINED_PENALTY * level.uncovered
    )


# two frames are one when their axes agree to this (the frames of one region's facing
# direction under one vertical are identical; the adjustment does not move a level's frame)
SAME_FRAME_COS = math.cos(math.radians(1.0))


def _same_frame(a: Frame, b: Frame) -> bool:
    """True if two instance frames have the same front and up (to `SAME_FRAME_COS`)."""
    return float(a.front @ b.front) >= SAME_FRAME_COS and float(a.up @ b.up) >= SAME_FRAME_COS


def _anchor_region(ctx: Context, level: Level) -> RegionView:
    """The region a verified level's frame anchor is bound to; where no region shows the
    anchor (`assign.framings`), its heaviest region."""
    bound = [r for r, role in level.binding.items() if role == level.structure.anchor_path]
    if not bound:
        bound = sorted(level.binding, key=lambda r: (-ctx.evidence.regions[r].weight, r))
    return ctx.evidence.regions[bound[0]]


def _unexplained(ctx: Context, levels: list[Level]) -> float:
    """The penalty for the significant regions no level binds."""
    return unexplained(ctx, {r for lv in levels for r in lv.binding})
