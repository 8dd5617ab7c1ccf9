//! Stanford PLY through `ply-rs-bw` (ASCII, binary little- and big-endian in; binary
//! little-endian out). Reads `vertex` {x, y, z} of any numeric type and `face`
//! {`vertex_indices` | `vertex_index`} lists of any integer type; other elements and properties
//! are skipped. Element counts from the header are checked against the limits and against the
//! bytes present before the parser sizes anything from them.

use std::io::Write;

use glam::DVec3;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    Addable, ElementDef, Encoding, Header, PropertyAccess, PropertyAccessResult, PropertyDef,
    PropertyType, ScalarType,
};
use ply_rs_bw::writer::Writer;

use super::polygon::Triangulator;
use super::MeshLimits;
use crate::mesh::error::{InvalidMesh, MeshError};
use crate::mesh::indexed::TriMesh;

const FORMAT: &str = "PLY";

pub(super) fn read(bytes: &[u8], limits: &MeshLimits) -> Result<TriMesh, MeshError> {
    let decode = |e: ply_rs_bw::parser::ParseError| MeshError::decode(FORMAT, tidy(&e.to_string()));
    let mut reader = Reader::new(bytes);
    // Header: the declared counts, checked before any payload is read.
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(decode)?;
    check_counts(&header, reader.get_ref().len(), limits)?;
    // Payload, element by element in header order (the format's only order).
    let mut positions = Vec::new();
    let mut polygons = Vec::new();
    for (name, def) in &header.elements {
        match name.as_str() {
            "vertex" => {
                let vs = Parser::<PlyVertex>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(decode)?;
                positions = vs.into_iter().map(|v| DVec3::from_array(v.xyz)).collect();
            }
            "face" => {
                polygons = Parser::<PlyFace>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(decode)?;
            }
            _ => {
                Parser::<Skip>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(decode)?;
            }
        }
    }
    // Faces once the vertices are known: a header may list the faces first, and cutting a
    // polygon needs its corners' positions.
    check_faces(&polygons, positions.len())?;
    let mut faces = Vec::with_capacity(polygons.len());
    let mut cut = Triangulator::new();
    for f in &polygons {
        cut.push(&positions, &f.indices, &mut faces, limits)?;
        limits.faces(faces.len() as u64)?;
    }
    Ok(TriMesh::new(positions, faces))
}

/// Refuses faces with a negative index, fewer than three corners, or an index past the
/// vertices; the last named by the face's number in the file (from 0), which its triangles
/// would not keep.
fn check_faces(polygons: &[PlyFace], vertices: usize) -> Result<(), MeshError> {
    for f in polygons {
        if f.negative {
            return Err(MeshError::decode(FORMAT, "a face has a negative index"));
        }
        if f.indices.len() < 3 {
            return Err(MeshError::decode(
                FORMAT,
                format!(
                    "a face has {} corners (3 or more expected)",
                    f.indices.len()
                ),
            ));
        }
    }
    let past = |i: &&u32| **i as usize >= vertices;
    let first = polygons
        .iter()
        .enumerate()
        .find_map(|(face, f)| f.indices.iter().find(past).map(|&i| (face, i)));
    if let Some((face, index)) = first {
        let count = polygons
            .iter()
            .flat_map(|f| &f.indices)
            .filter(past)
            .count();
        return Err(InvalidMesh::IndexOutOfRange {
            count,
            face,
            index: u64::from(index),
            vertices,
        }
        .into());
    }
    Ok(())
}

/// The parser's message on one line: for a header line it cannot parse it prints the line
/// and then its grammar's error as Rust debug output (`ParseError { location: LineCol { …`),
/// which says nothing to a user but the tokens it expected.
fn tidy(message: &str) -> String {
    let mut lines = message.lines();
    let mut out = lines.next().unwrap_or_default().trim().to_string();
    for line in lines.map(str::trim) {
        if let Some(text) = line.strip_prefix("String: '") {
            out.push_str(&format!(" `{}`", text.trim_end_matches('\'').trim()));
        } else if let Some(set) = line.split("expected: {").nth(1) {
            let tokens: Vec<&str> = set
                .split('}')
                .next()
                .unwrap_or_default()
                .split(", ")
                .map(|t| t.trim_matches(|c| c == '"' || c == '\\'))
                .filter(|t| t.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'))
                .filter(|t| !t.is_empty())
                .collect();
            if !tokens.is_empty() {
                out.push_str(&format!(" (expected {})", tokens.join(", ")));
            }
        } else if !matches!(line, "" | "'") && !line.starts_with("Error:") {
            out.push(' ');
            out.push_str(line.trim_end_matches('\''));
        }
    }
    out
}

/// Declared counts against the limits, the needed properties, and the body length (every
/// element with a property takes at least one byte, ASCII or binary).
fn check_counts(header: &Header, body: usize, limits: &MeshLimits) -> Result<(), MeshError> {
    let vertex = header
        .elements
        .get("vertex")
        .ok_or_else(|| MeshError::decode(FORMAT, "no `vertex` element in the header"))?;
    for axis in ["x", "y", "z"] {
        match vertex.properties.get(axis).map(|p| &p.data_type) {
            Some(PropertyType::Scalar(_)) => {}
            _ => {
                return Err(MeshError::decode(
                    FORMAT,
                    format!("the vertex element has no scalar `{axis}`"),
                ))
            }
        }
    }
    limits.vertices(vertex.count as u64)?;
    if let Some(face) = header.elements.get("face") {
        let has_indices = face.properties.iter().any(|(n, p)| {
            matches!(p.data_type, PropertyType::List(..))
                && (n == "vertex_indices" || n == "vertex_index")
        });
        if !has_indices {
            return Err(MeshError::decode(
                FORMAT,
                "the face element has no `vertex_indices` list",
            ));
        }
        limits.faces(face.count as u64)?;
    }
    for (name, def) in &header.elements {
        if def.properties.is_empty() && def.count > 0 {
            return Err(MeshError::decode(
                FORMAT,
                format!(
                    "element `{name}` has {} entries but no properties",
                    def.count
                ),
            ));
        }
        if def.count > body {
            return Err(MeshError::decode(
                FORMAT,
                format!(
                    "truncated: element `{name}` claims {} entries but only {body} bytes follow \
                     the header",
                    def.count
                ),
            ));
        }
    }
    Ok(())
}

/// A vertex: x, y, z of whatever numeric type the file declares.
struct PlyVertex {
    xyz: [f64; 3],
}

impl PlyVertex {
    fn set(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        let i = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => return PropertyAccessResult::Ignored,
        };
        self.xyz[i] = v;
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self { xyz: [0.0; 3] }
    }
    fn set_char(&mut self, n: &str, v: i8) -> PropertyAccessResult {
        self.set(n, f64::from(v))
    }
    fn set_uchar(&mut self, n: &str, v: u8) -> PropertyAccessResult {
        self.set(n, f64::from(v))
    }
    fn set_short(&mut self, n: &str, v: i16) -> PropertyAccessResult {
        self.set(n, f64::from(v))
    }
    fn set_ushort(&mut self, n: &str, v: u16) -> PropertyAccessResult {
        self.set(n, f64::from(v))
    }
    fn set_int(&mut self, n: &str, v: i32) -> PropertyAccessResult {
        self.set(n, f64::from(v))
    }
    fn set_uint(&mut self, n: &str, v: u32) -> PropertyAccessResult {
        self.set(n, f64::from(v))
    }
    fn set_float(&mut self, n: &str, v: f32) -> PropertyAccessResult {
        self.set(n, f64::from(v))
    }
    fn set_double(&mut self, n: &str, v: f64) -> PropertyAccessResult {
        self.set(n, v)
    }
}

