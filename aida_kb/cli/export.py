"""`aida-kb export`: a model file in a standard 3-D format (OBJ, glTF, CityJSON, PLY)."""

from __future__ import annotations

import argparse
from typing import Any

EXAMPLE = """\
formats (all in a frame whose up axis is the model's estimated vertical; each file records
the transform T_export_world from the model's frame, the left camera of view 00):
  obj        model.obj + model.mtl (+ model_atlas.png): y up, one group per part, normals,
             texture coordinates with --scene
  glb        model.glb: binary glTF 2.0, y up, the texture embedded with --scene
  cityjson   model.city.json: CityJSON 2.0, z up; a Building (BuildingParts for the other
             solids), LoD2 Solids with one semantic surface per face
  ply        model_points.ply: the stereo points of every view (needs --scene)
With --scene the images of the scene's views are back-projected onto the faces (texture
atlas); faces no view sees get a neutral grey material and are marked unseen.

examples:
  aida-kb export out/m/model.json --format glb -o out/export
  aida-kb export out/m/model.json --format obj --scene out/house -o out/export
  aida-kb export out/m/model.json --format cityjson --format ply --scene out/house -o out/e
  aida-kb export out/m/model.json --format cityjson -o out/e --origin 85000,446000,0 \
      --heading 30 --epsg 28992     # on the map: origin, bearing of view 00's look, CRS
"""


# aida_kb.io.export.EXPORT_FORMATS, written out: building the parser imports nothing heavy
FORMATS = ("obj", "glb", "cityjson", "ply")


def register(subparsers: Any) -> None:
    """Add the `export` command."""
    p = subparsers.add_parser(
        "export",
        help="a model file as OBJ, glTF (.glb), CityJSON or PLY, textured from its scene",
        description=(
            "Write the model of MODEL (model.json) in standard 3-D formats, in a frame whose "
            "up axis is the model's estimated vertical; textured from SCENE_DIR's images."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", metavar="MODEL", help="model.json (aida-kb reconstruct)")
    p.add_argument(
        "--format",
        dest="formats",
        action="append",
        required=True,
        choices=FORMATS,
        help="output format (repeat for several)",
    )
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder")
    p.add_argument(
        "--scene", metavar="SCENE_DIR", default=None, help="scene directory: texture, points"
    )
    p.add_argument("--stem", default="model", help="file name stem (default: model)")
    p.add_argument(
        "--origin",
        metavar="E,N,H",
        default=None,
        help="CityJSON: map coordinates (metres) of the model's origin (below its centre)",
    )
    p.add_argument(
        "--heading",
        metavar="DEG",
        type=float,
        default=0.0,
        help="CityJSON: compass bearing of the direction view 00 looks in (with --origin)",
    )
    p.add_argument(
        "--epsg", metavar="CODE", type=int, default=None, help="CityJSON: the map's EPSG code"
    )
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Export; print the files written."""
    import numpy as np

    from aida_kb.errors import FormatError
    from aida_kb.io.atomic import make_dirs
    from aida_kb.io.export import ExportFrame, Georeference, export_files, write_files
    from aida_kb.io.model import read_model
    from aida_kb.io.scene import read_scene

    if "ply" in args.formats and args.scene is None:
        raise FormatError("--format ply: the stereo points need the scene (--scene SCENE_DIR)")
    if not args.stem or "/" in args.stem or args.stem in (".", ".."):
        raise FormatError(f"--stem {args.stem!r}: must be a plain file name")
    georeference = None
    if args.origin is not None:
        try:
            east, north, height = (float(v) for v in args.origin.split(","))
        except ValueError:
            raise FormatError(f"--origin {args.origin!r}: expected E,N,H in metres") from None
        georeference = Georeference((east, north, height), args.heading, args.epsg)
        georeference.apply(ExportFrame("z-up", np.eye(3), np.zeros(3)))  # checks the numbers
    elif args.epsg is not None or args.heading:
        raise FormatError("--heading and --epsg place the model on the map: give --origin too")
    model = read_model(args.model)
    out = make_dirs(args.output)
    files: dict[str, bytes] = {}
    formats = list(dict.fromkeys(args.formats))
    if args.scene is None:
        for fmt in formats:
            files.update(export_files(model, fmt, stem=args.stem, georeference=georeference))
    else:
        from aida_kb.texture.exports import model_exports
        from aida_kb.vision.evidence import scene_evidence

        scene = read_scene(args.scene, with_truth=False)
        products: list[Any] = []
        if "ply" in formats:
            views = [c.view for c in model.cameras if c.view in {v.id for v in scene.views}]
            _, products = scene_evidence(scene, views=views)
        files, _ = model_exports(
            model, scene, products, formats=formats, stem=args.stem, georeference=georeference
        )
    for path in write_files(out, files):
        print(f"wrote {path}")
    return 0
