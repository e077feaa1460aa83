"""Occlux's measurement harness: what ``occlux check-cycles`` and ``occlux chart`` run, and what
the tests measure with. Not part of the ``occlux`` wheel that users install; it lives in the
repository (lab/python) and builds on the user package (``occlux``, ``occlux.blender``).

- :mod:`occlux_lab.cycles`: Occlux's Monte Carlo references against Cycles, within noise
  (``python -m occlux_lab.cycles``, what ``occlux check-cycles`` runs), and Cycles' time-error
  curve for ``occlux chart`` (``python -m occlux_lab.cycles.curve``).
- :mod:`occlux_lab.peers`: the other renderers of ``occlux chart`` (``python -m
  occlux_lab.peers.vtk``, ``python -m occlux_lab.peers.eevee``).

It is not installed: whoever runs it puts lab/python on the import path (the ``occlux``
launchers set PYTHONPATH, the tests' conftest.py and the scripts under docs/ and bench/ insert
it into sys.path), in a Python that has the ``occlux`` package and Blender (bpy).
"""
