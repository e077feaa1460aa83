//! Where a normalised transfer function's 0 and 1 lie among a volume's values.
//!
//! Spanning the minimum to the maximum lets one voxel decide the whole classification: a CT
//! with one metal voxel at 5008 puts all tissue near 0, and negative values wrapped into an
//! unsigned type stretch the range many times over. The robust window is read from the values'
//! distribution instead (a deterministic sample of at most [`SAMPLE`] voxels):
//!
//! 1. Normalised 0 is the 0.1th percentile of the values.
//! 2. The background is the most common of [`BANDS`] equal value bands between the 0.1th and
//!    99.9th percentiles: the air of a CT, the empty space around a simulated field.
//! 3. Normalised 1 is the 99.9th percentile of the voxels outside the background band, so a
//!    mostly empty volume's window still spans its object, and a few outlier voxels do not
//!    move it (they are classified as the window's top, as any value beyond it).
//! 4. Integer values that are negative numbers wrapped into an unsigned type (all values
//!    integral in [0, 2^b), those at 2^(b-1) and above holding at least [`WRAPPED_SHARE`] of
//!    the voxels and lying apart from the rest by a gap of more than a quarter of the range,
//!    for b = 8 or 16) are cut away: values above `cut` are classified as the window's bottom,
//!    as the negative numbers they stand for would be.

use crate::volume::Volume;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::fmt;

/// Voxels the statistics are read from, at most.
const SAMPLE: usize = 1 << 20;
/// A gap between sorted neighbours wider than this share of the whole range sets wrapped
/// values apart.
const GAP_SHARE: f64 = 0.25;
/// Share of the voxels from which values at 2^(b-1) and above count as wrapped rather than as
/// outliers.
const WRAPPED_SHARE: f64 = 0.01;
/// Bands the background is found among.
const BANDS: usize = 256;

/// What normalised positions 0 and 1 mean; the scene's `classification.range`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ValueRange {
    /// Read from the values' distribution ([`Window::robust`]); `"robust"` in a scene.
    #[default]
    #[serde(with = "robust_word")]
    Robust,
    /// The smallest to the largest value; `"full"` in a scene.
    #[serde(with = "full_word")]
    Full,
    /// Given values (`[lo, hi]` in a scene), or a window already resolved for a volume.
    Window(Window),
}

/// A resolved window on the volume's values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(from = "WindowForm", into = "WindowForm")]
pub struct Window {
    /// The value normalised 0 stands for.
    pub lo: f32,
    /// The value normalised 1 stands for.
    pub hi: f32,
    /// Values above this (the data's largest, below a population of wrapped values) are
    /// classified as `lo`.
    pub cut: Option<f32>,
}

/// A window as a scene writes it: `[lo, hi]`, or `{ lo, hi, cut }` as resolved.
#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum WindowForm {
    Pair([f32; 2]),
    Full { lo: f32, hi: f32, cut: Option<f32> },
}

impl From<WindowForm> for Window {
    fn from(form: WindowForm) -> Self {
        match form {
            WindowForm::Pair([lo, hi]) => Window { lo, hi, cut: None },
            WindowForm::Full { lo, hi, cut } => Window { lo, hi, cut },
        }
    }
}

impl From<Window> for WindowForm {
    fn from(w: Window) -> Self {
        match w.cut {
            None => WindowForm::Pair([w.lo, w.hi]),
            Some(cut) => WindowForm::Full {
                lo: w.lo,
                hi: w.hi,
                cut: Some(cut),
            },
        }
    }
}

/// Serde for a unit variant written as one fixed word.
macro_rules! word {
    ($module:ident, $word:literal) => {
        mod $module {
            use serde::{de::Error, Deserialize, Deserializer, Serializer};
            pub fn serialize<S: Serializer>(s: S) -> Result<S::Ok, S::Error> {
                s.serialize_str($word)
            }
            pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<(), D::Error> {
                let text = String::deserialize(d)?;
                if text == $word {
                    Ok(())
                } else {
                    Err(D::Error::custom(format!("expected \"{}\"", $word)))
                }
            }
        }
    };
}
word!(robust_word, "robust");
word!(full_word, "full");

