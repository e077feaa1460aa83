//! GPU twin of IPSVI: src/render/ipsvi/ipsvi.wgsl traces the pixels of a line against the cache,
//! one invocation per pixel, and src/render/ipsvi/ipsvi_merge.wgsl merges the line's writes into
//! the cache as `cpu::merge` does (exactly and whatever the threads do, with 32-bit atomics: see
//! src/render/ipsvi/ipsvi_cache.wgsl). Per line: the trace, in one dispatch or, when the line's
//! rays could write more than the write list holds, in pieces that all read the same cache; after
//! each piece a one-invocation kernel sizes the merge's indirect dispatches from the counters, and
//! after the line's last piece the commit updates the cache. Nothing is read back until the end,
//! and dispatches go to the GPU in batches (one compute pass per submission, wgpu ordering them
//! with barriers, as DOS's slabs). With multiple scattering, each light's sweep begins with the
//! chord pass (the shader's `chord_depths`, one invocation per cache texel), which writes every
//! cache ray's optical depth through the box as `cpu::chord_depths` does.

use super::cache::{CacheMap, Map};
use super::sweep::Lines;
use super::{finish, Gathered, IpsviInput, Scattering, Sweep};
use crate::error::{Error, Result};
use crate::gpu::lut_shape::LutShapeUniform;
use crate::gpu::view::ViewUniform;
use crate::gpu::{
    buffer,
    shader::{self, Wgsl},
    GpuContext,
};
use crate::lights::Light;
use crate::optics::occupancy::CELL;
use crate::progress::Progress;
use crate::render::raycast::gpu::GpuVolume;
use crate::render::{RenderImage, BACKGROUND_DEPTH};
use crate::transport::scattering::bands::coefficients_for;
use crate::transport::scattering::InScattered;
use bytemuck::{Pod, Zeroable};
use glam::{UVec2, UVec3, Vec2, Vec3};

/// The light cache's layout and lookups, shared by the trace and the merge.
const CACHE: Wgsl = Wgsl {
    name: "ipsvi_cache.wgsl",
    text: include_str!("ipsvi_cache.wgsl"),
    includes: &[],
};
const TRACE: Wgsl = Wgsl {
    name: "ipsvi.wgsl",
    text: include_str!("ipsvi.wgsl"),
    includes: &[&CACHE],
};
const MERGE: Wgsl = Wgsl {
    name: "ipsvi_merge.wgsl",
    text: include_str!("ipsvi_merge.wgsl"),
    includes: &[&CACHE],
};
/// Invocations per workgroup of the trace and of the chord pass (the shader's WORKGROUP).
const TRACE_WORKGROUP: u32 = 64;
/// Bytes of the write list `render` allows: a line's pieces are as long as their rays'
/// writes fit in it (about 1500 rays of 900 steps), so that even a whole image swept as one
/// line (an orthographic view along a sun) never needs more.
pub const WRITE_LIST_BYTES: u64 = 64 << 20;
/// Bytes of one listed write (the shader's `Write`: texel, hi, lo).
const WRITE_BYTES: u64 = 12;
/// Trace pieces per submission: bounds the bind groups alive at once and keeps cancellation
/// prompt.
const PIECES_PER_SUBMIT: usize = 64;

/// `GpuCacheMap::kind`: the shader's MAP_* constants.
const MAP_PARALLEL: u32 = 0;
const MAP_PLANAR: u32 = 1;
const MAP_SPHERE: u32 = 2;

/// `Params::light_kind`: the shader's LIGHT_* constants.
const LIGHT_DIRECTIONAL: u32 = 1;
const LIGHT_POINT: u32 = 2;

/// The shader's `CacheMap`: a [`CacheMap`] with the fields its kind does not use zeroed.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuCacheMap {
    kind: u32,
    texel: f32,
    size: UVec2,
    light: Vec3,
    _pad0: u32,
    /// Parallel: the light's direction of travel; planar: the plane's axis.
    axis: Vec3,
    _pad1: u32,
    e1: Vec3,
    _pad2: u32,
    e2: Vec3,
    _pad3: u32,
    origin: Vec2,
    _pad4: [u32; 2],
}

