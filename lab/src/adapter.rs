//! `occlux adapter`: the GPU adapter that Occlux's GPU paths open, described as a benchmark
//! records it (name, driver, backend, device type), with `--hardware` refusing a software
//! rasterizer so that a GPU check never reports the CPU's speed under a GPU's name.

use occlux::error::{Error, Result};
use occlux::gpu::{shared_context, GpuContext};
use serde::Serialize;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct AdapterArgs {
    /// Refuse a software rasterizer (lavapipe/llvmpipe, WARP): an error, and no JSON written.
    #[arg(long)]
    pub hardware: bool,
    /// Also write the description as JSON here.
    #[arg(short, long)]
    pub out: Option<PathBuf>,
}

/// What wgpu says of the adapter, as benchmark reports hold it.
#[derive(Serialize, Debug, Clone)]
pub struct AdapterReport {
    pub name: String,
    /// PCI vendor and device ids (0 where the backend has none).
    pub vendor: u32,
    pub device: u32,
    /// wgpu's device type: DiscreteGpu, IntegratedGpu, VirtualGpu, Cpu (a software
    /// rasterizer) or Other.
    pub device_type: String,
    pub driver: String,
    pub driver_info: String,
    pub backend: String,
    /// Whether `device_type` is Cpu: the kernels run as CPU code.
    pub software: bool,
}

impl AdapterReport {
    pub fn of(ctx: &GpuContext) -> Self {
        let info = &ctx.adapter_info;
        Self {
            name: info.name.clone(),
            vendor: info.vendor,
            device: info.device,
            device_type: format!("{:?}", info.device_type),
            driver: info.driver.clone(),
            driver_info: info.driver_info.clone(),
            backend: format!("{:?}", info.backend),
            software: ctx.is_software(),
        }
    }
}

/// Opens the adapter, refuses a software one under `--hardware`, prints its description unless
/// `quiet` and writes it as JSON when asked.
pub fn run(args: &AdapterArgs, quiet: bool) -> Result<()> {
    let ctx = shared_context()?;
    let report = AdapterReport::of(&ctx);
    if args.hardware && report.software {
        return Err(Error::Gpu(format!(
            "the adapter {} (driver {} {}) is a software rasterizer, refused by --hardware: \
             its timings would be the CPU's",
            report.name, report.driver, report.driver_info
        )));
    }
    if !quiet {
        println!(
            "{} ({}, {}), driver {} {}",
            report.name, report.device_type, report.backend, report.driver, report.driver_info
        );
    }
    match &args.out {
        Some(path) => super::write_report(path, &report, quiet),
        None => Ok(()),
    }
}