/// How a robust window was found, for the user: the numbers behind it.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowReport {
    pub window: Window,
    /// The background band's centre.
    pub background: f32,
    /// Share of the sampled voxels above the window's top (outliers and wrapped values).
    pub above: f64,
    /// Share of the sampled voxels cut away as wrapped negative values.
    pub wrapped: f64,
}

impl ValueRange {
    /// The window on `volume`'s values.
    pub fn window(&self, volume: &Volume) -> Window {
        match self {
            ValueRange::Robust => Window::robust(volume).window,
            ValueRange::Full => {
                let (lo, hi) = volume.value_range();
                Window { lo, hi, cut: None }
            }
            ValueRange::Window(w) => *w,
        }
    }

    /// Checks a given window.
    pub fn validate(&self) -> crate::error::Result<()> {
        if let ValueRange::Window(w) = self {
            if !(w.lo.is_finite() && w.hi.is_finite() && w.hi > w.lo) {
                return Err(crate::error::Error::param(
                    "classification.range",
                    format!(
                        "must be [lo, hi] with finite lo < hi, got [{}, {}]",
                        w.lo, w.hi
                    ),
                ));
            }
            if w.cut.is_some_and(|c| !c.is_finite()) {
                return Err(crate::error::Error::param(
                    "classification.range.cut",
                    "must be finite",
                ));
            }
        }
        Ok(())
    }
}

impl Window {
    /// The robust window of `volume`'s values (the module's steps), with how it was found.
    pub fn robust(volume: &Volume) -> WindowReport {
        let mut sample = sample(volume.values());
        sample.sort_unstable_by(f32::total_cmp);
        let mut report = robust_of_sorted(&sample);
        // The cut sits at the data's largest value (of every voxel, not only the sample's),
        // not in the gap: values interpolated between the data and a wrapped neighbour lie
        // above it and classify as the bottom too, or the boundary would show as a dense shell.
        if let Some(gap_middle) = report.window.cut {
            report.window.cut = volume
                .values()
                .par_iter()
                .copied()
                .filter(|v| *v < gap_middle)
                .reduce(|| f32::NEG_INFINITY, f32::max)
                .into();
        }
        report
    }

    /// Normalised position of raw value `v`.
    pub fn normalise(&self, v: f32) -> f32 {
        (v - self.lo) / (self.hi - self.lo)
    }

    /// Raw value of normalised position `x`.
    pub fn raw(&self, x: f32) -> f32 {
        self.lo + x * (self.hi - self.lo)
    }
}

impl fmt::Display for Window {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} .. {}", self.lo, self.hi)?;
        if let Some(cut) = self.cut {
            write!(f, " (values above {cut} classified as {})", self.lo)?;
        }
        Ok(())
    }
}

impl fmt::Display for WindowReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} (background {}; {:.3} % of voxels above the top",
            self.window,
            self.background,
            100.0 * self.above
        )?;
        if self.wrapped > 0.0 {
            write!(
                f,
                "; {:.1} % wrapped negative values cut away",
                100.0 * self.wrapped
            )?;
        }
        write!(f, ")")
    }
}

/// Most bins [`histogram`] counts into.
pub const MAX_HISTOGRAM_BINS: usize = 1 << 16;

