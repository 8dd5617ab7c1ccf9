//! The OBJ, PLY, STL and JSON mesh readers (and the repair that follows them in the server)
//! must turn any bytes into a mesh or an error, within the limits given.
#![no_main]

use libfuzzer_sys::fuzz_target;
use zerotile_codec::mesh::io::{read_bytes, Format, MeshLimits};
use zerotile_codec::mesh::repair;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let format = match pick % 5 {
        0 => Some(Format::Obj),
        1 => Some(Format::Ply),
        2 => Some(Format::Stl),
        3 => Some(Format::Json),
        _ => None,
    };
    let limits = MeshLimits {
        max_vertices: 1 << 16,
        max_faces: 1 << 16,
        max_bytes: 1 << 20,
    };
    if let Ok(mesh) = read_bytes(rest, format, &limits) {
        assert!(mesh.faces.len() <= limits.max_faces);
        if let Ok((clean, _)) = repair(&mesh) {
            let n = clean.positions.len() as u32;
            assert!(clean.faces.iter().flatten().all(|&v| v < n));
        }
    }
});