impl GpuCacheMap {
    fn new(map: &CacheMap) -> Self {
        let base = Self {
            size: map.size,
            ..Self::zeroed()
        };
        match map.map() {
            Map::Parallel {
                travel,
                e1,
                e2,
                origin,
                texel,
            } => Self {
                kind: MAP_PARALLEL,
                texel,
                axis: travel,
                e1,
                e2,
                origin,
                ..base
            },
            Map::Planar {
                light,
                axis,
                e1,
                e2,
                origin,
                texel,
            } => Self {
                kind: MAP_PLANAR,
                texel,
                light,
                axis,
                e1,
                e2,
                origin,
                ..base
            },
            Map::Sphere { light } => Self {
                kind: MAP_SPHERE,
                light,
                ..base
            },
        }
    }
}

/// The shader's `Params` uniform, one per light, field for field (see src/render/ipsvi/ipsvi.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    view: ViewUniform,
    lut: LutShapeUniform,
    map: GpuCacheMap,
    light: Vec3,
    light_kind: u32,
    colour: Vec3,
    g: f32,
    cells: UVec3,
    cell_voxels: u32,
    step: f32,
    light_step: f32,
    ert_threshold: f32,
    piecewise: u32,
    first_pass: u32,
    /// 0 single scattering, 1 the diffusion term (binding 9: chords), 2 the transport field
    /// (binding 9: the field's bands, [`InScattered::bands`]'s layout).
    multiple: u32,
    _pad: [u32; 2],
    /// The transport field's grid (its first cell's centre, spacing and cells).
    field_origin: Vec3,
    _pad_origin: f32,
    field_spacing: Vec3,
    _pad_spacing: f32,
    field_dims: UVec3,
    /// The field's coefficients per colour channel.
    field_coefficients: u32,
}

impl Params {
    /// The uniform of light pass `pass` (0 records emission, transmittance and depth).
    fn new(
        input: &IpsviInput,
        step: f32,
        cells: [usize; 3],
        pass: usize,
        sweep: &Sweep,
        field: Option<&InScattered>,
    ) -> Self {
        let (light_kind, light, colour) = match *sweep.light {
            Light::Directional {
                to_light,
                irradiance,
            } => (LIGHT_DIRECTIONAL, to_light, irradiance),
            Light::Point {
                position,
                intensity,
            } => (LIGHT_POINT, position, intensity),
            // Never swept (Shape::of has no sweep for it); as a sun of no irradiance it would
            // add nothing.
            Light::Ambient { .. } => (LIGHT_DIRECTIONAL, Vec3::Z, Vec3::ZERO),
        };
        Self {
            view: ViewUniform::new(input.camera, input.volume),
            lut: LutShapeUniform::new(input.lut),
            map: GpuCacheMap::new(&sweep.map),
            light,
            light_kind,
            colour,
            g: input.params.g,
            cells: UVec3::new(cells[0] as u32, cells[1] as u32, cells[2] as u32),
            cell_voxels: CELL as u32,
            step,
            light_step: 2.0 * step,
            ert_threshold: input.params.ert_threshold,
            piecewise: u32::from(input.params.piecewise),
            first_pass: u32::from(pass == 0),
            multiple: match input.params.scattering {
                Scattering::Single => 0,
                Scattering::Multiple => 1,
                Scattering::Transport => 2,
            },
            _pad: [0; 2],
            field_origin: field.map_or(Vec3::ZERO, |f| f.grid.origin()),
            _pad_origin: 0.0,
            field_spacing: field.map_or(Vec3::ONE, |f| f.grid.spacing()),
            _pad_spacing: 0.0,
            field_dims: field.map_or(UVec3::ONE, |f| {
                let [x, y, z] = f.grid.dims();
                UVec3::new(x as u32, y as u32, z as u32)
            }),
            field_coefficients: field.map_or(1, |f| f.bands.per_channel() as u32),
        }
    }
}

/// Uploads the inputs and renders; also returns the `shadow` factor per pixel.
pub fn render(
    ctx: &GpuContext,
    input: &IpsviInput,
    progress: &dyn Progress,
) -> Result<RenderImage> {
    render_with_write_list(ctx, input, progress, WRITE_LIST_BYTES)
}

