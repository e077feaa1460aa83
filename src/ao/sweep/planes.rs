//! How a volume's plane-by-plane sweep fits the adapter: the host side of
//! shaders/shared/plane.wgsl, shared by the physical and geometric octant kernels and the
//! signed distance's. Plane t holds the voxels whose sweep indices sum to t; they are
//! independent, so each plane is one dispatch.

use crate::error::{Error, Result};
use crate::gpu::GpuContext;

/// Invocations per workgroup of the 1D kernels (`@workgroup_size(64, 1, 1)`).
pub(super) const WORKGROUP_1D: u32 = 64;
/// Side of a plane kernel's workgroup (`@workgroup_size(8, 8, 1)`).
const WORKGROUP_PLANE: u32 = 8;
/// The most storage buffers a plane kernel binds: the physical sweep_plane's group of octants
/// and its seven half-step grids.
const PLANE_STORAGE_BUFFERS: u32 = 8;

/// How a volume's sweep fits the adapter: checked before anything is allocated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Plan {
    pub(crate) dims: [usize; 3],
    /// Voxels of one padded grid.
    pub(crate) padded_voxels: usize,
    /// Octants per group (one storage binding holds a group's grids).
    pub(crate) group: usize,
    /// The axis solved from the plane index: the longest, so that the dispatch over the other
    /// two wastes the fewest invocations.
    pub(crate) solved_axis: usize,
}

impl Plan {
    pub(crate) fn new(dims: [usize; 3], limits: &wgpu::Limits) -> Result<Self> {
        let padded_voxels: usize = dims.iter().map(|n| n + 2).product();
        let binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let grid_bytes = padded_voxels as u64 * 4;
        if grid_bytes > binding {
            return Err(Error::Gpu(format!(
                "the sweep of a {}x{}x{} volume needs {:.1} MiB per padded octant grid, over \
                 the adapter's max_storage_buffer_binding_size of {:.1} MiB: use the CPU twin \
                 (--device cpu) or a smaller volume",
                dims[0],
                dims[1],
                dims[2],
                mib(grid_bytes),
                mib(binding)
            )));
        }
        if limits.max_storage_buffers_per_shader_stage < PLANE_STORAGE_BUFFERS {
            return Err(Error::Gpu(format!(
                "the sweep binds {PLANE_STORAGE_BUFFERS} storage buffers in one kernel, over \
                 the adapter's max_storage_buffers_per_shader_stage of {}",
                limits.max_storage_buffers_per_shader_stage
            )));
        }
        // Indices into a group's buffer are u32 in the shader.
        let group = (binding / grid_bytes)
            .min(u32::MAX as u64 / padded_voxels as u64)
            .min(8) as usize;
        let solved_axis = (0..3).rev().max_by_key(|&a| dims[a]).unwrap_or(2);
        let plan = Self {
            dims,
            padded_voxels,
            group,
            solved_axis,
        };
        let max = limits.max_compute_workgroups_per_dimension;
        let widest = (1..3)
            .map(|o| dims[(solved_axis + o) % 3].div_ceil(WORKGROUP_PLANE as usize))
            .max()
            .unwrap_or(0);
        let items = padded_voxels * group;
        if widest > max as usize || items.div_ceil(WORKGROUP_1D as usize) > (max as usize).pow(2) {
            return Err(Error::Gpu(format!(
                "the sweep of a {}x{}x{} volume needs {widest} workgroups along one dimension \
                 of a plane's dispatch (or {} in all for a 1D kernel), over the adapter's \
                 max_compute_workgroups_per_dimension of {max}",
                dims[0],
                dims[1],
                dims[2],
                items.div_ceil(WORKGROUP_1D as usize)
            )));
        }
        Ok(plan)
    }

    /// Anti-diagonal planes per octant.
    pub(crate) fn planes(&self) -> usize {
        self.dims.iter().sum::<usize>() - 2
    }

    pub(crate) fn groups(&self) -> usize {
        8usize.div_ceil(self.group)
    }

