//! Format round trips and bad inputs.

use glam::DVec3;

use super::*;
use crate::mesh::error::{InvalidMesh, MeshError};

fn shared(name: &str) -> std::path::PathBuf {
    crate::fixtures::shared_data(&format!("meshes/{name}"))
}

fn limits() -> MeshLimits {
    MeshLimits::default()
}

fn quad() -> TriMesh {
    TriMesh::new(
        vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.5), DVec3::Y],
        vec![[0, 1, 2], [0, 2, 3]],
    )
}

/// Same faces, positions equal to f32 precision (PLY and GLB store f32).
fn assert_same_f32(a: &TriMesh, b: &TriMesh) {
    assert_eq!(a.faces, b.faces);
    assert_eq!(a.positions.len(), b.positions.len());
    for (p, q) in a.positions.iter().zip(&b.positions) {
        assert_eq!(p.as_vec3(), q.as_vec3());
    }
}

#[test]
fn obj_to_ply_to_obj_round_trips_fandisk() {
    let obj = read_path(&shared("fandisk.obj"), &limits()).expect("fandisk");
    let ply = write_bytes(&obj, Format::Ply).expect("ply");
    let back = read_bytes(&ply, None, &limits()).expect("ply reads");
    assert_same_f32(&obj, &back);
    let text = write_bytes(&back, Format::Obj).expect("obj");
    let again = read_bytes(&text, Some(Format::Obj), &limits()).expect("obj reads");
    // OBJ text holds f64 exactly: the second hop changes nothing.
    assert_eq!(again, back);
}

#[test]
fn obj_and_json_keep_f64_exactly() {
    let mut m = quad();
    m.positions[2] = DVec3::new(0.1, 1.0 / 3.0, -1e-300);
    // Shortest round-trip digits, 17 of them for most: serde_json's default parser is not
    // correctly rounded there, and read -3.6488749249916674 (a QEM vertex of the cow) one
    // ulp off, so a JSON answer uploaded again was another mesh.
    m.positions[3] = DVec3::new(-3.6488749249916674, 5.998088e-7, 1e22 / 3.0);
    let mut x = 0x9E37_79B9_7F4A_7C15_u64;
    for _ in 0..200 {
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // A finite f64 of any exponent from 2^-60 to 2^60, either sign.
            f64::from_bits((x & 0x800F_FFFF_FFFF_FFFF) | ((1023 - 60 + x % 121) << 52))
        };
        let n = m.positions.len() as u32;
        let mut corner = || DVec3::new(next(), next(), next());
        m.positions.extend([corner(), corner(), corner()]);
        m.faces.push([n, n + 1, n + 2]);
    }
    for format in [Format::Obj, Format::Json] {
        let bytes = write_bytes(&m, format).expect("encodes");
        assert_eq!(Format::sniff(&bytes), Some(format));
        let back = read_bytes(&bytes, None, &limits()).expect("decodes");
        let off = m
            .positions
            .iter()
            .zip(&back.positions)
            .find(|(a, b)| a != b);
        assert!(off.is_none(), "{}: {off:?}", format.name());
        assert_eq!(back, m);
    }
}

/// Coordinates at f64's ends read back bit for bit from OBJ and JSON, and OBJ writes them
/// in a few characters: 1e-300 was 300 digits in fixed notation. Ordinary coordinates are
/// written as before.
#[test]
fn obj_and_json_write_extreme_coordinates_short_and_exact() {
    let extremes = [
        1e-300,
        5e-324,
        f64::MAX,
        -0.0,
        -1.2345e-300,
        f64::MIN_POSITIVE,
        -9.999999999999999e-6,
        1e16,
        1.2345678901234567e16,
        -1e300,
    ];
    let mut m = quad();
    m.positions[2] = DVec3::new(0.5, -3.6488749249916674, 1000.0);
    for c in extremes.chunks(3) {
        let n = m.positions.len() as u32;
        let at = |i: usize| c.get(i).copied().unwrap_or(0.25);
        m.positions
            .extend([DVec3::new(at(0), at(1), at(2)), DVec3::X, DVec3::Y]);
        m.faces.push([n, n + 1, n + 2]);
    }
    let bits = |m: &TriMesh| -> Vec<[u64; 3]> {
        m.positions
            .iter()
            .map(|p| p.to_array().map(f64::to_bits))
            .collect()
    };
    for format in [Format::Obj, Format::Json] {
        let bytes = write_bytes(&m, format).expect("encodes");
        let back = read_bytes(&bytes, Some(format), &limits()).expect("decodes");
        assert_eq!(bits(&back), bits(&m), "{}", format.name());
        assert_eq!(back.faces, m.faces, "{}", format.name());
    }
    let obj = String::from_utf8(write_bytes(&m, Format::Obj).expect("encodes")).expect("text");
    let longest = obj.lines().map(str::len).max().unwrap_or(0);
    assert!(longest <= 80, "a {longest}-character line:\n{obj}");
    assert!(obj.contains("\nv 0.5 -3.6488749249916674 1000\n"), "{obj}");
    assert!(
        obj.contains("\nv 1e-300 5e-324 1.7976931348623157e308\n"),
        "{obj}"
    );
    assert!(obj.contains("\nv -0 -1.2345e-300 "), "{obj}");
    assert!(
        obj.contains("\nv -9.999999999999999e-6 1e16 12345678901234568\n"),
        "{obj}"
    );
    assert!(obj.contains("\nv -1e300 0.25 0.25\n"), "{obj}");
    // serde_json writes them short already (ryu): 1e-300, 1.7976931348623157e308.
    let json = String::from_utf8(write_bytes(&m, Format::Json).expect("encodes")).expect("text");
    let longest = json.split([',', '[']).map(str::len).max().unwrap_or(0);
    assert!(longest <= 24, "a {longest}-character number: {json}");
}

