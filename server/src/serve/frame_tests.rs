//! `?frame=enu` on tiles and views: the same mesh as the scheme's, moved into metres about
//! the tile's centre or the view's target.

use axum::http::{Method, StatusCode};
use glam::DVec3;
use zerotile_codec::geo::{Ellipsoid, EnuFrame};

use super::tests::{error_code, get, hill_dataset, id, router_over, send, ROOT};

/// Positions of a mesh JSON (`{positions, …}`) at `at` (a JSON pointer).
pub(super) fn positions(body: &[u8], at: &str) -> Vec<DVec3> {
    let v: serde_json::Value = serde_json::from_slice(body).unwrap();
    let flat: Vec<f64> = v
        .pointer(at)
        .and_then(|p| p.as_array())
        .unwrap_or_else(|| panic!("no {at} in {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    flat.chunks(3)
        .map(|c| DVec3::new(c[0], c[1], c[2]))
        .collect()
}

fn origin(h: &axum::http::HeaderMap) -> [f64; 3] {
    let s = h["x-frame-origin"].to_str().unwrap();
    let v: Vec<f64> = s.split(',').map(|x| x.parse().unwrap()).collect();
    [v[0], v[1], v[2]]
}

/// Every vertex of `enu` is WGS84's placement, in the frame at `origin`, of its vertex in
/// `scheme` (whose x, y `lonlat` turns into degrees), to 1e-6 m.
fn assert_placed(
    origin: [f64; 3],
    scheme: &[DVec3],
    enu: &[DVec3],
    lonlat: impl Fn(DVec3) -> [f64; 2],
) {
    let f = EnuFrame::at(Ellipsoid::WGS84, origin[0], origin[1], origin[2]);
    assert_eq!(scheme.len(), enu.len());
    for (&p, &m) in scheme.iter().zip(enu) {
        let [lon, lat] = lonlat(p);
        assert!(
            (f.from_geodetic(lon, lat, p.z) - m).length() < 1e-6,
            "{p} → {m}"
        );
    }
}

fn extent(ps: &[DVec3]) -> DVec3 {
    let lo = ps.iter().fold(DVec3::INFINITY, |a, &p| a.min(p));
    let hi = ps.iter().fold(DVec3::NEG_INFINITY, |a, &p| a.max(p));
    hi - lo
}

/// The geodetic tile 8/100/150 spans 0.703125° both ways about (−109.3359375°, 15.8203125°):
/// in ENU it is that many metres of the ellipsoid (~75 × 78 km) about its centre, each
/// vertex where WGS84 puts the scheme's (lon, lat, height), and only the GLB, OBJ and JSON
/// meshes take the frame.
#[tokio::test]
async fn an_enu_tile_is_the_scheme_tile_in_metres_about_its_centre() {
    let tile = id(8, 100, 150);
    let app = router_over(hill_dataset("frame-tile", "geodetic", &[ROOT, tile]));
    let base = "/v1/datasets/hill/tiles/8/100/150";
    let (s, h_scheme, scheme) = get(&app, &format!("{base}.json?threshold=1")).await;
    assert_eq!(s, StatusCode::OK);
    assert!(!h_scheme.contains_key("x-frame-origin"));
    let (s, h, enu) = get(&app, &format!("{base}.json?threshold=1&frame=enu")).await;
    assert_eq!(s, StatusCode::OK, "{}", String::from_utf8_lossy(&enu));
    assert_ne!(h["etag"], h_scheme["etag"]);
    assert_eq!(h["x-triangles"], h_scheme["x-triangles"]);

    let o = origin(&h);
    assert_eq!(o, [-109.3359375, 15.8203125, 0.0]);
    let metres = positions(&enu, "/positions");
    assert_placed(o, &positions(&scheme, "/positions"), &metres, |d| {
        [d.x, d.y]
    });
    // The ground size: 0.703125° of the meridian (~110.6 km a degree at 16°N) and of the
    // parallel (cos 16° of the equator's 111.3 km a degree), to within a percent.
    let e = extent(&metres);
    let deg = 0.703125;
    assert!((e.y / (deg * 110_650.0) - 1.0).abs() < 0.01, "{e}");
    let parallel = deg * 111_320.0 * 15.82_f64.to_radians().cos();
    assert!((e.x / parallel - 1.0).abs() < 0.01, "{e}");
    // The hill's 80 m of relief plus the curvature's drop at the corners, ~0.4 km.
    assert!(e.z > 80.0 && e.z < 700.0, "{e}");
    let c = metres.iter().fold(DVec3::ZERO, |a, &p| a + p) / metres.len() as f64;
    assert!(c.x.abs() < 0.1 * e.x && c.y.abs() < 0.1 * e.y, "{c}");

    for fmt in ["obj", "glb"] {
        let (s, h, _) = get(&app, &format!("{base}.{fmt}?threshold=1&frame=enu")).await;
        assert_eq!(s, StatusCode::OK, "{fmt}");
        assert_eq!(origin(&h), o, "{fmt}");
    }
    for (uri, code) in [
        (format!("{base}.png?frame=enu"), "bad_frame"),
        (format!("{base}.terrain?frame=enu"), "bad_frame"),
        (format!("{base}.bin?frame=enu"), "bad_frame"),
        (format!("{base}.json?frame=ecef"), "bad_frame"),
    ] {
        let (s, _, body) = get(&app, &uri).await;
        assert_eq!(s, StatusCode::BAD_REQUEST, "{uri}");
        assert_eq!(error_code(&body), code, "{uri}");
    }
    let (s, _, _) = get(&app, &format!("{base}.png?frame=scheme")).await;
    assert_eq!(s, StatusCode::OK);
}

/// A mercator tile goes through longitude and latitude: its ENU mesh is the geodetic
/// placement of each EPSG:3857 vertex.
#[tokio::test]
async fn an_enu_mercator_tile_is_placed_through_its_longitudes_and_latitudes() {
    let tile = id(6, 20, 25);
    let app = router_over(hill_dataset("frame-merc", "mercator", &[ROOT, tile]));
    let base = "/v1/datasets/hill/tiles/6/20/25.json?threshold=1";
    let (_, _, scheme) = get(&app, base).await;
    let (s, h, enu) = get(&app, &format!("{base}&frame=enu")).await;
    assert_eq!(s, StatusCode::OK);
    let o = origin(&h);
    let (xy, metres) = (
        positions(&scheme, "/positions"),
        positions(&enu, "/positions"),
    );
    assert_placed(o, &xy, &metres, |p| {
        zerotile_codec::geo::mercator_to_lonlat([p.x, p.y])
    });
    // Mercator stretches by 1 / cos(lat): the ENU tile is smaller than its EPSG:3857 span.
    let (ex, em) = (extent(&xy), extent(&metres));
    let shrink = o[1].to_radians().cos();
    assert!((em.x / (ex.x * shrink) - 1.0).abs() < 0.05, "{ex} {em}");
}

/// A view in ENU is about its target: the body names the origin, the mesh is the scheme's
/// view moved there, and a local grid, with no place on the Earth, is refused.
#[tokio::test]
async fn an_enu_view_is_about_its_target() {
    let app = router_over(hill_dataset(
        "frame-view",
        "geodetic",
        &[ROOT, id(8, 100, 150)],
    ));
    let view = "/v1/datasets/hill/view?eye=-109.34,15.8,20000&target=-109.33,15.83,0&fov=60";
    let (s, h0, scheme) = get(&app, view).await;
    assert_eq!(s, StatusCode::OK, "{}", String::from_utf8_lossy(&scheme));
    let (s, h, enu) = get(&app, &format!("{view}&frame=enu")).await;
    assert_eq!(s, StatusCode::OK);
    assert_ne!(h["etag"], h0["etag"]);
    let v: serde_json::Value = serde_json::from_slice(&enu).unwrap();
    assert_eq!(v["origin"], serde_json::json!([-109.33, 15.83, 0.0]));
    assert_eq!(origin(&h), [-109.33, 15.83, 0.0]);
    let v0: serde_json::Value = serde_json::from_slice(&scheme).unwrap();
    assert!(v0.get("origin").is_none());
    assert_eq!(v["triangles"], v0["triangles"]);
    assert_placed(
        [-109.33, 15.83, 0.0],
        &positions(&scheme, "/mesh/positions"),
        &positions(&enu, "/mesh/positions"),
        |d| [d.x, d.y],
    );

    let (s, h, _) = get(&app, &format!("{view}&frame=enu&format=glb")).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(origin(&h), [-109.33, 15.83, 0.0]);
    // Its 304s, by tag and by `*`, carry the origin too, as a tile's does.
    let tag = h["etag"].to_str().unwrap().to_string();
    for none_match in [tag.as_str(), "*"] {
        let (s, h, _) = send(
            &app,
            Method::GET,
            &format!("{view}&frame=enu&format=glb"),
            &[("if-none-match", none_match)],
        )
        .await;
        assert_eq!(s, StatusCode::NOT_MODIFIED, "{none_match}");
        assert_eq!(origin(&h), [-109.33, 15.83, 0.0], "{none_match}");
    }

    let local = router_over(hill_dataset("frame-local", "local", &[ROOT]));
    for uri in [
        "/v1/datasets/hill/view?eye=128,128,1000&target=128,129,0&fov=60&frame=enu",
        "/v1/datasets/hill/tiles/0/0/0.json?frame=enu",
    ] {
        let (s, _, body) = get(&local, uri).await;
        assert_eq!(s, StatusCode::BAD_REQUEST, "{uri}");
        assert_eq!(error_code(&body), "bad_frame", "{uri}");
    }
}