/// As [`render`] with a write list of at most `bytes` (and at most one storage binding): a
/// smaller list cuts long lines into more trace dispatches, and changes nothing else.
pub fn render_with_write_list(
    ctx: &GpuContext,
    input: &IpsviInput,
    progress: &dyn Progress,
    bytes: u64,
) -> Result<RenderImage> {
    let step = input.setup()?;
    let sweeps = input.sweeps();
    let volume = GpuVolume::upload(ctx, input.volume, input.lut)?;
    let (cells, occupancy_buffer) = volume.occupancy();
    let multiple = input.params.scattering == Scattering::Multiple;
    let grid = input.transport_medium()?;
    let field_len = grid.as_ref().map_or(0, |g| {
        3 * coefficients_for(input.params.g) * g.scattering.len()
    });
    let lists = Lists::new(
        ctx,
        &sweeps,
        writes_per_ray(input, step),
        bytes,
        multiple,
        field_len,
    )?;
    let camera = input.camera;
    let outputs = Outputs::new(ctx, (camera.width * camera.height) as usize)?;
    let kernels = Kernels::new(ctx, &lists, multiple)?;
    let mut progress = LineProgress {
        progress,
        done: 0,
        work: sweeps.iter().map(|s| s.lines.count() as u64).sum(),
    };
    let shared = Shared {
        ctx,
        kernels: &kernels,
        lists: &lists,
        outputs: &outputs,
        volume: &volume,
        occupancy: occupancy_buffer,
    };
    for (pass, sweep) in sweeps.iter().enumerate() {
        // The light's transport field, solved on the GPU and read back, replaces the last
        // light's (writes reach the queue after the submissions that read the last one).
        let field = match &grid {
            Some(grid) => {
                let field =
                    input.transport_field(Some(ctx), grid, sweep.light, progress.progress)?;
                ctx.queue.write_buffer(
                    &lists.chords,
                    0,
                    bytemuck::cast_slice(field.bands.values()),
                );
                Some(field)
            }
            None => None,
        };
        let params = Params::new(input, step, cells, pass, sweep, field.as_ref());
        shared.sweep(&params, sweep, &mut progress)?;
    }
    lists.check_overflow(ctx)?;
    let gathered = outputs.read(ctx)?;
    Ok(finish(camera, input.lighting.background, &gathered))
}

/// Most writes one view ray can leave: each write releases a cache ray that the view ray
/// began to hold at one of its samples, at most four per sample, and a ray through the box
/// takes at most ceil(diagonal / step) samples (one more for the rounding of its clipped
/// span). The list's overflow flag would catch a ray beyond it.
fn writes_per_ray(input: &IpsviInput, step: f32) -> u64 {
    let (lo, hi) = input.volume.bounds();
    let samples = ((hi - lo).length() / step).ceil() as u64 + 1;
    4 * samples
}

/// Reports one unit per line, over every light's lines, as the CPU twin does.
struct LineProgress<'a> {
    progress: &'a dyn Progress,
    done: u64,
    work: u64,
}

impl LineProgress<'_> {
    fn line_done(&mut self) {
        self.done += 1;
        self.progress.update(self.done, self.work);
    }
}

/// The trace's pipeline and the merge's, with the merge's bind groups (the same buffers for
/// every light), and the chord pass's pipeline with multiple scattering (only then built).
struct Kernels {
    trace: wgpu::ComputePipeline,
    chords: Option<wgpu::ComputePipeline>,
    arguments: (wgpu::ComputePipeline, wgpu::BindGroup),
    merge: (wgpu::ComputePipeline, wgpu::BindGroup),
    commit: (wgpu::ComputePipeline, wgpu::BindGroup),
}