#[test]
fn ascii_and_big_endian_ply_read() {
    let ascii = b"ply\nformat ascii 1.0\ncomment hi\nelement vertex 4\nproperty float x\n\
property float y\nproperty float z\nproperty uchar red\nelement face 1\n\
property list uchar int vertex_indices\nend_header\n0 0 0 1\n1 0 0 2\n1 1 0.5 3\n0 1 0 4\n\
4 0 1 2 3\n";
    let m = read_bytes(ascii, None, &limits()).expect("ascii ply");
    assert_eq!(m, quad());
    let mut be = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty double x\n\
property double y\nproperty double z\nelement face 1\nproperty list uchar uint vertex_indices\n\
end_header\n"
        .to_vec();
    for v in [0.0f64, 0., 0., 1., 0., 0., 0., 1., 0.] {
        be.extend_from_slice(&v.to_be_bytes());
    }
    be.push(3);
    for i in [0u32, 1, 2] {
        be.extend_from_slice(&i.to_be_bytes());
    }
    let m = read_bytes(&be, Some(Format::Ply), &limits()).expect("big-endian ply");
    assert_eq!(m.faces, vec![[0, 1, 2]]);
    assert_eq!(m.positions[1], DVec3::X);
}

#[test]
fn stl_binary_and_ascii_read_and_weld() {
    let ascii = b"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n\
vertex 1 1 0.5\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n\
vertex 1 1 0.5\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
    let m = read_bytes(ascii, None, &limits()).expect("ascii stl");
    assert_eq!(m, quad());
    let bin = binary_stl(&quad(), b"solid but actually binary");
    assert_eq!(Format::sniff(&bin), Some(Format::Stl));
    assert_eq!(
        read_bytes(&bin, None, &limits()).expect("binary stl"),
        quad()
    );
}

/// What editors and older exporters write around the same quad: a UTF-8 byte-order mark,
/// an ASCII STL solid without a name (or indented), a Latin-1 comment in an OBJ. Each was
/// refused: the BOM'd OBJ lost its first vertex ("index out of bounds"), the BOM'd JSON was
/// "expected value", the STLs were read as binary (a limit error for ~1.7e9 faces), and the
/// Latin-1 OBJ was "read error".
#[test]
fn text_meshes_read_past_a_bom_a_bare_solid_and_latin1_bytes() {
    const BOM: &[u8] = b"\xEF\xBB\xBF";
    let obj = b"v 0 0 0\nv 1 0 0\nv 1 1 0.5\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
    let json = write_bytes(&quad(), Format::Json).unwrap();
    let facets = "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n\
vertex 1 1 0.5\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n\
vertex 1 1 0.5\nvertex 0 1 0\nendloop\nendfacet\nendsolid\n";
    let mut latin1 = b"# cr\xe9\xe9 par un vieux logiciel\no caf\xe9\n".to_vec();
    latin1.extend_from_slice(obj);
    let cases: Vec<(&str, Vec<u8>, Format)> = vec![
        ("OBJ with a BOM", [BOM, obj].concat(), Format::Obj),
        ("JSON with a BOM", [BOM, &json].concat(), Format::Json),
        ("OBJ with Latin-1 bytes", latin1, Format::Obj),
        (
            "bare solid",
            format!("solid\n{facets}").into_bytes(),
            Format::Stl,
        ),
        (
            "bare solid, CRLF",
            format!("solid\r\n{facets}").into_bytes(),
            Format::Stl,
        ),
        (
            "indented solid",
            format!("  solid t\n{facets}").into_bytes(),
            Format::Stl,
        ),
        (
            "STL with a BOM",
            [BOM, format!("solid t\n{facets}").as_bytes()].concat(),
            Format::Stl,
        ),
        (
            "PLY with a BOM",
            [
                BOM,
                b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
                  property float z\nelement face 2\nproperty list uchar int vertex_indices\n\
                  end_header\n0 0 0\n1 0 0\n1 1 0.5\n0 1 0\n3 0 1 2\n3 0 2 3\n",
            ]
            .concat(),
            Format::Ply,
        ),
    ];
    for (what, bytes, format) in cases {
        assert_eq!(Format::sniff(&bytes), Some(format), "{what}");
        for given in [None, Some(format)] {
            let m = read_bytes(&bytes, given, &limits()).unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_eq!(m, quad(), "{what}");
        }
    }
    // A word that merely starts with "solid" is no ASCII STL.
    let solidly = format!("solidly\n{facets}");
    assert!(read_bytes(solidly.as_bytes(), Some(Format::Stl), &limits()).is_err());
}

/// An ASCII STL with Latin-1 bytes in its solid's name (and its endsolid's) is text: it was
/// taken for binary and refused ("failed to fill whole buffer").
#[test]
fn an_ascii_stl_with_a_latin1_name_reads() {
    let facets = b"facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n\
vertex 1 1 0.5\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n\
vertex 1 1 0.5\nvertex 0 1 0\nendloop\nendfacet\n";
    for (first, last) in [
        (&b"solid caf\xe9\n"[..], &b"endsolid caf\xe9\n"[..]),
        (b"solid\t\xe9t\xe9\r\n", b"endsolid\n"),
        (b"solid t\n", b"endsolid caf\xe9 \xc3\n"),
    ] {
        let bytes = [first, facets, last].concat();
        let what = String::from_utf8_lossy(&[first, last].concat()).into_owned();
        assert_eq!(Format::sniff(&bytes), Some(Format::Stl), "{what}");
        for given in [None, Some(Format::Stl)] {
            let m = read_bytes(&bytes, given, &limits()).unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_eq!(m, quad(), "{what}");
        }
    }
}

/// OBJ polylines (`l`) are no faces: tobj parsed them like `f`, so an edge drawn through
/// three vertices came out as a triangle, and a file of only polylines as a mesh.
#[test]
fn obj_polylines_are_not_faces() {
    let quad_and_lines = b"v 0 0 0\nv 1 0 0\nv 1 1 0.5\nv 0 1 0\nv 5 5 5\n\
        l 1 2 3 4 1\n  l\t2 5 4\nf 1 2 3\nl 1 5\nf 1 3 4\nl\x0b1 2 5\nl\xc2\xa02 3 5\nlod 1\n";
    let m = read_bytes(quad_and_lines, Some(Format::Obj), &limits()).expect("reads");
    assert_eq!(m, quad());
    let only_lines = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n";
    assert!(
        matches!(
            read_bytes(only_lines, Some(Format::Obj), &limits()),
            Err(MeshError::Invalid(InvalidMesh::Empty))
        ),
        "a polyline read as a face"
    );
}

