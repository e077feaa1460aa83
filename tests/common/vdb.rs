//! Reading a grid of an OpenVDB file with vdb-rs directly, as an independent reader of what
//! Occlux writes.

use std::collections::HashMap;
use std::path::Path;

/// Grid `name` of the file at `path`: its voxels by index, and its map's scale and translation.
pub fn read_with_vdb_rs(path: &Path, name: &str) -> (HashMap<[i32; 3], f32>, [f64; 3], [f64; 3]) {
    let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let mut reader = vdb_rs::VdbReader::new(file).unwrap();
    let grid = reader.read_grid::<f32>(name).unwrap();
    let voxels = grid
        .iter()
        .map(|(p, v, level)| {
            assert!(level == vdb_rs::VdbLevel::Voxel, "no tiles expected");
            ([p.x as i32, p.y as i32, p.z as i32], v)
        })
        .collect();
    match grid.transform {
        vdb_rs::Map::ScaleTranslateMap {
            scale_values,
            translation,
            ..
        } => (voxels, scale_values.to_array(), translation.to_array()),
        _ => panic!("expected a scale-translate map"),
    }
}
