"""The renderers a user would pick instead of Occlux, as series of ``occlux chart``: each one
renders an Occlux scene at a few settings of its own quality axis, times each render and writes
the images for the chart to measure against the path-traced truth.

Every peer is a module run as ``python -m occlux_lab.peers.NAME SCENE --estimator E --out DIR``
(``E``: ``ambient``, ``single`` or ``multiple``, the lighting the chart measures: the scene's
ambient light, or its suns and lamps with single or multiple scattering). It writes one linear
RGB OpenEXR per setting (the scene camera's size, row 0 at the top, framed as Occlux frames it)
and ``DIR/NAME-E-curve.json`` (see :func:`.common.write_curve`), and exits 0; a scene it cannot
map is exit code 2 with ``error: ...`` on stderr. Cycles (``occlux_lab.cycles.curve``) writes the
same JSON with sample counts as its settings.
"""
