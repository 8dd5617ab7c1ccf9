//! Wavefront OBJ through `tobj`: positions and faces only (normals, texture coordinates,
//! materials, points and polylines are ignored), polygons cut into triangles by [`Triangulator`].

use std::borrow::Cow;
use std::io::Write;

use glam::DVec3;

use super::polygon::Triangulator;
use super::MeshLimits;
use crate::mesh::error::{InvalidMesh, MeshError};
use crate::mesh::indexed::TriMesh;

const FORMAT: &str = "OBJ";

/// A text whose first meaningful line is an OBJ statement.
pub(super) fn looks_like_obj(text: &[u8]) -> bool {
    const STATEMENTS: [&[u8]; 10] = [
        b"#", b"v ", b"v\t", b"vn", b"vt", b"f ", b"o ", b"g ", b"mtllib", b"usemtl",
    ];
    STATEMENTS.iter().any(|s| text.starts_with(s))
}

pub(super) fn read(bytes: &[u8], limits: &MeshLimits) -> Result<TriMesh, MeshError> {
    // Count statements before tobj allocates: a cheap bound for the limits.
    let (v_lines, f_lines) = count_statements(bytes);
    limits.vertices(v_lines)?;
    limits.faces(f_lines)?;
    // Parse: positions indexed per model, polygons as the file has them (tobj would fan them).
    let options = tobj::LoadOptions {
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
        ..tobj::LoadOptions::default()
    };
    // tobj reads lines as UTF-8 and fails the whole file ("read error") on one byte that is
    // not, which older exporters write in comments and names (Latin-1 "Créé par"); none of
    // those bytes can be in a number the mesh needs, so they are replaced instead.
    let text = for_tobj(super::lenient_text(bytes));
    let mut reader = text.as_bytes();
    let (models, _materials) = tobj::load_obj_buf(&mut reader, &options, |_| {
        // Material libraries are never opened: a mesh upload must not read other files.
        Err(tobj::LoadError::GenericFailure)
    })
    .map_err(|e| {
        let at = super::obj_locate::locate(&text, &e);
        MeshError::decode(FORMAT, at.map_or(e.to_string(), |at| format!("{e}: {at}")))
    })?;
    // Concatenate models (tobj gives each its own copy of the vertices it uses), cutting
    // their polygons into triangles.
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    let mut model_of = Vec::new();
    let mut cut = Triangulator::new();
    let mut polygon = Vec::new();
    for (m, model) in models.iter().enumerate() {
        let base = positions.len() as u32;
        let mesh = &model.mesh;
        positions.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|p| DVec3::new(p[0], p[1], p[2])),
        );
        model_of.resize(positions.len(), m as u32);
        // No arities: every face is a triangle.
        let mut corners = mesh.indices.iter().map(|&i| base + i);
        let arities = mesh.face_arities.iter().map(|&n| n as usize);
        for n in arities.chain(std::iter::repeat(3)) {
            polygon.clear();
            polygon.extend(corners.by_ref().take(n));
            if polygon.len() < n {
                break;
            }
            cut.push(&positions, &polygon, &mut faces, limits)?;
        }
    }
    let count = positions.iter().filter(|p| !p.is_finite()).count();
    if count > 0 {
        if let Some((vertex, line)) = first_non_finite_v(&text) {
            return Err(InvalidMesh::NonFiniteObjVertex {
                count,
                vertex,
                line,
            }
            .into());
        }
    }
    let mut out = TriMesh::new(positions, faces);
    if models.len() > 1 {
        rejoin_models(&mut out, &model_of);
    }
    Ok(out)
}

/// The first `v` statement with a coordinate that reads as NaN or infinite: its number, as
/// faces count them (from 1), and its line.
fn first_non_finite_v(text: &str) -> Option<(usize, usize)> {
    let mut vertex = 0;
    for (k, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if words.next() != Some("v") {
            continue;
        }
        vertex += 1;
        let bad = words
            .take(3)
            .any(|w| w.parse::<f64>().is_ok_and(|x| !x.is_finite()));
        if bad {
            return Some((vertex, k + 1));
        }
    }
    None
}

/// Statements whose argument is a name (tobj takes the rest of the line), which may hold a `#`.
const NAMED: [&str; 4] = ["o", "g", "usemtl", "mtllib"];

