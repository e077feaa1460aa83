// The VAO openness of each voxel from its box statistics: mirrors src/ao/vao/estimate.rs.
// The exact erf (ESTIMATOR_GAUSS_EXACT_ERF) is Abramowitz and Stegun 7.1.26 (absolute error
// below 1.5e-7, under f32's resolution of the result); the CPU twin calls libm's erff.

const PI: f32 = 3.14159265358979;
const BETA_MIN: f32 = 1.0e-6;
const BETA_MAX: f32 = 1.0e6;
const ERF_SATURATION: f32 = 10.0;

// Params.estimator (vao::Estimator::shader_code).
const ESTIMATOR_CDF: u32 = 0u;
const ESTIMATOR_GAUSS: u32 = 1u;
const ESTIMATOR_GAUSS_EXACT_ERF: u32 = 2u;
const ESTIMATOR_PENNER: u32 = 3u;

// Mirrored by vao::gpu::EstimateParams.
struct Params {
    voxels: u32,
    estimator: u32,
    // 1: out_variance receives each voxel's variance.
    write_variance: u32,
    // Voxels per row of the dispatch grid.
    voxels_per_row: u32,
    // Scale and offset of the map to [0, 1] that the statistics were computed under.
    scale: f32,
    offset: f32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> field: array<f32>;
@group(0) @binding(2) var<storage, read> stat_min: array<f32>;
@group(0) @binding(3) var<storage, read> stat_max: array<f32>;
@group(0) @binding(4) var<storage, read> stat_mean: array<f32>;
@group(0) @binding(5) var<storage, read> stat_second: array<f32>;
@group(0) @binding(6) var<storage, read_write> out_open: array<f32>;
@group(0) @binding(7) var<storage, read_write> out_variance: array<f32>;

fn erf_winitzki(x: f32) -> f32 {
    let a = 8.0 * (PI - 3.0) / (3.0 * PI * (4.0 - PI));
    let x2 = x * x;
    let ax2 = a * x2;
    let e = max(1.0 - exp(-x2 * (4.0 / PI + ax2) / (1.0 + ax2)), 0.0);
    return sign(x) * sqrt(e);
}

fn erf_exact(x: f32) -> f32 {
    let ax = abs(x);
    let t = 1.0 / (1.0 + 0.3275911 * ax);
    let poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
    return sign(x) * (1.0 - poly * exp(-ax * ax));
}

fn power_cdf(v: f32, lo: f32, hi: f32, mean: f32) -> f32 {
    let t = clamp((v - lo) / (hi - lo), 0.0, 1.0);
    let below = max(mean - lo, 0.0);
    let above = max(hi - mean, 0.0);
    var beta = BETA_MAX;
    if (above > 0.0) {
        beta = clamp(below / above, BETA_MIN, BETA_MAX);
    }
    if (t <= 0.0) {
        return 0.0;
    }
    return pow(t, beta);
}

fn normal_cdf(v: f32, mean: f32, variance: f32, exact: bool) -> f32 {
    let d = v - mean;
    if (variance > 0.0) {
        let x = clamp(d / sqrt(2.0 * variance), -ERF_SATURATION, ERF_SATURATION);
        if (exact) {
            return 0.5 * (1.0 + erf_exact(x));
        }
        return 0.5 * (1.0 + erf_winitzki(x));
    }
    if (d > 0.0) {
        return 1.0;
    }
    if (d < 0.0) {
        return 0.0;
    }
    return 0.5;
}

fn penner(v: f32, mean: f32, variance: f32) -> f32 {
    let d = v - mean;
    if (d <= 0.0) {
        return 0.0;
    }
    let spread = variance + d * d;
    if (spread > 0.0) {
        return 1.0 - variance / spread;
    }
    return 1.0;
}

@compute @workgroup_size(64, 1, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * params.voxels_per_row;
    if (i >= params.voxels) {
        return;
    }
    let v = field[i] * params.scale + params.offset;
    let lo = stat_min[i];
    let hi = stat_max[i];
    let mean = stat_mean[i];
    let variance = max(stat_second[i] - mean * mean, 0.0);
    var f = 0.5;
    if (hi > lo) {
        switch params.estimator {
            case ESTIMATOR_GAUSS: { f = normal_cdf(v, mean, variance, false); }
            case ESTIMATOR_GAUSS_EXACT_ERF: { f = normal_cdf(v, mean, variance, true); }
            case ESTIMATOR_PENNER: { f = penner(v, mean, variance); }
            // ESTIMATOR_CDF
            default: { f = power_cdf(v, lo, hi, mean); }
        }
    }
    out_open[i] = clamp(f, 0.0, 1.0);
    if (params.write_variance == 1u) {
        out_variance[i] = variance;
    }
}
