"""The images' choice between a model's twins (`aida_kb.register.twins`)."""

from __future__ import annotations

import math

from aida_kb.register.twins import (
    CONFIRM_MARGIN,
    CONFIRM_NCC,
    PoseSupport,
    photometric_choice,
    undecided_rivals,
)

SPAN = 20.0  # degrees: poses farther apart are different poses


def _s(ncc: float, shared: int = 5000, model: int = 10000) -> PoseSupport:
    return PoseSupport(ncc, shared, model)


def test_a_square_towers_twins_correlating_alike_are_undecided() -> None:
    # preset tower seed 3 (views 80 degrees apart): the same windows on four walls
    angles = [-170.0, 10.0, -80.0, 99.9]
    supports = [PoseSupport(math.nan, 0, 113563), _s(0.97), _s(0.927), _s(0.906)]
    assert photometric_choice(angles, supports, SPAN) is None
    # the segments' choice stands (10 degrees), but its twins are not ruled out
    assert undecided_rivals(10.0, supports[1], angles, supports, SPAN) == (-80.0, 99.9)


def test_twins_the_images_rule_out_are_not_undecided() -> None:
    angles = [30.0, 120.0, -150.0]
    taken = _s(0.9)
    supports = [taken, _s(0.9 - CONFIRM_MARGIN - 0.01), PoseSupport(0.95, 10, 10000)]
    # 120: correlates clearly worse; -150: shares too few pixels to be judged
    assert undecided_rivals(30.0, taken, angles, supports, SPAN) == ()
    # a rival near the pose taken is that pose again, whatever it correlates
    assert undecided_rivals(30.0, taken, [30.0, 40.0], [taken, _s(0.95)], SPAN) == ()


def test_without_images_of_the_pose_taken_a_confirmed_rival_is_undecided() -> None:
    taken = PoseSupport(math.nan, 0, 10000)
    angles = [0.0, 90.0, 180.0]
    supports = [taken, _s(CONFIRM_NCC + 0.01), _s(CONFIRM_NCC - 0.01)]
    assert undecided_rivals(0.0, taken, angles, supports, SPAN) == (90.0,)
