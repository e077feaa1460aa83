//! Ready-made classifications. Value positions are normalised to the volume's value range.

use super::{
    Classification, ControlPoint, TransferFunction, TransferFunction1D, TransferFunction2D,
    ValueUnits, Widget, WidgetShape, DEFAULT_LUT_SIZE,
};
use crate::error::{Error, Result};

/// The preset names `preset` accepts.
pub const PRESETS: &[&str] = &[
    "ct-bone",
    "ct-soft-tissue",
    "mri",
    "simulation",
    "boundary-2d",
];

fn point(value: f32, sigma_t: f32, albedo: [f32; 3]) -> ControlPoint {
    ControlPoint::new(value, sigma_t, albedo, [0.0; 3])
}

/// A preset by name; extinctions are per world unit for a volume about 2 units across.
pub fn preset(name: &str) -> Result<Classification> {
    let tf = match name {
        // Air and soft tissue clear, bone dense and bright.
        "ct-bone" => TransferFunction::OneD(TransferFunction1D::new(vec![
            point(0.0, 0.0, [0.9, 0.85, 0.75]),
            point(0.35, 0.0, [0.9, 0.85, 0.75]),
            point(0.55, 10.0, [0.95, 0.92, 0.85]),
            point(1.0, 25.0, [1.0, 0.97, 0.92]),
        ])?),
        // Soft tissue translucent and reddish, bone denser.
        "ct-soft-tissue" => TransferFunction::OneD(TransferFunction1D::new(vec![
            point(0.0, 0.0, [0.8, 0.4, 0.3]),
            point(0.12, 0.0, [0.8, 0.4, 0.3]),
            point(0.25, 1.0, [0.85, 0.45, 0.35]),
            point(0.45, 1.5, [0.9, 0.6, 0.5]),
            point(0.6, 6.0, [0.95, 0.92, 0.85]),
            point(1.0, 14.0, [1.0, 0.97, 0.92]),
        ])?),
        // MRI intensities: background noise clear, tissue gradually denser.
        "mri" => TransferFunction::OneD(TransferFunction1D::new(vec![
            point(0.0, 0.0, [0.8, 0.8, 0.8]),
            point(0.1, 0.0, [0.8, 0.8, 0.8]),
            point(0.5, 8.0, [0.85, 0.8, 0.75]),
            point(1.0, 20.0, [0.95, 0.9, 0.85]),
        ])?),
        // A smooth field: a linear ramp, blue to orange.
        "simulation" => TransferFunction::OneD(TransferFunction1D::new(vec![
            point(0.0, 0.0, [0.2, 0.4, 0.9]),
            point(0.5, 5.0, [0.8, 0.8, 0.8]),
            point(1.0, 20.0, [0.95, 0.6, 0.2]),
        ])?),
        // Kniss' boundary emphasis: material boundaries have high gradient magnitude.
        "boundary-2d" => TransferFunction::TwoD(TransferFunction2D::new(vec![Widget {
            shape: WidgetShape::Trapezoid,
            value: 0.5,
            width_bottom: 0.1,
            width_top: Some(0.8),
            gradient: [0.1, 1.0],
            sigma_t: 40.0,
            albedo: [0.9, 0.85, 0.8],
            emission: [0.0; 3],
        }])?),
        other => {
            return Err(Error::param(
                "classification.preset",
                format!("unknown preset '{other}'; known: {}", PRESETS.join(", ")),
            ))
        }
    };
    Ok(Classification {
        tf,
        units: ValueUnits::Normalized,
        density_scale: 1.0,
        lut_size: DEFAULT_LUT_SIZE,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_listed_preset_builds() {
        for name in PRESETS {
            preset(name).unwrap().validate().unwrap();
        }
        assert!(preset("nope").unwrap_err().to_string().contains("ct-bone"));
    }
}