/// A binary STL whose header starts like text ("solid", then a newline, tab or space) and
/// which has bytes past its records reads as binary, as it did before bare `solid` lines
/// were taken for text; broken text with such a start is still the text's error.
#[test]
fn a_padded_binary_stl_with_a_solid_header_is_binary() {
    for header in [
        &b"solid\nexported"[..],
        b"solid\texported",
        b"solid exported",
    ] {
        let mut bytes = binary_stl(&quad(), header);
        bytes.extend_from_slice(&[0, 0]);
        assert_eq!(Format::sniff(&bytes), Some(Format::Stl));
        for given in [None, Some(Format::Stl)] {
            let m = read_bytes(&bytes, given, &limits())
                .unwrap_or_else(|e| panic!("{:?}: {e}", String::from_utf8_lossy(header)));
            assert_eq!(m.face_count(), 2);
            assert_eq!(m.vertex_count(), 4);
        }
    }
    let err = read_bytes(
        b"solid t\nfacet normal 0 0 1\nouter loop\n",
        None,
        &limits(),
    )
    .expect_err("broken text");
    assert!(err.to_string().starts_with("STL:"), "{err}");
}

/// A binary STL whose count is smaller than its records was read to the count, the rest
/// dropped without a word; a count larger than them was already refused. Zero padding, or a
/// few bytes of anything, still reads.
#[test]
fn a_binary_stl_count_short_of_its_records_is_refused() {
    let mut short = binary_stl(&quad(), b"binary");
    short[80..84].copy_from_slice(&1u32.to_le_bytes());
    let err = read_bytes(&short, Some(Format::Stl), &limits()).expect_err("count too small");
    let m = err.to_string();
    assert!(
        m.contains(
            "claims 1 triangles (134 bytes), but the file has 184 bytes, 1 whole triangles more"
        ),
        "{m}"
    );
    // Unlabelled, its length matches no binary STL, so nothing takes it.
    assert!(read_bytes(&short, None, &limits()).is_err());
    for pad in [vec![0u8; 200], vec![7u8; 49]] {
        let mut padded = binary_stl(&quad(), b"binary");
        padded.extend_from_slice(&pad);
        let m = read_bytes(&padded, Some(Format::Stl), &limits()).expect("padding reads");
        assert_eq!(m.face_count(), 2);
    }
}

/// A header line the PLY parser cannot read was told with its grammar's debug output
/// (`ParseError { location: LineCol { … }, expected: ExpectedSet { … } }`): now the line,
/// its text and the words it could have started with, on one line.
#[test]
fn a_bad_ply_header_line_is_told_in_words() {
    let cases: [(&[u8], &str); 2] = [
        (
            b"ply\nformat binary_middle_endian 1.0\nelement vertex 3\nproperty float x\nend_header\n",
            "`format binary_middle_endian 1.0` (expected ascii, binary_big_endian, binary_little_endian)",
        ),
        (
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n0 0 0\n",
            "`0 0 0` (expected comment, element, end_header,",
        ),
    ];
    for (bytes, told) in cases {
        let m = read_bytes(bytes, Some(Format::Ply), &limits())
            .expect_err("bad header")
            .to_string();
        assert!(m.contains(told), "{m}");
        for debug in ["ParseError", "LineCol", "ExpectedSet", "\n", "\\"] {
            assert!(!m.contains(debug), "{debug:?} in {m}");
        }
    }
}

/// tobj's errors name no line ("OBJ: face vertex index out of bounds"); the reader's do.
#[test]
fn an_obj_error_names_its_line() {
    let m = read_bytes(
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\n# zero-based, as a hand-written file might be\nf 0 1 2\n",
        Some(Format::Obj),
        &limits(),
    )
    .expect_err("index 0")
    .to_string();
    assert!(
        m.starts_with("OBJ: face vertex index out of bounds: line 5 `f 0 1 2`: OBJ counts"),
        "{m}"
    );
}

fn binary_stl(m: &TriMesh, header: &[u8]) -> Vec<u8> {
    let mut b = vec![0u8; 80];
    b[..header.len()].copy_from_slice(header);
    b.extend_from_slice(&(m.faces.len() as u32).to_le_bytes());
    for t in &m.faces {
        b.extend_from_slice(&[0u8; 12]);
        for &i in t {
            for c in m.positions[i as usize].as_vec3().to_array() {
                b.extend_from_slice(&c.to_le_bytes());
            }
        }
        b.extend_from_slice(&[0, 0]);
    }
    b
}

#[test]
fn glb_has_a_valid_container_and_bounds() {
    let bytes = write_bytes(&quad(), Format::Glb).expect("glb");
    assert_eq!(&bytes[..4], b"glTF");
    let word = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    assert_eq!(word(4), 2);
    assert_eq!(word(8) as usize, bytes.len());
    let json_len = word(12) as usize;
    assert_eq!(&bytes[16..20], b"JSON");
    assert_eq!(json_len % 4, 0);
    let doc: serde_json::Value =
        serde_json::from_slice(&bytes[20..20 + json_len]).expect("json chunk");
    assert_eq!(
        doc["accessors"][0]["max"],
        serde_json::json!([1.0, 1.0, 0.5])
    );
    assert_eq!(doc["accessors"][2]["count"], 6);
    let bin_at = 20 + json_len;
    assert_eq!(&bytes[bin_at + 4..bin_at + 8], b"BIN\0");
    assert_eq!(word(bin_at) as usize, bytes.len() - bin_at - 8);
    assert_eq!(doc["buffers"][0]["byteLength"], 4 * 12 * 2 + 2 * 12);
}

/// The JSON chunk of a GLB and the BIN chunk's bytes (empty when there is none), after
/// checking the container's lengths.
fn glb_chunks(bytes: &[u8]) -> (serde_json::Value, &[u8]) {
    let word = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    assert_eq!((&bytes[..4], word(4)), (&b"glTF"[..], 2));
    assert_eq!(word(8) as usize, bytes.len());
    let json_len = word(12) as usize;
    assert_eq!((&bytes[16..20], json_len % 4), (&b"JSON"[..], 0));
    let doc = serde_json::from_slice(&bytes[20..20 + json_len]).expect("json chunk");
    let bin_at = 20 + json_len;
    if bin_at == bytes.len() {
        return (doc, &[]);
    }
    assert_eq!(&bytes[bin_at + 4..bin_at + 8], b"BIN\0");
    assert_eq!(word(bin_at) as usize, bytes.len() - bin_at - 8);
    (doc, &bytes[bin_at + 8..])
}