/// A face: its corner list, whatever integer type the file declares.
struct PlyFace {
    indices: Vec<u32>,
    negative: bool,
}

impl PlyFace {
    fn set<T: Copy + TryInto<u32>>(&mut self, name: &str, v: &[T]) -> PropertyAccessResult {
        if name != "vertex_indices" && name != "vertex_index" {
            return PropertyAccessResult::Ignored;
        }
        self.indices.clear();
        for &i in v {
            match i.try_into() {
                Ok(i) => self.indices.push(i),
                Err(_) => self.negative = true,
            }
        }
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        Self {
            indices: Vec::new(),
            negative: false,
        }
    }
    fn set_list_char(&mut self, n: &str, v: Vec<i8>) -> PropertyAccessResult {
        self.set(n, &v)
    }
    fn set_list_uchar(&mut self, n: &str, v: Vec<u8>) -> PropertyAccessResult {
        self.set(n, &v)
    }
    fn set_list_short(&mut self, n: &str, v: Vec<i16>) -> PropertyAccessResult {
        self.set(n, &v)
    }
    fn set_list_ushort(&mut self, n: &str, v: Vec<u16>) -> PropertyAccessResult {
        self.set(n, &v)
    }
    fn set_list_int(&mut self, n: &str, v: Vec<i32>) -> PropertyAccessResult {
        self.set(n, &v)
    }
    fn set_list_uint(&mut self, n: &str, v: Vec<u32>) -> PropertyAccessResult {
        self.set(n, &v)
    }
}

/// An element whose contents are skipped (and the writer's unused element type).
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Self
    }
}

/// Binary little-endian: f32 x, y, z and `uchar uint` index lists, as most tools write.
pub(super) fn write(mesh: &TriMesh, out: &mut impl Write) -> Result<(), MeshError> {
    let encode = |e: std::io::Error| MeshError::Encode {
        format: FORMAT,
        what: e.to_string(),
    };
    // Past f32's range a coordinate would be written as an infinity other tools choke on,
    // and the file would not be the mesh (GLB refuses the same).
    if let Some((i, p)) = mesh
        .positions
        .iter()
        .enumerate()
        .find(|(_, p)| !p.as_vec3().is_finite())
    {
        return Err(MeshError::Encode {
            format: FORMAT,
            what: format!("vertex {i} at {p} is beyond f32's range"),
        });
    }
    let mut header = Header::new();
    header.encoding = Encoding::BinaryLittleEndian;
    header.comments.push("zerotile".into());
    let mut vertex = ElementDef::new("vertex".into());
    vertex.count = mesh.positions.len();
    for axis in ["x", "y", "z"] {
        let p = PropertyDef::new(axis.into(), PropertyType::Scalar(ScalarType::Float));
        vertex.properties.add(p);
    }
    let mut face = ElementDef::new("face".into());
    face.count = mesh.faces.len();
    let list = PropertyType::List(ScalarType::UChar, ScalarType::UInt);
    face.properties
        .add(PropertyDef::new("vertex_indices".into(), list));
    header.elements.add(vertex);
    header.elements.add(face);
    let mut w = std::io::BufWriter::new(out);
    Writer::<Skip>::new()
        .write_header(&mut w, &header)
        .map_err(encode)?;
    // The payload is fixed-size records: written directly, 12 + 13 bytes per vertex / face.
    for p in &mesh.positions {
        for c in p.as_vec3().to_array() {
            w.write_all(&c.to_le_bytes())?;
        }
    }
    for t in &mesh.faces {
        w.write_all(&[3])?;
        for i in t {
            w.write_all(&i.to_le_bytes())?;
        }
    }
    w.flush()?;
    Ok(())
}
