//! A quantized-mesh-1.0 reader written from the format's README alone, independent of the
//! codec's decoder, for the end-to-end tests: it checks every invariant a client relies on
//! and returns what it read.

/// A tile as the wire has it.
#[derive(Debug)]
pub struct Tile {
    pub min_height: f32,
    pub max_height: f32,
    pub u: Vec<u16>,
    pub v: Vec<u16>,
    pub h: Vec<u16>,
    pub triangles: Vec<[u32; 3]>,
    /// West, south, east, north.
    pub edges: [Vec<u32>; 4],
    /// (extension id, payload).
    pub extensions: Vec<(u8, Vec<u8>)>,
}

struct Cursor<'a> {
    b: &'a [u8],
    at: usize,
}

impl Cursor<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], String> {
        let end = self.at.checked_add(n).ok_or("length overflow")?;
        let s = self
            .b
            .get(self.at..end)
            .ok_or_else(|| format!("truncated: {n} bytes at {}", self.at))?;
        self.at = end;
        Ok(s)
    }
    fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }
    fn u16(&mut self) -> Result<u16, String> {
        let s = self.take(2)?;
        Ok(u16::from_le_bytes([s[0], s[1]]))
    }
    fn u32(&mut self) -> Result<u32, String> {
        let s = self.take(4)?;
        Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    }
    fn f32(&mut self) -> Result<f32, String> {
        Ok(f32::from_bits(self.u32()?))
    }
}

fn zigzag(v: u16) -> i32 {
    i32::from(v >> 1) ^ -i32::from(v & 1)
}

/// Reads a tile and checks: quantised values in 0..=32767, triangle indices below the vertex
/// count and high-water-mark coded, edge vertices on their edges, nothing after the
/// extensions.
pub fn read(bytes: &[u8]) -> Result<Tile, String> {
    let mut c = Cursor { b: bytes, at: 0 };
    // Header: centre (3 f64), min/max height (2 f32), sphere (4 f64), occlusion point (3 f64).
    c.take(24)?;
    let (min_height, max_height) = (c.f32()?, c.f32()?);
    if min_height
        .partial_cmp(&max_height)
        .is_none_or(|o| o.is_gt())
    {
        return Err(format!("heights {min_height}..{max_height}"));
    }
    c.take(56)?;
    debug_assert_eq!(c.at, 88);

    // Vertices: three zig-zag delta coded arrays.
    let n = c.u32()? as usize;
    if n > bytes.len() {
        return Err(format!("{n} vertices in {} bytes", bytes.len()));
    }
    let mut arrays = [Vec::new(), Vec::new(), Vec::new()];
    for a in &mut arrays {
        let mut value = 0i32;
        for _ in 0..n {
            value += zigzag(c.u16()?);
            if !(0..=32767).contains(&value) {
                return Err(format!("quantised value {value} outside 0..=32767"));
            }
            a.push(value as u16);
        }
    }
    let [u, v, h] = arrays;

    // Indices: 16-bit up to 65 536 vertices, padded to their size first.
    let wide = n > 65_536;
    let width = if wide { 4 } else { 2 };
    if !c.at.is_multiple_of(width) {
        c.take(width - c.at % width)?;
    }
    let index = |c: &mut Cursor| -> Result<u32, String> {
        if wide {
            c.u32()
        } else {
            c.u16().map(u32::from)
        }
    };
    let t = c.u32()? as usize;
    let mut highest = 0u32;
    let mut triangles = Vec::with_capacity(t.min(bytes.len()));
    for _ in 0..t {
        let mut tri = [0u32; 3];
        for slot in &mut tri {
            let code = index(&mut c)?;
            if code > highest {
                return Err(format!(
                    "index code {code} above the high-water mark {highest}"
                ));
            }
            let i = highest - code;
            if code == 0 {
                highest += 1;
            }
            if i as usize >= n {
                return Err(format!("index {i} ≥ {n} vertices"));
            }
            *slot = i;
        }
        triangles.push(tri);
    }

    // Edges: west (u = 0), south (v = 0), east (u = max), north (v = max).
    let mut edges: [Vec<u32>; 4] = Default::default();
    for (k, e) in edges.iter_mut().enumerate() {
        let count = c.u32()? as usize;
        for _ in 0..count {
            let i = index(&mut c)?;
            let (uu, vv) = (
                *u.get(i as usize).ok_or("edge index past the vertices")?,
                v[i as usize],
            );
            let on = match k {
                0 => uu == 0,
                1 => vv == 0,
                2 => uu == 32767,
                _ => vv == 32767,
            };
            if !on {
                return Err(format!(
                    "edge {k} vertex {i} at ({uu}, {vv}) is not on its edge"
                ));
            }
            e.push(i);
        }
    }

    // Extensions to the end.
    let mut extensions = Vec::new();
    while c.at < bytes.len() {
        let id = c.u8()?;
        let len = c.u32()? as usize;
        extensions.push((id, c.take(len)?.to_vec()));
    }
    Ok(Tile {
        min_height,
        max_height,
        u,
        v,
        h,
        triangles,
        edges,
        extensions,
    })
}