/// The text as tobj should read it, line for line with the file's, so a message naming a line
/// names the file's:
/// - A comment is cut off: `#` starts one anywhere in a line (`f 1 2 4 # note`), but tobj
///   takes it only at the start and read the rest as numbers, refusing the whole file. Names
///   are left whole (a `usemtl` left without one is an error to tobj, and names are not used).
/// - A polyline statement (`l a b c …`) is blanked: tobj parses `l` like `f`, so a polyline
///   through three or more vertices (a CAD export's edges, a curve) became polygons, triangles
///   the file never had; polylines are no surface. (Removed, they shifted the lines after
///   them in messages.)
fn for_tobj(text: Cow<'_, str>) -> Cow<'_, str> {
    // tobj splits statements on any Unicode whitespace; so must this, or `l` + vertical tab
    // or no-break space would still reach it as a polygon.
    let polyline = |line: &str| keyword(line) == Some("l");
    let commented =
        |line: &str| line.contains('#') && !keyword(line).is_some_and(|k| NAMED.contains(&k));
    if !text.lines().any(|l| polyline(l) || commented(l)) {
        return text;
    }
    let mut kept = String::with_capacity(text.len());
    for line in text.lines() {
        let statement = if polyline(line) {
            ""
        } else if commented(line) {
            line.split('#').next().unwrap_or_default()
        } else {
            line
        };
        kept.push_str(statement);
        kept.push('\n');
    }
    kept.into()
}

/// A statement's first word.
fn keyword(line: &str) -> Option<&str> {
    line.split_whitespace().next()
}

/// Lines starting `v ` and `f `: upper bounds of vertices and lower bounds of triangles.
fn count_statements(bytes: &[u8]) -> (u64, u64) {
    let (mut v, mut f) = (0, 0);
    for line in bytes.split(|&c| c == b'\n') {
        let line = line.trim_ascii_start();
        match line {
            [b'v', b' ' | b'\t', ..] => v += 1,
            [b'f', b' ' | b'\t', ..] => f += 1,
            _ => {}
        }
    }
    (v, f)
}

/// Re-shares vertices that tobj duplicated across `o`/`g` groups: a position that appears once
/// in each of several models is one file vertex. Duplicates inside one model are kept, so a file
/// that is unwelded on purpose stays unwelded.
fn rejoin_models(mesh: &mut TriMesh, model_of: &[u32]) {
    let key = |p: DVec3| p.to_array().map(|c| (c + 0.0).to_bits());
    let mut order: Vec<u32> = (0..mesh.positions.len() as u32).collect();
    order.sort_unstable_by_key(|&i| (key(mesh.positions[i as usize]), i));
    let mut canon: Vec<u32> = (0..mesh.positions.len() as u32).collect();
    let mut start = 0;
    while start < order.len() {
        let k = key(mesh.positions[order[start] as usize]);
        let end = order[start..]
            .iter()
            .position(|&i| key(mesh.positions[i as usize]) != k)
            .map_or(order.len(), |n| start + n);
        let run = &order[start..end];
        let mut models: Vec<u32> = run.iter().map(|&i| model_of[i as usize]).collect();
        models.sort_unstable();
        let distinct = models.windows(2).all(|w| w[0] != w[1]);
        if run.len() > 1 && distinct {
            for &i in run {
                canon[i as usize] = run[0];
            }
        }
        start = end;
    }
    for i in mesh.faces.iter_mut().flatten() {
        *i = canon[*i as usize];
    }
    mesh.drop_unreferenced();
}

pub(super) fn write(mesh: &TriMesh, out: &mut impl Write) -> Result<(), MeshError> {
    let mut w = std::io::BufWriter::new(out);
    writeln!(
        w,
        "# zerotile: {} vertices, {} faces",
        mesh.positions.len(),
        mesh.faces.len()
    )?;
    for p in &mesh.positions {
        writeln!(w, "v {} {} {}", Coord(p.x), Coord(p.y), Coord(p.z))?;
    }
    for t in &mesh.faces {
        let [a, b, c] = t.map(|i| u64::from(i) + 1);
        writeln!(w, "f {a} {b} {c}")?;
    }
    w.flush()?;
    Ok(())
}

/// An f64 in the shortest digits that read back to it. `{}` gives those in fixed notation
/// only, so 1e-300 was 300 digits; outside ordinary magnitudes (the range in which serde_json
/// and ryu write fixed notation too) exponent notation (`1e-300`, which OBJ readers parse)
/// is used where it is shorter, and ordinary coordinates are written as they always were.
struct Coord(f64);

impl std::fmt::Display for Coord {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let x = self.0;
        if x == 0.0 || (1e-5..1e16).contains(&x.abs()) {
            return write!(f, "{x}");
        }
        let (fixed, exp) = (x.to_string(), format!("{x:e}"));
        f.write_str(if exp.len() < fixed.len() {
            &exp
        } else {
            &fixed
        })
    }
}
