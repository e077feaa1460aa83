//! USD stages: a `UsdVol.Volume` whose `OpenVDBAsset` fields point at the grids of an exported
//! VDB file, with the scene's camera and lights, `metersPerUnit` and `upAxis`.
//!
//! The stage is first described as plain data ([`StageDescription`]): the conventions (camera
//! apertures, light frames, units) are worked out once, here. That description is written as
//! `.usda` text by [`write_usda`] (the CLI needs no Python), or handed as JSON to the Python
//! package, which authors the same stage through usd-core's `pxr` API.
//!
//! Conventions: one scene unit is one metre (Blender's default); Z is up. A USD camera looks down
//! its local -Z with +Y up, a `DistantLight` shines down its local -Z; transforms are USD's
//! row-vector matrices (the last row holds the translation).
//!
//! Importers make an object of every imageable prim they reach (Blender 5's USD import makes an
//! empty of each), so only the root `Xform` groups: the `OpenVDBAsset` field prims, read through
//! the Volume's `field:` relationships and never drawn themselves, are `invisible`, and `/Render`,
//! which only holds the `RenderSettings`, is a typeless prim rather than a `Scope`. Blender's
//! import reads no `RenderSettings`: the add-on's Import Occlux Stage applies its resolution and
//! camera.

use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::export::atomic::write_bytes_atomic;
use crate::lights::Light;
use glam::{DMat4, DVec3, Vec3};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// Camera apertures are authored in tenths of a scene unit, as USD's conventions ask; the
/// vertical aperture is fixed and the focal length carries the field of view.
const VERTICAL_APERTURE: f64 = 24.0;

/// Everything a stage holds, in USD's terms.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StageDescription {
    pub meters_per_unit: f64,
    pub up_axis: &'static str,
    /// The root prim, also the stage's default prim.
    pub root: String,
    pub volume: VolumePrim,
    pub camera: CameraPrim,
    pub lights: Vec<LightPrim>,
    /// Image size of the renders that go with the stage (a `UsdRender.Settings` prim).
    pub resolution: [u32; 2],
    /// A sequence's first and last time codes (`startTimeCode`, `endTimeCode`); None for one
    /// file.
    pub time_codes: Option<[u32; 2]>,
}

/// The volume prim and its fields.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VolumePrim {
    pub name: String,
    /// World-space bounds of the grids: the prim's `extent`.
    pub extent: [[f32; 3]; 2],
    pub fields: Vec<FieldPrim>,
}

/// One `OpenVDBAsset`: prim name, the VDB file (relative to the stage) and the grid in it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FieldPrim {
    pub name: String,
    pub file_path: String,
    pub field_name: String,
    /// A sequence: the file at each time code (`filePath.timeSamples`); `file_path` stays the
    /// default for readers that ignore time.
    pub time_samples: Vec<(u32, String)>,
}

/// A `UsdGeom.Camera`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CameraPrim {
    pub name: String,
    /// Local-to-world, USD row-vector layout (rows: right, up, backward, position).
    pub transform: [[f64; 4]; 4],
    /// "perspective" or "orthographic".
    pub projection: &'static str,
    pub focal_length: f64,
    pub horizontal_aperture: f64,
    pub vertical_aperture: f64,
    pub clipping_range: [f64; 2],
}

/// A `UsdLux` light: `kind` is "DistantLight", "SphereLight" (a point: `treatAsPoint`) or
/// "DomeLight" (uniform ambient). Radiance is `intensity * color`, `color`'s largest channel 1.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LightPrim {
    pub name: String,
    pub kind: &'static str,
    pub transform: [[f64; 4]; 4],
    pub intensity: f64,
    pub color: [f64; 3],
}

/// Checks that `file` can be written between `@` as a USD asset path.
fn check_asset_path(file: &str) -> Result<()> {
    if file.is_empty() || file.contains(['@', '\n', '\\']) {
        return Err(Error::param(
            "usd",
            format!("'{file}' cannot be written as a USD asset path"),
        ));
    }
    Ok(())
}