/// Counts of `values` in `bins` equal bins over [`lo`, `hi`] (a window on them, for a panel
/// to draw), binned as numpy's `histogram(values, bins, range=(lo, hi))` bins in f64: bin i
/// holds edge(i) <= v < edge(i + 1), edge(i) = lo + i (hi - lo) / bins, the last bin also
/// holds `hi`, and values outside [lo, hi] are not counted. Counted in parallel over the
/// values as they lie (no copy). Errors name `histogram.bins` (in 1..=[`MAX_HISTOGRAM_BINS`])
/// and `histogram.range` (finite lo < hi).
pub fn histogram(values: &[f32], lo: f32, hi: f32, bins: usize) -> crate::error::Result<Vec<u64>> {
    if !(1..=MAX_HISTOGRAM_BINS).contains(&bins) {
        return Err(crate::error::Error::param(
            "histogram.bins",
            format!("must be in 1..={MAX_HISTOGRAM_BINS}, got {bins}"),
        ));
    }
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(crate::error::Error::param(
            "histogram.range",
            format!("must be finite lo < hi, got [{lo}, {hi}]"),
        ));
    }
    // In f64, as numpy's linspace places the edges: a window may span more than an f32 holds.
    let (lo, hi) = (lo as f64, hi as f64);
    let step = (hi - lo) / bins as f64;
    let edge = |i: usize| if i == bins { hi } else { i as f64 * step + lo };
    let bin = |v: f64| {
        // The index from the value's position, then moved by one where rounding put it
        // across an edge, so that the edges decide, as in numpy.
        let mut i = (((v - lo) / (hi - lo)) * bins as f64) as usize;
        i = i.min(bins - 1);
        if v < edge(i) {
            i -= 1;
        } else if i + 1 < bins && v >= edge(i + 1) {
            i += 1;
        }
        i
    };
    let counts = values
        .par_chunks(1 << 16)
        .fold(
            || vec![0u64; bins],
            |mut counts, chunk| {
                for &v in chunk {
                    let v = v as f64;
                    if (lo..=hi).contains(&v) {
                        counts[bin(v)] += 1;
                    }
                }
                counts
            },
        )
        .reduce(
            || vec![0u64; bins],
            |mut a, b| {
                a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
                a
            },
        );
    Ok(counts)
}

/// At most [`SAMPLE`] values at a fixed stride; the stride is odd so that it does not follow
/// one axis of a power-of-two grid.
fn sample(values: &[f32]) -> Vec<f32> {
    if values.len() <= SAMPLE {
        return values.to_vec();
    }
    let stride = (values.len() / SAMPLE) | 1;
    values.iter().step_by(stride).copied().collect()
}

fn robust_of_sorted(sorted: &[f32]) -> WindowReport {
    let n = sorted.len();
    let kept = n - wrapped_count(sorted);
    let values = &sorted[..kept];
    let lo = quantile(values, 0.001);
    let top = quantile(values, 0.999);
    let band = background_band(values, lo, top);
    let foreground: Vec<f32> = match band {
        Some((a, b)) => values
            .iter()
            .copied()
            .filter(|v| *v < a || *v > b)
            .collect(),
        None => Vec::new(),
    };
    let hi = if foreground.is_empty() {
        top
    } else {
        quantile(&foreground, 0.999)
    };
    // A window never collapses: a constant volume spans one unit, as the table's axis.
    let hi = if hi > lo { hi } else { lo + 1.0 };
    let cut = (kept < n).then(|| 0.5 * (values[kept - 1] + sorted[kept]));
    WindowReport {
        window: Window { lo, hi, cut },
        background: band.map_or(lo, |(a, b)| 0.5 * (a + b)),
        above: values.iter().filter(|v| **v > hi).count() as f64 / n as f64,
        wrapped: (n - kept) as f64 / n as f64,
    }
}

/// How many of the sorted values (from the top) are negative numbers wrapped into an unsigned
/// type of 8 or 16 bits; 0 when the values do not look so.
fn wrapped_count(sorted: &[f32]) -> usize {
    let (min, max) = (sorted[0], sorted[sorted.len() - 1]);
    if min < 0.0 || sorted.iter().any(|v| v.fract() != 0.0) {
        return 0;
    }
    for bits in [8u32, 16] {
        let (half, full) = ((1u32 << (bits - 1)) as f32, (1u32 << bits) as f32);
        if max >= full || max < half {
            continue;
        }
        let first = sorted.partition_point(|v| *v < half);
        let wrapped = sorted.len() - first;
        let apart = first == 0
            || (sorted[first] - sorted[first - 1]) as f64 > GAP_SHARE * (max - min) as f64;
        if first > 0 && apart && wrapped as f64 >= WRAPPED_SHARE * sorted.len() as f64 {
            return wrapped;
        }
    }
    0
}

