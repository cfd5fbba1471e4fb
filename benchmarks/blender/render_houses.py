"""Houses rendered by Blender's path tracer, independently of aida_kb.synth (not a test).

aida-kb's own renderer (aida_kb.synth) and its interpreter were developed together: a scene
from it is no independent check of what the interpreter reports. This script builds houses
in Blender (https://www.blender.org, the ``bpy`` module from PyPI) with its own geometry,
procedural materials (plaster, brick, roof tiles whose courses run along the eaves, dark
low-texture roofs), a sun and a physical sky, windows standing out of the walls, grass or
asphalt ground, and renders calibrated stereo views with Cycles (path tracing, its own
anti-aliasing and noise, denoised). It writes each scene in aida-kb's scene format
(docs/formats.md: scene.yaml, calib.yaml, views/NN/left.png, right.png, truth.json) from
that document alone — it does not import aida_kb — so the format's description is checked
as well. No depth; labels.png only with ``--labels`` (each face's truth label, windows as
their wall's, the ground 1000, as a hand labeller would mark them): without, what a user's
photographs give.

Run it with a Python that has bpy (Blender 4.2's module; about 520 MB)::

    python3 -m venv /tmp/bpyenv && /tmp/bpyenv/bin/pip install bpy==4.2.0
    /tmp/bpyenv/bin/python benchmarks/blender/render_houses.py --out /tmp/blender --count 6

then judge the reconstructions with the project's Python::

    .venv/bin/python benchmarks/independent.py /tmp/blender

Every house is drawn from its seed (``--start``; each scene's seed is in its truth.json):
kind (gable, hip, flat, shed), width, depth, eave height, pitch, materials, sun, camera
distance, height, azimuth, focal length, baseline and the turn between views.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import sys
from pathlib import Path

import bpy  # type: ignore[import-not-found]

WIDTH_PX, HEIGHT_PX = 720, 540  # the images' size (a 4:3 sensor, as the synth presets)
SAMPLES = 12  # path-tracing samples per pixel, then denoised (OpenImageDenoise): grain like a
# camera's at a fraction of the time (32 samples took 3 min an image on a loaded 2-core machine)
BOUNCES = 3  # light bounces: sun, sky and one or two inter-reflections
WINDOW_PROUD_M = 0.04  # windows stand this far out of their wall (frames and sills do)
KINDS = ("gable", "hip", "flat", "shed")
GROUND_LABEL = 1000  # the ground's id in labels.png (docs/formats.md)
# OpenCV's camera axes (x right, y down, z forward) in Blender's camera frame (z backward)
CV_FROM_BLENDER_CAMERA = ((1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, -1.0))

Vec = tuple[float, float, float]


# ---- small vector helpers (plain Python: bpy's numpy may differ from the project's) ----------
def sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def dot(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def unit(a: Vec) -> Vec:
    n = math.sqrt(dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def matvec(m: tuple[Vec, Vec, Vec] | list[list[float]], v: Vec) -> Vec:
    return (dot(tuple(m[0]), v), dot(tuple(m[1]), v), dot(tuple(m[2]), v))  # type: ignore[arg-type]


def newell(poly: list[Vec]) -> Vec:
    """The unit normal of a planar polygon (Newell's method), right-handed with its order."""
    n = [0.0, 0.0, 0.0]
    for i, p in enumerate(poly):
        q = poly[(i + 1) % len(poly)]
        n[0] += (p[1] - q[1]) * (p[2] + q[2])
        n[1] += (p[2] - q[2]) * (p[0] + q[0])
        n[2] += (p[0] - q[0]) * (p[1] + q[1])
    return unit((n[0], n[1], n[2]))


# ---- the house ---------------------------------------------------------------------------
def house_faces(kind: str, w: float, d: float, h: float, pitch: float) -> list[dict]:
    """The house's faces in its own frame (x along the front, y backward, z up, metres):
    role, concept, material kind, polygon counter-clockwise seen from outside. The roles are
    those of kb/buildings.kb's House (the front is an eave side)."""
    x0, x1, y0, y1 = -w / 2, w / 2, -d / 2, d / 2
    t = math.tan(pitch)
    faces: list[dict] = []

    def add(role: str, concept: str, material: str, poly: list[Vec]) -> None:
        faces.append({"role": role, "concept": concept, "material": material, "polygon": poly})

    add("body.floor", "Floor", "floor", [(x0, y0, 0), (x1, y0, 0), (x1, y1, 0), (x0, y1, 0)])
    if kind == "shed":
        hb = h + d * t  # rising from the front eave to the back
        add("body.front", "Wall", "wall", [(x0, y0, 0), (x1, y0, 0), (x1, y0, h), (x0, y0, h)])
        add("body.back", "Wall", "wall", [(x0, y1, 0), (x1, y1, 0), (x1, y1, hb), (x0, y1, hb)])
        add("body.left", "Wall", "wall", [(x0, y0, 0), (x0, y1, 0), (x0, y1, hb), (x0, y0, h)])
        add("body.right", "Wall", "wall", [(x1, y0, 0), (x1, y1, 0), (x1, y1, hb), (x1, y0, h)])
        add(
            "body.roof.top",
            "RoofPlane",
            "roof",
            [(x0, y0, h), (x1, y0, h), (x1, y1, hb), (x0, y1, hb)],
        )
    else:
        add("body.front", "Wall", "wall", [(x0, y0, 0), (x1, y0, 0), (x1, y0, h), (x0, y0, h)])
        add("body.back", "Wall", "wall", [(x0, y1, 0), (x1, y1, 0), (x1, y1, h), (x0, y1, h)])
        if kind == "gable":
            hr = h + d / 2 * t
            add(
                "body.left",
                "Wall",
                "wall",
                [(x0, y0, 0), (x0, y1, 0), (x0, y1, h), (x0, 0, hr), (x0, y0, h)],
            )
            add(
                "body.right",
                "Wall",
                "wall",
                [(x1, y0, 0), (x1, y1, 0), (x1, y1, h), (x1, 0, hr), (x1, y0, h)],
            )
            add(
                "body.roof.front",
                "RoofPlane",
                "roof",
                [(x0, y0, h), (x1, y0, h), (x1, 0, hr), (x0, 0, hr)],
            )
            add(
                "body.roof.back",
                "RoofPlane",
                "roof",
                [(x0, y1, h), (x1, y1, h), (x1, 0, hr), (x0, 0, hr)],
            )
        else:
            add("body.left", "Wall", "wall", [(x0, y0, 0), (x0, y1, 0), (x0, y1, h), (x0, y0, h)])
            add("body.right", "Wall", "wall", [(x1, y0, 0), (x1, y1, 0), (x1, y1, h), (x1, y0, h)])
            if kind == "flat":
                add(
                    "body.roof.top",
                    "RoofPlane",
                    "roof",
                    [(x0, y0, h), (x1, y0, h), (x1, y1, h), (x0, y1, h)],
                )
            else:  # hip: one pitch all round, the ridge along the front (w > d)
                hr, r0, r1 = h + d / 2 * t, x0 + d / 2, x1 - d / 2
                add(
                    "body.roof.front",
                    "RoofPlane",
                    "roof",
                    [(x0, y0, h), (x1, y0, h), (r1, 0, hr), (r0, 0, hr)],
                )
                add(
                    "body.roof.back",
                    "RoofPlane",
                    "roof",
                    [(x0, y1, h), (x1, y1, h), (r1, 0, hr), (r0, 0, hr)],
                )
                add("body.roof.left", "RoofPlane", "roof", [(x0, y0, h), (x0, y1, h), (r0, 0, hr)])
                add("body.roof.right", "RoofPlane", "roof", [(x1, y0, h), (x1, y1, h), (r1, 0, hr)])
    centre = (0.0, 0.0, h / 2)
    for f in faces:  # counter-clockwise from outside: the normal points away from the centre
        poly = f["polygon"]
        mid = tuple(sum(p[i] for p in poly) / len(poly) for i in range(3))
        if dot(newell(poly), sub(mid, centre)) < 0:  # type: ignore[arg-type]
            f["polygon"] = poly[::-1]
        f["normal"] = newell(f["polygon"])
    return faces


def windows(faces: list[dict], h: float, rng: random.Random) -> list[tuple[str, list[Vec]]]:
    """Window panes on the walls, each with its wall's role: rows per storey, standing
    WINDOW_PROUD_M out of the wall."""
    storeys = max(1, int(h // 2.8))
    out: list[tuple[str, list[Vec]]] = []
    for f in faces:
        if f["concept"] != "Wall":
            continue
        n = f["normal"]
        poly = f["polygon"]
        u = unit(cross((0.0, 0.0, 1.0), n))  # along the wall, horizontal
        us = [dot(p, u) for p in poly]
        lo, hi = min(us), max(us)
        base = poly[0]
        plane = dot(base, n) + WINDOW_PROUD_M
        count = max(1, int((hi - lo) // 3.2))
        step = (hi - lo) / count
        ww, wh = rng.uniform(0.9, 1.4), rng.uniform(1.1, 1.6)
        for s in range(storeys):
            z0 = s * (h / storeys) + 0.9
            if z0 + wh > h - 0.3:
                continue
            for k in range(count):
                c = lo + (k + 0.5) * step
                corners = [
                    (c - ww / 2, z0),
                    (c + ww / 2, z0),
                    (c + ww / 2, z0 + wh),
                    (c - ww / 2, z0 + wh),
                ]
                pane = []
                for a, z in corners:
                    horiz = (u[0] * a, u[1] * a, 0.0)
                    p = (horiz[0] + n[0] * plane, horiz[1] + n[1] * plane, z)
                    pane.append(p)
                if dot(newell(pane), n) < 0:
                    pane = pane[::-1]
                out.append((f["role"], pane))
    return out


# ---- Blender scene -----------------------------------------------------------------------
def material(name: str, kind: str, u: Vec, v: Vec, rng: random.Random) -> bpy.types.Material:
    """A procedural material whose pattern lies in the face's own (u, v) axes, metres."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    bsdf = nodes["Principled BSDF"]
    coords = nodes.new("ShaderNodeTexCoord")
    du = nodes.new("ShaderNodeVectorMath")
    du.operation = "DOT_PRODUCT"
    du.inputs[1].default_value = u
    dv = nodes.new("ShaderNodeVectorMath")
    dv.operation = "DOT_PRODUCT"
    dv.inputs[1].default_value = v
    links.new(coords.outputs["Object"], du.inputs[0])
    links.new(coords.outputs["Object"], dv.inputs[0])
    uv = nodes.new("ShaderNodeCombineXYZ")
    links.new(du.outputs["Value"], uv.inputs[0])
    links.new(dv.outputs["Value"], uv.inputs[1])
    noise = nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = rng.uniform(1.5, 4.0)
    noise.inputs["Detail"].default_value = 12.0
    links.new(uv.outputs["Vector"], noise.inputs["Vector"])
    bsdf.inputs["Roughness"].default_value = 0.85
    if kind in ("brick", "tiles"):
        brick = nodes.new("ShaderNodeTexBrick")
        brick.inputs["Scale"].default_value = 1.0
        if kind == "brick":
            brick.inputs["Brick Width"].default_value = 0.25
            brick.inputs["Row Height"].default_value = 0.075
            brick.inputs["Mortar Size"].default_value = 0.012
            hue = rng.uniform(0.55, 0.8)
            brick.inputs["Color1"].default_value = (hue, 0.3 * hue, 0.2 * hue, 1)
            brick.inputs["Color2"].default_value = (0.8 * hue, 0.28 * hue, 0.18 * hue, 1)
            brick.inputs["Mortar"].default_value = (0.7, 0.68, 0.62, 1)
        else:  # roof tiles: courses along the eave (u), rows up the slope (v)
            brick.inputs["Brick Width"].default_value = 0.32
            brick.inputs["Row Height"].default_value = rng.uniform(0.22, 0.35)
            brick.inputs["Mortar Size"].default_value = 0.02
            dark = rng.random() < 0.3
            base = (0.06, 0.06, 0.07) if dark else (0.45, 0.13, 0.07)
            brick.inputs["Color1"].default_value = (*base, 1)
            brick.inputs["Color2"].default_value = (*tuple(0.85 * c for c in base), 1)
            brick.inputs["Mortar"].default_value = (*tuple(0.5 * c for c in base), 1)
        links.new(uv.outputs["Vector"], brick.inputs["Vector"])
        mix = nodes.new("ShaderNodeMix")
        mix.data_type = "RGBA"
        mix.blend_type = "MULTIPLY"
        mix.inputs["Factor"].default_value = 0.35
        links.new(brick.outputs["Color"], mix.inputs[6])
        links.new(noise.outputs["Color"], mix.inputs[7])
        links.new(mix.outputs[2], bsdf.inputs["Base Color"])
    else:  # plaster, flat roof felt, ground: two tones by noise
        ramp = nodes.new("ShaderNodeValToRGB")
        tone = {
            "plaster": [(0.75, 0.7, 0.6), (0.55, 0.5, 0.42)],
            "felt": [(0.18, 0.18, 0.19), (0.1, 0.1, 0.11)],
            "grass": [(0.12, 0.2, 0.05), (0.05, 0.1, 0.03)],
            "asphalt": [(0.2, 0.2, 0.2), (0.1, 0.1, 0.1)],
        }[kind]
        jitter = rng.uniform(0.85, 1.15)
        ramp.color_ramp.elements[0].color = (*tuple(min(1.0, c * jitter) for c in tone[0]), 1)
        ramp.color_ramp.elements[1].color = (*tuple(min(1.0, c * jitter) for c in tone[1]), 1)
        noise.inputs["Scale"].default_value = rng.uniform(3.0, 8.0)
        links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
        links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def polygon_object(name: str, poly: list[Vec], mat: bpy.types.Material, index: int = 0) -> None:
    """One planar polygon (world frame) as an object of its own; `index`: its label."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(p) for p in poly], [], [list(range(len(poly)))])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    obj.data.materials.append(mat)
    obj.pass_index = index  # the object index pass: labels.png
    bpy.context.scene.collection.objects.link(obj)


def look_at(position: Vec, target: Vec) -> list[list[float]]:
    """Blender camera rotation (3x3, columns: camera x, y, z in the world) looking at target."""
    back = unit(sub(position, target))  # the camera's +z points backward
    right = unit(cross((0.0, 0.0, 1.0), back))
    up = cross(back, right)
    return [[right[i], up[i], back[i]] for i in range(3)]


def cv_pose(rot: list[list[float]], position: Vec) -> tuple[list[list[float]], Vec]:
    """OpenCV pose R, t (x_cam = R x_world + t) of a Blender camera (rotation, position)."""
    rt = [[rot[r][c] for r in range(3)] for c in range(3)]  # world -> Blender camera
    R = [
        [sum(CV_FROM_BLENDER_CAMERA[i][k] * rt[k][j] for k in range(3)) for j in range(3)]
        for i in range(3)
    ]
    t = matvec(R, position)
    return R, (-t[0], -t[1], -t[2])


def render(
    path: Path, rot: list[list[float]], position: Vec, focal_px: float, exposure: float
) -> None:
    scene = bpy.context.scene
    cam = scene.camera
    from mathutils import Matrix, Vector  # type: ignore[import-not-found]

    m = Matrix(
        [
            [rot[0][0], rot[0][1], rot[0][2]],
            [rot[1][0], rot[1][1], rot[1][2]],
            [rot[2][0], rot[2][1], rot[2][2]],
        ]
    )
    cam.matrix_world = Matrix.Translation(Vector(position)) @ m.to_4x4()
    cam.data.sensor_fit = "HORIZONTAL"
    cam.data.sensor_width = 36.0
    cam.data.lens = focal_px * 36.0 / WIDTH_PX
    scene.view_settings.exposure = exposure
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)


def matrix_text(name: str, rows: int, cols: int, values: list[float]) -> str:
    """One matrix of calib.yaml as cv2.FileStorage writes it (docs/formats.md)."""
    data = ", ".join(repr(float(x)) for x in values)
    head = f"{name}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n"
    return head + f"   data: [ {data} ]\n"


def label_output(folder: Path | None) -> None:
    """Write the object index pass of the next render as FOLDER/labels.png (16-bit, the ids
    themselves: raw, not colour-managed), or nothing (None)."""
    scene = bpy.context.scene
    tree = scene.node_tree
    node = tree.nodes.get("labels")
    if node is None:
        bpy.context.view_layer.use_pass_object_index = True
        layers = tree.nodes.get("Render Layers") or tree.nodes.new("CompositorNodeRLayers")
        scale = tree.nodes.new("CompositorNodeMath")
        scale.operation = "DIVIDE"
        scale.inputs[1].default_value = 65535.0
        node = tree.nodes.new("CompositorNodeOutputFile")
        node.name = "labels"
        node.format.file_format = "PNG"
        node.format.color_mode = "BW"
        node.format.color_depth = "16"
        node.format.color_management = "OVERRIDE"
        node.format.view_settings.view_transform = "Raw"
        node.file_slots[0].path = "labels"
        tree.links.new(layers.outputs["IndexOB"], scale.inputs[0])
        tree.links.new(scale.outputs[0], node.inputs[0])
    node.mute = folder is None
    if folder is not None:
        node.base_path = str(folder)


def build_scene(seed: int, out: Path, with_labels: bool, samples: int = SAMPLES) -> dict:
    rng = random.Random(seed)
    kind = KINDS[seed % len(KINDS)]
    depth = rng.uniform(7.0, 11.0)
    width = rng.uniform(depth * 1.2, depth * 1.9)
    height = rng.uniform(5.5, 9.5)
    pitch = math.radians(rng.uniform(10.0, 22.0) if kind == "shed" else rng.uniform(25.0, 45.0))
    faces = house_faces(kind, width, depth, height, pitch)
    turn = math.radians(rng.uniform(-25.0, 25.0))  # the house's own orientation on the ground
    c, s = math.cos(turn), math.sin(turn)
    rz = ((c, -s, 0.0), (s, c, 0.0), (0.0, 0.0, 1.0))
    for f in faces:
        f["polygon"] = [matvec(rz, p) for p in f["polygon"]]
        f["normal"] = matvec(rz, f["normal"])
    panes = windows(faces, height, rng)  # the faces are turned already

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = True
    scene.cycles.max_bounces = BOUNCES
    scene.render.resolution_x, scene.render.resolution_y = WIDTH_PX, HEIGHT_PX
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.color_depth = "8"
    scene.view_settings.view_transform = "Standard"
    scene.use_nodes = True  # the compositor: labels.png from the object index pass
    # light: a sun and a physical sky that agrees with it
    sun_elev = math.radians(rng.uniform(25.0, 60.0))
    sun_azim = rng.uniform(0.0, 2 * math.pi)
    world = bpy.data.worlds.new("world")
    scene.world = world
    world.use_nodes = True
    sky = world.node_tree.nodes.new("ShaderNodeTexSky")
    sky.sky_type = "NISHITA"
    sky.sun_elevation, sky.sun_rotation = sun_elev, sun_azim
    sky.sun_disc = False
    world.node_tree.links.new(
        sky.outputs["Color"], world.node_tree.nodes["Background"].inputs["Color"]
    )
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.25
    sun_data = bpy.data.lights.new("sun", "SUN")
    sun_data.energy = rng.uniform(3.0, 5.0)
    sun_data.angle = math.radians(0.5)
    sun = bpy.data.objects.new("sun", sun_data)
    direction = (
        math.cos(sun_elev) * math.sin(sun_azim),
        -math.cos(sun_elev) * math.cos(sun_azim),
        math.sin(sun_elev),
    )
    sun.rotation_euler = (0.0, 0.0, 0.0)
    from mathutils import Vector  # type: ignore[import-not-found]

    sun.rotation_euler = Vector(direction).to_track_quat("Z", "Y").to_euler()
    scene.collection.objects.link(sun)
    # the house
    wall_kind = rng.choice(["plaster", "brick"])
    roof_kind = "felt" if kind == "flat" else "tiles"
    materials: dict[str, str] = {}
    labels = {f["role"]: k for k, f in enumerate(faces, start=1)}  # truth.json's labels
    for f in faces:
        if f["role"] == "body.floor":
            continue
        n = f["normal"]
        horizontal = abs(n[2]) > 0.999
        u = (1.0, 0.0, 0.0) if horizontal else unit(cross((0.0, 0.0, 1.0), n))
        v = unit(cross(n, u))
        mk = wall_kind if f["concept"] == "Wall" else roof_kind
        materials[f["role"]] = mk
        mat = material(f["role"], mk, u, v, rng)
        polygon_object(f["role"], f["polygon"], mat, labels[f["role"]])
    glass = bpy.data.materials.new("glass")
    glass.use_nodes = True
    glass.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (
        0.03,
        0.04,
        0.05,
        1,
    )
    glass.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.15
    for i, (role, pane) in enumerate(panes):  # a window is labelled as its wall, as by hand
        polygon_object(f"window{i}", pane, glass, labels[role])
    ground_kind = rng.choice(["grass", "asphalt"])
    ground = [
        (-200.0, -200.0, 0.0),
        (200.0, -200.0, 0.0),
        (200.0, 200.0, 0.0),
        (-200.0, 200.0, 0.0),
    ]
    polygon_object(
        "ground",
        ground,
        material("ground", ground_kind, (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), rng),
        GROUND_LABEL,
    )
    # cameras: view 00 looks at the front from an angle, the others step round the house
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    focal = rng.uniform(650.0, 1100.0)
    size = math.hypot(width, depth)
    distance = focal * size / (0.65 * WIDTH_PX)
    baseline = rng.uniform(0.04, 0.07) * distance
    elevation = math.radians(rng.uniform(-5.0, 20.0))  # looking down at up to 20 deg, up at 5
    azimuth = turn + math.radians(rng.uniform(-40.0, 40.0))
    step = math.radians(rng.choice([-1, 1]) * rng.uniform(20.0, 35.0))
    n_views = 2
    target = (0.0, 0.0, height * 0.6)
    view_dir = out / "views"
    poses = []
    for k in range(n_views):
        a = azimuth + k * step
        position = (
            distance * math.cos(elevation) * math.sin(a),
            -distance * math.cos(elevation) * math.cos(a),
            max(1.6, target[2] + distance * math.sin(elevation)),
        )
        rot = look_at(position, target)
        right_axis = (rot[0][0], rot[1][0], rot[2][0])
        right_position = (
            position[0] + baseline * right_axis[0],
            position[1] + baseline * right_axis[1],
            position[2] + baseline * right_axis[2],
        )
        exposure = rng.uniform(-0.1, 0.1)
        folder = view_dir / f"{k:02d}"
        folder.mkdir(parents=True, exist_ok=True)
        if with_labels:
            label_output(folder)
        render(folder / "left.png", rot, position, focal, 0.0)
        if with_labels:
            frame = next(folder.glob("labels*.png"))  # the output node numbers the frame
            frame.rename(folder / "labels.png")
            label_output(None)
        render(folder / "right.png", rot, right_position, focal, exposure)
        poses.append(cv_pose(rot, position))
    # files of docs/formats.md, in the left camera of view 00's frame
    R0, t0 = poses[0]

    def to_world(p: Vec) -> Vec:
        q = matvec(R0, p)
        return (q[0] + t0[0], q[1] + t0[1], q[2] + t0[2])

    cx, cy = WIDTH_PX / 2 - 0.5, HEIGHT_PX / 2 - 0.5  # Blender's centre; OpenCV's pixel centres
    K = [[focal, 0.0, cx], [0.0, focal, cy], [0.0, 0.0, 1.0]]
    parts = []
    for label, f in enumerate(faces, start=1):
        n = matvec(R0, f["normal"])
        poly = [to_world(p) for p in f["polygon"]]
        parts.append(
            {
                "role": f["role"],
                "concept": f["concept"],
                "label": label,
                "material": materials.get(f["role"], "floor"),
                "normal": list(n),
                "d": dot(n, poly[0]),
                "polygon": [list(p) for p in poly],
            }
        )
    up = matvec(R0, (0.0, 0.0, 1.0))
    views = []
    for k, (R, t) in enumerate(poses):
        # x_cam = R_k x_blender + t_k = R_k R0^T (x_world - t0) + t_k
        R0T = [[R0[j][i] for j in range(3)] for i in range(3)]
        Rw = [[sum(R[i][m] * R0T[m][j] for m in range(3)) for j in range(3)] for i in range(3)]
        tw = sub(t, matvec(Rw, t0))
        views.append({"view": f"{k:02d}", "K": K, "R": Rw, "t": list(tw)})
    roof_concept = {"gable": "GableRoof", "hip": "HipRoof", "flat": "FlatRoof", "shed": "ShedRoof"}[
        kind
    ]
    truth = {
        "version": 1,
        "object": "House",
        "parts": parts,
        "ground": {"label": 1000, "normal": list(up), "d": dot(up, to_world((0.0, 0.0, 0.0)))},
        "views": views,
        "parameters": {
            "renderer": "blender-cycles-4.2",
            "kind": kind,
            "knowledge": "buildings.kb",
            "width": width,
            "depth": depth,
            "height": height,
            "pitch_deg": math.degrees(pitch),
            "roof": kind,
            "seed": float(seed),
            "preset": f"blender-{seed}",
            "n_views": float(n_views),
            "focal_px": focal,
            "distance_m": distance,
            "baseline_m": baseline,
            "elevation_deg": math.degrees(elevation),
            "step_deg": math.degrees(step),
            "walls": wall_kind,
            "ground": ground_kind,
            "labels": with_labels,
        },
        "concepts": {"body.roof": roof_concept},
    }
    (out / "truth.json").write_text(json.dumps(truth, indent=1))
    calib = "%YAML:1.0\n---\n" + f"image_width: {WIDTH_PX}\nimage_height: {HEIGHT_PX}\n"
    calib += matrix_text("K1", 3, 3, [x for row in K for x in row])
    calib += matrix_text("D1", 1, 5, [0.0] * 5)
    calib += matrix_text("K2", 3, 3, [x for row in K for x in row])
    calib += matrix_text("D2", 1, 5, [0.0] * 5)
    calib += matrix_text("R", 3, 3, [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0])
    calib += matrix_text("T", 3, 1, [-baseline, 0.0, 0.0])
    (out / "calib.yaml").write_text(calib)
    lines = [
        "format: aida-kb-scene",
        "version: 2",
        f"name: blender-{seed}",
        "calib: calib.yaml",
        "scale: metres",
        "truth: truth.json",
        "views:",
    ]
    for k in range(n_views):
        lines += [
            f"- id: '{k:02d}'",
            f"  left: views/{k:02d}/left.png",
            f"  right: views/{k:02d}/right.png",
        ]
        if with_labels:
            lines.append(f"  labels: views/{k:02d}/labels.png")
    (out / "scene.yaml").write_text("\n".join(lines) + "\n")
    return truth["parameters"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True, help="folder for the scene folders (created)")
    parser.add_argument("--count", type=int, default=8, help="number of houses (default 8)")
    parser.add_argument("--start", type=int, default=70000, help="first seed (default 70000)")
    parser.add_argument(
        "--samples", type=int, default=SAMPLES, help=f"path-tracing samples (default {SAMPLES})"
    )
    parser.add_argument(
        "--labels", action="store_true", help="also write labels.png (each face's truth label)"
    )
    args = parser.parse_args(sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else None)
    root = Path(args.out)
    root.mkdir(parents=True, exist_ok=True)
    for seed in range(args.start, args.start + args.count):
        folder = root / f"scene-{seed}"
        if (folder / "scene.yaml").exists():
            continue
        params = build_scene(seed, folder, args.labels, args.samples)
        print(f"seed {seed}: {params['kind']} rendered into {folder}", flush=True)
    os.sync()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
