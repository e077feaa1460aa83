//! `occlux.render` and `occlux.write_exr`: a scene rendered on the chosen device, its image as
//! numpy arrays, and the multilayer EXR the CLI writes.

use crate::arrays::readonly_view;
use crate::scene::PyScene;
use crate::volume::PyVolume;
use crate::{py_err, unknown_choice};
use numpy::{PyArray2, PyArray3};
use occlux::export::exr::{self, render_layers, Precision};
use occlux::gpu::{Compute, DeviceChoice};
use occlux::pipeline::{self, header_metadata, Settled};
use occlux::progress::{NoProgress, Progress};
use occlux::render::RenderImage;
use occlux::render::Rendered;
use occlux::scene::Scene;
use occlux::volume::Volume;
use pyo3::exceptions::PyRuntimeWarning;
use pyo3::prelude::*;
use pyo3::types::PyBool;
use std::borrow::Cow;
use std::ffi::CString;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// A rendered image: linear radiance with the background composited in, the volume's opacity
/// as alpha, and depth. Immutable: `beauty` and `depth` are read-only views of its memory.
#[pyclass(name = "RenderResult", module = "occlux", frozen)]
pub struct PyRenderResult {
    image: RenderImage,
    device: String,
    /// A `method = "auto"` scene's plan record, written into the EXR header.
    plan: Option<serde_json::Value>,
}

#[pymethods]
impl PyRenderResult {
    /// Linear RGBA, float32, shape (height, width, 4), row 0 at the top.
    #[getter]
    fn beauty<'py>(this: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let image = &this.get().image;
        let shape = (image.height as usize, image.width as usize, 4);
        // SAFETY: the pixels belong to this frozen RenderResult, which never changes them.
        unsafe { readonly_view(this.clone().into_any(), image.rgba.as_flattened(), shape) }
    }

    /// Distance from the eye to where the ray's opacity crosses 0.5 (1e10 where it never does),
    /// float32, shape (height, width).
    #[getter]
    fn depth<'py>(this: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let image = &this.get().image;
        let shape = (image.height as usize, image.width as usize);
        // SAFETY: as for `beauty`.
        unsafe { readonly_view(this.clone().into_any(), &image.depth, shape) }
    }

    /// Directional occlusion shading's occlusion layer, float32, shape (height, width, 2):
    /// [..., 0] is P, each sample's lit fraction of the ambient light weighted by its
    /// contribution to the pixel (transmittance in front times opacity) and summed along the
    /// ray, and [..., 1] is A, the coverage (the sum of those weights, = beauty's alpha). So
    /// 0 <= P <= A, P = A where nothing occludes, P = A = 0 where the ray meets nothing; P / A
    /// is the mean occlusion of what the pixel shows. Shade another render of the same view
    /// by `render * (1 - strength * (A - P))`. None for methods that compute none.
    #[getter]
    fn occlusion<'py>(this: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyArray3<f32>>>> {
        factor(this, "occlusion")
    }

    /// IPSVI's (and half-angle slicing's) shadow layer, float32, shape (height, width, 2):
    /// [..., 0] is P, the lights' transmittance at each sample (weighted by their irradiance)
    /// weighted by the sample's contribution and summed along the ray, [..., 1] the coverage
    /// A, as for `occlusion`. None for methods that compute none.
    #[getter]
    fn shadow<'py>(this: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyArray3<f32>>>> {
        factor(this, "shadow")
    }

    /// For a scene with `method = "auto"`: what the planner chose, as JSON text (the
    /// configuration, the budget, the predicted error and time); None otherwise.
    #[getter]
    fn plan(&self) -> Option<String> {
        self.plan.as_ref().map(|p| p.to_string())
    }

    #[getter]
    fn width(&self) -> u32 {
        self.image.width
    }

    #[getter]
    fn height(&self) -> u32 {
        self.image.height
    }

    /// Where it ran: the GPU adapter ("llvmpipe (LLVM 15, 256 bits), Vulkan") or "cpu".
    #[getter]
    fn device(&self) -> &str {
        &self.device
    }

    fn __repr__(&self) -> String {
        format!(
            "RenderResult({}x{}, device='{}')",
            self.image.width, self.image.height, self.device
        )
    }
}

