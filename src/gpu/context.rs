//! Opening a wgpu device, choosing between GPU and CPU, and turning wgpu errors into `Error::Gpu`.

use std::sync::{Arc, OnceLock};

use crate::error::{Error, Result};

use super::shader::PipelineCache;

/// Backends Occlux asks for. GL is left out on purpose: its EGL start costs seconds, and on
/// llvmpipe its 3D storage writes are wrong beyond slice 0.
const BACKENDS: wgpu::Backends = wgpu::Backends::VULKAN
    .union(wgpu::Backends::METAL)
    .union(wgpu::Backends::DX12);

/// How to get a driver, appended to every "no adapter" message.
const DRIVER_HINT: &str = "install a Vulkan driver (without a GPU on Debian/Ubuntu: \
     `apt-get install mesa-vulkan-drivers`, the lavapipe software driver)";

/// An open wgpu device with what the kernels need to know about it.
#[derive(Debug)]
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter_info: wgpu::AdapterInfo,
    /// The adapter's own limits, requested in full (large 3D textures and storage bindings).
    pub limits: wgpu::Limits,
    pub(super) pipelines: PipelineCache,
}

impl GpuContext {
    /// Opens the highest-performance Vulkan/Metal/DX12 adapter with its full limits. No
    /// optional feature is needed: kernels interpolate volumes themselves (see `texture`).
    pub fn open() -> Result<Self> {
        pollster::block_on(Self::open_async())
    }

    async fn open_async() -> Result<Self> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        // WGPU_BACKEND may narrow the choice, never widen it to GL.
        desc.backends &= BACKENDS;
        let instance = wgpu::Instance::new(desc);
        let adapter = instance
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                ..Default::default()
            })
            .await
            .map_err(|e| {
                Error::Gpu(format!("no Vulkan/Metal/DX12 adapter ({e}): {DRIVER_HINT}"))
            })?;
        let limits = adapter.limits();
        let adapter_info = adapter.get_info();
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("occlux"),
                required_features: wgpu::Features::empty(),
                required_limits: limits.clone(),
                experimental_features: wgpu::ExperimentalFeatures::disabled(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|e| {
                Error::Gpu(format!(
                    "adapter {} found but its device did not open ({e}): {DRIVER_HINT}",
                    adapter_info.name
                ))
            })?;
        Ok(Self {
            device,
            queue,
            adapter_info,
            limits,
            pipelines: PipelineCache::default(),
        })
    }

    /// Whether the adapter is a software rasterizer (lavapipe/llvmpipe, WARP): the kernels then
    /// run as CPU code, so its timings say nothing about a GPU.
    pub fn is_software(&self) -> bool {
        self.adapter_info.device_type == wgpu::DeviceType::Cpu
    }

    /// "llvmpipe (LLVM 15, 256 bits), Vulkan".
    pub fn describe(&self) -> String {
        format!(
            "{}, {:?}",
            self.adapter_info.name, self.adapter_info.backend
        )
    }

    /// Runs `f` with validation and out-of-memory errors captured, so that a failed wgpu call
    /// (a texture too large for memory, a shader that does not compile) becomes `Error::Gpu`
    /// naming `what` instead of wgpu's default panic.
    pub fn checked<T>(&self, what: &str, f: impl FnOnce() -> T) -> Result<T> {
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let value = f();
        // Scopes pop innermost first.
        let invalid = pollster::block_on(validation.pop());
        let oom = pollster::block_on(memory.pop());
        match invalid.or(oom) {
            None => Ok(value),
            Some(e) => Err(Error::Gpu(format!("{what}: {e}"))),
        }
    }

    /// Blocks until all submitted work is done.
    pub fn wait(&self) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(drop)
            .map_err(|e| Error::Gpu(format!("waiting for the device: {e}")))
    }
}

/// One context per process: opening a device (and warming shader JITs) is paid once, and a
/// failure is remembered rather than retried.
pub fn shared_context() -> Result<Arc<GpuContext>> {
    static SHARED: OnceLock<std::result::Result<Arc<GpuContext>, String>> = OnceLock::new();
    SHARED
        .get_or_init(|| GpuContext::open().map(Arc::new).map_err(gpu_message))
        .clone()
        .map_err(Error::Gpu)
}