#[test]
fn glb_views_are_aligned_and_normals_unit() {
    // A vertex no face uses still gets a unit normal (+z) and counts in the bounds.
    let mut m = quad();
    m.positions.push(DVec3::new(5.0, 5.0, 5.0));
    let bytes = write_bytes(&m, Format::Glb).expect("glb");
    let (doc, bin) = glb_chunks(&bytes);
    assert_eq!(
        doc["buffers"][0]["byteLength"].as_u64(),
        Some(bin.len() as u64)
    );
    let views = doc["bufferViews"].as_array().expect("views");
    for (a, accessor) in doc["accessors"]
        .as_array()
        .expect("accessors")
        .iter()
        .enumerate()
    {
        let view = &views[accessor["bufferView"].as_u64().expect("view") as usize];
        let (offset, length) = (view["byteOffset"].as_u64(), view["byteLength"].as_u64());
        let (offset, length) = (offset.expect("offset"), length.expect("length"));
        assert_eq!(offset % 4, 0, "accessor {a}");
        let width = if accessor["type"] == "VEC3" { 12 } else { 4 };
        assert_eq!(accessor["count"].as_u64().expect("count") * width, length);
        assert!(offset + length <= bin.len() as u64);
    }
    let normals = &bin[12 * 5..2 * 12 * 5];
    for n in normals.chunks_exact(12) {
        let c: Vec<f32> = n
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes")))
            .collect();
        let len = c.iter().map(|x| x * x).sum::<f32>().sqrt();
        assert!((len - 1.0).abs() < 1e-6, "{c:?}");
    }
    assert_eq!(
        doc["accessors"][0]["max"],
        serde_json::json!([5.0, 5.0, 5.0])
    );
}

/// Normals given are the ones stored, in place of the mesh's own; a count other than the
/// vertices' is refused rather than written past or short of the positions.
#[test]
fn glb_takes_the_normals_it_is_given() {
    let m = quad();
    let n = m.positions.len();
    let given: Vec<DVec3> = (0..n)
        .map(|i| DVec3::new(i as f64, 1.0, 0.0).normalize())
        .collect();
    let bytes = write_z_up_glb_with_normals(&m, &given).expect("glb");
    let (_, bin) = glb_chunks(&bytes);
    let stored: Vec<f32> = bin[12 * n..24 * n]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes")))
        .collect();
    let want: Vec<f32> = given.iter().flat_map(|v| v.as_vec3().to_array()).collect();
    assert_eq!(stored, want);
    // Without them, the mesh's own: the same file as write_z_up_bytes.
    let own = m.vertex_normals();
    assert_eq!(
        write_z_up_glb_with_normals(&m, &own).expect("glb"),
        write_z_up_bytes(&m, Format::Glb).expect("glb")
    );
    let err = write_z_up_glb_with_normals(&m, &given[1..]).unwrap_err();
    assert!(
        err.to_string().contains("3 normals for 4 vertices"),
        "{err}"
    );
}

/// A zoom-15 web-mercator tile (EPSG:3857 metres, a 4.777 m grid near x = −8·10⁶): stored
/// as f32 as they are, its columns came out 4 or 5 m apart. Relative to the node's
/// translation every vertex reads back within a millimetre; a mesh about the origin gets no
/// translation and keeps its coordinates.
#[test]
fn glb_of_a_far_mesh_is_stored_about_its_centre() {
    let step = 4.777_314_267_823_516;
    let (x0, y0) = (-7_959_202.3, 5_578_136.9);
    let positions: Vec<DVec3> = (0..9)
        .map(|k| {
            DVec3::new(
                x0 + step * f64::from(k % 3),
                y0 + step * f64::from(k / 3),
                312.25,
            )
        })
        .collect();
    let faces = (0..2u32)
        .flat_map(|r| (0..2u32).map(move |c| 3 * r + c))
        .flat_map(|a| [[a, a + 1, a + 4], [a, a + 4, a + 3]])
        .collect();
    let far = TriMesh::new(positions.clone(), faces);
    let bytes = write_bytes(&far, Format::Glb).expect("glb");
    let (doc, bin) = glb_chunks(&bytes);
    let t: Vec<f64> = doc["nodes"][0]["translation"]
        .as_array()
        .expect("a translation")
        .iter()
        .map(|v| v.as_f64().expect("number"))
        .collect();
    for (k, p) in positions.iter().enumerate() {
        let stored: Vec<f64> = bin[12 * k..12 * k + 12]
            .chunks_exact(4)
            .map(|b| f64::from(f32::from_le_bytes(b.try_into().expect("4 bytes"))))
            .collect();
        let back = DVec3::new(stored[0] + t[0], stored[1] + t[1], stored[2] + t[2]);
        assert!(
            (back - *p).abs().max_element() < 1e-3,
            "{k}: {back} for {p}"
        );
    }
    // Without it, the f32 grid would not have been a 4.777 m grid.
    assert!((f64::from((x0 + step) as f32) - f64::from(x0 as f32) - step).abs() > 0.2);

    let (doc, _) = glb_chunks(&write_bytes(&quad(), Format::Glb).expect("glb"));
    assert_eq!(doc["nodes"][0], serde_json::json!({"mesh": 0}));

    // A geodetic zoom-15 patch (2.1e-5° apart) with 200 m of relief: the degrees are far from
    // the origin for their extent, the heights are not; each axis is judged on its own.
    let d = 360.0 / f64::from(1u32 << 16);
    let geo = TriMesh::new(
        vec![
            DVec3::new(-72.0, 44.0, 0.0),
            DVec3::new(-72.0 + d, 44.0, 200.0),
            DVec3::new(-72.0, 44.0 + d, 50.0),
        ],
        vec![[0, 1, 2]],
    );
    let bytes = write_bytes(&geo, Format::Glb).expect("glb");
    let (doc, bin) = glb_chunks(&bytes);
    let t = &doc["nodes"][0]["translation"];
    assert_eq!(t[2], 0.0, "{t}");
    for (k, p) in geo.positions.iter().enumerate() {
        for axis in 0..2 {
            let at = 12 * k + 4 * axis;
            let stored = f32::from_le_bytes(bin[at..at + 4].try_into().expect("4 bytes"));
            let back = f64::from(stored) + t[axis].as_f64().expect("number");
            assert!((back - p[axis]).abs() < 1e-9, "{k}/{axis}: {back} for {p}");
        }
    }
}

