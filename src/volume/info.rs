//! What a volume file holds (`occlux info` prints it), as a user reads it: format, dims, spacing, bounds,
//! the NaN and infinite values it holds and where, percentiles of its finite values and a
//! histogram whose bars are logarithmic in the count, so that a lone outlier voxel shows.
//!
//! Bad values do not stop it: the file is read with [`NonFinite::Census`], and the statistics
//! are over the finite voxels only. Of a time series it says how many steps there are and
//! describes the first.

use super::loaders::NonFiniteVoxels;
use super::{frame_count, load_with_info, LoadOptions, NonFinite, Volume};
use crate::classify::{ControlPoint, Window, WindowReport};
use crate::error::Result;
use std::fmt::Write;
use std::path::Path;

/// Percentiles `occlux info` prints.
pub const PERCENTILES: [f64; 6] = [0.1, 1.0, 50.0, 99.0, 99.9, 100.0];
/// Bins of the printed histogram.
const BINS: usize = 24;
/// Bins of the histogram percentiles are read from (each then interpolated linearly).
const FINE_BINS: usize = 1 << 16;

/// The finite values' statistics.
#[derive(Clone, Debug, PartialEq)]
pub struct Statistics {
    /// Finite voxels.
    pub count: u64,
    pub min: f32,
    pub max: f32,
    /// The values at [`PERCENTILES`] (the last is the maximum), read from a histogram of
    /// 65536 bins over [min, max]: within a bin's width, (max - min) / 65536.
    pub percentiles: Vec<f32>,
    /// Voxels in each of [`BINS`] equal bins over [min, max].
    pub histogram: Vec<u64>,
}

impl Statistics {
    /// Statistics of `volume`'s values, less the `replaced` voxels the census set to 0.
    pub fn of(volume: &Volume, replaced: usize) -> Option<Self> {
        let values = volume.values();
        // Real zeros: those the census did not put there.
        let zeros = values.iter().filter(|v| **v == 0.0).count() - replaced;
        let (mut min, mut max) = (f32::INFINITY, f32::NEG_INFINITY);
        for &v in values.iter().filter(|v| **v != 0.0) {
            min = min.min(v);
            max = max.max(v);
        }
        if zeros > 0 {
            (min, max) = (min.min(0.0), max.max(0.0));
        }
        let count = (values.len() - replaced) as u64;
        if count == 0 {
            return None;
        }
        let fine = histogram(values, min, max, FINE_BINS, replaced);
        let width = (max as f64 - min as f64) / FINE_BINS as f64;
        let percentiles = PERCENTILES
            .iter()
            .map(|&p| {
                if p >= 100.0 {
                    return max;
                }
                let rank = p / 100.0 * count as f64;
                let mut below = 0u64;
                for (b, &n) in fine.iter().enumerate() {
                    if (below + n) as f64 >= rank && n > 0 {
                        let within = (rank - below as f64) / n as f64;
                        return (min as f64 + (b as f64 + within) * width) as f32;
                    }
                    below += n;
                }
                max
            })
            .collect();
        Some(Self {
            count,
            min,
            max,
            percentiles,
            histogram: histogram(values, min, max, BINS, replaced),
        })
    }
}

/// Counts of `values` in `bins` equal bins over [lo, hi], less `replaced` zeros.
/// In f64: finite f32 values near +-3.4e38 span more than an f32 holds.
fn histogram(values: &[f32], lo: f32, hi: f32, bins: usize, replaced: usize) -> Vec<u64> {
    let (lo, hi) = (lo as f64, hi as f64);
    let scale = if hi > lo {
        bins as f64 / (hi - lo)
    } else {
        0.0
    };
    let bin = |v: f32| (((v as f64 - lo) * scale).max(0.0) as usize).min(bins - 1);
    let mut counts = vec![0u64; bins];
    for &v in values {
        counts[bin(v)] += 1;
    }
    counts[bin(0.0)] -= replaced as u64;
    counts
}

