//! Heights above EGM96 served above the ellipsoid where a client takes them so
//! (quantized-mesh, `frame=enu`), and as they are everywhere else.

use axum::http::StatusCode;
use zerotile_codec::formats::quantized_mesh;
use zerotile_codec::geo::geoid::{lattice_for, undulation_exact};
use zerotile_codec::geo::{Ellipsoid, EnuFrame, VerticalDatum};

use super::dataset::Dataset;
use super::frame;
use super::frame_tests::positions;
use super::tests::{get, hill_file_with, id, router_over, ROOT};

/// The geodetic tile 8/100/150: 0.703125° about (−109.3359375°, 15.8203125°), off Mexico,
/// where EGM96 lies some metres from the ellipsoid.
const TILE: &str = "/v1/datasets/hill/tiles/8/100/150";
const WEST: f64 = -109.6875;
const SOUTH: f64 = 15.468_75;
const SPAN: f64 = 0.703_125;

/// Two routers over one hill: its heights above EGM96, and not said.
fn hills(tag: &str) -> (axum::Router, axum::Router) {
    let open = |datum: Option<VerticalDatum>, tag: &str| {
        let file = hill_file_with(tag, "geodetic", &[ROOT, id(8, 100, 150)], |m| {
            m.vertical_datum = datum;
        });
        router_over(Dataset::open(&file).unwrap())
    };
    (
        open(Some(VerticalDatum::Egm96), &format!("{tag}-egm96")),
        open(None, &format!("{tag}-none")),
    )
}

fn json(body: &[u8]) -> serde_json::Value {
    serde_json::from_slice(body).unwrap_or_else(|e| panic!("{e}: {:?}", body))
}

/// The geoid is metres off the ellipsoid here, or these tests would show nothing.
#[test]
fn the_tile_lies_where_the_geoid_is_metres_off_the_ellipsoid() {
    let n = undulation_exact(WEST + SPAN / 2.0, SOUTH + SPAN / 2.0);
    assert!(n.abs() > 1.0, "N = {n}");
}

/// A quantized-mesh tile of EGM96 heights is the same mesh as that of heights not said,
/// each vertex raised by the geoid's undulation there (to 0.16 m: the 7.5′ lattice's
/// interpolation, and each tile's 16-bit height steps of under a centimetre here).
#[tokio::test]
async fn quantized_mesh_heights_are_raised_to_the_ellipsoid() {
    let (egm96, none) = hills("geoid-qm");
    let uri = format!("{TILE}.terrain?threshold=1");
    let (s, _, raised) = get(&egm96, &uri).await;
    assert_eq!(s, StatusCode::OK);
    let (s, _, plain) = get(&none, &uri).await;
    assert_eq!(s, StatusCode::OK);
    let raised = quantized_mesh::decode(&raised).unwrap();
    let plain = quantized_mesh::decode(&plain).unwrap();
    assert_eq!((&raised.u, &raised.v), (&plain.u, &plain.v));
    assert_eq!(raised.triangles, plain.triangles);
    for i in 0..raised.vertex_count() {
        let lon = WEST + f64::from(raised.u[i]) / 32767.0 * SPAN;
        let lat = SOUTH + f64::from(raised.v[i]) / 32767.0 * SPAN;
        let n = undulation_exact(lon, lat);
        let (up, h) = (raised.height_m(i).unwrap(), plain.height_m(i).unwrap());
        assert!(
            (up - h - n).abs() < 0.16,
            "{lon}, {lat}: {up} against {h} + {n}"
        );
    }
    // The header's range moved with the heights.
    let moved = raised.header.min_height - plain.header.min_height;
    assert!(moved.abs() > 1.0, "{moved}");
}

