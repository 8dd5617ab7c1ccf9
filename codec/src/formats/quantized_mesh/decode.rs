//! quantized-mesh-1.0 decoder, written from the format README (not from the encoder), for
//! tests, tools and Rust clients.
//!
//! Untrusted bytes: every count is checked against the bytes that remain before anything is
//! allocated for it, so memory stays proportional to the input; every index is checked
//! against the vertex count, and every quantised value against 0..=32767. Malformed input is
//! a [`QmError`], never a panic.

use super::{
    QmError, QmHeader, QuantizedMesh, WaterMask, EXTENSION_METADATA, EXTENSION_OCT_NORMALS,
    EXTENSION_WATER_MASK, MAX_VERTICES_16_BIT, QUANTIZED_MAX, WATER_MASK_SIDE,
};

/// Decodes one uncompressed quantized-mesh-1.0 tile (gunzip first if it came gzipped).
/// Unknown extensions are skipped and listed; a repeated extension is an error.
pub fn decode(bytes: &[u8]) -> Result<QuantizedMesh, QmError> {
    let mut r = Reader { bytes, at: 0 };

    // Header: 3 + 4 + 3 doubles around two floats.
    let header = QmHeader {
        center: r.f64x3("header centre")?,
        min_height: r.f32("header minimum height")?,
        max_height: r.f32("header maximum height")?,
        bounding_sphere_center: r.f64x3("header bounding sphere")?,
        bounding_sphere_radius: r.f64("header bounding sphere radius")?,
        horizon_occlusion_point: r.f64x3("header horizon occlusion point")?,
    };

    // Vertex data: three arrays of zig-zag coded deltas.
    let n = r.count("vertex count", 6)?;
    let u = r.zigzag_array(n, "u")?;
    let v = r.zigzag_array(n, "v")?;
    let height = r.zigzag_array(n, "height")?;

    // Index data: 32-bit above 65 536 vertices, after padding to the index size.
    let width = if n > MAX_VERTICES_16_BIT { 4 } else { 2 };
    r.align(width)?;
    let t = r.count("triangle count", 3 * width as u64)?;
    let mut triangles = Vec::with_capacity(t);
    let mut highest: u64 = 0;
    for k in 0..t {
        let mut tri = [0u32; 3];
        for slot in &mut tri {
            // High-water mark: code 0 introduces the next new vertex.
            let code = u64::from(r.index(width, "triangle index")?);
            if code > highest {
                return Err(QmError::Malformed(format!(
                    "triangle {k}: index code {code} is above the high-water mark {highest}"
                )));
            }
            let index = highest - code;
            if index >= n as u64 {
                return Err(QmError::Malformed(format!(
                    "triangle {k}: index {index} is past the {n} vertices"
                )));
            }
            *slot = index as u32;
            if code == 0 {
                highest += 1;
            }
        }
        triangles.push(tri);
    }

    // Edge lists: west, south, east, north.
    let mut edges: [Vec<u32>; 4] = Default::default();
    for (list, name) in edges.iter_mut().zip(["west", "south", "east", "north"]) {
        let k = r.count(name, width as u64)?;
        list.reserve_exact(k);
        for _ in 0..k {
            let index = r.index(width, name)?;
            if index as usize >= n {
                return Err(QmError::Malformed(format!(
                    "{name} edge index {index} is past the {n} vertices"
                )));
            }
            list.push(index);
        }
    }
    let [west, south, east, north] = edges;

    // Extensions: id, length, data, until the bytes end.
    let mut mesh = QuantizedMesh {
        header,
        u,
        v,
        height,
        triangles,
        west,
        south,
        east,
        north,
        normals: None,
        water_mask: None,
        metadata: None,
        unknown_extensions: Vec::new(),
    };
    while r.remaining() > 0 {
        let id = r.u8("extension id")?;
        let len = r.u32("extension length")?;
        let data = r.take(u64::from(len), "extension data")?;
        let repeated = || QmError::Malformed(format!("extension {id} appears twice"));
        match id {
            EXTENSION_OCT_NORMALS => {
                if mesh.normals.is_some() {
                    return Err(repeated());
                }
                if data.len() != 2 * n {
                    return Err(QmError::Malformed(format!(
                        "oct normals hold {} bytes for {n} vertices (2 each)",
                        data.len()
                    )));
                }
                mesh.normals = Some(data.chunks_exact(2).map(|c| [c[0], c[1]]).collect());
            }
            EXTENSION_WATER_MASK => {
                if mesh.water_mask.is_some() {
                    return Err(repeated());
                }
                mesh.water_mask = Some(match data {
                    [value] => WaterMask::Uniform(*value),
                    grid if grid.len() == WATER_MASK_SIDE * WATER_MASK_SIDE => {
                        WaterMask::Grid(grid.to_vec())
                    }
                    other => {
                        return Err(QmError::Malformed(format!(
                            "water mask of {} bytes (1 or 65 536)",
                            other.len()
                        )))
                    }
                });
            }
            EXTENSION_METADATA => {
                if mesh.metadata.is_some() {
                    return Err(repeated());
                }
                mesh.metadata = Some(metadata(data)?);
            }
            other => mesh.unknown_extensions.push(other),
        }
    }
    Ok(mesh)
}