/// `Auto`: the GPU if it opened and is hardware, else the CPU with a one-line notice saying
/// why. A software rasterizer (lavapipe, WARP) runs the kernels as CPU code, where Occlux's
/// vectorised CPU twins are faster or as fast (measured on 2 cores: VAO 10x, DOS 20-50x, the
/// ray caster about the same).
fn auto(opened: Result<Arc<GpuContext>>) -> (Compute, Option<String>) {
    match opened {
        Ok(ctx) if ctx.is_software() => (
            Compute::Cpu,
            Some(format!(
                "the GPU adapter {} is a software rasterizer: using the CPU, which is faster \
                 (--device gpu uses the adapter anyway)",
                ctx.describe()
            )),
        ),
        Ok(ctx) => (Compute::Gpu(ctx), None),
        Err(e) => (
            Compute::Cpu,
            Some(format!(
                "no GPU adapter ({}): using the CPU",
                gpu_message(e)
            )),
        ),
    }
}

/// The message of an `Error::Gpu` without the "GPU: " prefix that Display adds.
fn gpu_message(e: Error) -> String {
    match e {
        Error::Gpu(message) => message,
        other => other.to_string(),
    }
}

/// What the user asked for with `--device` (or `device =` in a scene file).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DeviceChoice {
    /// A hardware GPU adapter if one opens, else the CPU (with a notice).
    #[default]
    Auto,
    /// A GPU adapter, or an error.
    Gpu,
    /// The CPU path; wgpu is never touched.
    Cpu,
}

impl std::str::FromStr for DeviceChoice {
    type Err = Error;

    /// `auto`, `gpu` or `cpu`, as `--device` and a scene's `device =` take them.
    fn from_str(name: &str) -> Result<Self> {
        let choices = [
            ("auto", DeviceChoice::Auto),
            ("gpu", DeviceChoice::Gpu),
            ("cpu", DeviceChoice::Cpu),
        ];
        crate::names::parse_name("device", name, &choices)
    }
}

/// Where kernels run: handed to every method, which dispatches to its GPU or CPU twin.
#[derive(Clone, Debug)]
pub enum Compute {
    Gpu(Arc<GpuContext>),
    Cpu,
}

impl Compute {
    /// Resolves a choice to a device, with a one-line notice when `Auto` falls back to the CPU.
    pub fn resolve(choice: DeviceChoice) -> Result<(Compute, Option<String>)> {
        match choice {
            DeviceChoice::Cpu => Ok((Compute::Cpu, None)),
            DeviceChoice::Gpu => Ok((Compute::Gpu(shared_context()?), None)),
            DeviceChoice::Auto => Ok(auto(shared_context())),
        }
    }

    /// "GPU: llvmpipe (LLVM 15, 256 bits), Vulkan" or "CPU: 2 threads".
    pub fn describe(&self) -> String {
        match self {
            Compute::Gpu(ctx) => format!("GPU: {}", ctx.describe()),
            Compute::Cpu => format!("CPU: {} threads", rayon::current_num_threads()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_falls_back_to_the_cpu_with_a_notice() {
        let (compute, notice) = auto(Err(Error::Gpu("no adapter here".into())));
        assert!(matches!(compute, Compute::Cpu));
        assert_eq!(
            notice.as_deref(),
            Some("no GPU adapter (no adapter here): using the CPU")
        );
        let (cpu, notice) = Compute::resolve(DeviceChoice::Cpu).unwrap();
        assert!(notice.is_none());
        assert_eq!(
            cpu.describe(),
            format!("CPU: {} threads", rayon::current_num_threads())
        );
    }

    #[test]
    fn auto_prefers_the_cpu_twins_to_a_software_rasterizer() {
        let opened = shared_context();
        let software = opened.as_ref().is_ok_and(|c| c.is_software());
        let hardware = opened.is_ok() && !software;
        let (compute, notice) = auto(opened);
        if hardware {
            assert!(matches!(compute, Compute::Gpu(_)) && notice.is_none());
        } else {
            assert!(matches!(compute, Compute::Cpu));
            let notice = notice.unwrap();
            assert!(
                !software || notice.contains("software rasterizer"),
                "{notice}"
            );
        }
    }

    #[test]
    fn device_choice_parses_lowercase_from_cli_and_toml() {
        assert_eq!("gpu".parse::<DeviceChoice>().unwrap(), DeviceChoice::Gpu);
        assert!("GPU".parse::<DeviceChoice>().is_err());
        #[derive(serde::Deserialize)]
        struct Scene {
            device: DeviceChoice,
        }
        let scene: Scene = toml::from_str("device = \"cpu\"").unwrap();
        assert_eq!(scene.device, DeviceChoice::Cpu);
        assert!(toml::from_str::<Scene>("device = \"GPU\"").is_err());
    }
}