impl Kernels {
    fn new(ctx: &GpuContext, lists: &Lists, multiple: bool) -> Result<Self> {
        let kernel = |entry: &str,
                      bindings: &[(u32, &wgpu::Buffer)]|
         -> Result<(wgpu::ComputePipeline, wgpu::BindGroup)> {
            let pipeline = shader::compute_pipeline(ctx, &MERGE, entry)?;
            let resources: Vec<_> = bindings
                .iter()
                .map(|(binding, buffer)| (*binding, buffer.as_entire_binding()))
                .collect();
            let group = shader::bind_group_at(ctx, &pipeline, &resources)?;
            Ok((pipeline, group))
        };
        let l = lists;
        Ok(Self {
            trace: shader::compute_pipeline(ctx, &TRACE, "main")?,
            chords: multiple
                .then(|| shader::compute_pipeline(ctx, &TRACE, "chord_depths"))
                .transpose()?,
            arguments: kernel(
                "arguments",
                &[
                    (0, &l.dispatch),
                    (1, &l.sizes),
                    (11, &l.writes),
                    (12, &l.counters),
                ],
            )?,
            merge: kernel(
                "merge",
                &[(1, &l.sizes), (11, &l.writes), (13, &l.line_first)],
            )?,
            commit: kernel(
                "commit",
                &[
                    (1, &l.sizes),
                    (10, &l.cache),
                    (12, &l.counters),
                    (13, &l.line_first),
                    (14, &l.touched),
                ],
            )?,
        })
    }
}

/// The cache and the merge's lists (src/render/ipsvi/ipsvi_cache.wgsl), shared by every light's
/// sweep: sized for the largest cache, and the write list for the longest line or as much of it as
/// `bytes` allows; also the chords of multiple scattering.
struct Lists {
    cache: wgpu::Buffer,
    /// Per texel, with the diffusion term, its cache ray's optical depth through the box (the
    /// shader's `chords`); with transport, the light's field's bands; one element
    /// otherwise (the trace binds it either way).
    chords: wgpu::Buffer,
    writes: wgpu::Buffer,
    counters: wgpu::Buffer,
    line_first: wgpu::Buffer,
    touched: wgpu::Buffer,
    /// The merge's indirect dispatch arguments.
    dispatch: wgpu::Buffer,
    sizes: wgpu::Buffer,
    /// Pixels one trace dispatch may hold: their rays' writes fit the list.
    piece_pixels: usize,
}

impl Lists {
    fn new(
        ctx: &GpuContext,
        sweeps: &[Sweep],
        per_ray: u64,
        bytes: u64,
        multiple: bool,
        field_len: usize,
    ) -> Result<Self> {
        let texels = sweeps.iter().map(|s| s.map.texels()).max().unwrap_or(1);
        let longest = sweeps
            .iter()
            .flat_map(|s| s.lines.starts.windows(2).map(|w| (w[1] - w[0]) as u64))
            .max()
            .unwrap_or(1);
        let binding = ctx
            .limits
            .max_storage_buffer_binding_size
            .min(ctx.limits.max_buffer_size);
        let dispatchable =
            ctx.limits.max_compute_workgroups_per_dimension as u64 * TRACE_WORKGROUP as u64;
        let piece_pixels = (bytes.min(binding) / WRITE_BYTES / per_ray)
            .min(longest)
            .min(dispatchable);
        if piece_pixels == 0 {
            return Err(Error::Gpu(format!(
                "a view ray of IPSVI can leave {per_ray} cache writes, more than its write \
                 list of {bytes} bytes holds: use a longer step, or --device cpu"
            )));
        }
        let capacity = (piece_pixels * per_ray) as usize;
        let dispatch = ctx.checked("buffer `ipsvi dispatch`", || {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ipsvi dispatch"),
                size: 6 * 4,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT,
                mapped_at_creation: false,
            })
        })?;
        Ok(Self {
            cache: buffer::output_buffer::<[u32; 2]>(ctx, "ipsvi cache", texels)?,
            chords: buffer::output_buffer::<f32>(
                ctx,
                "ipsvi chords",
                if multiple { texels } else { field_len.max(1) },
            )?,
            writes: buffer::output_buffer::<[u32; 3]>(ctx, "ipsvi writes", capacity)?,
            counters: buffer::output_buffer::<u32>(ctx, "ipsvi counters", 3)?,
            line_first: buffer::storage_buffer(
                ctx,
                "ipsvi line first",
                &vec![u32::MAX; 2 * texels],
            )?,
            touched: buffer::output_buffer::<u32>(ctx, "ipsvi touched", texels)?,
            dispatch,
            sizes: buffer::output_buffer::<u32>(ctx, "ipsvi sizes", 2)?,
            piece_pixels: piece_pixels as usize,
        })
    }

    /// An error if some trace dispatch wrote more than the list holds (which
    /// [`writes_per_ray`] rules out).
    fn check_overflow(&self, ctx: &GpuContext) -> Result<()> {
        let counters: Vec<u32> = buffer::read_buffer(ctx, &self.counters)?;
        if counters[2] != 0 {
            return Err(Error::Gpu(
                "IPSVI's write list overflowed, so the image would be wrong: a bug, please \
                 report it (--device cpu renders it)"
                    .into(),
            ));
        }
        Ok(())
    }
}

