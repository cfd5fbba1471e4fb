"""Viewpoint registration: the pose of a new view against a fixed model (paper §5, §6.2).

>>> from aida_kb.register import RigidModel, register_view      # doctest: +SKIP
>>> model = RigidModel.from_model(read_model("model.json"))
>>> reg = register_view(model, reference_camera, p1, p2)         # no initial guess
>>> reg.camera.pose, reg.angle_deg, reg.rms_px
"""

from __future__ import annotations

from aida_kb.geometry.rig import Rig
from aida_kb.register.match import Matches, chamfer_cost, match_segments
from aida_kb.register.model import RigidModel, VisibleEdges
from aida_kb.register.pose import EdgeObservations, PoseFit, RegionObservations, fit_pose
from aida_kb.register.register import (
    RegionMeasurements,
    Registration,
    RegistrationOptions,
    StereoSegments,
    angle_about,
    image_edges,
    match_regions,
    orbit_pivot,
    polish,
    refine,
    register_view,
    rival_turns,
    rivals_left,
    symmetry_order,
    turned,
    vertical_axis,
)

__all__ = [
    "EdgeObservations",
    "Matches",
    "PoseFit",
    "RegionMeasurements",
    "RegionObservations",
    "Registration",
    "RegistrationOptions",
    "Rig",
    "RigidModel",
    "StereoSegments",
    "VisibleEdges",
    "angle_about",
    "chamfer_cost",
    "fit_pose",
    "image_edges",
    "match_regions",
    "match_segments",
    "orbit_pivot",
    "polish",
    "refine",
    "register_view",
    "rival_turns",
    "rivals_left",
    "symmetry_order",
    "turned",
    "vertical_axis",
]
