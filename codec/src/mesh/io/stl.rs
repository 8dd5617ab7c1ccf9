//! STL through `stl_io` (ASCII and binary in). STL stores every triangle with its own three
//! corners; `stl_io` welds bit-identical corners, which is the mesh the file means.

use std::borrow::Cow;
use std::collections::HashMap;
use std::io::Cursor;

use glam::DVec3;

use super::MeshLimits;
use crate::mesh::error::MeshError;
use crate::mesh::indexed::TriMesh;

const FORMAT: &str = "STL";
/// 80-byte header and a little-endian u32 triangle count.
const HEADER: usize = 84;
/// Normal, three corners (12 f32) and a u16 attribute word.
const RECORD: u64 = 50;

/// The triangle count a binary STL header claims, if the bytes are long enough to hold it.
fn claimed(bytes: &[u8]) -> Option<u64> {
    let count: [u8; 4] = bytes.get(80..HEADER)?.try_into().ok()?;
    Some(u64::from(u32::from_le_bytes(count)))
}

/// Binary STL has no magic number: its length must be exactly 84 + 50 × the claimed count.
pub(super) fn is_binary(bytes: &[u8]) -> bool {
    claimed(bytes).is_some_and(|n| HEADER as u64 + RECORD * n == bytes.len() as u64)
}

/// An ASCII STL's text from its `solid` keyword on, past a byte-order mark and blank space.
/// The solid's name is optional, so `solid` may end its line: files whose first line was a
/// bare `solid` were read as binary and refused for the huge triangle count their text spelt.
fn ascii_text(bytes: &[u8]) -> Option<&[u8]> {
    let text = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let text = text.trim_ascii_start();
    let after = text.strip_prefix(b"solid")?;
    after
        .first()
        .is_none_or(u8::is_ascii_whitespace)
        .then_some(text)
}

pub(super) fn read(bytes: &[u8], limits: &MeshLimits) -> Result<TriMesh, MeshError> {
    let ascii = ascii_text(bytes).filter(|_| !is_binary(bytes));
    let mesh = if let Some(text) = ascii {
        // A binary file whose header starts with "solid" and which has bytes past its records
        // (some exporters pad) looks like text: read as binary when the text fails, and if
        // that fails too (its claimed count checked against the limits and the bytes first)
        // the text's error stands.
        read_ascii(text).or_else(|ascii_err| read_binary(bytes, limits).map_err(|_| ascii_err))?
    } else {
        read_binary(bytes, limits)?
    };
    limits.vertices(mesh.vertices.len() as u64)?;
    limits.faces(mesh.faces.len() as u64)?;
    let positions = mesh
        .vertices
        .iter()
        .map(|v| DVec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2])))
        .collect();
    let faces = mesh
        .faces
        .iter()
        .map(|t| t.vertices.map(|i| u32::try_from(i).unwrap_or(u32::MAX)))
        .collect();
    Ok(TriMesh::new(positions, faces))
}

fn read_ascii(text: &[u8]) -> Result<stl_io::IndexedMesh, MeshError> {
    // stl_io reads lines as UTF-8, and on one byte that is not (a Latin-1 solid name, "solid
    // caf\xe9") took the file for binary ("failed to fill whole buffer"); numbers and keywords
    // are ASCII, so such bytes are replaced, as the OBJ reader does.
    // stl_io takes a file for ASCII only when it starts with "solid " (space included): a
    // bare "solid" gets its space in the same one copy, not a second copy of the first.
    let text: Cow<str> = match text.strip_prefix(b"solid") {
        Some(rest) if !rest.starts_with(b" ") => {
            let mut s = String::with_capacity(text.len() + 1);
            s.push_str("solid ");
            super::push_lenient(&mut s, rest);
            s.into()
        }
        _ => super::lenient_text(text),
    };
    stl_io::read_stl(&mut Cursor::new(text.as_bytes()))
        .map_err(|e| MeshError::decode(FORMAT, e.to_string()))
}

/// Binary STL, read in place. stl_io tells binary from text by looking for "solid ", so a
/// header starting with it needed a copy of the whole file with those bytes blanked, and its
/// look reads a line, which in binary data without a newline byte runs to the file's end.
/// The records are fixed-size, so they are read here and welded as stl_io welds them (by the
/// corners' bit patterns, in order of first use).
fn read_binary(bytes: &[u8], limits: &MeshLimits) -> Result<stl_io::IndexedMesh, MeshError> {
    // The claimed count against the limits and the bytes present, before reading.
    let n = claimed(bytes).ok_or_else(|| {
        MeshError::decode(
            FORMAT,
            format!("truncated: {} bytes, no header", bytes.len()),
        )
    })?;
    // The bytes first: another format sent as STL "claims" hundreds of millions of
    // triangles, and a limit error for those would hide what is wrong.
    let need = HEADER as u64 + RECORD * n;
    let records = usize::try_from(need)
        .ok()
        .and_then(|need| bytes.get(HEADER..need))
        .ok_or_else(|| {
            MeshError::decode(
                FORMAT,
                format!(
                    "truncated, or not STL (text STL starts with \"solid\"): the binary header \
                     claims {n} triangles ({need} bytes), the file has {}",
                    bytes.len()
                ),
            )
        })?;
    // Past the records, padding (some exporters add a few bytes, or zeros) is let be; a whole
    // record's worth of data more is a count that is too small, and reading only what it
    // claims dropped those triangles silently.
    let rest = &bytes[records.len() + HEADER..];
    if rest.len() >= RECORD as usize && rest.iter().any(|&b| b != 0) {
        return Err(MeshError::decode(
            FORMAT,
            format!(
                "the binary header claims {n} triangles ({need} bytes), but the file has {} \
                 bytes, {} whole triangles more: a wrong count would drop them",
                bytes.len(),
                rest.len() / RECORD as usize
            ),
        ));
    }
    limits.faces(n)?;
    let mut index: HashMap<[u32; 3], usize> = HashMap::new();
    let mut vertices = Vec::new();
    let mut faces = Vec::with_capacity(records.len() / RECORD as usize);
    for r in records.chunks_exact(RECORD as usize) {
        let f = |k: usize| f32::from_le_bytes([r[k], r[k + 1], r[k + 2], r[k + 3]]);
        let mut corners = [0; 3];
        for (c, at) in corners.iter_mut().zip([12, 24, 36]) {
            let p = [f(at), f(at + 4), f(at + 8)];
            *c = *index.entry(p.map(f32::to_bits)).or_insert_with(|| {
                vertices.push(stl_io::Vertex::new(p));
                vertices.len() - 1
            });
        }
        faces.push(stl_io::IndexedTriangle {
            normal: stl_io::Normal::new([f(0), f(4), f(8)]),
            vertices: corners,
        });
    }
    Ok(stl_io::IndexedMesh { vertices, faces })
}
