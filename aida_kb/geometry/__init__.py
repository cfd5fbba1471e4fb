"""Geometry: planes with local frames, CAHV cameras, polygons, polyhedra."""
