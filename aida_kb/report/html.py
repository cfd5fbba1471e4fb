"""`report.html`: every stage of a reconstruction on one self-contained page (works offline).

Images are embedded as data URIs (JPEG for photographs and renders, PNG for false colour);
the page needs no network and no script to show (a few lines of inline script only count
the images that decoded, for the browser test). Per view: the input images, depth and
certainty, the segmentation (regions, and the scene's labels.png) in false colour with a
legend, the line segments, the model's edges projected with the camera the registration
started from (before) and the final one (after), and the textured model drawn through the
view's camera beside the photograph. Then the verdict, the cameras, the instance tree, the
residual table (with each constraint's `.kb` location when the interpretation carries one),
the rejected hypotheses and why, and renders of the textured model from around it.
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.interpret.pipeline import Reconstruction
from aida_kb.interpret.report import explanation, instance_tree
from aida_kb.interpret.result import Interpretation
from aida_kb.io.atomic import write_text_atomic
from aida_kb.io.export import export_frame, model_up
from aida_kb.io.model import ReconstructedModel
from aida_kb.io.scene import Scene, read_image, read_labels
from aida_kb.register.evidence import camera_of
from aida_kb.texture.atlas import distorted_pixels
from aida_kb.texture.render import render_view
from aida_kb.vision.debug import colour_map, lines_image, region_colours
from aida_kb.vision.evidence import ViewProducts

U8 = npt.NDArray[np.uint8]
FloatArray = npt.NDArray[np.float64]

REPORT_FILE = "report.html"
# JPEG quality of embedded photographs and renders (small page, no visible loss)
JPEG_QUALITY = 85
# renders of the textured model from around it: turns about the vertical from view 00, deg
ORBIT_TURNS_DEG = (-50.0, 50.0, 180.0)
# ... looking down on it by this much, degrees
ORBIT_ELEVATION_DEG = 25.0
# points along each model edge when it is drawn through a distorting lens
EDGE_SAMPLES = 24

STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em; color: #222; max-width: 1400px; }
h1 { font-size: 1.5em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: .2em; }
figure { display: inline-block; margin: .3em; vertical-align: top; }
figure img { max-width: 420px; border: 1px solid #aaa; display: block; }
figcaption { font-size: .85em; color: #555; max-width: 420px; }
table { border-collapse: collapse; font-size: .85em; margin: .5em 0; }
td, th { border: 1px solid #ccc; padding: .15em .4em; text-align: left; }
tr.rejected td { background: #fdd; }
.ok { color: #070; font-weight: bold; } .bad { color: #b00; font-weight: bold; }
.swatch { display: inline-block; width: 1em; height: 1em; border: 1px solid #888;
          vertical-align: middle; }
pre { background: #f6f6f6; padding: .6em; overflow-x: auto; }
"""

COUNT_IMAGES = """
window.addEventListener("load", function () {
  var images = document.images, decoded = 0;
  for (var i = 0; i < images.length; i++) {
    if (images[i].complete && images[i].naturalWidth > 0) { decoded++; }
  }
  document.body.setAttribute("data-images", String(images.length));
  document.body.setAttribute("data-images-decoded", String(decoded));
});
"""


def _data_uri(image_rgb: U8, *, png: bool = False) -> str:
    bgr = image_rgb[:, :, ::-1] if image_rgb.ndim == 3 else image_rgb
    if png:
        ok, data = cv2.imencode(".png", bgr)
        kind = "png"
    else:
        ok, data = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
        kind = "jpeg"
    if not ok:  # pragma: no cover - cv2 encodes any uint8 image
        raise ValueError("image could not be encoded")
    return f"data:image/{kind};base64,{base64.b64encode(data.tobytes()).decode('ascii')}"


def _figure(image_rgb: U8, caption: str, *, png: bool = False, cls: str = "") -> str:
    uri = _data_uri(image_rgb, png=png)
    klass = f' class="{cls}"' if cls else ""
    return (
        f'<figure{klass}><img src="{uri}" alt="{html.escape(caption)}">'
        f"<figcaption>{html.escape(caption)}</figcaption></figure>"
    )


def _rgb(bgr: U8) -> U8:
    out: U8 = np.ascontiguousarray(bgr[:, :, ::-1])
    return out