/// In ENU the heights are above the ellipsoid the frame stands on: each vertex is WGS84's
/// placement of (lon, lat, h + N), to the lattice's 0.15 m. In the scheme's frame they are
/// as stored.
#[tokio::test]
async fn enu_meshes_stand_on_the_ellipsoid_and_scheme_meshes_keep_the_heights() {
    let (egm96, none) = hills("geoid-enu");
    let (s, _, scheme) = get(&egm96, &format!("{TILE}.json?threshold=1")).await;
    assert_eq!(s, StatusCode::OK);
    let (_, _, scheme_none) = get(&none, &format!("{TILE}.json?threshold=1")).await;
    assert_eq!(scheme, scheme_none);

    let (s, h, enu) = get(&egm96, &format!("{TILE}.json?threshold=1&frame=enu")).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(h["x-frame-origin"], "-109.3359375,15.8203125,0");
    let f = EnuFrame::at(Ellipsoid::WGS84, -109.335_937_5, 15.820_312_5, 0.0);
    let (scheme, enu) = (
        positions(&scheme, "/positions"),
        positions(&enu, "/positions"),
    );
    assert_eq!(scheme.len(), enu.len());
    for (p, m) in scheme.iter().zip(&enu) {
        let want = f.from_geodetic(p.x, p.y, p.z + undulation_exact(p.x, p.y));
        assert!((want - *m).length() < 0.15, "{p}: {m} against {want}");
    }

    // A view's too.
    let view = "/v1/datasets/hill/view?eye=-109.34,15.8,20000&target=-109.33,15.83,0&fov=60";
    let (s, _, plain) = get(&egm96, view).await;
    assert_eq!(s, StatusCode::OK);
    let (_, _, enu) = get(&egm96, &format!("{view}&frame=enu")).await;
    let f = EnuFrame::at(Ellipsoid::WGS84, -109.33, 15.83, 0.0);
    let plain = positions(&plain, "/mesh/positions");
    let enu = positions(&enu, "/mesh/positions");
    assert!(!plain.is_empty());
    for (p, m) in plain.iter().zip(&enu) {
        let want = f.from_geodetic(p.x, p.y, p.z + undulation_exact(p.x, p.y));
        assert!((want - *m).length() < 0.15, "{p}: {m} against {want}");
    }
}

/// A tall, thin view's box takes the lattice of its height: a few dozen nodes, where its
/// width's (7.5′) would be a column of hundreds, a millisecond each. A tile's box, as wide as
/// tall, keeps its width's, the one every tile of its zoom shares.
#[test]
fn a_box_takes_the_lattice_of_its_larger_side() {
    let file = hill_file_with("geoid-box", "geodetic", &[ROOT], |m| {
        m.vertical_datum = Some(VerticalDatum::Egm96);
    });
    let d = Dataset::open(&file).unwrap();
    let tall = frame::geoid(&d, [-109.6, -20.0, -109.1, 20.0]).unwrap();
    assert!(tall.nodes() <= 11 * 11, "{} nodes", tall.nodes());
    let tile = frame::geoid(&d, [WEST, SOUTH, WEST + SPAN, SOUTH + SPAN]).unwrap();
    let own = lattice_for(SPAN).patch(WEST, SOUTH, WEST + SPAN, SOUTH + SPAN);
    assert_eq!(tile.nodes(), own.nodes());
    assert_eq!(
        tile.undulation(WEST + 0.1, SOUTH + 0.2),
        own.undulation(WEST + 0.1, SOUTH + 0.2)
    );
    // Heights as they are: no patch.
    let plain = Dataset::open(&hill_file_with(
        "geoid-box-none",
        "geodetic",
        &[ROOT],
        |_| {},
    ))
    .unwrap();
    assert!(frame::geoid(&plain, [WEST, SOUTH, WEST + SPAN, SOUTH + SPAN]).is_none());
}

/// The dataset's JSON says which heights are raised.
#[tokio::test]
async fn the_dataset_says_its_vertical_datum() {
    let (egm96, none) = hills("geoid-meta");
    let (_, _, body) = get(&egm96, "/v1/datasets/hill").await;
    assert_eq!(json(&body)["vertical_datum"], "egm96");
    let (_, _, body) = get(&none, "/v1/datasets/hill").await;
    assert_eq!(json(&body)["vertical_datum"], serde_json::Value::Null);
}