/// Where the non-finite voxels lie, as stored in the file: "voxel [i, j, k]" for one, else the
/// first and the box around them all.
fn whereabouts(census: &NonFiniteVoxels, dims: [usize; 3]) -> String {
    let at = |index: usize| {
        let [nx, ny] = [dims[0].max(1), dims[1].max(1)];
        [index % nx, (index / nx) % ny, index / (nx * ny)]
    };
    let first = at(census.indices[0]);
    if census.indices.len() == 1 {
        return format!("voxel {first:?}");
    }
    let (mut lo, mut hi) = (first, first);
    for &index in &census.indices[1..] {
        let v = at(index);
        for a in 0..3 {
            lo[a] = lo[a].min(v[a]);
            hi[a] = hi[a].max(v[a]);
        }
    }
    format!("first at voxel {first:?}, all within voxels {lo:?} .. {hi:?}")
}

/// `v` to the decimals that a bin of `width` resolves (percentiles are read within a fine
/// bin, so further digits say nothing).
fn to_bin(v: f32, width: f64) -> String {
    if width.is_nan() || width <= 0.0 {
        return v.to_string();
    }
    let decimals = (-width.log10().floor()).max(0.0) as usize;
    format!("{v:.decimals$}")
}

/// A histogram bin's edge: four decimals, in scientific notation when that would be long.
fn bin_edge(v: f64) -> String {
    if v.abs() < 1e8 {
        format!("{v:.4}")
    } else {
        format!("{v:.4e}")
    }
}

/// Loads `file` (the first frame of a time series) and describes it, line by line, as `occlux
/// info` prints it; with `suggest`, a `[classification]` to paste into a scene follows.
pub fn describe(file: &Path, options: &LoadOptions, suggest: bool) -> Result<String> {
    let mut out = String::new();
    // Writing into a String cannot fail.
    macro_rules! emit {
        ($($line:tt)*) => {{
            let _ = writeln!(out, $($line)*);
        }};
    }
    let frames = frame_count(file, options)?;
    let options = LoadOptions {
        non_finite: NonFinite::Census,
        frame: Some(0),
        ..options.clone()
    };
    let (vol, source) = load_with_info(file, &options)?;
    let [nx, ny, nz] = vol.dims();
    let (blo, bhi) = vol.bounds();
    let voxels = vol.values().len();
    emit!("file      {}", file.display());
    emit!(
        "format    {} ({}{})",
        source.format,
        source.scalar,
        source
            .grid
            .as_ref()
            .map_or(String::new(), |g| format!(", grid '{g}'"))
    );
    emit!(
        "dims      {nx} x {ny} x {nz} ({voxels} voxels, {:.1} MiB as f32)",
        voxels as f64 * 4.0 / (1 << 20) as f64
    );
    if frames > 1 {
        emit!("time steps {frames} (occlux series reads each; info describes the first)");
    }
    emit!("spacing   {}", vol.spacing());
    emit!("origin    {}", vol.origin());
    emit!("bounds    {blo} .. {bhi}");
    emit!("frame     {}", source.frame);
    let census = &source.non_finite;
    let bad = census.indices.len();
    if bad > 0 {
        emit!(
            "NOT FINITE {bad} of {voxels} voxels ({} NaN, {} +inf, {} -inf), {}; Occlux refuses \
             the file unless the scene sets volume.replace_non_finite; the statistics below are \
             of the finite voxels",
            census.nan,
            census.positive_infinite,
            census.negative_infinite,
            whereabouts(census, census.stored_dims)
        );
    }
    let Some(stats) = Statistics::of(&vol, bad) else {
        emit!("values    none finite");
        return Ok(out);
    };
    emit!("values    {} .. {}", stats.min, stats.max);
    match &source.hounsfield {
        Some(why) => emit!("units     Hounsfield ({why}): CT presets read them in HU"),
        None => emit!("units     not stated by the file"),
    }
    // The window is read from finite values only; a census left zeros where others were.
    let report = (bad == 0).then(|| Window::robust(&vol));
    if let Some(report) = &report {
        emit!("window    {report}: presets' normalised 0..1");
    }
    // Widths and bin edges in f64: the range of finite f32 values may exceed f32's.
    let fine_width = (stats.max as f64 - stats.min as f64) / FINE_BINS as f64;
    let percentiles: Vec<String> = PERCENTILES
        .iter()
        .zip(&stats.percentiles)
        .map(|(p, v)| format!("p{p} {}", to_bin(*v, fine_width)))
        .collect();
    emit!("quantiles {}", percentiles.join(", "));
    emit!(
        "histogram ({BINS} bins over the value range; bars grow with log10 of the count, so one \
         voxel shows)"
    );
    let width = (stats.max as f64 - stats.min as f64) / BINS as f64;
    let scale = 40.0 / (stats.count as f64 + 1.0).log10();
    for (b, &count) in stats.histogram.iter().enumerate() {
        let bar = ((count as f64 + 1.0).log10() * scale).ceil() as usize;
        emit!(
            "  {:>12} .. {:<12} {count:>11} {:7.3}% {}",
            bin_edge(stats.min as f64 + b as f64 * width),
            bin_edge(stats.min as f64 + (b + 1) as f64 * width),
            count as f64 / stats.count as f64 * 100.0,
            "#".repeat(bar)
        );
    }
    if suggest {
        match (&source.hounsfield, &report) {
            (Some(_), _) => emit!(
                "\n# paste into a scene: the file's values are Hounsfield units\n\
                 [classification]\npreset = \"ct-soft-tissue\"   # or \"ct-bone\"\nunits = \"hu\""
            ),
            (None, Some(report)) => emit!("\n{}", suggestion(report)),
            (None, None) => emit!(
                "\n# no suggestion: set volume.replace_non_finite first, the window needs finite values"
            ),
        }
    }
    Ok(out)
}

