//! What the chart reads off its points: the Pareto front of time against error, and how much
//! faster than a path tracer a point reaches its error.

/// Whether each (seconds, error) point is on the Pareto front: no other point is at least as
/// fast and at least as accurate and better in one of the two. Points with a non-finite or
/// non-positive time or error are never on it.
pub fn front(points: &[(f64, f64)]) -> Vec<bool> {
    let usable = |&(t, e): &(f64, f64)| t.is_finite() && e.is_finite() && t > 0.0 && e > 0.0;
    points
        .iter()
        .map(|p| {
            usable(p)
                && !points
                    .iter()
                    .any(|q| usable(q) && q.0 <= p.0 && q.1 <= p.1 && (q.0 < p.0 || q.1 < p.1))
        })
        .collect()
}

/// A path tracer's time and error at increasing samples per pixel.
#[derive(Clone, Debug)]
pub struct Curve {
    /// (samples per pixel, seconds, error), in order of samples.
    pub points: Vec<(u32, f64, f64)>,
}

/// How the path tracer's time for an error was found.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Reached {
    /// At one sample: the path tracer's first sample is already as accurate (so the speed-up
    /// is its bias floor: no fewer samples exist).
    FirstSample,
    /// At a sample count within the measured ones.
    Interpolated,
    /// At a sample count beyond them.
    Extrapolated,
}

impl Curve {
    /// The path tracer's time to reach `error` and how it was found, by the laws a path tracer
    /// follows: time = fixed + per_sample * spp (a least-squares line through the measured
    /// times: the fixed part is the scene and volume build) and error = c / sqrt(spp) (c the
    /// geometric mean of error * sqrt(spp) over the measurements), at least one sample. None
    /// with fewer than two usable measurements.
    pub fn time_for(&self, error: f64) -> Option<(f64, Reached)> {
        let pts: Vec<(f64, f64, f64)> = self
            .points
            .iter()
            .filter(|&&(n, t, e)| n > 0 && t.is_finite() && e.is_finite() && t > 0.0 && e > 0.0)
            .map(|&(n, t, e)| (n as f64, t, e))
            .collect();
        if pts.len() < 2 || !error.is_finite() || error <= 0.0 {
            return None;
        }
        let count = pts.len() as f64;
        let log_c = pts
            .iter()
            .map(|&(n, _, e)| (e * n.sqrt()).ln())
            .sum::<f64>()
            / count;
        let needed = (log_c.exp() / error).powi(2).max(1.0);
        let mean_n = pts.iter().map(|p| p.0).sum::<f64>() / count;
        let mean_t = pts.iter().map(|p| p.1).sum::<f64>() / count;
        let spread = pts.iter().map(|p| (p.0 - mean_n).powi(2)).sum::<f64>();
        let per_sample = if spread > 0.0 {
            (pts.iter()
                .map(|p| (p.0 - mean_n) * (p.1 - mean_t))
                .sum::<f64>()
                / spread)
                .max(0.0)
        } else {
            0.0
        };
        let fixed = (mean_t - per_sample * mean_n).max(0.0);
        let (lo, hi) = pts.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| {
            (lo.min(p.0), hi.max(p.0))
        });
        let how = if needed <= 1.0 {
            Reached::FirstSample
        } else if (lo..=hi).contains(&needed) {
            Reached::Interpolated
        } else {
            Reached::Extrapolated
        };
        Some((fixed + per_sample * needed, how))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_front_keeps_what_nothing_beats() {
        let points = [
            (1.0, 0.5),
            (2.0, 0.2),
            (2.0, 0.3), // beaten by (2, 0.2)
            (0.5, 0.9),
            (3.0, 0.6), // beaten by (1, 0.5)
            (f64::NAN, 0.01),
            (4.0, 0.0), // no error is not measurable on log axes
        ];
        assert_eq!(
            front(&points),
            [true, true, false, true, false, false, false]
        );
        // Equal points are both on it.
        assert_eq!(front(&[(1.0, 1.0), (1.0, 1.0)]), [true, true]);
    }

    #[test]
    fn a_path_tracer_is_read_by_its_laws() {
        // error = 2 / sqrt(spp), time = 3 + 0.1 spp: measured at 1, 4, 16 spp.
        let curve = Curve {
            points: [1u32, 4, 16]
                .iter()
                .map(|&n| (n, 3.0 + 0.1 * n as f64, 2.0 / (n as f64).sqrt()))
                .collect(),
        };
        // At a measured error: that count's time; between: between; beyond: the laws.
        let (t, how) = curve.time_for(1.0).unwrap();
        assert!(
            (t - 3.4).abs() < 1e-6 && how == Reached::Interpolated,
            "{t}"
        );
        let (t, _) = curve.time_for(0.7).unwrap();
        assert!(3.4 < t && t < 4.6, "{t}");
        let (t, how) = curve.time_for(0.25).unwrap(); // 64 spp
        assert!(
            (t - 9.4).abs() < 1e-6 && how == Reached::Extrapolated,
            "{t}"
        );
        // Worse than one sample: one sample's time.
        let (t, how) = curve.time_for(5.0).unwrap();
        assert!((t - 3.1).abs() < 1e-6 && how == Reached::FirstSample, "{t}");
        // Noisy times that fall with samples: the build alone, never a negative cost.
        let noisy = Curve {
            points: vec![(1, 7.6, 1.0), (4, 7.5, 0.5), (16, 6.9, 0.25)],
        };
        let (t, _) = noisy.time_for(0.1).unwrap();
        assert!((t - (7.6 + 7.5 + 6.9) / 3.0).abs() < 1e-9, "{t}");
        assert!(curve.time_for(0.0).is_none());
        let one = Curve {
            points: vec![(4, 1.0, 0.5)],
        };
        assert!(one.time_for(0.1).is_none());
    }
}
