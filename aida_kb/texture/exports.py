"""Every export of a reconstructed model, textured from its scene: file name -> content."""

from __future__ import annotations

from collections.abc import Sequence

from aida_kb.io.export import EXPORT_FORMATS, Atlas, Georeference, export_files
from aida_kb.io.model import ReconstructedModel
from aida_kb.io.scene import Scene
from aida_kb.texture.atlas import texture_model
from aida_kb.texture.points import stereo_points
from aida_kb.vision.evidence import ViewProducts


def model_exports(
    model: ReconstructedModel,
    scene: Scene,
    products: Sequence[ViewProducts],
    *,
    formats: Sequence[str] = EXPORT_FORMATS,
    stem: str = "model",
    georeference: Georeference | None = None,
) -> tuple[dict[str, bytes], Atlas]:
    """The files of `formats` (OBJ + MTL + atlas, GLB, CityJSON, PLY) and the atlas.

    The atlas comes from every view of `scene` the model has a camera for; the PLY holds the
    stereo points of `products` (the vision front end's depth of each view).
    """
    atlas = texture_model(model, scene)
    points = stereo_points(products, model, scene) if "ply" in formats else None
    files: dict[str, bytes] = {}
    for fmt in formats:
        files.update(
            export_files(
                model, fmt, stem=stem, atlas=atlas, points=points, georeference=georeference
            )
        )
    return files, atlas