#[test]
fn glb_of_a_mesh_without_faces_is_an_empty_scene() {
    // What an octree level coarser than the object gives: no face, so no primitive glTF
    // could hold (count ≥ 1); the file is a scene with nothing in it and no BIN chunk.
    for m in [
        TriMesh::new(vec![], vec![]),
        TriMesh::new(vec![DVec3::ZERO, DVec3::X], vec![]),
    ] {
        let bytes = write_bytes(&m, Format::Glb).expect("glb");
        let (doc, bin) = glb_chunks(&bytes);
        assert!(bin.is_empty());
        assert_eq!(
            doc,
            serde_json::json!({
                "asset": {"version": "2.0", "generator": "zerotile"},
                "scene": 0,
                "scenes": [{}],
            })
        );
    }
}

#[test]
fn glb_refuses_what_gltf_cannot_hold() {
    // Finite in f64, infinite in f32: glTF floats must be finite.
    let mut far = quad();
    far.positions[1] = DVec3::new(1e39, 0.0, 0.0);
    let e = write_bytes(&far, Format::Glb).expect_err("f32 overflow");
    assert!(matches!(e, MeshError::Encode { format: "GLB", .. }), "{e}");
    // An index past the vertices would make the accessors read past their views.
    let mut broken = quad();
    broken.faces.push([0, 1, 9]);
    let e = write_bytes(&broken, Format::Glb).expect_err("index out of range");
    assert!(
        matches!(e, MeshError::Invalid(InvalidMesh::IndexOutOfRange { .. })),
        "{e}"
    );
}

/// Binary PLY stores f32 too: a vertex past its range was written as an infinity, exit 0.
/// OBJ and JSON keep f64 and write it.
#[test]
fn ply_refuses_a_coordinate_past_f32() {
    for x in [1e39, -1e39] {
        let mut far = quad();
        far.positions[1] = DVec3::new(0.0, 0.0, x);
        let e = write_bytes(&far, Format::Ply).expect_err("f32 overflow");
        assert!(matches!(e, MeshError::Encode { format: "PLY", .. }), "{e}");
        assert!(e.to_string().contains("vertex 1"), "{e}");
        for ok in [Format::Obj, Format::Json] {
            let back = read_bytes(&write_bytes(&far, ok).unwrap(), Some(ok), &limits());
            assert_eq!(back.unwrap().positions[1].z, x, "{ok:?}");
        }
    }
    // f32::MAX itself is finite, and written.
    let mut edge = quad();
    edge.positions[1] = DVec3::new(f64::from(f32::MAX), 0.0, 0.0);
    assert!(write_bytes(&edge, Format::Ply).is_ok());
}

#[test]
fn write_path_replaces_atomically_by_extension() {
    let dir = crate::fixtures::scratch_dir("mesh-write-path");
    for ext in ["obj", "ply", "glb", "json"] {
        let path = dir.join(format!("q.{ext}"));
        write_path(&quad(), &path).expect("writes");
        assert!(path.metadata().expect("exists").len() > 0);
    }
    let leftovers = std::fs::read_dir(&dir)
        .expect("dir")
        .filter(|e| {
            e.as_ref()
                .is_ok_and(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        })
        .count();
    assert_eq!(leftovers, 0);
    assert!(matches!(
        write_path(&quad(), &dir.join("q.xyz")),
        Err(MeshError::Unsupported(_))
    ));
}

#[test]
fn empty_input_is_an_error() {
    for bytes in [&b""[..], b"  \n\n", b"# only a comment\n"] {
        assert!(read_bytes(bytes, Some(Format::Obj), &limits()).is_err());
    }
    assert!(matches!(
        read_bytes(b"v 0 0 0\n", Some(Format::Obj), &limits()),
        Err(MeshError::Invalid(InvalidMesh::Empty))
    ));
}

#[test]
fn nan_coordinates_are_rejected() {
    let obj = b"v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n";
    assert!(matches!(
        read_bytes(obj, None, &limits()),
        Err(MeshError::Invalid(InvalidMesh::NonFiniteObjVertex {
            count: 1,
            vertex: 2,
            line: 2
        }))
    ));
    // Named as the file numbers it, not as tobj renumbers the vertices faces use (this NaN
    // vertex is used last, so it was "vertex 3").
    let obj = b"# nan\nv nan 0 0\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 2 3 4\nf 2 3 1\n";
    let e = read_bytes(obj, None, &limits()).unwrap_err().to_string();
    assert!(
        e.ends_with("1 vertex has NaN or infinite coordinates (first: `v` statement 1, line 2)"),
        "{e}"
    );
    // Other formats count from 0, in their own order, and say so.
    let e = InvalidMesh::NonFiniteCoordinates { count: 2, first: 2 }.to_string();
    assert_eq!(
        e,
        "2 vertices have NaN or infinite coordinates (first: vertex index 2, from 0)"
    );
    let json = br#"{"positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0,1,7]}"#;
    assert!(matches!(
        read_bytes(json, None, &limits()),
        Err(MeshError::Invalid(InvalidMesh::IndexOutOfRange {
            index: 7,
            ..
        }))
    ));
}

#[test]
fn out_of_range_indices_are_rejected_in_every_format() {
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n";
    assert!(read_bytes(obj, None, &limits()).is_err());
    let mut bad = quad();
    bad.faces[1][2] = 9;
    let ply = write_bytes(&bad, Format::Ply).expect("ply encodes any indices");
    assert!(matches!(
        read_bytes(&ply, None, &limits()),
        Err(MeshError::Invalid(InvalidMesh::IndexOutOfRange {
            index: 9,
            ..
        }))
    ));
}

#[test]
fn truncated_binary_ply_and_stl_are_errors() {
    let ply = write_bytes(&quad(), Format::Ply).expect("ply");
    for cut in [ply.len() - 1, ply.len() - 13, ply.len() / 2, 40] {
        assert!(
            read_bytes(&ply[..cut], Some(Format::Ply), &limits()).is_err(),
            "cut {cut}"
        );
    }
    let stl = binary_stl(&quad(), b"x");
    for cut in [stl.len() - 1, 90, 84, 50, 0] {
        let r = read_bytes(&stl[..cut], Some(Format::Stl), &limits());
        assert!(
            matches!(r, Err(MeshError::Decode { .. })),
            "cut {cut}: {r:?}"
        );
    }
}

#[test]
fn huge_claimed_counts_fail_before_allocating() {
    let ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n\
property float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0";
    assert!(matches!(
        read_bytes(ply, None, &limits()),
        Err(MeshError::Limit {
            what: "vertices",
            ..
        })
    ));
    let generous = MeshLimits {
        max_vertices: usize::MAX,
        max_faces: usize::MAX,
        max_bytes: u64::MAX,
        max_polygon_corners: usize::MAX,
    };
    assert!(matches!(
        read_bytes(ply, None, &generous),
        Err(MeshError::Decode { .. })
    ));
    // A binary list that claims 4 billion entries.
    let mut list = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
property float y\nproperty float z\nelement face 1\nproperty list uint uint vertex_indices\n\
end_header\n"
        .to_vec();
    list.extend_from_slice(&[0u8; 36]);
    list.extend_from_slice(&u32::MAX.to_le_bytes());
    list.extend_from_slice(&[0u8; 12]);
    assert!(read_bytes(&list, None, &generous).is_err());
    let mut stl = vec![0u8; 80];
    stl.extend_from_slice(&u32::MAX.to_le_bytes());
    // Claimed past the bytes present: what is wrong is the file (an OBJ sent as STL reads
    // as a header claiming ~5e8 triangles), not the limit.
    let err = read_bytes(&stl, Some(Format::Stl), &limits()).unwrap_err();
    assert!(matches!(err, MeshError::Decode { .. }), "{err:?}");
    assert!(err.to_string().contains("or not STL"), "{err}");
    let obj = b"# OBJ\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".repeat(3);
    let err = read_bytes(&obj, Some(Format::Stl), &limits()).unwrap_err();
    assert!(err.to_string().contains("or not STL"), "{err}");
    // All there but over the limit: the limit's error.
    let one = MeshLimits {
        max_faces: 1,
        ..MeshLimits::default()
    };
    assert!(matches!(
        read_bytes(&binary_stl(&quad(), b"x"), Some(Format::Stl), &one),
        Err(MeshError::Limit { what: "faces", .. })
    ));
    let small = MeshLimits {
        max_bytes: 10,
        ..MeshLimits::default()
    };
    assert!(matches!(
        read_bytes(&stl, None, &small),
        Err(MeshError::Limit { what: "bytes", .. })
    ));
}

#[test]
fn garbage_is_unsupported_or_malformed_never_a_panic() {
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let base = write_bytes(&quad(), Format::Ply).expect("ply");
    for _ in 0..300 {
        let mut b = base.clone();
        for _ in 0..4 {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let at = (seed >> 33) as usize % b.len();
            b[at] = (seed >> 17) as u8;
        }
        let _ = read_bytes(&b, None, &limits());
    }
    assert!(matches!(
        read_bytes(b"\x00\x01binary junk", None, &limits()),
        Err(MeshError::Unsupported(_))
    ));
}

/// The QA pass's pentagon, notched at (1, 0.5): area 2.5, normal +z.
const NOTCHED: [[f64; 2]; 5] = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, 0.5], [0.0, 2.0]];