/// The shading factor `name` of a result as a read-only (height, width, 2) array of (P, A),
/// if it has one.
fn factor<'py>(
    this: &Bound<'py, PyRenderResult>,
    name: &str,
) -> PyResult<Option<Bound<'py, PyArray3<f32>>>> {
    let image = &this.get().image;
    let shape = (image.height as usize, image.width as usize, 2);
    image
        .factor(name)
        // SAFETY: the values belong to this frozen RenderResult, which never changes them.
        .map(|f| unsafe { readonly_view(this.clone().into_any(), f.values.as_flattened(), shape) })
        .transpose()
}

fn parse_device(device: &str) -> PyResult<DeviceChoice> {
    match device {
        "auto" => Ok(DeviceChoice::Auto),
        "gpu" => Ok(DeviceChoice::Gpu),
        "cpu" => Ok(DeviceChoice::Cpu),
        other => Err(unknown_choice("device", other, &["auto", "gpu", "cpu"])),
    }
}

/// Where to compute, for a `device` argument: "auto" (a GPU adapter if one opens, else the CPU
/// with a RuntimeWarning saying why), "gpu" (or OccluxError) or "cpu".
pub(crate) fn compute(py: Python<'_>, device: &str) -> PyResult<Compute> {
    let choice = parse_device(device)?;
    // Opening an adapter the first time takes a while: without the GIL.
    let (compute, notice) = py.detach(|| Compute::resolve(choice)).map_err(py_err)?;
    if let Some(notice) = notice {
        let message = CString::new(notice).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<PyRuntimeWarning>(), &message, 1)?;
    }
    Ok(compute)
}

/// The scene and volume to render: the scene as it is with the volume given, or the scene
/// settled for its own volume (loaded without the GIL; camera framed, window resolved: see
/// `Scene.load`).
pub(crate) fn scene_volume<'a>(
    py: Python<'_>,
    scene: &'a Scene,
    volume: Option<&'a PyVolume>,
) -> PyResult<(Cow<'a, Scene>, Cow<'a, Volume>)> {
    match volume {
        Some(volume) => Ok((Cow::Borrowed(scene), Cow::Borrowed(&volume.inner))),
        None => {
            let loaded = py.detach(|| scene.load()).map_err(py_err)?;
            Ok((Cow::Owned(loaded.scene), Cow::Owned(loaded.volume)))
        }
    }
}

/// The scene settled for rendering: a `method = "auto"` scene planned (quietly, without the
/// GIL; the choice is in the result's `plan` and the EXR header), any other as it is.
pub(crate) fn settled<'a>(
    py: Python<'_>,
    scene: Cow<'a, Scene>,
    volume: &Volume,
    compute: &Compute,
) -> PyResult<Settled<'a>> {
    if scene.auto.is_none() {
        return Ok(Settled {
            scene,
            planned: None,
        });
    }
    let planned = py
        .detach(|| pipeline::settle(&scene, volume, compute, &|_: &str| {}))
        .map_err(py_err)?;
    Ok(Settled {
        scene: Cow::Owned(planned.scene.into_owned()),
        planned: planned.planned,
    })
}

/// Forwards the core's progress to a Python callable `progress(done, total)`, taking the GIL
/// for each call. The core's work cannot be interrupted, so the first exception the callable
/// raises silences it and is raised once the work is done.
/// A callable that returns `False` cancels the work (the call then raises OccluxError
/// "cancelled").
struct PyProgress {
    callback: Py<PyAny>,
    error: Mutex<Option<PyErr>>,
    cancelled: AtomicBool,
}