/// The metadata extension's body: a u32 length, then that many bytes of JSON.
fn metadata(data: &[u8]) -> Result<serde_json::Value, QmError> {
    let mut r = Reader { bytes: data, at: 0 };
    let len = r.u32("metadata JSON length")?;
    let json = r.take(u64::from(len), "metadata JSON")?;
    if r.remaining() != 0 {
        return Err(QmError::Malformed(format!(
            "metadata extension has {} bytes after its JSON",
            r.remaining()
        )));
    }
    serde_json::from_slice(json)
        .map_err(|e| QmError::Malformed(format!("metadata is not JSON: {e}")))
}

/// A little-endian cursor that names what it was reading when the bytes run out.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn remaining(&self) -> usize {
        self.bytes.len() - self.at
    }

    fn take(&mut self, need: u64, what: &'static str) -> Result<&'a [u8], QmError> {
        let have = self.remaining();
        match usize::try_from(need) {
            Ok(k) if k <= have => {
                let slice = &self.bytes[self.at..self.at + k];
                self.at += k;
                Ok(slice)
            }
            _ => Err(QmError::Truncated {
                what,
                at: self.at,
                need,
                have,
            }),
        }
    }

    fn array<const N: usize>(&mut self, what: &'static str) -> Result<[u8; N], QmError> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N as u64, what)?);
        Ok(out)
    }

    fn u8(&mut self, what: &'static str) -> Result<u8, QmError> {
        Ok(self.array::<1>(what)?[0])
    }

    fn u16(&mut self, what: &'static str) -> Result<u16, QmError> {
        Ok(u16::from_le_bytes(self.array(what)?))
    }

    fn u32(&mut self, what: &'static str) -> Result<u32, QmError> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    fn f32(&mut self, what: &'static str) -> Result<f32, QmError> {
        Ok(f32::from_le_bytes(self.array(what)?))
    }

    fn f64(&mut self, what: &'static str) -> Result<f64, QmError> {
        Ok(f64::from_le_bytes(self.array(what)?))
    }

    fn f64x3(&mut self, what: &'static str) -> Result<[f64; 3], QmError> {
        Ok([self.f64(what)?, self.f64(what)?, self.f64(what)?])
    }

    /// A u32 count of items of `item_bytes` each, refused unless that many bytes remain:
    /// the bound that keeps allocations proportional to the input.
    fn count(&mut self, what: &'static str, item_bytes: u64) -> Result<usize, QmError> {
        let k = self.u32(what)?;
        let need = u64::from(k) * item_bytes;
        if need > self.remaining() as u64 {
            return Err(QmError::Truncated {
                what,
                at: self.at,
                need,
                have: self.remaining(),
            });
        }
        Ok(k as usize)
    }

    fn index(&mut self, width: usize, what: &'static str) -> Result<u32, QmError> {
        if width == 4 {
            self.u32(what)
        } else {
            self.u16(what).map(u32::from)
        }
    }

    /// Skips the padding that aligns the index data to `width` bytes from the file start.
    fn align(&mut self, width: usize) -> Result<(), QmError> {
        let pad = (width - self.at % width) % width;
        self.take(pad as u64, "index padding").map(|_| ())
    }

    /// `n` values, each the previous plus a zig-zag decoded delta, checked to 0..=32767.
    fn zigzag_array(&mut self, n: usize, what: &'static str) -> Result<Vec<u16>, QmError> {
        let mut out = Vec::with_capacity(n);
        let mut value: i32 = 0;
        for i in 0..n {
            let code = i32::from(self.u16(what)?);
            value += (code >> 1) ^ -(code & 1);
            if !(0..=i32::from(QUANTIZED_MAX)).contains(&value) {
                return Err(QmError::Malformed(format!(
                    "{what} of vertex {i} decodes to {value}, outside 0..=32767"
                )));
            }
            out.push(value as u16);
        }
        Ok(out)
    }
}