def false_colour(ids: npt.NDArray[np.integer]) -> tuple[U8, list[tuple[int, tuple[int, int, int]]]]:
    """(H, W) ids (0 = none) in distinct colours (0 black): the RGB image and the legend."""
    values = np.unique(ids)
    colours = region_colours(len(values) + 1)[:, ::-1]  # BGR -> RGB
    index = np.searchsorted(values, ids)
    lut = colours[1 : len(values) + 1].copy()
    lut[values == 0] = 0
    image: U8 = np.ascontiguousarray(lut[index])
    legend = [
        (int(v), (int(c[0]), int(c[1]), int(c[2])))
        for v, c in zip(values, lut, strict=True)
        if v != 0
    ]
    return image, legend


def _legend(
    items: Sequence[tuple[int, tuple[int, int, int]]],
    names: dict[int, str],
    heading: str = "interpreted as",
) -> str:
    rows = "".join(
        f'<tr><td><span class="swatch" style="background: rgb{c}"></span></td>'
        f"<td>{v}</td><td>{html.escape(names.get(v, ''))}</td></tr>"
        for v, c in items
    )
    return f"<table><tr><th></th><th>id</th><th>{heading}</th></tr>{rows}</table>"


def _edges_image(
    image_rgb: U8,
    model: ReconstructedModel,
    camera: PinholeCamera,
    D: FloatArray,
    colour: tuple[int, int, int],
) -> U8:
    """The model's edges of faces turned towards the camera, drawn over the image."""
    out = image_rgb.copy()
    centre = camera.centre
    for part in model.parts:
        poly = np.array(part.polygon, dtype=np.float64)
        if float(np.array(part.normal) @ (centre - poly.mean(axis=0))) <= 0:
            continue
        for a, b in zip(poly, np.roll(poly, -1, axis=0), strict=True):
            t = np.linspace(0.0, 1.0, EDGE_SAMPLES)[:, None]
            pts = a + t * (b - a)
            cam = pts @ camera.R_cam_world.T + camera.t_cam_world
            if np.any(cam[:, 2] <= 1e-6):
                continue
            px = distorted_pixels(cam, camera.K, D)
            cv2.polylines(
                out, [np.round(px * 16).astype(np.int32)], False, colour, 3, cv2.LINE_AA, 4
            )
    return out


def _camera_of(model: ReconstructedModel, view: str) -> PinholeCamera | None:
    return next((camera_of(c) for c in model.cameras if c.view == view), None)


def _bound_roles(interp: Interpretation) -> dict[str, str]:
    """Evidence region id 'VIEW/REGION' -> the role it was bound to."""
    return {b: inst.role for inst in interp.instances for b in inst.bindings}


