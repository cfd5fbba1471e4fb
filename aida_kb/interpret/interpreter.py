"""Hypothesis-verification interpretation (paper §2 and §5; ERNEST-style control).

The goal hypothesis (a scene concept, e.g. House) is expanded top-down: along con-of to its
world-layer realisation (HouseBody), along part-of into sub-hypotheses for the obligatory
parts, and along is-a into the alternatives of abstract parts (a roof: gable, hip, flat,
shed). Planar parts are matched to evidence regions (orientation and slope ranges in the
instance frame, see `hypotheses`); parts the reference camera cannot see are inserted from
the knowledge. Each alternative is verified by one adjustment with the project's solver
(`verify`, `aida_kb.solve`): if a constraint's normalised cost in the residual report exceeds
its threshold, or a part that the camera should see has no evidence, the alternative is
rejected and the search goes on with the others.

Hierarchy (paper §5): the main body (obligatory parts) is verified first; then optional
parts (wings, oriels) are hypothesised one at a time from the regions the body does not
explain, adjusted with the body's planes fixed. The search is `search.best_first` over these
levels: its cost is the residual report's reduced normalised cost plus a penalty for
evidence left unexplained; it is deterministic and counts the hypotheses it expands.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np
import numpy.typing as npt

from aida_kb.constraints import kind_of
from aida_kb.errors import AidaError, GeometryError, InterpretError
from aida_kb.interpret.closure import ClosingFace, close, closing_faces, inside_face
from aida_kb.interpret.edges import EdgeMatch, match_segments
from aida_kb.interpret.hypotheses import (
    DEFAULT_PITCH_DEG,
    DOWNWARD,
    UPWARD,
    Frame,
    PlanarPart,
    candidates,
    faces_camera,
    front_region,
    placed_offsets,
    predicted_normal,
    support_offset,
)
from aida_kb.interpret.knowledge import Knowledge, Node, Structure, join
from aida_kb.interpret.observe import EvidenceView, RegionView, estimate_up, slope_deg
from aida_kb.interpret.result import INSERTED, HypothesisTrace, Instance
from aida_kb.interpret.search import best_first
from aida_kb.interpret.verify import (
    BLAME_EVALUATIONS,
    BlameGroup,
    EdgeEvidence,
    Outcome,
    PlaneInit,
    Verification,
    blame_group,
    build_verification,
    position_data,
    tilt_constraints,
    verify,
)
from aida_kb.solve import ConstraintResidual

FloatArray = npt.NDArray[np.float64]

UNEXPLAINED_PENALTY = 4.0  # cost of leaving all evidence weight unexplained
MAX_ASSIGNMENTS = 6  # alternatives of region assignment tried per structure and frame
MIN_WALL_WEIGHT_FRACTION = 0.02  # a region lighter than this fraction of the total is clutter
# ... unless it is evidence for a smaller part (an oriel's side) beside a verified body
MIN_PART_WEIGHT_FRACTION = 0.01
# a smaller part's face the camera should see may lack evidence (a grazing side of an oriel,
# its region too small for a plane fit) if its image is below this fraction of its front's
MAX_UNSEEN_SIDE_FRACTION = 0.35
# segments are matched to the initial model within the first distance, then re-matched to
# the adjusted model within the next (outliers of the first matching drop out)
MATCH_DISTANCES_PX = (25.0, 8.0)
BLAME_CANDIDATES = 6  # constraints left out in turn to find a contradiction's culprit
MAX_MEAN_COST = 1.0  # an adjustment whose constraints miss by more than sigma on average fails
SEGMENT_PENALTY = 4.0  # cost of leaving every segment of the bound regions unexplained


@dataclass
class Trace:
    """The hypotheses of one interpretation run, in creation order."""

    entries: list[HypothesisTrace] = field(default_factory=list)
    step: int = 0

    def create(self, concept: str, role: str, parent: int | None, reason: str = "") -> int:
        """Record a new hypothesis; return its id."""
        hid = len(self.entries)
        self.entries.append(
            HypothesisTrace(
                id=hid,
                parent=parent,
                concept=concept,
                role=role,
                status="created",
                step=self.step,
                reason=reason,
            )
        )
        return hid

    def verify(self, hid: int, reason: str = "") -> None:
        """Mark a hypothesis verified."""
        self.entries[hid] = self.entries[hid].model_copy(
            update={"status": "verified", "step": self.step, "reason": reason}
        )

    def reject(self, hid: int, reason: str, row: ConstraintResidual | None = None) -> None:
        """Mark a hypothesis rejected, with the constraint (its report row) that felled it:
        its label, normalised cost and ``.kb`` line."""
        self.entries[hid] = self.entries[hid].model_copy(
            update={
                "status": "rejected",
                "step": self.step,
                "reason": reason,
                "constraint": None if row is None else row.label,
                "cost": None if row is None else row.normalised_cost,
                "span": None if row is None else row.span,
            }
        )


@dataclass(frozen=True)
class Level:
    """A verified level of the interpretation: one structure with its bindings and planes."""

    hid: int
    structure: Structure
    binding: dict[str, str]  # region id -> role path
    inserted: tuple[str, ...]
    outcome: Outcome
    frame: Frame
    polygons: dict[str, FloatArray]  # role path -> closed face polygon (N, 3), world, metres
    closing: tuple[ClosingFace, ...]  # faces of its solid from the levels it belongs to
    verification: Verification  # the problem it was verified by (its last adjustment)
    misfit: float  # adjustment cost plus the penalty for unexplained segments of bound regions


@dataclass(frozen=True)
class Pending:
    """An alternative of the main body waiting to be verified, with its optimistic cost."""

    structure: Structure
    front: RegionView
    estimate: float


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
    messages: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        camera = self.evidence.camera
        self._last: Verification | None = None
        self._views = sorted(self.evidence.cameras)
        self._pinholes = tuple(self.evidence.cameras[v].pinhole for v in self._views)
        self.regions = [
            r for r in self.evidence.regions.values() if r.view == self.evidence.reference_view
        ]
        self.total_weight = sum(r.weight for r in self.regions) or 1.0
        self.up = estimate_up(
            self.regions, camera, segments_px=self.evidence.lines_px.get(camera.view)
        )
        self.segments = [s for s in self.evidence.segments if s.view == camera.view]

    # ---- the goal and its realisation ------------------------------------------------------
    def body_slot(self) -> tuple[str, str, Node | None]:
        """(role, concept, goal node) of the world-layer body realising the goal."""
        goal = self.knowledge.concept(self.goal)
        if goal.abstract:
            raise InterpretError(f"goal {self.goal!r} is abstract; name a concrete concept")
        real = self.knowledge.realisation(self.goal)
        if real is None or self.knowledge.is_planar(real.concept):
            if self.knowledge.is_planar(self.goal):
                raise InterpretError(f"goal {self.goal!r} has no parts to interpret")
            return "", self.goal, None
        return real.role, real.concept, Node("", self.goal, self.goal, None, "goal")

    # ---- level 0: the main body --------------------------------------------------------------
    def body_candidates(self, parent: int) -> list[Pending]:
        """The alternatives of the main body, not yet verified, with optimistic costs.

        The estimate is the penalty for the regions the alternative's best assignment leaves
        unexplained: its adjustment can only add to that (an admissible estimate).
        """
        role, concept, _ = self.body_slot()
        structures = self.knowledge.structures(concept, role, None if not role else "", "con-of")
        framed = [s for s in structures if s.anchor is not None]
        if not framed:
            hid = self.trace.create(concept, role, parent)
            self.trace.reject(
                hid, f"{concept} declares no frame ('frame from PART'): no part predicts the others"
            )
            return []
        walls = [r for r in self.regions if abs(slope_deg(r.normal, self.up) - 90.0) <= 15.0]
        fronts = _ranked_fronts(walls, self.evidence)
        if not fronts:
            hid = self.trace.create(concept, role, parent)
            anchor = framed[0].anchor_path
            self.trace.reject(hid, f"no evidence for {anchor}: no vertical region seen")
            return []
        out: list[Pending] = []
        for structure in framed:
            for front in fronts:
                frame = Frame.from_front(front.normal, self.up)
                options = self._assignments(
                    structure, frame, _forced(structure, front), frozenset()
                )
                bound = options[0] if not isinstance(options, str) else {}
                estimate = self._unexplained_ids(set(bound))
                out.append(Pending(structure, front, estimate))
        return out

    def verify_body(self, pending: Pending, parent: int) -> tuple[Level, float] | None:
        """Verify one alternative of the main body; its level and cost, or None if rejected."""
        frame = Frame.from_front(pending.front.normal, self.up)
        level = self._try(
            pending.structure,
            frame,
            parent,
            {},
            {},
            forced=_forced(pending.structure, pending.front),
        )
        if level is None:
            return None
        return level, level.misfit + self._unexplained([level])

    # ---- level 1..: optional parts ----------------------------------------------------------
    def optional_alternatives(self, state: State, parent: int) -> list[tuple[Level, float]]:
        """Verified alternatives for one more optional part of the body, with their costs."""
        body = state.levels[0]
        role, concept, _ = self.body_slot()
        used = {r for lv in state.levels for r in lv.binding}
        free = [
            r
            for r in self.regions
            if r.id not in used and self._significant(r, MIN_PART_WEIGHT_FRACTION)
        ]
        walls = [r for r in free if abs(slope_deg(r.normal, self.up) - 90.0) <= 15.0]
        if not walls:
            return []
        fixed_planes = {k: v for lv in state.levels for k, v in lv.outcome.planes.items()}
        guessed = frozenset(r for lv in state.levels for r in lv.inserted)
        choices = {r: c for lv in state.levels for r, c in lv.structure.choices}
        out: list[tuple[Level, float]] = []
        for slot in self.knowledge.concept(concept).slots:
            if slot.link != "part-of" or slot.obligatory:
                continue
            count = sum(
                1
                for lv in state.levels[1:]
                if lv.structure.root.startswith(join(role, slot.role) + "[")
            )
            if slot.max is not None and count >= slot.max:
                continue
            sub_role = f"{join(role, slot.role)}[{count}]"
            for structure in self.knowledge.structures(slot.concept, sub_role, role, "part-of"):
                if structure.anchor is None:
                    continue
                for front in _ranked_fronts(walls, self.evidence):
                    frame = Frame.from_front(front.normal, self.up)
                    level = self._try(
                        structure,
                        frame,
                        parent,
                        fixed_planes,
                        choices,
                        forced=_forced(structure, front),
                        exclude=used,
                        body_frame=body.frame,
                        guessed=guessed,
                    )
                    if level is not None:
                        # a verified smaller part costs its misfit in proportion to the
                        # evidence it explains (the body's misfit counts whole): whether to
                        # add it is decided by that evidence, not by its few constraints
                        levels = [*state.levels, level]
                        share = sum(self.evidence.regions[r].weight for r in level.binding)
                        out.append(
                            (
                                level,
                                state.cost
                                - self._unexplained(list(state.levels))
                                + level.misfit * share / self.total_weight
                                + self._unexplained(levels),
                            )
                        )
        return out

    # ---- one alternative: match, initialise, adjust, verify ------------------------------
    def _try(
        self,
        structure: Structure,
        frame: Frame,
        parent: int,
        fixed: dict[str, tuple[FloatArray, float]],
        choices: dict[str, str],
        *,
        forced: dict[str, RegionView],
        exclude: set[str] | frozenset[str] = frozenset(),
        body_frame: Frame | None = None,
        guessed: frozenset[str] = frozenset(),
    ) -> Level | None:
        root = structure.nodes[0]
        what = "; ".join(
            x for x in (structure.describe(), *(f"{k}={r.id}" for k, r in forced.items())) if x
        )
        hid = self.trace.create(root.concept, root.role, parent, f"[{what}]")
        smaller = bool(fixed)  # a part of a verified level (paper §5: smaller parts later)
        assignments = self._assignments(structure, frame, forced, exclude, smaller=smaller)
        if isinstance(assignments, str):
            self.trace.reject(hid, f"[{what}] {assignments}")
            return None
        best: Level | None = None
        # why each assignment fell; the trace names the first that a constraint felled (the
        # assignments come heaviest evidence first), else the first. A contradiction's culprit
        # is searched for (`_blame`, many solves) only when its reason is the one reported.
        reasons: list[Reason | Callable[[], Reason]] = []
        offered = {rid for binding in assignments for rid in binding}
        for binding in assignments:
            try:
                outcome, inserted, loose, visible = self._adjust(
                    structure, frame, binding, fixed, choices, guessed
                )
            except _UnseenError as exc:
                reasons.append((str(exc), None))
                continue
            except AidaError as exc:
                reasons.append((f"adjustment failed: {exc}", None))
                continue
            worst = outcome.worst_rejected()
            if outcome.cost > MAX_MEAN_COST:
                # the constraints together do not fit: name the one to blame, which need not
                # be the first over its threshold (the compromise spreads a contradiction)
                reasons.append(partial(self._blame, outcome, self._last, worst))
                continue
            if worst is not None:
                reasons.append((_over(worst), worst))
                continue
            try:
                polygons, closing = self._close(structure, outcome, fixed, frame)
            except GeometryError as exc:
                reasons.append((f"its planes do not close a solid: {exc}", None))
                continue
            outside = self._outside(binding, polygons) or self._unseen(visible, polygons, forced)
            if outside:
                reasons.append((outside, None))
                continue
            # evidence an alternative could have bound but leaves out counts against it
            left_out = sum(self.evidence.regions[r].weight for r in offered - set(binding))
            misfit = (
                outcome.cost
                + SEGMENT_PENALTY * loose
                + UNEXPLAINED_PENALTY * left_out / self.total_weight
            )
            assert self._last is not None
            level = Level(
                hid,
                structure,
                binding,
                inserted,
                outcome,
                frame,
                polygons,
                closing,
                self._last,
                misfit,
            )
            if best is None or level.misfit < best.misfit:
                best = level
        if best is None:
            why = _first_named(reasons)
            self.trace.reject(hid, f"[{what}] {why[0]}", why[1])
            return None
        self.trace.verify(hid, f"[{what}] cost {best.misfit:.3g}")
        return best

    def _level_with(
        self, leaf: PlanarPart, regions: list[RegionView], forced: dict[str, RegionView]
    ) -> list[RegionView]:
        """The regions that can be a level part's evidence given its anchor: a part facing
        upward (a flat roof, an oriel's top) lies above the anchor's centre, one facing downward
        below it (the ground is neither)."""
        front = _anchor(forced)
        if front is None or leaf.direction not in (UPWARD, DOWNWARD):
            return regions
        sign = 1.0 if leaf.direction == UPWARD else -1.0
        return [r for r in regions if sign * float((r.centroid_m - front.centroid_m) @ self.up) > 0]

    def _assignments(
        self,
        structure: Structure,
        frame: Frame,
        forced: dict[str, RegionView],
        exclude: set[str] | frozenset[str],
        *,
        smaller: bool = False,
    ) -> list[dict[str, str]] | str:
        """Alternative bindings region id -> role path, or the reason there are none.

        For the smaller parts of a verified level (``smaller``) lighter regions count
        (`MIN_PART_WEIGHT_FRACTION`), a part meeting the front must be seen beside it
        (`EvidenceView.beside`), and each part may also be left unbound
        (inserted; `_unseen` checks that the camera could miss it).
        """
        options: list[list[RegionView | None]] = []
        minimum = MIN_PART_WEIGHT_FRACTION if smaller else MIN_WALL_WEIGHT_FRACTION
        available = [
            r for r in self.regions if r.id not in exclude and self._significant(r, minimum)
        ]
        front = _anchor(forced)
        anchor = structure.anchor_path
        meets_front = {b if a == anchor else a for a, b in structure.adjacency if anchor in (a, b)}
        for leaf in structure.leaves:
            if leaf.role == anchor and front is not None:
                options.append([front])
                continue
            usable = self._level_with(leaf, available, forced)
            if smaller and front is not None and leaf.role in meets_front:
                usable = [r for r in usable if self.evidence.beside(front.id, r.id)]
            found: list[RegionView | None] = list(candidates(leaf, usable, frame))
            if not found:
                if leaf.role == anchor:
                    return f"no evidence for {leaf.role} ({leaf.concept})"
                found = [None]
            elif smaller:
                found.append(None)
            options.append(found)
        out: list[dict[str, str]] = []
        for combo in itertools.product(*options):
            ids = [r.id for r in combo if r is not None]
            if len(set(ids)) != len(ids):
                continue
            out.append(
                {r.id: leaf.role for r, leaf in zip(combo, structure.leaves, strict=True) if r}
            )
            if len(out) >= MAX_ASSIGNMENTS:
                break
        if not out:
            return "no consistent assignment of regions to parts"
        return out

    def _adjust(
        self,
        structure: Structure,
        frame: Frame,
        binding: dict[str, str],
        fixed: dict[str, tuple[FloatArray, float]],
        choices: dict[str, str],
        guessed: frozenset[str] = frozenset(),
    ) -> tuple[Outcome, tuple[str, ...], float, tuple[str, ...]]:
        """Initialise, match segments, adjust twice (re-matching in between).

        ``guessed``: fixed parts of verified levels that were inserted from knowledge, not
        seen. A segment on the edge between such a part and one of this structure explains
        that segment but is not taken as a measurement: its position would measure the guess
        (a wing's foot on the body's inserted floor, seen at a grazing angle, moved the wing's
        seen front wall 1.7 m away from its own stereo evidence).

        Returns the outcome, the inserted role paths, the fraction of the length of the
        segments bordering bound regions that no edge of the structure explains, and the
        inserted parts of a smaller structure that would face the camera (to be checked by
        their size once closed). An inserted part of the main body that would face the
        camera rejects the alternative at once.
        """
        role_to_region = {role: self.evidence.regions[rid] for rid, role in binding.items()}
        pts = [self.evidence.points_on(rid) for rid in binding]
        points = np.concatenate(pts) if pts else np.zeros((0, 3))
        pitches = [
            slope_deg(role_to_region[leaf.role].normal, self.up)
            for leaf in structure.leaves
            if leaf.pitched and leaf.role in role_to_region
        ]
        # an inserted tilted plane starts at the seen tilted planes' mean slope, else at the
        # tilt the knowledge declares (a constant, or its attribute's default)
        pitch = float(np.mean(pitches)) if pitches else None
        planes: list[PlaneInit] = []
        inserted: list[str] = []
        visible: list[str] = []
        for leaf in structure.leaves:
            region = role_to_region.get(leaf.role)
            if region is not None:
                planes.append(PlaneInit(leaf.role, leaf.concept, region.normal, region.offset_m))
                continue
            inserted.append(leaf.role)
            tilt = leaf.tilt_deg if leaf.tilt_deg is not None else DEFAULT_PITCH_DEG
            n = predicted_normal(leaf, frame, pitch if pitch is not None else tilt)
            if len(points):
                d = support_offset(n, points)
            else:
                d = float(n @ self.evidence.camera.centre_m) - 10.0
            for placed in self._placed(structure, leaf, n, frame, role_to_region, fixed, choices):
                d = max(d, placed)
            centre = points.mean(axis=0) if len(points) else self.evidence.camera.centre_m
            on_plane = centre + (d - float(n @ centre)) * n
            if faces_camera(n, on_plane, self.evidence.camera):
                if fixed:
                    visible.append(leaf.role)
                    planes.append(PlaneInit(leaf.role, leaf.concept, n, d))
                    continue
                raise _UnseenError(
                    f"{leaf.role} ({leaf.concept}) would face camera {self.evidence.camera.view} "
                    "but no region fits it"
                )
            planes.append(PlaneInit(leaf.role, leaf.concept, n, d))
        for role, (n, d) in sorted(fixed.items()):
            planes.append(PlaneInit(role, "", n, d, fixed=True))
        index = {p.role: i for i, p in enumerate(planes)}
        tilts = tilt_constraints(
            self.knowledge,
            [(leaf.role, leaf.concept) for leaf in structure.leaves],
            self._floor(structure, set(index)),
            index,
        )
        positions = {
            role: position_data(region, self.evidence.cameras[region.view])
            for role, region in role_to_region.items()
        }
        fillers = {**choices, **dict(structure.choices)}
        root_role, root_concept, _ = self.body_slot()
        adjacency: dict[str, set[str]] = {}
        # a smaller part also meets the verified part it stands on or out of (an oriel's
        # sides meet the body's front wall): segments along those edges are its evidence too
        closing = self._closing(structure, frame, fixed)
        pairs = [*structure.adjacency, *((n, c.source) for c in closing for n in c.neighbours)]
        for a, b in pairs:
            adjacency.setdefault(a, set()).add(b)
            adjacency.setdefault(b, set()).add(a)
        adj = {k: frozenset(v) for k, v in adjacency.items()}
        declared = self._declared_edges(structure)
        current = {p.role: (p.normal, p.offset_m) for p in planes}
        outcome: Outcome | None = None
        matches: list[EdgeMatch] = []
        for distance_px in MATCH_DISTANCES_PX:
            rematched = self._matches(binding, current, adj, distance_px)
            if outcome is not None and _same_matches(rematched, matches):
                break
            matches = rematched
            verification = build_verification(
                self.knowledge,
                root_role,
                root_concept,
                planes,
                fillers,
                positions,
                self._edge_evidence(
                    [m for m in matches if not guessed.intersection(m.parts)], binding
                ),
                declared,
                self._pinholes,
                tilts,
            )
            self._last = verification
            outcome = verify(verification)
            current = dict(outcome.planes)
            planes = [
                replace(p, normal=current[p.role][0], offset_m=current[p.role][1]) for p in planes
            ]
        assert outcome is not None
        matched = {m.segment.id for m in matches}
        bordering = [
            s for s in self.segments if s.length_px >= 8.0 and any(r in binding for r in s.regions)
        ]
        total = sum(s.length_px for s in bordering)
        loose = sum(s.length_px for s in bordering if s.id not in matched)
        return outcome, tuple(inserted), loose / total if total > 0 else 0.0, tuple(visible)

    def _blame(
        self, outcome: Outcome, full: Verification | None, worst: ConstraintResidual | None
    ) -> Reason:
        """The constraint that makes an inconsistent adjustment inconsistent.

        No single constraint is over its threshold, but together they do not fit (the
        report's reduced cost is above MAX_MEAN_COST): the least-squares compromise has spread
        the contradiction. Each blame group (`verify.blame_group`: an internal constraint with
        the others of its label and owner, a region's position constraint) is left out in
        turn — the `BLAME_CANDIDATES` that miss most, relative to their thresholds — and the
        one whose removal lowers the reduced cost most is blamed, with its row in the full
        adjustment. ``worst`` (the first constraint over its threshold, if any) is named too.
        """
        head = (
            f"its constraints contradict each other (reduced normalised cost "
            f"{outcome.cost:.3g} > {MAX_MEAN_COST:g})"
        )
        tail = f"; {_over(worst)}" if worst is not None else ""
        if full is None:
            return head + tail, None
        groups: dict[BlameGroup, list[int]] = {}
        for i, c in enumerate(full.constraints):
            g = blame_group(c)
            if g is not None:
                groups.setdefault(g, []).append(i)
        group_of = {i: g for g, members in groups.items() for i in members}
        misses: dict[BlameGroup, float] = {}
        row_of: dict[BlameGroup, ConstraintResidual] = {}
        for row, members in zip(outcome.residuals, outcome.members, strict=True):
            g = group_of.get(members[0])
            if g is None:
                continue
            miss = row.normalised_cost / row.threshold
            if miss >= misses.get(g, -1.0):
                misses[g], row_of[g] = miss, row
        ranked = sorted(groups, key=lambda g: (-misses.get(g, 0.0), g))[:BLAME_CANDIDATES]
        best: tuple[float, BlameGroup] | None = None
        for g in sorted(ranked):
            try:
                trial = full.without(set(groups[g]), outcome.planes)
                cost = verify(trial, BLAME_EVALUATIONS).cost
            except AidaError:
                continue
            if best is None or cost < best[0]:
                best = (cost, g)
        if best is None:
            return head + tail, None
        cost, g = best
        blamed = row_of.get(g)
        if blamed is None:
            return head + tail, None
        owner = ", ".join(blamed.parts) if g[2] else (g[1] or "the goal")
        where = f" ({blamed.where})" if blamed.where else ""
        text = f"{head}; without '{g[0]}' of {owner}{where} it would be {cost:.3g}{tail}"
        return text, blamed

    def _placed(
        self,
        structure: Structure,
        leaf: PlanarPart,
        normal: FloatArray,
        frame: Frame,
        seen: dict[str, RegionView],
        fixed: dict[str, tuple[FloatArray, float]],
        choices: dict[str, str],
    ) -> list[float]:
        """The offsets the knowledge's ``unseen`` placements give an inserted part
        (`hypotheses.placed_offsets`), from its structure's seen regions and the fixed planes."""
        fillers = {**choices, **dict(structure.choices)}
        found = [(p, paths) for p, _, paths in self.knowledge.placements(leaf.role, fillers)]
        if not found:
            return []
        planes = {**fixed, **{r: (g.normal, g.offset_m) for r, g in seen.items()}}
        tilted = [
            self.evidence.points_on(seen[x.role].id)
            for x in structure.leaves
            if x.pitched and x.direction == "forward" and x.role in seen
        ]
        return placed_offsets(
            found,
            normal,
            frame,
            planes,
            {r: g.centroid_m for r, g in seen.items()},
            lambda role: self.evidence.points_on(seen[role].id),
            self.knowledge.direction,
            np.concatenate(tilted) if tilted else np.zeros((0, 3)),
        )

    def _floor(self, structure: Structure, known: set[str]) -> str | None:
        """The ground the parts' slopes refer to: the outermost known part facing downward."""
        grounds = [r for r in known if self.knowledge.direction(r) == DOWNWARD]
        del structure
        return min(grounds, key=lambda r: (r.count("."), r)) if grounds else None

    def _outside(self, binding: dict[str, str], polygons: dict[str, FloatArray]) -> str:
        """Why a bound region does not lie on its part's closed face ('' if all do).

        A region is the visible part of a face: its centroid, projected onto the face's
        plane, must fall inside the face (with a margin of a tenth of the face's size).
        """
        for rid, role in sorted(binding.items()):
            face = polygons.get(role)
            if face is None or len(face) < 3:
                continue
            centroid = self.evidence.regions[rid].centroid_m
            if not inside_face(face, centroid, margin=0.1):
                return f"region {rid} lies outside the face of {role} in the closed model"
        return ""

    def _unseen(
        self,
        visible: tuple[str, ...],
        polygons: dict[str, FloatArray],
        forced: dict[str, RegionView],
    ) -> str:
        """Why an inserted part the camera should see cannot have been missed ('' if none).

        Its closed face, projected into the reference camera, must be smaller than
        `MAX_UNSEEN_SIDE_FRACTION` of the front's region.
        """
        front = _anchor(forced)
        camera = self.evidence.camera
        for role in visible:
            pixels = camera.pinhole.project(polygons[role])
            x, y = pixels[:, 0], pixels[:, 1]
            area = 0.5 * abs(float(x @ np.roll(y, -1) - y @ np.roll(x, -1)))
            limit = MAX_UNSEEN_SIDE_FRACTION * (front.area_px if front is not None else 0.0)
            if area > limit:
                return (
                    f"{role} would face camera {camera.view} ({area:.0f} px, more than "
                    f"{limit:.0f}) but no region fits it"
                )
        return ""

    def _closing(
        self, structure: Structure, frame: Frame, fixed: dict[str, tuple[FloatArray, float]]
    ) -> list[ClosingFace]:
        """The face that closes a smaller structure in its whole (`closure.closing_faces`)."""
        return closing_faces(
            structure.root,
            structure.leaves,
            frame,
            fixed,
            self.knowledge.attachment(structure.root),
            {r: self.knowledge.concept_at(r) for r in fixed},
        )

    def _close(
        self,
        structure: Structure,
        outcome: Outcome,
        fixed: dict[str, tuple[FloatArray, float]],
        frame: Frame,
    ) -> tuple[dict[str, FloatArray], tuple[ClosingFace, ...]]:
        """The closed solid of a structure's planes (`closure`): polygons and closing faces.

        Raises GeometryError (naming the parts) if the planes do not close a solid with a
        face for every part.
        """
        closing = self._closing(structure, frame, fixed)
        faces = [(leaf.role, *outcome.planes[leaf.role]) for leaf in structure.leaves]
        faces += [(c.role, c.normal, c.offset_m) for c in closing]
        adjacency = list(structure.adjacency)
        adjacency += [(c.role, other) for c in closing for other in c.neighbours]
        return close(faces, adjacency), tuple(closing)

    def _matches(
        self,
        binding: dict[str, str],
        planes: dict[str, tuple[FloatArray, float]],
        adjacency: dict[str, frozenset[str]],
        max_distance_px: float,
    ) -> list[EdgeMatch]:
        segs = [s for s in self.segments if any(r in binding for r in s.regions)]
        return match_segments(
            segs, binding, planes, adjacency, self.evidence.cameras, max_distance_px
        )

    def _edge_evidence(
        self, matches: list[EdgeMatch], binding: dict[str, str]
    ) -> list[EdgeEvidence]:
        """The matched segments as evidence (each with its camera and the part it borders)."""
        out: list[EdgeEvidence] = []
        for m in matches:
            bound = {binding[r] for r in m.segment.regions if r in binding}
            owner = next(p for p in m.parts if p in bound)
            out.append(
                EdgeEvidence(m.parts, owner, self._views.index(m.segment.view), m.segment.ends_px)
            )
        return out

    def _declared_edges(self, structure: Structure) -> set[tuple[str, str]]:
        """Edges a concept measures itself (``measure edge(edge(a, b))``), as sorted pairs."""
        fillers = {n.role: n.concept for n in structure.nodes}
        out: set[tuple[str, str]] = set()
        for node in structure.nodes:
            for spec in self.knowledge.concept(node.concept).constraints:
                segment = kind_of(spec.kind).evidence == "segment"
                if not (spec.measurement and segment and len(spec.args) == 2):
                    continue
                if not self.knowledge.holds(node.role, spec.requires, fillers):
                    continue
                a, b = (join(node.role, x) for x in spec.args)
                out.add((a, b) if a <= b else (b, a))
        return out

    # ---- costs ---------------------------------------------------------------------------------
    def _significant(self, region: RegionView, fraction: float = MIN_WALL_WEIGHT_FRACTION) -> bool:
        return region.weight >= fraction * self.total_weight

    def _unexplained(self, levels: list[Level]) -> float:
        return self._unexplained_ids({r for lv in levels for r in lv.binding})

    def _unexplained_ids(self, used: set[str]) -> float:
        left = sum(r.weight for r in self.regions if r.id not in used and self._significant(r))
        return UNEXPLAINED_PENALTY * left / self.total_weight

    # ---- the search --------------------------------------------------------------------------
    def run(self) -> tuple[State | None, int, int]:
        """Search; return the best complete state (or None), expansions, goal hypothesis id."""
        goal_id = self.trace.create(self.goal, "", None, "goal")
        start = State((), False, 0.0)

        def expand(state: State) -> list[tuple[State, float]]:
            self.trace.step += 1
            if state.pending is not None:
                verified = self.verify_body(state.pending, goal_id)
                if verified is None:
                    return []
                level, cost = verified
                return [(State((level,), False, cost), cost)]
            if not state.levels:
                return [
                    (State((), False, p.estimate, p), p.estimate)
                    for p in self.body_candidates(goal_id)
                ]
            successors = [(State(state.levels, True, state.cost), state.cost)]
            for level, cost in self.optional_alternatives(state, state.levels[0].hid):
                successors.append((State((*state.levels, level), False, cost), cost))
            return successors

        result = best_first(start, expand, lambda s: s.done, max_expansions=50)
        if result.best is None:
            self.trace.reject(goal_id, "no alternative of its realisation was verified")
        else:
            self.trace.verify(goal_id, f"verified with cost {result.cost:.3g}")
        return result.best, result.expanded, goal_id

    def instances(self, state: State) -> list[Instance]:
        """The instance nodes of an accepted state (goal, body, parts, image-layer regions)."""
        role, concept, goal_node = self.body_slot()
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
        del role, concept
        return out


Reason = tuple[str, ConstraintResidual | None]  # text, the rejecting constraint's report row


def _first_named(reasons: list[Reason | Callable[[], Reason]]) -> Reason:
    """The first reason that names a constraint (evaluating deferred ones in turn), else the
    first reason."""
    first: Reason | None = None
    for entry in reasons:
        reason = entry() if callable(entry) else entry
        if reason[1] is not None:
            return reason
        first = first or reason
    return first or ("no assignment verified", None)


def _over(r: ConstraintResidual) -> str:
    """What a constraint over its threshold says, for the trace (with its ``.kb`` line)."""
    limit = f"; reject above {r.reject_above:.3g} {r.unit}" if r.reject_above is not None else ""
    where = f" at {r.where}" if r.where else ""
    return (
        f"{r.label}{where} ({r.kind}) residual {r.residual:.3g} {r.unit}, normalised cost "
        f"{r.normalised_cost:.3g} above its threshold {r.threshold:.3g}{limit} "
        f"(parts {', '.join(r.parts)})"
    )


def _same_matches(a: list[EdgeMatch], b: list[EdgeMatch]) -> bool:
    """True if two edge matchings pair the same segments with the same edges."""
    return [(m.segment.id, m.parts) for m in a] == [(m.segment.id, m.parts) for m in b]


class _UnseenError(AidaError):
    """An inserted part would be visible: the alternative predicts evidence that is missing."""


def _forced(structure: Structure, region: RegionView) -> dict[str, RegionView]:
    """The region taken as the evidence of a structure's frame anchor, by its relative role."""
    assert structure.anchor is not None
    return {structure.anchor: region}


def _anchor(forced: dict[str, RegionView]) -> RegionView | None:
    """The anchor's region of a forced assignment (None: none)."""
    return next(iter(forced.values()), None)


def _ranked_fronts(walls: list[RegionView], evidence: EvidenceView) -> list[RegionView]:
    """Up to two front candidates: the best by `front_region`, then the next best."""
    first = front_region(walls, evidence.camera)
    if first is None:
        return []
    rest = [w for w in walls if w.id != first.id and _facing(w, evidence) > 0.0]
    second = front_region(rest, evidence.camera)
    return [first] if second is None else [first, second]


def _facing(region: RegionView, evidence: EvidenceView) -> float:
    to_cam = evidence.camera.centre_m - region.centroid_m
    return float(region.normal @ to_cam) / float(np.linalg.norm(to_cam))