    /// Dispatches in all, given the distinct step lengths: half steps, then per group a fill,
    /// the planes and an average.
    #[cfg(test)]
    pub(crate) fn dispatches(&self, lengths: usize) -> usize {
        lengths + self.groups() * (self.planes() + 2)
    }

    /// Workgroups of plane `t`'s dispatch for `octants` octants: the enumerated axes' ranges
    /// on the plane, as sweep_plane recomputes them.
    pub(crate) fn plane_workgroups(&self, t: usize, octants: usize) -> [u32; 3] {
        let n = self.dims.map(|n| n as i64);
        let s = self.solved_axis;
        let (a, b) = ((s + 1) % 3, (s + 2) % 3);
        let t = t as i64;
        let range = |axis: usize, other: usize| {
            let lo = (t - (n[other] - 1) - (n[s] - 1)).max(0);
            let hi = t.min(n[axis] - 1);
            ((hi - lo + 1).max(0) as u32).div_ceil(WORKGROUP_PLANE)
        };
        [range(a, b), range(b, a), octants as u32]
    }
}

fn mib(bytes: u64) -> f64 {
    bytes as f64 / (1u64 << 20) as f64
}

/// A 1D kernel's workgroups for `items` invocations as a 2D grid within the per-dimension
/// limit (checked by [`Plan::new`]), and the invocations per grid row.
pub(crate) fn grid(ctx: &GpuContext, items: usize) -> ([u32; 3], u32) {
    let groups = items.div_ceil(WORKGROUP_1D as usize).max(1) as u32;
    let x = groups.min(ctx.limits.max_compute_workgroups_per_dimension);
    ([x, groups.div_ceil(x), 1], x * WORKGROUP_1D)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// wgpu's default limits: a 128 MiB storage binding, as lavapipe's.
    fn limits() -> wgpu::Limits {
        wgpu::Limits::default()
    }

    #[test]
    fn groups_fill_a_storage_binding_and_dispatches_follow_the_planes() {
        let small = Plan::new([13, 9, 7], &limits()).unwrap();
        assert_eq!((small.group, small.groups(), small.planes()), (8, 1, 27));
        assert_eq!(small.solved_axis, 0);
        // 256 x 256 x 128: 8.65 M padded voxels, 34.6 MB a grid: three octants per 128 MiB.
        let big = Plan::new([256, 256, 128], &limits()).unwrap();
        assert_eq!((big.group, big.groups(), big.planes()), (3, 3, 638));
        assert_eq!(big.dispatches(3), 3 + 3 * 640);
        let roomy = wgpu::Limits {
            max_storage_buffer_binding_size: 1 << 30,
            max_buffer_size: 1 << 30,
            ..limits()
        };
        let one_group = Plan::new([256, 256, 128], &roomy).unwrap();
        assert_eq!(one_group.dispatches(3), 3 + 640);
        // The enumerated axes' ranges: a corner plane has one voxel, a middle plane spans both.
        assert_eq!(small.plane_workgroups(0, 8), [1, 1, 8]);
        assert_eq!(small.plane_workgroups(13, 8), [2, 1, 8]);
        assert_eq!(small.plane_workgroups(26, 8), [1, 1, 8]);
    }

    #[test]
    fn volumes_over_the_adapters_limits_are_refused_naming_the_limit() {
        let err = Plan::new([512, 512, 512], &limits())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("max_storage_buffer_binding_size") && err.contains("512x512x512"),
            "{err}"
        );
        let few = wgpu::Limits {
            max_storage_buffers_per_shader_stage: 4,
            ..limits()
        };
        let err = Plan::new([8, 8, 8], &few).unwrap_err().to_string();
        assert!(
            err.contains("max_storage_buffers_per_shader_stage"),
            "{err}"
        );
        let narrow = wgpu::Limits {
            max_compute_workgroups_per_dimension: 4,
            ..limits()
        };
        let err = Plan::new([64, 64, 64], &narrow).unwrap_err().to_string();
        assert!(
            err.contains("max_compute_workgroups_per_dimension"),
            "{err}"
        );
    }
}