def _view_section(
    rec: Reconstruction, prod: ViewProducts, scene: Scene, previous: str | None
) -> str:
    model = rec.interpretation.model
    vid = prod.evidence.id
    view = scene.view(vid)
    left = _rgb(read_image(view.left))
    right = _rgb(read_image(view.right))
    parts = [f'<section class="view" id="view-{html.escape(vid)}"><h2>View {vid}</h2>']
    overlay: list[str] = []
    if model is not None:
        cam = _camera_of(model, vid)
        D = np.asarray(view.rig.D1, dtype=np.float64)
        if cam is not None:
            overlay.append("<h3>The model in this view</h3>")
            if previous is not None:
                start = _camera_of(model, previous)
                if start is not None:
                    overlay.append(
                        _figure(
                            _edges_image(left, model, start, D, (255, 160, 0)),
                            f"model edges with the camera registration started from (view "
                            f"{previous}'s): before registration",
                            cls="edges",
                        )
                    )
            after = "after registration" if previous is not None else "the reference view"
            overlay.append(
                _figure(
                    _edges_image(left, model, cam, D, (0, 255, 0)),
                    f"model edges with view {vid}'s final camera: {after}",
                    cls="edges",
                )
            )
            if rec.atlas is not None:
                drawn, _ = render_view(model, rec.atlas, cam, D=D, background=left // 3)
                overlay.append(
                    _figure(drawn, f"the textured model through view {vid}'s camera", cls="render")
                )
    parts += overlay
    parts.append("<h3>Input and stereo</h3>")
    figs = [
        _figure(left, f"view {vid}: left image (input)", cls="input"),
        _figure(right, f"view {vid}: right image (input)", cls="input"),
        _figure(
            _rgb(colour_map(prod.depth.depth_m, invert=True)),
            "depth (near = red, far = blue; black: no depth)",
            png=True,
        ),
        _figure(
            np.clip(prod.depth.certainty * 255.0, 0, 255).astype(np.uint8),
            "certainty (white = 1)",
            png=True,
        ),
        _figure(_rgb(lines_image(prod)), "line segments: green two regions, yellow one, red none"),
    ]
    parts.append("".join(figs))
    bound = _bound_roles(rec.interpretation)
    seg, legend = false_colour(prod.regions)
    names = {v: bound.get(f"{vid}/{v}", "") for v, _ in legend}
    parts.append("<h3>Segmentation</h3>")
    parts.append(_figure(seg, f"regions of view {vid} ({len(legend)}), false colour", png=True))
    parts.append(_legend(legend, names))
    if view.labels is not None:
        labels = read_labels(view.labels)
        lab, lab_legend = false_colour(labels)
        parts.append(
            _figure(
                lab,
                f"labels.png ({labels.dtype}, {len(lab_legend)} labels), false colour",
                png=True,
            )
        )
        parts.append(_legend(lab_legend, {}, "label of labels.png"))
    parts.append("</section>")
    return "".join(parts)


def _orbit_camera(
    model: ReconstructedModel, reference: PinholeCamera, turn_deg: float
) -> PinholeCamera:
    """A camera turned about the model's vertical through its centre, looking down at it."""
    up = model_up(model)
    pts = np.array([v for p in model.parts for v in p.polygon], dtype=np.float64)
    centre = pts.mean(axis=0)
    radius = float(np.max(np.linalg.norm(pts - centre, axis=1)))
    back = reference.centre - centre
    back -= float(back @ up) * up
    back /= max(float(np.linalg.norm(back)), 1e-9)
    a = math.radians(turn_deg)
    side = np.cross(up, back)
    horizontal = math.cos(a) * back + math.sin(a) * side
    e = math.radians(ORBIT_ELEVATION_DEG)
    f = float(reference.K[0, 0])
    half = min(reference.width, reference.height) / 2.0
    distance = 1.15 * radius * f / half / math.cos(e) + radius
    eye = centre + distance * (math.cos(e) * horizontal + math.sin(e) * up)
    z = centre - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, up)  # image x right, y down (OpenCV) with the vertical pointing up
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return PinholeCamera(reference.K, R, -R @ eye, reference.width, reference.height)


def _rows(interp: Interpretation) -> str:
    out = []
    for r in interp.residuals:
        where = r.where  # the constraint's .kb file:line:col ('' for one the code adds)
        cls = "residual rejected" if r.rejected else "residual"
        sigma = "" if r.sigma is None else f"{r.sigma:.4g}"
        out.append(
            f'<tr class="{cls}"><td>{html.escape(r.label)}</td>'
            f"<td>{html.escape(str(where) if where else '—')}</td>"
            f"<td>{html.escape(r.kind)}</td><td>{html.escape(r.concept)}</td>"
            f"<td>{html.escape(r.owner)}</td><td>{html.escape(', '.join(r.parts))}</td>"
            f"<td>{r.residual:.4g} {html.escape(r.unit)}</td><td>{sigma}</td>"
            f"<td>{r.normalised_cost:.4g}</td><td>{r.threshold:.4g}</td>"
            f"<td>{'rejects' if r.rejected else 'ok'}</td></tr>"
        )
    head = (
        "<tr><th>constraint</th><th>.kb</th><th>kind</th><th>concept</th><th>owner</th>"
        "<th>parts</th><th>residual</th><th>sigma</th><th>normalised cost</th>"
        "<th>threshold</th><th></th></tr>"
    )
    return f'<table id="residuals">{head}{"".join(out)}</table>'


