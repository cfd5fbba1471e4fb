"""The solver on the paper-sized synthetic house: restoration, hypotheses, fixed parts, errors."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from aida_kb.constraints import Constraint, PositionData
from aida_kb.constraints.kernels import meeting_angle
from aida_kb.errors import SolveError
from aida_kb.geometry.polygon import intersect_planes
from aida_kb.solve.problem import Evaluation, build_problem
from aida_kb.solve.solver import EXACT_MAX_UNKNOWNS, SolveResult, choose_tr_solver, solve
from aida_kb.testing.houses import SyntheticScene, house_row, perturbed


@pytest.fixture(scope="module")
def house() -> SyntheticScene:
    # region plane fits good to 0.03 degrees and 1 cm; the start is 3 degrees and 30 cm off
    return house_row(1, seed=0, evidence_angle_deg=0.03, evidence_offset_m=0.01)


def _build(scene: SyntheticScene, constraints: tuple[Constraint, ...] | None = None, **kw: object):
    n0, d0 = perturbed(scene, seed=1, angle_deg=3.0, offset_m=0.3)
    return build_problem(
        n0,
        d0,
        scene.constraints if constraints is None else constraints,
        centres=scene.centres,
        names=scene.names,
        **kw,  # type: ignore[arg-type]
    )


def _vertex_error(scene: SyntheticScene, result: SolveResult) -> float:
    v = intersect_planes(result.normals[scene.vertex_planes], result.offsets[scene.vertex_planes])
    return float(np.max(np.linalg.norm(v - scene.vertices, axis=1)))


def _angle_error_deg(scene: SyntheticScene, result: SolveResult) -> float:
    """Largest error of the angle between any two planes that meet at a vertex."""
    pairs = {
        (int(t[i]), int(t[j])) for t in scene.vertex_planes for i, j in ((0, 1), (0, 2), (1, 2))
    }
    a, b = np.array(sorted(pairs)).T
    true = meeting_angle(scene.normals[a], scene.normals[b])[0]
    got = meeting_angle(result.normals[a], result.normals[b])[0]
    return float(np.degrees(np.max(np.abs(true - got))))


def test_paper_house_has_28_parts_and_51_constraints(house: SyntheticScene) -> None:
    assert len(house.names) == 28
    assert len(house.constraints) == 51
    assert house.vertices.shape[0] >= 30


def test_perturbed_house_is_restored(house: SyntheticScene) -> None:
    problem = _build(house)
    start = solve(problem, max_iterations=1)  # barely moved: still far from the truth
    assert _vertex_error(house, start) > 0.02 * house.size
    result = solve(problem)
    assert result.success, result.message
    assert _angle_error_deg(house, result) < 0.1
    assert _vertex_error(house, result) < 0.01 * house.size
    assert not result.report.exceeding
    assert result.cost == pytest.approx(result.report.total_cost)


def test_wrong_hypothesis_is_flagged_right_one_is_not(house: SyntheticScene) -> None:
    label = "angle(h0.body.front, h0.body.wings[0].front)"
    index = next(i for i, c in enumerate(house.constraints) if c.label == label)

    def with_value(deg: float) -> tuple[Constraint, ...]:
        c = replace(
            house.constraints[index],
            value=math.radians(deg),
            sigma=math.radians(1.0),
            reject_above=math.radians(5.0),
        )
        return (*house.constraints[:index], c, *house.constraints[index + 1 :])

    right = solve(_build(house, with_value(135.0))).report.by_label(label)
    wrong = solve(_build(house, with_value(90.0))).report.by_label(label)
    assert not right.rejected
    assert right.normalised_cost < 0.1 * right.threshold
    assert wrong.rejected
    assert wrong.normalised_cost > 20 * wrong.threshold
    assert math.degrees(wrong.residual) > 20.0


def test_fixed_parts_stay_fixed(house: SyntheticScene) -> None:
    fixed = [house.index("h0.body.front"), house.index("h0.body.roof.front")]
    problem = _build(house, fixed_parts=fixed)
    result = solve(problem)
    n0, d0 = problem.frames.planes(np.zeros((28, 3)))
    np.testing.assert_array_equal(result.normals[fixed], n0[fixed])
    np.testing.assert_array_equal(result.offsets[fixed], d0[fixed])
    moved = np.linalg.norm(result.normals - n0, axis=1)
    assert np.count_nonzero(moved > 1e-6) >= 20


def test_hierarchical_mode_fixes_the_main_parts_first(house: SyntheticScene) -> None:
    problem = _build(house)
    main = [
        i for i, name in enumerate(house.names) if ".wings" not in name and ".oriels" not in name
    ]
    result = solve(problem, levels=[main])
    assert len(main) == 9
    assert _vertex_error(house, result) < 0.01 * house.size
    # the main parts of the hierarchical result are those of a solve of the body alone
    body_only = [i for i, c in enumerate(house.constraints) if set(c.parts) <= set(main)]
    alone = solve(_build(house, tuple(house.constraints[i] for i in body_only)))
    np.testing.assert_allclose(result.normals[main], alone.normals[main], atol=1e-7)
    joint = solve(problem)
    assert joint.cost <= result.cost + 1e-9


def test_exact_and_lsmr_reach_the_same_minimum(house: SyntheticScene) -> None:
    problem = _build(house)
    auto = solve(problem)
    assert auto.tr_solvers == ("exact",)  # 84 unknowns: dense
    lsmr = solve(problem, tr_solver="lsmr")
    assert lsmr.tr_solvers == ("lsmr",)
    assert auto.success
    assert lsmr.success
    # the exact trust-region steps end at least as low as the iterative ones
    assert auto.cost <= lsmr.cost * (1 + 1e-12)
    assert lsmr.cost == pytest.approx(auto.cost, rel=1e-8)
    np.testing.assert_allclose(lsmr.normals, auto.normals, atol=1e-6)
    # hierarchical: each level chooses by its own size; cg uses no trust region
    main = [i for i, name in enumerate(house.names) if ".wings" not in name]
    assert solve(problem, levels=[main], tr_solver="lsmr").tr_solvers == ("lsmr", "lsmr")
    assert solve(problem, method="cg", max_iterations=2).tr_solvers == ()


def test_undetermined_directions_keep_their_start() -> None:
    # the offsets of parts 1-3 and some of their rotations are free: no constraint fixes them
    n = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.2], [0.0, 1.0, 0.1], [0.3, -1.0, 0.0]])
    region = PositionData(n_init=(0.0, 0.0, 1.0), c_init=(0.0, 0.0, 5.0))
    cons = [
        Constraint(kind="position", parts=(0,), sigma=0.01, measurement=True, position=region),
        Constraint(kind="angle", parts=(0, 1), value=math.radians(90), sigma=0.01),
        Constraint(kind="symmetry", parts=(0, 1, 0, 2), sigma=0.01),
        Constraint(kind="symmetry", parts=(1, 3, 2, 3), sigma=0.01),
    ]
    problem = build_problem(n, np.array([5.0, 2.0, 3.0, 1.0]), cons)
    result = solve(problem, tr_solver="exact")
    assert result.success
    assert result.cost < 1e-12
    np.testing.assert_allclose(result.params[:, 0], 0.0, atol=1e-12)  # offsets
    # rotations: no more than the symmetries need (without the anchor rows, part 3 turned by
    # 13 rad on rounding noise)
    assert np.max(np.abs(result.params[:, 1:])) < 0.8


def test_auto_tr_solver_threshold() -> None:
    assert choose_tr_solver(1) == "exact"
    assert choose_tr_solver(EXACT_MAX_UNKNOWNS) == "exact"
    assert choose_tr_solver(EXACT_MAX_UNKNOWNS + 1) == "lsmr"
    assert choose_tr_solver(EXACT_MAX_UNKNOWNS + 1, "exact") == "exact"
    assert choose_tr_solver(3, "lsmr") == "lsmr"
    big = house_row(2, seed=0)
    n0, d0 = perturbed(big, seed=1, angle_deg=1.0, offset_m=0.1)
    result = solve(build_problem(n0, d0, big.constraints, centres=big.centres))
    assert result.tr_solvers == ("lsmr",)  # 56 parts, 168 unknowns
    assert result.success


def test_cg_reaches_the_same_minimum_on_a_small_problem(house: SyntheticScene) -> None:
    names = ("front", "left")
    parts = [house.index(f"h0.body.oriels[0].{r}") for r in names]
    cons = tuple(
        replace(
            c,
            parts=tuple(parts.index(p) for p in c.parts),
            sigma=c.sigma if c.measurement else math.radians(0.5),
        )
        for c in house.constraints
        if set(c.parts) <= set(parts)
    )
    assert len(cons) == 3
    n0, d0 = perturbed(house, seed=2, angle_deg=1.0, offset_m=0.05)
    problem = build_problem(n0[parts], d0[parts], cons, centres=house.centres[parts])
    trf = solve(problem)
    cg = solve(problem, method="cg")
    assert cg.method == "cg"
    assert trf.cost <= cg.cost * (1 + 1e-6)
    assert cg.cost == pytest.approx(trf.cost, rel=1e-3)


def test_robust_loss_limits_a_bad_measurement(house: SyntheticScene) -> None:
    i = house.index("h0.body.oriels[1].front")
    k = next(j for j, c in enumerate(house.constraints) if c.kind == "position" and c.parts == (i,))
    c = house.constraints[k]
    assert c.position is not None
    turn = np.cross(house.normals[i], [0.0, 1.0, 0.0])
    bad_n = house.normals[i] + math.tan(math.radians(10.0)) * turn / np.linalg.norm(turn)
    bad_n /= np.linalg.norm(bad_n)  # a region fit 10 degrees off
    bad = replace(c, position=replace(c.position, n_init=tuple(float(v) for v in bad_n)))
    cons = (*house.constraints[:k], bad, *house.constraints[k + 1 :])
    plain = solve(_build(house, cons))
    robust = solve(_build(house, cons), loss="soft_l1", f_scale=3.0)
    huber = solve(_build(house, cons), loss="huber", f_scale=3.0)
    front = house.index("h0.body.front")

    def drag(result: SolveResult) -> float:
        # the outlier drags the body's front through the oriel's parallel constraint
        cos = float(result.normals[front] @ house.normals[front])
        return math.degrees(math.acos(min(1.0, cos)))

    assert drag(robust) < 0.5 * drag(plain)
    assert drag(huber) < 0.5 * drag(plain)
    assert huber.report.rows[k].rejected
    assert robust.report.rows[k].rejected
    assert not plain.report.rows[k - 1].rejected


def test_sparse_jacobian_matches_finite_differences(house: SyntheticScene) -> None:
    problem = _build(house, fixed_parts=[0, 5])
    free = np.array([i for i in range(28) if i not in (0, 5)])
    for loss in ("linear", "soft_l1", "huber"):
        ev = Evaluation(problem, free, loss=loss, f_scale=0.5)  # type: ignore[arg-type]
        x = np.random.default_rng(3).normal(scale=0.05, size=ev.n_params)
        f, J = ev.residuals_and_jacobian(x)
        assert J.shape == (f.size, ev.n_params)
        np.testing.assert_allclose(f, ev.residuals(x))
        f_dense, J_dense = ev.residuals_and_dense_jacobian(x)
        np.testing.assert_array_equal(f_dense, f)
        np.testing.assert_allclose(J_dense, J.toarray(), rtol=0, atol=1e-15)
        eps = 1e-7
        cols = np.random.default_rng(4).choice(ev.n_params, size=12, replace=False)
        for j in cols:
            dx = np.zeros_like(x)
            dx[j] = eps
            num = (ev.residuals(x + dx) - ev.residuals(x - dx)) / (2 * eps)
            np.testing.assert_allclose(J[:, j].toarray()[:, 0], num, atol=1e-4, rtol=1e-5)


def test_jacobian_sums_a_part_that_occurs_twice_in_one_constraint() -> None:
    rng = np.random.default_rng(7)
    n = rng.normal(size=(4, 3))
    cons = [
        Constraint(kind="parallel_edge", parts=(0, 1, 0, 2), sigma=0.1),
        Constraint(kind="symmetry", parts=(0, 1, 1, 3), sigma=0.1),
        Constraint(kind="angle", parts=(2, 3), value=2.0, sigma=0.1),
    ]
    problem = build_problem(n, rng.normal(size=4), cons)
    ev = Evaluation(problem, np.arange(4))
    x = rng.normal(scale=0.05, size=ev.n_params)
    f, J = ev.residuals_and_jacobian(x)
    np.testing.assert_allclose(ev.residuals_and_dense_jacobian(x)[1], J.toarray(), atol=1e-15)
    eps = 1e-7
    num = np.empty((f.size, ev.n_params))
    for j in range(ev.n_params):
        dx = np.zeros_like(x)
        dx[j] = eps
        num[:, j] = (ev.residuals(x + dx) - ev.residuals(x - dx)) / (2 * eps)
    np.testing.assert_allclose(J.toarray(), num, atol=1e-5, rtol=1e-5)


def _position(n: tuple[float, float, float] = (0.0, 0.0, 1.0), **kw: float) -> Constraint:
    return Constraint(
        kind="position",
        parts=(0,),
        sigma=0.01,
        measurement=True,
        position=PositionData(n_init=n, c_init=(0.0, 0.0, 5.0), **kw),  # type: ignore[arg-type]
    )


@pytest.mark.parametrize(
    ("constraint", "message"),
    [
        (Constraint(kind="angle", parts=(0, 7), value=1.0, sigma=0.1), "unknown part index 7"),
        (Constraint(kind="angle", parts=(0, 1), value=math.nan, sigma=0.1), "angle target"),
        (Constraint(kind="angle", parts=(0, 1), value=1.0, sigma=0.0), "sigma must be"),
        (Constraint(kind="angle", parts=(0, 1), value=1.0, sigma=math.nan), "sigma must be"),
        (Constraint(kind="angle", parts=(0, 1), value=1.0), "needs a tolerance"),
        (Constraint(kind="parallel", parts=(0,), sigma=0.1), "relates 2 parts"),
        (Constraint(kind="parallel", parts=(1, 1), sigma=0.1), "itself"),
        (Constraint(kind="position", parts=(0,), sigma=0.1), "region evidence"),
        (_position(n=(0.0, math.nan, 1.0)), "n_init is not finite"),
        (_position(n=(0.0, 0.5, 0.5)), "unit vector"),
        (_position(w_c=0.0), "w_c must be"),
        (Constraint(kind="edge", parts=(0, 1), sigma=1.0), "image segment"),
    ],
)
def test_degenerate_input_is_a_clear_solve_error(constraint: Constraint, message: str) -> None:
    n = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    with pytest.raises(SolveError, match=message):
        build_problem(n, np.ones(3), [constraint])


@pytest.mark.parametrize(
    ("constraint", "named"),
    [
        # the edge of two parallel planes has no direction
        (Constraint(kind="parallel_edge", parts=(0, 1, 2, 3), sigma=0.01), "a, b, c, d"),
        # "same facing" asked of opposite normals: the rotation between them has no axis
        (Constraint(kind="parallel", parts=(0, 4), sigma=0.01, sign=1, label="p"), "'p'"),
    ],
)
def test_degenerate_geometry_is_a_solve_error_naming_the_parts(
    constraint: Constraint, named: str, recwarn: pytest.WarningsRecorder
) -> None:
    n = np.array([[0, 0, 1.0], [0, 0, 1.0], [1.0, 0, 0], [0, 1.0, 0], [0, 0, -1.0]])
    names = ["a", "b", "c", "d", "e"]
    problem = build_problem(n, np.arange(5.0), [constraint], names=names)
    with pytest.raises(SolveError, match="degenerate geometry") as info:
        solve(problem)
    assert named in str(info.value)
    assert ", ".join(names[p] for p in constraint.parts) in str(info.value)
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]


def test_weights_from_tolerances_or_explicit() -> None:
    # two angle targets for one pair of walls: the solution is their weighted mean
    n = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    deg = math.radians(1.0)

    def meet(w90: dict[str, float], w100: dict[str, float]) -> float:
        cons = [
            Constraint(kind="angle", parts=(0, 1), value=math.radians(90), **w90),
            Constraint(kind="angle", parts=(0, 1), value=math.radians(100), **w100),
        ]
        result = solve(build_problem(n, np.ones(2), cons, fixed_parts=[0]))
        assert result.cost == pytest.approx(sum(r.cost for r in result.report.rows))
        return math.degrees(meeting_angle(result.normals[:1], result.normals[1:])[0][0])

    # sigma 1 and 2 degrees: weights 4:1
    assert meet({"sigma": deg}, {"sigma": 2 * deg}) == pytest.approx(92.0, abs=1e-6)
    # an explicit weight overrides the tolerance in the objective (1:1 here) ...
    assert meet({"sigma": deg}, {"sigma": 2 * deg, "weight": 1 / deg**2}) == pytest.approx(
        95.0, abs=1e-6
    )
    # ... while the tolerance still normalises the report
    cons = [Constraint(kind="angle", parts=(0, 1), value=1.0, sigma=0.1, weight=7.0)]
    row = solve(build_problem(n, np.ones(2), cons, fixed_parts=[0, 1])).report.rows[0]
    assert row.cost == pytest.approx(7.0 * row.residual**2)
    assert row.normalised_cost == pytest.approx(row.residual**2 / 0.01)


def test_position_cost_is_the_papers_eq_4() -> None:
    # region fit: normal +z, centre (0, 0, 5); the part tilted by theta about that centre's
    # axis and moved s along the fit's normal
    theta, s, w_c, w_n, sigma = 0.05, 0.3, 7.0, 4.0, 0.02
    n = np.array([[math.sin(theta), 0.0, math.cos(theta)]])
    d = n[0] @ np.array([0.0, 0.0, 5.0 + s])
    region = PositionData(n_init=(0.0, 0.0, 1.0), c_init=(0.0, 0.0, 5.0), w_c=w_c, w_n=w_n)
    c = Constraint(kind="position", parts=(0,), sigma=sigma, measurement=True, position=region)
    row = solve(build_problem(n, [d], [c], fixed_parts=[0])).report.rows[0]
    shift = s * math.cos(theta) ** 2  # the projected centre's move along the fit's normal
    expected = w_c / sigma**2 * (theta**2 + w_n * shift**2)
    assert row.cost == pytest.approx(expected, rel=1e-12)
    assert row.normalised_cost == pytest.approx(expected, rel=1e-12)  # W = 1/sigma²


def test_bad_planes_and_options_are_solve_errors() -> None:
    n = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    good = [Constraint(kind="angle", parts=(0, 1), value=1.0, sigma=0.1)]
    with pytest.raises(SolveError, match="non-finite"):
        build_problem(np.array([[0.0, 0.0, 1.0], [np.nan, 0.0, 0.0]]), np.ones(2), good)
    with pytest.raises(SolveError, match="unknown fixed part index 5"):
        build_problem(n, np.ones(2), good, fixed_parts=[5])
    problem = build_problem(n, np.ones(2), good)
    with pytest.raises(SolveError, match="unknown method"):
        solve(problem, method="bfgs")  # type: ignore[arg-type]
    with pytest.raises(SolveError, match="unknown tr_solver"):
        solve(problem, tr_solver="cholesky")  # type: ignore[arg-type]
    with pytest.raises(SolveError, match="level 0: unknown part index 9"):
        solve(problem, levels=[[9]])
