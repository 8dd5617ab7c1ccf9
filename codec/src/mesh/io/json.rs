//! The JSON mesh shape web clients post and fetch:
//! `{"positions": [x0, y0, z0, x1, ...], "indices": [a0, b0, c0, a1, ...]}`.

use std::io::Write;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::MeshLimits;
use crate::mesh::error::MeshError;
use crate::mesh::indexed::TriMesh;

const FORMAT: &str = "JSON";

#[derive(Deserialize)]
struct Flat {
    positions: Vec<f64>,
    indices: Vec<u64>,
}

#[derive(Serialize)]
struct FlatOut {
    positions: Vec<f64>,
    indices: Vec<u32>,
}

pub(super) fn read(bytes: &[u8], limits: &MeshLimits) -> Result<TriMesh, MeshError> {
    let flat: Flat =
        serde_json::from_slice(bytes).map_err(|e| MeshError::decode(FORMAT, e.to_string()))?;
    if !flat.positions.len().is_multiple_of(3) || !flat.indices.len().is_multiple_of(3) {
        return Err(MeshError::decode(
            FORMAT,
            format!(
                "positions ({}) and indices ({}) must be multiples of 3",
                flat.positions.len(),
                flat.indices.len()
            ),
        ));
    }
    limits.vertices(flat.positions.len() as u64 / 3)?;
    limits.faces(flat.indices.len() as u64 / 3)?;
    let positions = flat
        .positions
        .chunks_exact(3)
        .map(|p| DVec3::new(p[0], p[1], p[2]))
        .collect();
    // An index past u32 is past any mesh's vertices: named here as sent, since clamped
    // for check() it would be reported as 4294967295.
    if let Some(k) = flat.indices.iter().position(|&i| u32::try_from(i).is_err()) {
        return Err(MeshError::decode(
            FORMAT,
            format!(
                "face {} has index {}, past the {} vertices",
                k / 3,
                flat.indices[k],
                flat.positions.len() / 3
            ),
        ));
    }
    let faces = flat
        .indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]].map(|i| u32::try_from(i).unwrap_or(u32::MAX)))
        .collect();
    Ok(TriMesh::new(positions, faces))
}

pub(super) fn write(mesh: &TriMesh, out: &mut impl Write) -> Result<(), MeshError> {
    let flat = FlatOut {
        positions: mesh.positions.iter().flat_map(|p| p.to_array()).collect(),
        indices: mesh.faces.iter().flatten().copied().collect(),
    };
    serde_json::to_writer(out, &flat).map_err(|e| MeshError::Encode {
        format: FORMAT,
        what: e.to_string(),
    })
}