/// What the trace accumulates per pixel (the shader's scattered_out, view_out, depth_out).
struct Outputs {
    scattered: wgpu::Buffer,
    view: wgpu::Buffer,
    depth: wgpu::Buffer,
}

impl Outputs {
    /// As [`Gathered::default`]: nothing scattered or emitted, transmittance 1, no depth.
    fn new(ctx: &GpuContext, pixels: usize) -> Result<Self> {
        Ok(Self {
            scattered: buffer::output_buffer::<[f32; 4]>(ctx, "ipsvi scattered", pixels)?,
            view: buffer::storage_buffer(
                ctx,
                "ipsvi view",
                &vec![[0.0f32, 0.0, 0.0, 1.0]; pixels],
            )?,
            depth: buffer::storage_buffer(
                ctx,
                "ipsvi depth",
                &vec![[BACKGROUND_DEPTH, 0.0]; pixels],
            )?,
        })
    }

    /// What each pixel gathered, as the CPU twin holds it.
    fn read(&self, ctx: &GpuContext) -> Result<Vec<Gathered>> {
        let scattered: Vec<[f32; 4]> = buffer::read_buffer(ctx, &self.scattered)?;
        let view: Vec<[f32; 4]> = buffer::read_buffer(ctx, &self.view)?;
        let depth: Vec<[f32; 2]> = buffer::read_buffer(ctx, &self.depth)?;
        Ok(scattered
            .iter()
            .zip(&view)
            .zip(&depth)
            .map(|((s, v), d)| Gathered {
                scattered: Vec3::new(s[0], s[1], s[2]),
                emitted: Vec3::new(v[0], v[1], v[2]),
                transmittance: v[3],
                depth: d[0],
                lit: s[3],
                irradiance: d[1],
            })
            .collect())
    }
}

/// A piece of a line traced by one dispatch: `count` pixels of the order buffer from byte
/// `offset` (an offset the adapter can bind a storage buffer at).
struct Piece {
    offset: u64,
    count: u32,
    ends_line: bool,
}

/// The pixels of `lines` in sweep order, cut into pieces of at most `piece_pixels`, each
/// starting at a multiple of `align` bytes (zeros between them): every piece is then a
/// binding of one buffer, and needs no uniform of its own.
fn pieces(lines: &Lines, piece_pixels: usize, align: usize) -> (Vec<u32>, Vec<Piece>) {
    let align = (align / 4).max(1);
    let mut order = Vec::with_capacity(lines.pixels.len());
    let mut pieces = Vec::new();
    for l in 0..lines.count() {
        let line = lines.line(l);
        let count = line.len().div_ceil(piece_pixels);
        for (i, piece) in line.chunks(piece_pixels).enumerate() {
            order.resize(order.len().next_multiple_of(align), 0);
            pieces.push(Piece {
                offset: 4 * order.len() as u64,
                count: piece.len() as u32,
                ends_line: i + 1 == count,
            });
            order.extend_from_slice(piece);
        }
    }
    (order, pieces)
}

/// What every light's sweep binds besides its own uniform and order of pixels.
struct Shared<'a> {
    ctx: &'a GpuContext,
    kernels: &'a Kernels,
    lists: &'a Lists,
    outputs: &'a Outputs,
    volume: &'a GpuVolume<'a>,
    occupancy: &'a wgpu::Buffer,
}

