"""aida-kb: explicit knowledge about man-made objects turned into accurate 3-D models.

The package is layered; a module may import only from layers below it
(see ``docs/architecture.md`` and ``tests/test_architecture.py``)::

    errors, diagnostics -> dsl -> kb -> geometry -> constraints -> solve
        -> io -> vision -> synth -> interpret -> cli
"""

__version__ = "0.1.0"
