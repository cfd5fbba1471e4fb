"""Texture: the images of every view back-projected onto the model, renders and stereo points.

`atlas.texture_model` builds the texture atlas (`aida_kb.io.export.Atlas`) that the exports
embed; `render.render_view` draws the textured model through a camera (the report's views and
the back-projection check); `points.stereo_points` gathers the stereo front end's points of
every view in the world frame for the PLY export.
"""