/// Checks that `name` can be a prim name: letters, digits and underscores, not starting with a
/// digit (USD's identifier rule).
pub fn check_prim_name(name: &str) -> Result<()> {
    let mut chars = name.chars();
    let ok = chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_');
    if ok {
        Ok(())
    } else {
        Err(Error::param(
            "usd",
            format!(
                "'{name}' cannot name a USD prim: use letters, digits and '_', not starting with a digit"
            ),
        ))
    }
}

impl StageDescription {
    /// The stage for a volume whose grids `grids` live in `vdb_file` (a path relative to the
    /// stage, e.g. "scene.vdb"), seen by `camera` and lit by `lights`; `bounds` are the
    /// volume's world-space bounds.
    pub fn new(
        vdb_file: &str,
        grids: &[&str],
        bounds: (Vec3, Vec3),
        camera: &Camera,
        lights: &[Light],
    ) -> Result<Self> {
        if grids.is_empty() {
            return Err(Error::param("usd", "a volume needs at least one grid"));
        }
        check_asset_path(vdb_file)?;
        let fields = grids
            .iter()
            .map(|&grid| {
                check_prim_name(grid)?;
                Ok(FieldPrim {
                    name: grid.to_owned(),
                    file_path: format!("./{vdb_file}"),
                    field_name: grid.to_owned(),
                    time_samples: Vec::new(),
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let diagonal = (bounds.1 - bounds.0).length() as f64;
        let distance = (camera.position.as_dvec3() - (0.5 * (bounds.0 + bounds.1)).as_dvec3())
            .length()
            .max(1e-3);
        Ok(Self {
            meters_per_unit: 1.0,
            up_axis: "Z",
            root: "World".into(),
            volume: VolumePrim {
                name: "Volume".into(),
                extent: [bounds.0.to_array(), bounds.1.to_array()],
                fields,
            },
            camera: camera_prim(camera, 1e-3 * distance, 10.0 * (distance + diagonal)),
            lights: lights
                .iter()
                .enumerate()
                .map(|(n, l)| light_prim(n, l))
                .collect(),
            resolution: [camera.width, camera.height],
            time_codes: None,
        })
    }

    /// The stage of a sequence: every field reads `files[i]` at time code `first + i` (a
    /// series' VDBs, relative to the stage), played at 24 frames per second as Blender does.
    pub fn with_time_samples(mut self, first: u32, files: &[String]) -> Result<Self> {
        if files.is_empty() {
            return Err(Error::param("usd", "a sequence needs at least one file"));
        }
        for file in files {
            check_asset_path(file)?;
        }
        let samples: Vec<(u32, String)> = files
            .iter()
            .zip(first..)
            .map(|(file, code)| (code, format!("./{file}")))
            .collect();
        for field in &mut self.volume.fields {
            field.time_samples = samples.clone();
        }
        self.time_codes = Some([first, first + files.len() as u32 - 1]);
        Ok(self)
    }

    /// The description as JSON, for the Python package's pxr authoring.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a stage description always serialises")
    }

    /// The stage as `.usda` text.
    pub fn to_usda(&self) -> String {
        let mut s = String::new();
        let root = &self.root;
        // Writing into a String cannot fail.
        let _ = writeln!(
            s,
            "#usda 1.0\n(\n    defaultPrim = \"{root}\"\n    doc = \"Written by Occlux {}\"\n    \
             metersPerUnit = {}\n    renderSettingsPrimPath = \"/Render/Settings\"\n    \
             upAxis = \"{}\"\n{})\n",
            env!("CARGO_PKG_VERSION"),
            self.meters_per_unit,
            self.up_axis,
            self.time_codes
                .map_or(String::new(), |[start, end]| format!(
                    "    startTimeCode = {start}\n    endTimeCode = {end}\n    \
                 timeCodesPerSecond = 24\n    framesPerSecond = 24\n"
                ))
        );
        let _ = writeln!(s, "def Xform \"{root}\"\n{{");
        self.volume_usda(&mut s);
        self.camera_usda(&mut s);
        for light in &self.lights {
            light_usda(&mut s, light);
        }
        let _ = writeln!(s, "}}\n");
        let [w, h] = self.resolution;
        let _ = writeln!(
            s,
            "def \"Render\"\n{{\n    def RenderSettings \"Settings\"\n    {{\n        \
             rel camera = </{root}/{}>\n        uniform int2 resolution = ({w}, {h})\n    }}\n}}",
            self.camera.name
        );
        s
    }

    fn volume_usda(&self, s: &mut String) {
        let v = &self.volume;
        let path = format!("/{}/{}", self.root, v.name);
        let _ = writeln!(s, "    def Volume \"{}\"\n    {{", v.name);
        let _ = writeln!(
            s,
            "        float3[] extent = [{}, {}]",
            tuple(&v.extent[0].map(f64::from)),
            tuple(&v.extent[1].map(f64::from))
        );
        for f in &v.fields {
            let _ = writeln!(s, "        rel field:{0} = <{path}/{0}>", f.name);
        }
        for f in &v.fields {
            let _ = writeln!(
                s,
                "\n        def OpenVDBAsset \"{}\"\n        {{\n            \
                 token fieldClass = \"fogVolume\"\n            \
                 token fieldDataType = \"float\"\n            \
                 token fieldName = \"{}\"\n            asset filePath = @{}@\n{}            \
                 token visibility = \"invisible\"\n        }}",
                f.name,
                f.field_name,
                f.file_path,
                time_samples(&f.time_samples)
            );
        }
        let _ = writeln!(s, "    }}\n");
    }

    fn camera_usda(&self, s: &mut String) {
        let c = &self.camera;
        let _ = writeln!(
            s,
            "    def Camera \"{}\"\n    {{\n        float2 clippingRange = {}\n        \
             float focalLength = {}\n        float horizontalAperture = {}\n        \
             token projection = \"{}\"\n        float verticalAperture = {}\n        \
             matrix4d xformOp:transform = {}\n        \
             uniform token[] xformOpOrder = [\"xformOp:transform\"]\n    }}\n",
            c.name,
            tuple(&c.clipping_range),
            c.focal_length,
            c.horizontal_aperture,
            c.projection,
            c.vertical_aperture,
            matrix(&c.transform)
        );
    }
}

/// A field's `filePath.timeSamples` line, or nothing for one file.
fn time_samples(samples: &[(u32, String)]) -> String {
    if samples.is_empty() {
        return String::new();
    }
    let entries: Vec<String> = samples
        .iter()
        .map(|(code, file)| format!("{code}: @{file}@"))
        .collect();
    format!(
        "            asset filePath.timeSamples = {{ {} }}\n",
        entries.join(", ")
    )
}

fn light_usda(s: &mut String, l: &LightPrim) {
    let extra = match l.kind {
        "DistantLight" => "        float inputs:angle = 0\n",
        "SphereLight" => "        float inputs:radius = 0\n        bool treatAsPoint = 1\n",
        _ => "",
    };
    let _ = writeln!(
        s,
        "    def {} \"{}\"\n    {{\n        color3f inputs:color = {}\n{extra}        \
         float inputs:intensity = {}\n        matrix4d xformOp:transform = {}\n        \
         uniform token[] xformOpOrder = [\"xformOp:transform\"]\n    }}\n",
        l.kind,
        l.name,
        tuple(&l.color),
        l.intensity,
        matrix(&l.transform)
    );
}

fn tuple(v: &[f64]) -> String {
    let items: Vec<String> = v.iter().map(|x| format!("{x}")).collect();
    format!("({})", items.join(", "))
}

fn matrix(m: &[[f64; 4]; 4]) -> String {
    let rows: Vec<String> = m.iter().map(|r| tuple(r)).collect();
    format!("( {} )", rows.join(", "))
}

/// A USD transform whose local X, Y, Z axes are `x`, `y`, `z` and whose origin is `at`.
fn frame(x: DVec3, y: DVec3, z: DVec3, at: DVec3) -> [[f64; 4]; 4] {
    let m = DMat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), at.extend(1.0));
    // glam's columns are USD's rows.
    m.to_cols_array_2d()
}

fn camera_prim(camera: &Camera, near: f64, far: f64) -> CameraPrim {
    let transform = frame(
        camera.right.as_dvec3(),
        camera.up.as_dvec3(),
        -camera.forward.as_dvec3(),
        camera.position.as_dvec3(),
    );
    let aspect = camera.width as f64 / camera.height as f64;
    let (projection, focal_length, vertical) = match camera.projection {
        Projection::Perspective { fov_y } => (
            "perspective",
            0.5 * VERTICAL_APERTURE / (0.5 * fov_y as f64).tan(),
            VERTICAL_APERTURE,
        ),
        // Orthographic apertures are the view's extent, in tenths of a scene unit.
        Projection::Orthographic { .. } => {
            let (_, hy) = camera.half_extent();
            ("orthographic", 50.0, 20.0 * hy as f64)
        }
    };
    CameraPrim {
        name: "Camera".into(),
        transform,
        projection,
        focal_length,
        horizontal_aperture: vertical * aspect,
        vertical_aperture: vertical,
        clipping_range: [near, far],
    }
}

/// Splits RGB into an intensity (the largest channel) and a colour whose largest channel is 1.
fn intensity_and_color(rgb: Vec3) -> (f64, [f64; 3]) {
    let peak = rgb.max_element() as f64;
    if peak > 0.0 {
        (peak, (rgb.as_dvec3() / peak).to_array())
    } else {
        (0.0, [1.0; 3])
    }
}

/// Any unit vector perpendicular to `z`.
fn perpendicular(z: DVec3) -> DVec3 {
    let helper = if z.z.abs() < 0.9 { DVec3::Z } else { DVec3::X };
    helper.cross(z).normalize()
}

fn light_prim(index: usize, light: &Light) -> LightPrim {
    let (kind, name, transform, rgb) = match *light {
        Light::Ambient { radiance } => (
            "DomeLight",
            "Ambient",
            DMat4::IDENTITY.to_cols_array_2d(),
            radiance,
        ),
        Light::Directional {
            to_light,
            irradiance,
        } => {
            // The light shines down its local -Z, so local Z points at the light.
            let z = to_light.as_dvec3().normalize();
            let x = perpendicular(z);
            (
                "DistantLight",
                "Sun",
                frame(x, z.cross(x), z, DVec3::ZERO),
                irradiance,
            )
        }
        Light::Point {
            position,
            intensity,
        } => (
            "SphereLight",
            "Point",
            frame(DVec3::X, DVec3::Y, DVec3::Z, position.as_dvec3()),
            intensity,
        ),
    };
    let (intensity, color) = intensity_and_color(rgb);
    LightPrim {
        name: format!("{name}{index}"),
        kind,
        transform,
        intensity,
        color,
    }
}

/// Writes the stage as `.usda`, atomically.
pub fn write_usda(path: &Path, stage: &StageDescription) -> Result<()> {
    write_bytes_atomic(path, stage.to_usda().as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::Light;

    fn camera(projection: Projection) -> Camera {
        Camera::look_at(
            Vec3::new(3.0, -2.0, 1.5),
            Vec3::ZERO,
            Vec3::Z,
            projection,
            320,
            200,
        )
        .unwrap()
    }

    fn stage(camera: &Camera, lights: &[Light]) -> StageDescription {
        let bounds = (Vec3::splat(-1.0), Vec3::splat(1.0));
        StageDescription::new("v.vdb", &["density", "ao"], bounds, camera, lights).unwrap()
    }

    fn row(m: &[[f64; 4]; 4], r: usize) -> DVec3 {
        DVec3::new(m[r][0], m[r][1], m[r][2])
    }

    #[test]
    fn the_camera_keeps_its_field_of_view_and_frame() {
        let fov_y = 0.6f32;
        let cam = camera(Projection::Perspective { fov_y });
        let c = stage(&cam, &[]).camera;
        let fov = 2.0 * (0.5 * c.vertical_aperture / c.focal_length).atan();
        assert!((fov - fov_y as f64).abs() < 1e-6, "{fov}");
        assert!((c.horizontal_aperture / c.vertical_aperture - 1.6).abs() < 1e-12);
        // USD cameras look down local -Z with +Y up: the rows are right, up, -forward, position.
        let forward = -row(&c.transform, 2);
        assert!((forward - cam.forward.as_dvec3()).length() < 1e-6);
        assert!((row(&c.transform, 1) - cam.up.as_dvec3()).length() < 1e-6);
        assert!((row(&c.transform, 3) - cam.position.as_dvec3()).length() < 1e-6);
        assert_eq!(c.transform[3][3], 1.0);

        let ortho = stage(&camera(Projection::Orthographic { scale: 4.0 }), &[]).camera;
        // The larger image side spans the orthographic scale: 4 units = 40 tenths.
        assert!((ortho.horizontal_aperture - 40.0).abs() < 1e-4, "{ortho:?}");
        assert_eq!(ortho.projection, "orthographic");
    }

    #[test]
    fn lights_point_where_the_scene_says() {
        let to_light = Vec3::new(-0.3, -1.0, 1.2).normalize();
        let lights = [
            Light::Ambient {
                radiance: Vec3::splat(0.25),
            },
            Light::Directional {
                to_light,
                irradiance: Vec3::new(2.0, 1.0, 0.5),
            },
            Light::Point {
                position: Vec3::new(1.0, 2.0, 3.0),
                intensity: Vec3::splat(5.0),
            },
        ];
        let stage = stage(&camera(Projection::Perspective { fov_y: 0.5 }), &lights);
        let kinds: Vec<_> = stage.lights.iter().map(|l| l.kind).collect();
        assert_eq!(kinds, ["DomeLight", "DistantLight", "SphereLight"]);
        let sun = &stage.lights[1];
        // A DistantLight shines down its local -Z: local Z is the direction to the light.
        assert!((row(&sun.transform, 2) - to_light.as_dvec3()).length() < 1e-6);
        let (x, y) = (row(&sun.transform, 0), row(&sun.transform, 1));
        assert!(x.dot(y).abs() < 1e-9 && (x.cross(y) - row(&sun.transform, 2)).length() < 1e-6);
        assert_eq!((sun.intensity, sun.color), (2.0, [1.0, 0.5, 0.25]));
        assert_eq!(
            row(&stage.lights[2].transform, 3),
            DVec3::new(1.0, 2.0, 3.0)
        );
        assert_eq!(stage.lights[0].intensity, 0.25);
    }

    #[test]
    fn fields_point_at_the_grids_and_names_are_checked() {
        let cam = camera(Projection::Perspective { fov_y: 0.5 });
        let s = stage(&cam, &[]);
        let fields: Vec<_> = s.volume.fields.iter().map(|f| &f.field_name).collect();
        assert_eq!(fields, ["density", "ao"]);
        assert!(s.volume.fields.iter().all(|f| f.file_path == "./v.vdb"));
        let usda = s.to_usda();
        assert!(usda.starts_with("#usda 1.0\n"));
        assert!(usda.contains("rel field:ao = </World/Volume/ao>"), "{usda}");
        // Field prims and the render settings' parent make no objects in an importer.
        assert_eq!(usda.matches("token visibility = \"invisible\"").count(), 2);
        assert!(
            usda.contains("def \"Render\"\n{") && !usda.contains("Scope"),
            "{usda}"
        );
        assert!(
            usda.contains("uniform int2 resolution = (320, 200)"),
            "{usda}"
        );
        assert!(s.to_json().contains("\"field_name\": \"ao\""));

        let bounds = (Vec3::ZERO, Vec3::ONE);
        for (grids, file, what) in [
            (&["2ao"][..], "v.vdb", "cannot name a USD prim"),
            (&["a-b"][..], "v.vdb", "cannot name a USD prim"),
            (&[][..], "v.vdb", "at least one grid"),
            (&["ok"][..], "a@b.vdb", "asset path"),
        ] {
            let err = StageDescription::new(file, grids, bounds, &cam, &[])
                .unwrap_err()
                .to_string();
            assert!(err.contains(what), "{err}");
        }
    }
}