/// The most populous of [`BANDS`] equal bands over [lo, hi] (values outside count in the end
/// bands), as its value bounds; None when lo = hi.
fn background_band(values: &[f32], lo: f32, hi: f32) -> Option<(f32, f32)> {
    let (lo, hi) = (lo as f64, hi as f64);
    if hi <= lo {
        return None;
    }
    let width = (hi - lo) / BANDS as f64;
    let mut counts = [0usize; BANDS];
    for &v in values {
        let band = ((v as f64 - lo) / width).clamp(0.0, (BANDS - 1) as f64);
        counts[band as usize] += 1;
    }
    let band = (0..BANDS).max_by_key(|&b| (counts[b], usize::MAX - b))?;
    Some((
        (lo + band as f64 * width) as f32,
        (lo + (band + 1) as f64 * width) as f32,
    ))
}

/// The `q` quantile of sorted values (linear between ranks).
fn quantile(sorted: &[f32], q: f64) -> f32 {
    let rank = q * (sorted.len() - 1) as f64;
    let i = rank.floor() as usize;
    let j = (i + 1).min(sorted.len() - 1);
    // In f64: two finite f32 values may lie further apart than an f32 holds.
    let t = rank - i as f64;
    (sorted[i] as f64 + (sorted[j] as f64 - sorted[i] as f64) * t) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn volume(values: Vec<f32>) -> Volume {
        let n = values.len();
        Volume::new([n, 1, 1], Vec3::ONE, Vec3::ZERO, values).unwrap()
    }

    /// A CT-like distribution: 60 % air at 0..4, tissue 40..80, bone 120..200.
    fn ct_like() -> Vec<f32> {
        (0..100_000)
            .map(|i| {
                let u = (i as f32 * 0.618_034).fract();
                match i % 10 {
                    0..=5 => 4.0 * u,
                    6..=8 => 40.0 + 40.0 * u,
                    _ => 120.0 + 80.0 * u,
                }
            })
            .collect()
    }

    #[test]
    fn one_outlier_voxel_does_not_move_the_window() {
        let plain = Window::robust(&volume(ct_like())).window;
        let mut values = ct_like();
        values[777] = 5008.0;
        let report = Window::robust(&volume(values));
        assert_eq!(report.window.lo, plain.lo);
        assert_eq!(report.window.hi, plain.hi);
        assert_eq!(report.window.cut, None);
        // About the top 0.1 % of the foreground, and the outlier: a small share.
        assert!(report.above > 0.0 && report.above < 1.5e-3, "{report}");
        // The window spans air to bone, not to the outlier.
        assert!(plain.lo < 0.1, "{plain:?}");
        assert!(plain.hi > 190.0 && plain.hi <= 200.0, "{plain:?}");
        assert!(report.background < 4.0, "{report}");
    }

    #[test]
    fn a_mostly_empty_volume_spans_its_object_not_its_air() {
        // 99.5 % air: the 99.9th percentile of every voxel would sit inside the object's range.
        let values: Vec<f32> = (0..200_000)
            .map(|i| {
                if i % 200 == 0 {
                    100.0 + (i as f32 * 0.618_034).fract() * 100.0
                } else {
                    0.0
                }
            })
            .collect();
        let w = Window::robust(&volume(values)).window;
        assert_eq!(w.lo, 0.0);
        assert!(w.hi > 199.0, "{w:?}");
    }

    #[test]
    fn a_fill_population_above_the_data_is_cut_away() {
        // Negative numbers wrapped into uint16: a fifth of the voxels near 64512, the data at
        // 0..4000, all integers.
        let wrapped = |fill: f32| -> Vec<f32> {
            ct_like()
                .into_iter()
                .enumerate()
                .map(|(i, v)| {
                    if i % 5 == 0 {
                        fill + (i % 7) as f32
                    } else {
                        (v * 20.0).round()
                    }
                })
                .collect()
        };
        let report = Window::robust(&volume(wrapped(64_512.0)));
        let w = report.window;
        assert!(w.lo < 5.0 && w.hi > 3800.0 && w.hi <= 4000.0, "{report}");
        // At the data's largest value.
        let data_top = wrapped(64_512.0)
            .into_iter()
            .filter(|v| *v < 32_768.0)
            .fold(0.0f32, f32::max);
        assert_eq!(w.cut, Some(data_top), "{report}");
        assert!((report.wrapped - 0.2).abs() < 1e-3, "{report}");
        // The same numbers as floats, or below the type's upper half, are data: no cut.
        let mut fractional = wrapped(64_512.0);
        fractional[1] += 0.5;
        assert_eq!(Window::robust(&volume(fractional)).window.cut, None);
        assert_eq!(Window::robust(&volume(wrapped(30_000.0))).window.cut, None);
    }

    #[test]
    fn constant_and_two_valued_volumes_get_usable_windows() {
        let w = Window::robust(&volume(vec![3.0; 10])).window;
        assert_eq!((w.lo, w.hi), (3.0, 4.0));
        // A slab: background 0, matter 1, so the window is the full range.
        let slab: Vec<f32> = (0..1000).map(|i| (i % 4 == 0) as u8 as f32).collect();
        let w = Window::robust(&volume(slab)).window;
        assert_eq!((w.lo, w.hi, w.cut), (0.0, 1.0, None));
    }

    #[test]
    fn the_histogram_counts_values_in_the_window_with_numpys_edges() {
        // 0..=9 once each over [0, 10) in 5 bins: two values a bin; outside values uncounted,
        // the window's top in the last bin.
        let values: Vec<f32> = (0..10).map(|v| v as f32).chain([-1.0, 10.5]).collect();
        assert_eq!(histogram(&values, 0.0, 10.0, 5).unwrap(), vec![2; 5]);
        assert_eq!(
            histogram(&[10.0], 0.0, 10.0, 5).unwrap(),
            vec![0, 0, 0, 0, 1]
        );
        // Tenths in f32 over [0, 1] in 10 bins: the edges decide. 0.7f32 (0.69999999) lies
        // below the edge 7 x 0.1 + 0 = 0.70000000000000007 and 0.9f32 (0.89999998) below
        // 0.9, so each falls into the bin before its own, as numpy bins them.
        let tenths: Vec<f32> = (0..=10).map(|i| i as f32 / 10.0).collect();
        let counts = histogram(&tenths, 0.0, 1.0, 10).unwrap();
        assert_eq!(counts, vec![1, 1, 1, 1, 1, 1, 2, 0, 2, 1]);
        // More values than one parallel chunk, all in the middle bin.
        let many = vec![0.5f32; 200_000];
        assert_eq!(histogram(&many, 0.0, 1.0, 3).unwrap(), vec![0, 200_000, 0]);
        // Bad bins and ranges are refused by name.
        let bins = histogram(&values, 0.0, 1.0, 0).unwrap_err().to_string();
        assert!(bins.contains("histogram.bins"), "{bins}");
        let over = histogram(&values, 0.0, 1.0, MAX_HISTOGRAM_BINS + 1).unwrap_err();
        assert!(over.to_string().contains("histogram.bins"), "{over}");
        for (lo, hi) in [
            (1.0, 1.0),
            (2.0, 1.0),
            (f32::NAN, 1.0),
            (0.0, f32::INFINITY),
        ] {
            let range = histogram(&values, lo, hi, 4).unwrap_err().to_string();
            assert!(range.contains("histogram.range"), "{range}");
        }
    }

    #[test]
    fn ranges_read_from_scene_words_and_pairs() {
        let parse = |text: &str| serde_json::from_str::<ValueRange>(text);
        assert_eq!(parse("\"robust\"").unwrap(), ValueRange::Robust);
        assert_eq!(parse("\"full\"").unwrap(), ValueRange::Full);
        assert_eq!(
            parse("[-1000, 1500]").unwrap(),
            ValueRange::Window(Window {
                lo: -1000.0,
                hi: 1500.0,
                cut: None
            })
        );
        assert!(parse("\"wide\"").is_err());
        let resolved = ValueRange::Window(Window {
            lo: 0.0,
            hi: 1.0,
            cut: Some(9.0),
        });
        let text = serde_json::to_string(&resolved).unwrap();
        assert_eq!(parse(&text).unwrap(), resolved);
        assert!(ValueRange::Window(Window {
            lo: 2.0,
            hi: 1.0,
            cut: None
        })
        .validate()
        .is_err());
    }
}