def _cameras(model: ReconstructedModel) -> str:
    frame = export_frame(model, "y-up")
    up = model_up(model)
    first = _camera_of(model, model.cameras[0].view) if model.cameras else None
    rows = []
    for c in model.cameras:
        cam = _camera_of(model, c.view)
        assert cam is not None
        C = frame.apply(cam.centre)[0]
        turn = ""
        if first is not None:
            a = first.optical_axis - float(first.optical_axis @ up) * up
            b = cam.optical_axis - float(cam.optical_axis @ up) * up
            turn = f"{math.degrees(math.atan2(float(np.cross(a, b) @ up), float(a @ b))):.2f}"
        rows.append(
            f"<tr><td>{html.escape(c.view)}</td><td>{c.K[0][0]:.1f}</td>"
            f"<td>{c.image_width}x{c.image_height}</td>"
            f"<td>{', '.join(f'{v:.3f}' for v in cam.centre)}</td>"
            f"<td>{', '.join(f'{v:.3f}' for v in C)}</td><td>{turn}</td></tr>"
        )
    return (
        '<table id="cameras"><tr><th>view</th><th>f (px)</th><th>image</th>'
        "<th>centre, world (m)</th><th>centre, y-up export frame (m)</th>"
        "<th>turn about the vertical from the first camera (deg)</th></tr>"
        + "".join(rows)
        + "</table>"
    )


def report_html(rec: Reconstruction) -> str:
    """The report page of a reconstruction (see the module docstring)."""
    interp = rec.interpretation
    scene = rec.scene
    model = interp.model
    title = f"aida-kb reconstruction of {scene.name if scene else rec.evidence.scene}"
    verdict = (
        '<span class="ok">accepted</span>'
        if interp.accepted
        else '<span class="bad">no model</span>'
    )
    body = [
        f"<h1>{html.escape(title)}</h1>",
        f'<p id="verdict">Verdict: {verdict}. {html.escape(interp.message)}</p>',
    ]
    if interp.cost is not None:
        body.append(f"<p>Cost {interp.cost:.4g}; {interp.expanded} hypotheses expanded.</p>")
    files = [p.name for p in rec.files if p.name != REPORT_FILE]
    if files:
        links = ", ".join(f'<a href="{html.escape(n)}">{html.escape(n)}</a>' for n in files)
        body.append(f"<p>Files: {links}</p>")
    if model is not None and rec.atlas is not None and scene is not None and model.cameras:
        reference = _camera_of(model, model.cameras[0].view)
        assert reference is not None
        body.append("<h2>The textured model</h2>")
        unseen = [p.role for p, s in zip(model.parts, rec.atlas.seen, strict=True) if not s]
        for turn in ORBIT_TURNS_DEG:
            cam = _orbit_camera(model, reference, turn)
            drawn, _ = render_view(model, rec.atlas, cam)
            drawn[np.all(drawn == 0, axis=2)] = 255
            body.append(
                _figure(drawn, f"turned {turn:g} deg from view 00, from above", cls="render")
            )
        body.append(
            "<p>Faces no view saw (neutral grey): "
            + html.escape(", ".join(unseen) if unseen else "none")
            + "</p>"
        )
    if scene is not None:
        ids = [p.evidence.id for p in rec.views]
        for k, prod in enumerate(rec.views):
            body.append(_view_section(rec, prod, scene, ids[k - 1] if k > 0 else None))
    if model is not None:
        body.append("<h2>Cameras</h2>" + _cameras(model))
    body.append("<h2>Instance tree</h2>")
    tree = instance_tree(interp)
    body.append(f"<pre>{html.escape(chr(10).join(tree) if tree else '(no instances)')}</pre>")
    body.append("<h2>Residuals of the accepted interpretation</h2>" + _rows(interp))
    body.append("<h2>Rejected hypotheses</h2>")
    rejected = explanation(interp)
    items = "".join(f"<li>{html.escape(line)}</li>" for line in rejected)
    body.append(f'<ul id="rejected">{items}</ul>' if rejected else "<p>none</p>")
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{html.escape(title)}</title><style>{STYLE}</style>"
        f"<script>{COUNT_IMAGES}</script></head><body>" + "\n".join(body) + "</body></html>\n"
    )


def write_report(directory: Path, rec: Reconstruction) -> list[str]:
    """Write `report.html` into `directory` (atomically); its name (the pipeline's `extra`)."""
    write_text_atomic(directory / REPORT_FILE, report_html(rec))
    return [REPORT_FILE]