/// The ramp `occlux info --suggest` suggests for a robust window, in the volume's own values:
/// clear up to the background band's top, a translucent middle and dense at the window's top
/// (sigma_t per world unit, for a volume 2 units across). Above a window's cut the suggestion
/// steps back to clear, as the window classifies it.
pub fn suggested_points(report: &WindowReport) -> [ControlPoint; 3] {
    let w = report.window;
    // In f64, as the statistics: a window may span more than an f32 holds.
    let (lo, hi) = (w.lo as f64, w.hi as f64);
    let clear = ((report.background as f64).max(lo) + 0.15 * (hi - lo)).min(lo + 0.6 * (hi - lo));
    let (clear, middle) = (clear as f32, (0.5 * (clear + hi)) as f32);
    [
        ControlPoint::new(clear, 0.0, [0.85, 0.8, 0.75], [0.0; 3]),
        ControlPoint::new(middle, 3.0, [0.9, 0.85, 0.8], [0.0; 3]),
        ControlPoint::new(w.hi, 20.0, [0.95, 0.93, 0.9], [0.0; 3]),
    ]
}

/// A `[classification]` a user can paste: [`suggested_points`], and the step back to clear
/// above a cut.
fn suggestion(report: &WindowReport) -> String {
    let w = report.window;
    let points = suggested_points(report);
    let mut text = format!(
        "# paste into a scene: a ramp on this file's values (robust window {w})\n\
         [classification]\nunits = \"raw\"\npoints = [\n"
    );
    let point = |p: &ControlPoint| {
        format!(
            "{{ value = {}, sigma_t = {}, albedo = {:?} }}",
            p.value, p.sigma_t, p.albedo
        )
    };
    for p in &points {
        text += &format!("\x20 {},\n", point(p));
    }
    if let Some(cut) = w.cut {
        let top = ControlPoint {
            value: cut,
            ..points[2].clone()
        };
        text += &format!(
            "\x20 {},  # wrapped values above\n\x20 {{ value = {}, sigma_t = 0 }},\n",
            point(&top),
            crate::classify::above(cut)
        );
    }
    text + "]\n# sigma_t is per world unit: with volume.fit = \"auto\" (2 units across)"
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn values_near_the_f32_limit_give_finite_quantiles_and_a_full_histogram() {
        // Issue 38: max - min overflowed f32 (inf), the quantiles were NaN and the histogram
        // put every voxel in the first bin.
        let mut values = vec![0.0f32; 998];
        values.extend([-3e38, 3e38]);
        let volume = Volume::new([1000, 1, 1], Vec3::ONE, Vec3::ZERO, values).unwrap();
        let stats = Statistics::of(&volume, 0).unwrap();
        assert_eq!((stats.min, stats.max), (-3e38, 3e38));
        assert!(
            stats.percentiles.iter().all(|p| p.is_finite()),
            "{:?}",
            stats.percentiles
        );
        let p50 = stats.percentiles[PERCENTILES.iter().position(|&x| x == 50.0).unwrap()];
        // Within a fine bin of 0: 6e38 / 65536 wide.
        assert!(p50.abs() <= 1e34, "{p50}");
        assert_eq!(stats.histogram[0], 1);
        assert_eq!(stats.histogram[BINS / 2], 998);
        assert_eq!(*stats.histogram.last().unwrap(), 1);
        assert_eq!(bin_edge(-3e38), "-3.0000e38");
        assert_eq!(bin_edge(12.5), "12.5000");
    }

    #[test]
    fn percentiles_and_bins_skip_the_replaced_voxels_and_keep_an_outlier() {
        // 0..999 once each, one outlier at 5008, and 7 voxels the census set to 0.
        let mut values: Vec<f32> = (0..1000).map(|v| v as f32 + 1.0).collect();
        values.push(5008.0);
        values.extend([0.0; 7]);
        let volume = Volume::new([1008, 1, 1], Vec3::ONE, Vec3::ZERO, values).unwrap();
        let stats = Statistics::of(&volume, 7).unwrap();
        assert_eq!(stats.count, 1001);
        assert_eq!((stats.min, stats.max), (1.0, 5008.0));
        // p50 of 1..1000 and 5008 is about 501; p99.9 lies below the outlier.
        let p = |q: f64| stats.percentiles[PERCENTILES.iter().position(|&x| x == q).unwrap()];
        assert!((p(50.0) - 501.0).abs() < 1.0, "{}", p(50.0));
        assert!(p(99.9) < 1001.0, "{}", p(99.9));
        assert_eq!(stats.histogram.iter().sum::<u64>(), 1001);
        assert_eq!(*stats.histogram.last().unwrap(), 1, "the outlier's bin");
    }

    #[test]
    fn real_zeros_count_and_an_all_bad_volume_has_no_statistics() {
        let volume =
            Volume::new([4, 1, 1], Vec3::ONE, Vec3::ZERO, vec![0.0, 0.0, 2.0, 0.0]).unwrap();
        let stats = Statistics::of(&volume, 1).unwrap();
        assert_eq!((stats.count, stats.min, stats.max), (3, 0.0, 2.0));
        assert!(Statistics::of(&volume, 0).is_some());
        let bad = Volume::new([2, 1, 1], Vec3::ONE, Vec3::ZERO, vec![0.0, 0.0]).unwrap();
        assert_eq!(Statistics::of(&bad, 2), None);
    }

    #[test]
    fn the_suggestion_pastes_the_suggested_points_and_a_cuts_step() {
        let report = WindowReport {
            window: Window {
                lo: 0.0,
                hi: 100.0,
                cut: Some(200.0),
            },
            background: 2.0,
            above: 0.0,
            wrapped: 0.1,
        };
        let values: Vec<f32> = suggested_points(&report).iter().map(|p| p.value).collect();
        // Clear at the background plus 15 % of the window, the middle halfway to the top.
        assert_eq!(values, vec![17.0, 58.5, 100.0]);
        let text = suggestion(&report);
        assert!(
            text.contains(
                "  { value = 17, sigma_t = 0, albedo = [0.85, 0.8, 0.75] },\n  \
                 { value = 58.5, sigma_t = 3, albedo = [0.9, 0.85, 0.8] },\n  \
                 { value = 100, sigma_t = 20, albedo = [0.95, 0.93, 0.9] },\n  \
                 { value = 200, sigma_t = 20, albedo = [0.95, 0.93, 0.9] },  # wrapped values above\n  \
                 { value = 200.00002, sigma_t = 0 },\n]"
            ),
            "{text}"
        );
    }

    #[test]
    fn whereabouts_name_the_first_voxel_and_the_box() {
        let census = NonFiniteVoxels {
            nan: 2,
            // [1, 1, 0] and [3, 2, 1] of a 4 x 3 x 2 grid.
            indices: vec![5, 3 + 4 * 2 + 12],
            ..Default::default()
        };
        assert_eq!(
            whereabouts(&census, [4, 3, 2]),
            "first at voxel [1, 1, 0], all within voxels [1, 1, 0] .. [3, 2, 1]"
        );
    }
}