/// An OBJ of one polygon through `corners`.
fn obj_polygon(corners: &[DVec3]) -> Vec<u8> {
    let mut text = String::new();
    for p in corners {
        text.push_str(&format!("v {} {} {}\n", p.x, p.y, p.z));
    }
    let refs: Vec<String> = (1..=corners.len()).map(|i| i.to_string()).collect();
    text.push_str(&format!("f {}\n", refs.join(" ")));
    text.into_bytes()
}

/// The summed areas of `m`'s triangles, and the least of their areas signed along `normal`
/// (negative: a triangle wound against it).
fn areas_along(m: &TriMesh, normal: DVec3) -> (f64, f64) {
    let vector_area = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        (b - a).cross(c - a) / 2.0
    };
    let total = m.faces.iter().map(|t| vector_area(t).length()).sum();
    let least = m
        .faces
        .iter()
        .map(|t| vector_area(t).dot(normal.normalize()))
        .fold(f64::INFINITY, f64::min);
    (total, least)
}

/// A concave polygon was fanned from its first corner: the QA pass's pentagon gave a triangle
/// outside it, over another and wound the other way (areas 3.5 for 2.5). Cut in its own plane,
/// in any plane and either way round, its triangles cover it once, wound as it is; in a PLY
/// too, whose faces may come before its vertices. Convex polygons are fanned as before.
#[test]
fn polygons_are_cut_inside_themselves_and_wound_as_they_are() {
    let tilt = glam::DMat3::from_axis_angle(DVec3::new(1.0, -2.0, 0.5).normalize(), 1.1);
    let far = DVec3::new(-7.9e6, 5.5e6, 312.0);
    for (place, at) in [
        ("flat", &(|p: DVec3| p) as &dyn Fn(DVec3) -> DVec3),
        ("tilted and far", &|p: DVec3| tilt * p + far),
    ] {
        for reversed in [false, true] {
            let mut corners: Vec<DVec3> = NOTCHED
                .iter()
                .map(|&[x, y]| at(DVec3::new(x, y, 0.0)))
                .collect();
            let mut normal = at(DVec3::Z) - at(DVec3::ZERO);
            if reversed {
                corners.reverse();
                normal = -normal;
            }
            let m = read_bytes(&obj_polygon(&corners), None, &limits()).expect("pentagon");
            let (total, least) = areas_along(&m, normal);
            let what = format!("{place}, reversed {reversed}: {:?}", m.faces);
            assert_eq!(m.faces.len(), 3, "{what}");
            assert!((total - 2.5).abs() < 1e-6, "{what}: area {total}");
            assert!(least > 0.0, "{what}: a triangle wound against the polygon");
        }
    }
    // The same pentagon as a PLY face listed before the vertices.
    let mut ply = String::from(
        "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n\
         element vertex 5\nproperty float x\nproperty float y\nproperty float z\n\
         end_header\n5 0 1 2 3 4\n",
    );
    for [x, y] in NOTCHED {
        ply.push_str(&format!("{x} {y} 0\n"));
    }
    let m = read_bytes(ply.as_bytes(), None, &limits()).expect("ply pentagon");
    let (total, least) = areas_along(&m, DVec3::Z);
    assert!((total - 2.5).abs() < 1e-12 && least > 0.0, "{:?}", m.faces);
    // Convex: the fan from the first corner, as every reader gave it before.
    let obj = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0.5 0\nf 1 2 3 4 5\n";
    let m = read_bytes(obj, None, &limits()).expect("pentagon");
    assert_eq!(m.faces, [[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
    let obj = b"v 0 0 0\nv 1 0 0\nv 1 1 0.5\nv 0 1 0\nf 1 2 3 4\n";
    assert_eq!(read_bytes(obj, None, &limits()).expect("quad"), quad());
}

/// Polygons that are not simple neither panic nor come out wound against themselves where
/// they have a side: repeated and collinear corners, bent out of their plane, crossing
/// themselves. With no net area (on a line, at a point, a figure eight) or with corners too
/// far out to measure, they are fanned as listed and repair drops what has no area.
#[test]
fn degenerate_polygons_are_cut_without_a_panic() {
    let concave = |z: [f64; 5]| -> Vec<DVec3> {
        NOTCHED
            .iter()
            .zip(z)
            .map(|(&[x, y], z)| DVec3::new(x, y, z))
            .collect()
    };
    let mut repeated = concave([0.0; 5]);
    repeated.insert(3, repeated[2]);
    repeated.insert(0, repeated[0]);
    let mut collinear = concave([0.0; 5]);
    collinear.insert(1, DVec3::new(1.0, 0.0, 0.0));
    // Bent: the notch lifted out of the plane.
    let bent = concave([0.0, 0.1, -0.1, 0.4, 0.05]);
    // Crossing itself: the notch pulled through the far side.
    let mut crossing = concave([0.0; 5]);
    crossing[3] = DVec3::new(1.0, -0.5, 0.0);
    crossing.push(DVec3::new(-0.5, 1.0, 0.0));
    for (what, corners) in [
        ("repeated", repeated),
        ("collinear", collinear),
        ("bent", bent),
        ("crossing", crossing),
    ] {
        let m = read_bytes(&obj_polygon(&corners), None, &limits()).expect(what);
        let (total, least) = areas_along(&m, DVec3::Z);
        assert!(total > 0.0 && least >= 0.0, "{what}: {:?}", m.faces);
    }
    let on_a_line: Vec<DVec3> = (0..6).map(|k| DVec3::X * f64::from(k % 4)).collect();
    let at_a_point = vec![DVec3::ONE; 5];
    let eight =
        [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]].map(|[x, y]| DVec3::new(x, y, 0.0));
    // Finite, but their differences are not.
    let huge = NOTCHED.map(|[x, y]| DVec3::new((x - 1.0) * 1.5e308, y * 0.8e308, 0.0));
    for (what, corners) in [
        ("on a line", on_a_line),
        ("at a point", at_a_point),
        ("eight", eight.to_vec()),
        ("huge", huge.to_vec()),
    ] {
        let m = read_bytes(&obj_polygon(&corners), None, &limits()).expect(what);
        assert_eq!(m.faces.len(), corners.len() - 2, "{what}: fanned");
    }
}

/// Ear clipping takes time growing with the square of the corners: a concave polygon past
/// the limit is refused, a convex one of any size fanned.
#[test]
fn a_concave_polygon_past_the_corner_limit_is_refused() {
    let few = MeshLimits {
        max_polygon_corners: 5,
        ..MeshLimits::default()
    };
    let flat = |[x, y]: [f64; 2]| DVec3::new(x, y, 0.0);
    let pentagon = obj_polygon(&NOTCHED.map(flat));
    assert_eq!(read_bytes(&pentagon, None, &few).expect("5").faces.len(), 3);
    let mut notched = NOTCHED.map(flat).to_vec();
    notched.insert(1, DVec3::new(1.0, -0.5, 0.0));
    let err = read_bytes(&obj_polygon(&notched), None, &few).expect_err("6 corners");
    assert!(
        matches!(
            err,
            MeshError::Limit {
                got: 6,
                limit: 5,
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("not convex"), "{err}");
    let circle: Vec<DVec3> = (0..100)
        .map(|k| {
            let a = f64::from(k) * std::f64::consts::TAU / 100.0;
            DVec3::new(a.cos(), a.sin(), 0.0)
        })
        .collect();
    let m = read_bytes(&obj_polygon(&circle), None, &few).expect("convex");
    assert_eq!(m.faces.len(), 98);
}

/// A PLY face past the vertices is named by its number in the file: the triangles of a quad
/// before it counted it as face 2.
#[test]
fn a_ply_index_out_of_range_names_the_file_face() {
    let ply = b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n\
        property float y\nproperty float z\nelement face 2\nproperty list uchar int \
        vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n3 0 2 7\n";
    let err = read_bytes(ply, None, &limits()).expect_err("index 7");
    assert!(
        matches!(
            err,
            MeshError::Invalid(InvalidMesh::IndexOutOfRange {
                count: 1,
                face: 1,
                index: 7,
                vertices: 4
            })
        ),
        "{err}"
    );
}

/// `#` starts a comment anywhere in an OBJ line: a vertex or face ending in one was refused
/// with the whole file (tobj takes comments only at a line's start). The lines keep their
/// numbers, so a message names the file's line, polylines (dropped) before it too.
#[test]
fn an_obj_comment_may_end_any_line() {
    let plain = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    let commented = "v 0 0 0 # origin\nv 1 0 0\nv 0 1 0\t#up\nv 0 0 1\nvn 0 0 1 # a normal\n\
                     usemtl red#1\nf 1 3 2\nf 1 2 4 # note\nf 1 4 3#tight\nf 2 3 4 # \u{e9}t\u{e9}\n";
    let want = read_bytes(plain, None, &limits()).expect("plain");
    let got = read_bytes(commented.as_bytes(), None, &limits()).expect("commented");
    assert_eq!(got, want);
    let bad = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n# c\nf 1 2 x7 # bad\n";
    let e = read_bytes(bad, None, &limits()).unwrap_err().to_string();
    assert!(
        e.ends_with("line 6 `f 1 2 x7`: `x7` is not a vertex index"),
        "{e}"
    );
}

#[test]
fn obj_groups_share_their_vertices_again() {
    let obj = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\ng a\nf 1 2 3\ng b\nf 1 3 4\n";
    let m = read_bytes(obj, None, &limits()).expect("two groups");
    assert_eq!(m.vertex_count(), 4);
    assert_eq!(m.edge_count(), 5);
}

/// A Markdown file starts like an OBJ (`#` is OBJ's comment): under a name that is no mesh
/// format's, it is refused as not a mesh; named `.obj`, the same text is an OBJ without faces.
#[test]
fn text_under_another_name_is_not_a_mesh() {
    let dir = crate::fixtures::scratch_dir("mesh-not-a-mesh");
    let text = "# zerotile\n\nTerrain tiles stored as EZW streams.\n";
    for (name, says) in [("README.md", "not a mesh"), ("notes.obj", "no faces")] {
        let path = dir.join(name);
        std::fs::write(&path, text).expect("write");
        let e = read_path(&path, &limits()).expect_err("no faces");
        assert!(e.to_string().contains(says), "{name}: {e}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Each format's extension names it again: an upload stored under `extension()` is found
/// by `from_path` at the next start. GLB, written only, is not among the readable formats.
#[test]
fn extensions_name_their_formats() {
    for f in [
        Format::Obj,
        Format::Ply,
        Format::Stl,
        Format::Glb,
        Format::Json,
    ] {
        assert_eq!(Format::from_extension(f.extension()), Some(f));
    }
    assert!(!Format::READABLE.contains(&Format::Glb));
    let glb = write_bytes(&quad(), Format::Glb).expect("writes");
    assert!(read_bytes(&glb, Some(Format::Glb), &limits()).is_err());
}

#[test]
fn text_with_stray_bytes_keeps_its_size_and_its_ascii() {
    // A padded binary STL whose header says "solid" goes through the text path first: its
    // copy must stay the input's size, not triple.
    let mut bytes = b"solid caf\xe9\n".to_vec();
    bytes.extend((0..3000).map(|i| 0x80 | (i % 64) as u8));
    bytes.extend_from_slice("endsolid \u{e9}t\u{e9}".as_bytes());
    let text = super::lenient_text(&bytes);
    assert_eq!(text.len(), bytes.len());
    assert!(text.starts_with("solid caf?\n"));
    assert!(
        text.ends_with("endsolid \u{e9}t\u{e9}"),
        "valid UTF-8 is kept"
    );
    assert!(matches!(
        super::lenient_text(b"v 1 2 3\n"),
        Cow::Borrowed(_)
    ));
}

/// The binary STL reader reads records in place; it must give stl_io's mesh (the same welded
/// corners in the same order) on a real model, and on every header stl_io can read as binary.
#[test]
fn binary_stl_reads_as_stl_io_reads_it() {
    let path = format!(
        "{}/../../shared/data/meshes/cow.obj",
        env!("CARGO_MANIFEST_DIR")
    );
    let cow = read_bytes(&std::fs::read(&path).expect("cow.obj"), None, &limits()).expect("cow");
    let bytes = binary_stl(&cow, b"binary cow");
    let want = stl_io::read_stl(&mut std::io::Cursor::new(&bytes)).expect("stl_io reads it");
    let got = read_bytes(&bytes, Some(Format::Stl), &limits()).expect("reads");
    assert_eq!(got.faces.len(), want.faces.len());
    assert_eq!(got.positions.len(), want.vertices.len());
    for (g, w) in got.faces.iter().zip(&want.faces) {
        assert_eq!(g.map(|i| i as usize), w.vertices);
    }
    for (g, w) in got.positions.iter().zip(&want.vertices) {
        assert_eq!(g.to_array(), [0, 1, 2].map(|k| f64::from(w[k])));
    }
    // The cow's corners are shared: welding joined them.
    assert!(got.positions.len() * 2 < got.faces.len() * 3);
}

/// A terrain mesh (z up) as GLB lies flat under glTF's +Y up: the node turns its stored
/// vertices a quarter turn about x, after which each sits at (x, z, −y) of its position
/// (QA: three.js showed a 977 m tall tile 19.6 km deep). The stored vertices stay those of
/// `write_bytes`, and an object mesh gets no rotation.
#[test]
fn glb_of_a_z_up_mesh_is_turned_onto_y_up() {
    let positions = vec![
        DVec3::new(-7_959_202.3, 5_578_136.9, 312.25),
        DVec3::new(-7_959_197.5, 5_578_136.9, 330.0),
        DVec3::new(-7_959_202.3, 5_578_141.7, 290.5),
    ];
    let tile = TriMesh::new(positions.clone(), vec![[0, 1, 2]]);
    let bytes = write_z_up_bytes(&tile, Format::Glb).expect("glb");
    let (doc, bin) = glb_chunks(&bytes);
    let node = &doc["nodes"][0];
    let num = |v: &serde_json::Value| v.as_f64().expect("number");
    let q: Vec<f64> = node["rotation"]
        .as_array()
        .expect("a rotation")
        .iter()
        .map(num)
        .collect();
    let t: Vec<f64> = node["translation"]
        .as_array()
        .expect("a translation")
        .iter()
        .map(num)
        .collect();
    assert!(
        (q.iter().map(|c| c * c).sum::<f64>() - 1.0).abs() < 1e-12,
        "unit: {q:?}"
    );
    let turn = glam::DQuat::from_xyzw(q[0], q[1], q[2], q[3]);
    for (k, p) in positions.iter().enumerate() {
        let stored: Vec<f64> = bin[12 * k..12 * k + 12]
            .chunks_exact(4)
            .map(|b| f64::from(f32::from_le_bytes(b.try_into().expect("4 bytes"))))
            .collect();
        let world =
            turn * DVec3::new(stored[0], stored[1], stored[2]) + DVec3::new(t[0], t[1], t[2]);
        let want = DVec3::new(p.x, p.z, -p.y);
        assert!(
            (world - want).abs().max_element() < 1e-3,
            "{k}: {world} for {want}"
        );
    }
    // Up is +Y: the tile's normal, +z before, is +Y after the turn.
    let n = turn * DVec3::Z;
    assert!((n - DVec3::Y).length() < 1e-12, "{n}");
    // Stored as write_bytes stores them; OBJ is the same either way; objects are not turned.
    let plain = write_bytes(&tile, Format::Glb).expect("glb");
    assert_eq!(glb_chunks(&plain).1, bin);
    assert!(glb_chunks(&plain).0["nodes"][0].get("rotation").is_none());
    assert_eq!(
        write_z_up_bytes(&tile, Format::Obj).expect("obj"),
        write_bytes(&tile, Format::Obj).expect("obj")
    );
}

/// A JSON index past u32 is named as sent (it was clamped first, and reported as
/// 4294967295).
#[test]
fn a_json_index_past_u32_is_named_as_sent() {
    let body = br#"{"positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0,1,4294967296]}"#;
    let e = read_bytes(body, Some(Format::Json), &limits())
        .unwrap_err()
        .to_string();
    assert!(e.contains("4294967296") && !e.contains("4294967295"), "{e}");
    assert!(e.contains("face 0") && e.contains("3 vertices"), "{e}");
}