impl Progress for PyProgress {
    fn update(&self, done: u64, total: u64) {
        let mut error = self.error.lock().unwrap_or_else(|e| e.into_inner());
        if error.is_none() {
            Python::attach(|py| match self.callback.call1(py, (done, total)) {
                Ok(answer) => {
                    if answer.bind(py).is(PyBool::new(py, false)) {
                        self.cancelled.store(true, Ordering::Relaxed);
                    }
                }
                Err(e) => *error = Some(e),
            });
        }
    }

    fn cancelled(&self) -> bool {
        self.cancelled.load(Ordering::Relaxed)
    }
}

/// Runs `work` without the GIL, reporting to `progress` (a callable `progress(done, total)`,
/// or None); an exception from the callable is raised once the work is done.
pub(crate) fn with_progress<T: Send>(
    py: Python<'_>,
    progress: Option<Py<PyAny>>,
    work: impl FnOnce(&dyn Progress) -> occlux::Result<T> + Send,
) -> PyResult<T> {
    let progress = progress.map(|callback| PyProgress {
        callback,
        error: Mutex::new(None),
        cancelled: AtomicBool::new(false),
    });
    let report: &dyn Progress = match &progress {
        Some(p) => p,
        None => &NoProgress,
    };
    let result = py.detach(|| work(report)).map_err(py_err)?;
    match progress.and_then(|p| p.error.into_inner().unwrap_or_else(|e| e.into_inner())) {
        Some(error) => Err(error),
        None => Ok(result),
    }
}

/// Renders the scene's method for `volume` without the GIL, reporting to `progress`.
pub(crate) fn render_scene(
    py: Python<'_>,
    scene: &Settled,
    volume: &Volume,
    compute: &Compute,
    progress: Option<Py<PyAny>>,
) -> PyResult<Rendered> {
    with_progress(py, progress, |report| {
        pipeline::render(scene, volume, compute, report)
    })
}

/// Renders `scene` with its own volume (loaded from the scene) or `volume`, on `device`:
/// "auto" (a GPU adapter if one opens, else the CPU with a RuntimeWarning), "gpu" (or
/// OccluxError) or "cpu". `progress(done, total)`, if given, is called as rows finish. The GIL
/// is released while it loads and renders.
#[pyfunction]
#[pyo3(signature = (scene, volume = None, device = "auto", progress = None))]
pub fn render(
    py: Python<'_>,
    scene: &PyScene,
    volume: Option<&PyVolume>,
    device: &str,
    progress: Option<Py<PyAny>>,
) -> PyResult<PyRenderResult> {
    let compute = compute(py, device)?;
    let (scene, volume) = scene_volume(py, &scene.inner, volume)?;
    let scene = settled(py, scene, &volume, &compute)?;
    let image = render_scene(py, &scene, &volume, &compute, progress)?.image;
    let device = match compute {
        Compute::Gpu(ctx) => ctx.describe(),
        Compute::Cpu => "cpu".into(),
    };
    let plan = scene.planned.as_ref().map(|p| p.record.clone());
    Ok(PyRenderResult {
        image,
        device,
        plan,
    })
}

/// Writes a render as a multilayer OpenEXR, atomically: layers `beauty` (R, G, B, A; float16
/// unless `float32`), `depth` (Z, always float32) and, for DOS, IPSVI and half-angle slicing,
/// `occlusion` or `shadow` (V: the factor premultiplied by coverage, A: the coverage), with the
/// scene's camera, method and lighting as text attributes in the header.
#[pyfunction]
#[pyo3(signature = (path, result, scene, float32 = false))]
pub fn write_exr(
    py: Python<'_>,
    path: PathBuf,
    result: &PyRenderResult,
    scene: &PyScene,
    float32: bool,
) -> PyResult<()> {
    let image = &result.image;
    let mut metadata = header_metadata(&Settled::named(&scene.inner));
    if let Some(record) = &result.plan {
        pipeline::insert_plan(&mut metadata, record);
    }
    let precision = if float32 {
        Precision::Float
    } else {
        Precision::Half
    };
    py.detach(|| {
        exr::write_exr(
            &path,
            image.width,
            image.height,
            &render_layers(image),
            &metadata,
            precision,
        )
    })
    .map_err(py_err)
}