impl Shared<'_> {
    /// One light's pass: with multiple scattering its chords first, then its lines in order,
    /// each traced against the cache and merged.
    fn sweep(&self, params: &Params, sweep: &Sweep, progress: &mut LineProgress) -> Result<()> {
        let ctx = self.ctx;
        let lines = &sweep.lines;
        let uniform = buffer::uniform_buffer(ctx, "ipsvi params", params)?;
        let chords = self
            .kernels
            .chords
            .as_ref()
            .map(|pipeline| self.chord_pass(pipeline, &uniform, sweep.map.texels()))
            .transpose()?;
        let align = ctx.limits.min_storage_buffer_offset_alignment as usize;
        let (order, pieces) = pieces(lines, self.lists.piece_pixels, align);
        let order = buffer::storage_buffer(ctx, "ipsvi order", &order)?;
        for (batch_index, batch) in pieces.chunks(PIECES_PER_SUBMIT).enumerate() {
            if progress.progress.cancelled() {
                return Err(Error::Cancelled);
            }
            let groups = batch
                .iter()
                .map(|piece| self.trace_group(&uniform, &order, piece))
                .collect::<Result<Vec<_>>>()?;
            ctx.checked("ipsvi dispatches", || {
                let mut encoder = ctx.device.create_command_encoder(&Default::default());
                if batch_index == 0 {
                    // A new light starts from an empty cache, and its chords before any trace.
                    encoder.clear_buffer(&self.lists.cache, 0, None);
                    if let Some((pipeline, group, workgroups)) = &chords {
                        let mut pass = encoder.begin_compute_pass(&Default::default());
                        pass.set_pipeline(pipeline);
                        pass.set_bind_group(0, group, &[]);
                        pass.dispatch_workgroups(workgroups[0], workgroups[1], 1);
                    }
                }
                self.encode(&mut encoder, batch, &groups);
                ctx.queue.submit([encoder.finish()]);
            })?;
            for _ in batch.iter().filter(|piece| piece.ends_line) {
                progress.line_done();
            }
        }
        Ok(())
    }

    /// The chord pass of one light: its pipeline, its bind group and its workgroups, one
    /// invocation per texel in rows of at most the adapter's workgroups per dimension (the
    /// shader's `chord_depths`).
    fn chord_pass<'p>(
        &self,
        pipeline: &'p wgpu::ComputePipeline,
        uniform: &wgpu::Buffer,
        texels: usize,
    ) -> Result<(&'p wgpu::ComputePipeline, wgpu::BindGroup, [u32; 2])> {
        let texture = self.volume.texture();
        let group = shader::bind_group_at(
            self.ctx,
            pipeline,
            &[
                (0, uniform.as_entire_binding()),
                (1, wgpu::BindingResource::TextureView(&texture.view)),
                (3, self.volume.lut_buffer().as_entire_binding()),
                (4, self.occupancy.as_entire_binding()),
                (9, self.lists.chords.as_entire_binding()),
            ],
        )?;
        // At most 8192^2 texels (MAX_CACHE_SIZE): the groups fit a u32.
        let groups = texels.div_ceil(TRACE_WORKGROUP as usize) as u32;
        let x = groups.clamp(1, self.ctx.limits.max_compute_workgroups_per_dimension);
        Ok((pipeline, group, [x, groups.div_ceil(x)]))
    }

    /// The trace's bind group for one piece.
    fn trace_group(
        &self,
        uniform: &wgpu::Buffer,
        order: &wgpu::Buffer,
        piece: &Piece,
    ) -> Result<wgpu::BindGroup> {
        let texture = self.volume.texture();
        let (lists, outputs) = (self.lists, self.outputs);
        let pixels = wgpu::BufferBinding {
            buffer: order,
            offset: piece.offset,
            size: wgpu::BufferSize::new(4 * piece.count as u64),
        };
        shader::bind_group_at(
            self.ctx,
            &self.kernels.trace,
            &[
                (0, uniform.as_entire_binding()),
                (1, wgpu::BindingResource::TextureView(&texture.view)),
                (3, self.volume.lut_buffer().as_entire_binding()),
                (4, self.occupancy.as_entire_binding()),
                (5, wgpu::BindingResource::Buffer(pixels)),
                (6, outputs.scattered.as_entire_binding()),
                (7, outputs.view.as_entire_binding()),
                (8, outputs.depth.as_entire_binding()),
                (9, lists.chords.as_entire_binding()),
                (10, lists.cache.as_entire_binding()),
                (11, lists.writes.as_entire_binding()),
                (12, lists.counters.as_entire_binding()),
                (13, lists.line_first.as_entire_binding()),
                (14, lists.touched.as_entire_binding()),
            ],
        )
    }

    /// Records the pieces of a batch: each traced, its writes merged, and the cache updated
    /// after a line's last piece.
    fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        batch: &[Piece],
        groups: &[wgpu::BindGroup],
    ) {
        let kernels = self.kernels;
        let dispatch = &self.lists.dispatch;
        let mut pass = encoder.begin_compute_pass(&Default::default());
        for (piece, group) in batch.iter().zip(groups) {
            pass.set_pipeline(&kernels.trace);
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(piece.count.div_ceil(TRACE_WORKGROUP), 1, 1);
            pass.set_pipeline(&kernels.arguments.0);
            pass.set_bind_group(0, &kernels.arguments.1, &[]);
            pass.dispatch_workgroups(1, 1, 1);
            pass.set_pipeline(&kernels.merge.0);
            pass.set_bind_group(0, &kernels.merge.1, &[]);
            pass.dispatch_workgroups_indirect(dispatch, 0);
            if piece.ends_line {
                pass.set_pipeline(&kernels.commit.0);
                pass.set_bind_group(0, &kernels.commit.1, &[]);
                pass.dispatch_workgroups_indirect(dispatch, 12);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::{assert_mirrors, check_mirror, u32_constant};

    #[test]
    fn uniforms_and_lists_match_the_shaders() {
        assert_mirrors!(
            Params,
            TRACE,
            "Params",
            [
                view,
                lut,
                map,
                light,
                light_kind,
                colour,
                g,
                cells,
                cell_voxels,
                step,
                light_step,
                ert_threshold,
                piecewise,
                first_pass,
                multiple,
                field_origin,
                field_spacing,
                field_dims,
                field_coefficients
            ]
        );
        assert_mirrors!(
            GpuCacheMap,
            TRACE,
            "CacheMap",
            [kind, texel, size, light, axis, e1, e2, origin]
        );
        check_mirror(
            &MERGE,
            "Write",
            WRITE_BYTES as usize,
            &[("texel", 0), ("hi", 4), ("lo", 8)],
        );
    }

    #[test]
    fn codes_match_the_shader() {
        for (name, code) in [
            ("MAP_PARALLEL", MAP_PARALLEL),
            ("MAP_PLANAR", MAP_PLANAR),
            ("MAP_SPHERE", MAP_SPHERE),
            ("LIGHT_DIRECTIONAL", LIGHT_DIRECTIONAL),
            ("LIGHT_POINT", LIGHT_POINT),
            ("WORKGROUP", TRACE_WORKGROUP),
        ] {
            assert_eq!(u32_constant(&TRACE, name), code, "{name}");
        }
    }

    #[test]
    fn pieces_cover_each_line_in_order_at_aligned_offsets() {
        let lines = Lines {
            pixels: (0..10).collect(),
            starts: vec![0, 1, 8, 10],
        };
        let (order, pieces) = pieces(&lines, 3, 16);
        let spans: Vec<(u64, u32, bool)> = pieces
            .iter()
            .map(|p| (p.offset, p.count, p.ends_line))
            .collect();
        assert_eq!(
            spans,
            [
                (0, 1, true),
                (16, 3, false),
                (32, 3, false),
                (48, 1, true),
                (64, 2, true)
            ]
        );
        let traced: Vec<u32> = pieces
            .iter()
            .flat_map(|p| {
                let at = p.offset as usize / 4;
                order[at..at + p.count as usize].to_vec()
            })
            .collect();
        assert_eq!(traced, (0..10).collect::<Vec<u32>>());
    }
}
