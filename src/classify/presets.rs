//! Ready-made classifications. Value positions are normalised on the robust window of the
//! volume's values ([`super::window`]): 0 near the background (a CT's air), 1 at the top of the
//! object's values, so one outlier voxel or a mostly empty volume does not move them. The CT
//! presets also come in Hounsfield units (`units = "hu"`), placed on the tissues' own values.

use super::{
    Classification, ControlPoint, TransferFunction, TransferFunction1D, TransferFunction2D,
    ValueRange, ValueUnits, Widget, WidgetShape, DEFAULT_LUT_SIZE,
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
        range: ValueRange::Robust,
    })
}

/// The presets that have a form in Hounsfield units.
pub const HU_PRESETS: &[&str] = &["ct-bone", "ct-soft-tissue"];

/// A preset in the given units: normalised as [`preset`], or a CT preset in Hounsfield units
/// (air -1000, fat about -100, soft tissue 20..80, cancellous bone 300, cortical bone 1000 and
/// more). Raw units have no presets: a preset is placed by statistics or by HU.
pub fn preset_in(name: &str, units: ValueUnits) -> Result<Classification> {
    let normalised = preset(name)?;
    let hu_points = match (units, name) {
        (ValueUnits::Normalized, _) => return Ok(normalised),
        (ValueUnits::Raw, _) => {
            return Err(Error::param(
                "classification.units",
                format!(
                    "presets are placed on normalised values or in Hounsfield units; use \
                     units = \"normalized\" or \"hu\" with preset '{name}', or give raw `points`"
                ),
            ))
        }
        // Air, lung and fat clear; bone from cancellous to cortical.
        (ValueUnits::Hu, "ct-bone") => vec![
            point(-1000.0, 0.0, [0.9, 0.85, 0.75]),
            point(150.0, 0.0, [0.9, 0.85, 0.75]),
            point(450.0, 10.0, [0.95, 0.92, 0.85]),
            point(1500.0, 25.0, [1.0, 0.97, 0.92]),
        ],
        // Fat faint, soft tissue translucent and reddish, bone dense.
        (ValueUnits::Hu, "ct-soft-tissue") => vec![
            point(-1000.0, 0.0, [0.8, 0.4, 0.3]),
            point(-400.0, 0.0, [0.8, 0.4, 0.3]),
            point(-100.0, 0.4, [0.85, 0.75, 0.45]),
            point(40.0, 1.5, [0.85, 0.45, 0.35]),
            point(250.0, 6.0, [0.95, 0.92, 0.85]),
            point(1500.0, 14.0, [1.0, 0.97, 0.92]),
        ],
        (ValueUnits::Hu, other) => {
            return Err(Error::param(
                "classification.units",
                format!(
                    "preset '{other}' has no form in Hounsfield units; those that do: {}",
                    HU_PRESETS.join(", ")
                ),
            ))
        }
    };
    Ok(Classification {
        tf: TransferFunction::OneD(TransferFunction1D::new(hu_points)?),
        units: ValueUnits::Hu,
        ..normalised
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

    #[test]
    fn ct_presets_have_hounsfield_forms_placed_on_tissue_values() {
        for name in HU_PRESETS {
            let c = preset_in(name, ValueUnits::Hu).unwrap();
            assert_eq!(c.units, ValueUnits::Hu);
            let lut = c.bake_over(-1024.0, 3071.0, None, 0.0);
            // Air and water are clear under ct-bone; bone is dense under both.
            assert_eq!(lut.lookup(-1000.0, 0.0).sigma_t, 0.0, "{name}");
            assert!(lut.lookup(1200.0, 0.0).sigma_t > 10.0, "{name}");
        }
        let bone = preset_in("ct-bone", ValueUnits::Hu).unwrap();
        assert_eq!(
            bone.bake_over(-1024.0, 3071.0, None, 0.0)
                .lookup(40.0, 0.0)
                .sigma_t,
            0.0
        );
        for name in PRESETS.iter().filter(|n| !HU_PRESETS.contains(n)) {
            let err = preset_in(name, ValueUnits::Hu).unwrap_err().to_string();
            assert!(err.contains("ct-bone") && err.contains(name), "{err}");
        }
        assert!(preset_in("ct-bone", ValueUnits::Raw).is_err());
        assert_eq!(
            preset_in("mri", ValueUnits::Normalized).unwrap(),
            preset("mri").unwrap()
        );
    }
}
