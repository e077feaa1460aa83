"""Occlux: fast illumination for scientific volumes, from Python.

Load or build a volume, classify it, render it on the GPU (or the CPU twin), and write OpenVDB
grids, OpenEXR layers and USD stages that Blender and other tools read::

    import occlux

    scene = occlux.Scene.load("examples/engine.toml")
    result = occlux.render(scene, device="auto")
    occlux.write_exr("engine.exr", result, scene)
    occlux.export(scene, "out/", stem="engine")  # out/engine.{exr,png,vdb,usda}
    truth = occlux.reference(scene, estimator="single", spp=256)  # .mean, .stderr
    grids = occlux.ao_volume(scene, method="cdf", radius=10)  # {"ao": Volume}
    [m["name"] for m in occlux.methods()]  # the registry: unshaded, gradient, ao, dos
    occlux.write_vdb("engine-ao.vdb", grids)

``write_exr_layers``, ``write_png``, ``write_text`` and ``write_reference`` write data made in
Python (numpy layers, an 8-bit picture, text, a reference) with the core's atomic writers.
``image_error`` and ``write_error_map`` measure an image against a reference of the same scene
(docs/architecture.md#error-measure's relative RMSE and bias over the volume's pixels, and a map
with a colour key). ``series`` renders and exports a time series (one scene over many volumes) as
Dask tasks, on a LocalCluster or any ``distributed.Client``; ``occlux series`` is its command line
twin. ``occlux.blender`` builds a scene in Blender 5 and renders it with Cycles, to compare with
Occlux's images (what the Blender add-on's Check Against Cycles runs).

``occlux.usd`` authors the same USD stages through usd-core's ``pxr`` API, into a file or into
a stage of your own pipeline.

Every error from the core is raised as :class:`OccluxError`, with the core's message.
"""

from occlux._occlux import (
    PHANTOMS,
    PRESETS,
    Classification,
    OccluxError,
    ReferenceResult,
    RenderResult,
    Scene,
    Volume,
    __version__,
    ao_volume,
    bake,
    export,
    image_error,
    methods,
    reference,
    render,
    stage_description,
    write_error_map,
    write_exr,
    write_exr_layers,
    write_png,
    write_reference,
    write_text,
    write_vdb,
)
from occlux.batch import SeriesError, SeriesResult, series

__all__ = [
    "PHANTOMS",
    "PRESETS",
    "Classification",
    "OccluxError",
    "ReferenceResult",
    "RenderResult",
    "Scene",
    "SeriesError",
    "SeriesResult",
    "Volume",
    "__version__",
    "ao_volume",
    "bake",
    "export",
    "image_error",
    "methods",
    "reference",
    "render",
    "series",
    "stage_description",
    "write_error_map",
    "write_exr",
    "write_exr_layers",
    "write_png",
    "write_reference",
    "write_text",
    "write_vdb",
]
