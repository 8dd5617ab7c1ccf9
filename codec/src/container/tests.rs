use super::*;

fn metadata() -> Metadata {
    Metadata {
        name: "test".into(),
        scheme: "geodetic".into(),
        tile_side: 257,
        min_zoom: 0,
        max_zoom: 2,
        bounds: [-72.0, 44.0, -71.0, 45.0],
        source_size: [1201, 1201],
        wavelet: crate::wavelet::Wavelet::Cdf97,
        step: 1.0,
        precision: Some(0.5),
        height_range: [115.0, 1908.0],
        source_height_range: None,
        vertical_datum: None,
        fill: 0.0,
        view: ViewParams { a: 50.0, b: 0.0 },
        // Zooms 0 to 2, one range each (not checked against the tiles here).
        available: vec![
            vec![Availability {
                start_x: 0,
                start_y: 0,
                end_x: 1,
                end_y: 0,
            }];
            3
        ],
        source: "N44W072.hgt".into(),
        source_crs: "EPSG:4326".into(),
        samples: 3 * 257 * 257,
        stream_bytes: 12,
        created: "2026-11-24T00:00:00Z".into(),
    }
}

fn sample() -> Vec<u8> {
    let mut w = Writer::new();
    w.add(TileId { z: 0, x: 1, y: 0 }, [1.0, 2.0, 3.0, 4.0], b"second");
    w.add(TileId { z: 0, x: 0, y: 0 }, [5.0, 6.0, 7.0, 8.0], b"first");
    w.add(TileId { z: 2, x: 3, y: 1 }, [0.5; 4], b"");
    w.finish(&metadata()).unwrap()
}

#[test]
fn round_trips_metadata_index_and_records() {
    let bytes = sample();
    let c = Container::parse(&bytes, &Limits::default()).unwrap();
    assert_eq!(c.metadata, metadata());
    assert_eq!(c.len(), 3);
    let id = TileId { z: 0, x: 1, y: 0 };
    let e = c.entry(id).unwrap();
    let rec = &bytes[e.offset as usize..e.offset as usize + e.len as usize];
    let r = TileRecord::parse(id, rec, &e).unwrap();
    assert_eq!(r.corners, [1.0, 2.0, 3.0, 4.0]);
    assert_eq!(r.stream, b"second");
    assert!(c.entry(TileId { z: 9, x: 0, y: 0 }).is_none());
    // Records follow the header in (z, x, y) order.
    let offsets: Vec<u64> = c.tiles().map(|(_, e)| e.offset).collect();
    assert_eq!(offsets[0] as usize, c.header_len());
    assert!(offsets.windows(2).all(|w| w[0] < w[1]));
}

#[test]
fn every_truncation_of_the_header_is_an_error() {
    let bytes = sample();
    let c = Container::parse(&bytes, &Limits::default()).unwrap();
    for cut in 0..c.header_len() {
        assert!(
            Container::parse(&bytes[..cut], &Limits::default()).is_err(),
            "cut {cut}"
        );
    }
}

#[test]
fn a_flipped_bit_in_a_record_fails_that_tile_only() {
    let mut bytes = sample();
    let c = Container::parse(&bytes, &Limits::default()).unwrap();
    let (bad, good) = (TileId { z: 0, x: 0, y: 0 }, TileId { z: 0, x: 1, y: 0 });
    let e = c.entry(bad).unwrap();
    bytes[e.offset as usize + 33] ^= 0x10;
    let read = |id: TileId| {
        let e = c.entry(id).unwrap();
        TileRecord::parse(
            id,
            &bytes[e.offset as usize..(e.offset + u64::from(e.len)) as usize],
            &e,
        )
        .map(|r| r.stream.to_vec())
    };
    assert!(matches!(read(bad), Err(ContainerError::Checksum(_))));
    assert_eq!(read(good).unwrap(), b"second");
}

#[test]
fn a_flipped_bit_in_the_header_is_detected() {
    let mut bytes = sample();
    bytes[40] ^= 1;
    // In the metadata JSON: the CRC refuses it before the JSON parser sees it.
    assert_eq!(
        Container::parse(&bytes, &Limits::default()).unwrap_err(),
        ContainerError::Checksum("the header".into())
    );
}

#[test]
fn bad_magic_version_and_sizes_are_errors_not_allocations() {
    let bytes = sample();
    let mut b = bytes.clone();
    b[0] = b'X';
    assert_eq!(
        Container::parse(&b, &Limits::default()).unwrap_err(),
        ContainerError::Magic
    );
    let mut b = bytes.clone();
    b[4] = 9;
    assert_eq!(
        Container::parse(&b, &Limits::default()).unwrap_err(),
        ContainerError::Version(9)
    );
    let mut b = bytes.clone();
    b[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(
        Container::parse(&b, &Limits::default()),
        Err(ContainerError::Limit(_))
    ));
    let mut b = bytes;
    b[16..20].copy_from_slice(&1_000_000u32.to_le_bytes());
    assert!(matches!(
        Container::parse(&b, &Limits::default()),
        Err(ContainerError::Malformed(_))
    ));
}

/// Recomputes the header CRC after a test edits the metadata or index, so only the check
/// under test can refuse the header.
fn reseal(bytes: &mut [u8]) {
    let header_len = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
    let crc = crc32fast::hash(&bytes[FIXED_LEN..header_len]);
    bytes[20..24].copy_from_slice(&crc.to_le_bytes());
}

/// Offset of index entry `k` (25 bytes each, after the metadata).
fn entry_at(bytes: &[u8], k: usize) -> usize {
    let meta_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    FIXED_LEN + meta_len + ENTRY_LEN * k
}

#[test]
fn a_flipped_bit_in_the_index_is_a_checksum_error() {
    // Bit 24 of the last entry's y: tile 2/3/1 would become 2/3/16777217, a well-formed
    // entry that only the header CRC can tell from the written one.
    let mut bytes = sample();
    let at = entry_at(&bytes, 2);
    assert_eq!(bytes[at], 2, "entry 2 is tile 2/3/1");
    bytes[at + 8] ^= 1;
    assert_eq!(
        Container::parse(&bytes, &Limits::default()).unwrap_err(),
        ContainerError::Checksum("the header".into())
    );
    // The same flip with the CRC recomputed parses: the CRC was the only guard.
    reseal(&mut bytes);
    let c = Container::parse(&bytes, &Limits::default()).unwrap();
    assert!(c
        .entry(TileId {
            z: 2,
            x: 3,
            y: 1 + (1 << 24)
        })
        .is_some());
}

#[test]
fn a_record_above_max_record_bytes_is_a_limit() {
    // The sample's records are 32 + 6 ("second"), 32 + 5 and 32 + 0 bytes long.
    let bytes = sample();
    let limits = |max_record_bytes| Limits {
        max_record_bytes,
        ..Limits::default()
    };
    assert!(Container::parse(&bytes, &limits(38)).is_ok());
    assert!(matches!(
        Container::parse(&bytes, &limits(37)),
        Err(ContainerError::Limit(m)) if m.contains("tile 0/1/0") && m.contains("38 bytes")
    ));
}

#[test]
fn index_entries_pointing_into_the_header_or_repeated_are_malformed() {
    let sample = sample();
    let header_len = Container::parse(&sample, &Limits::default())
        .unwrap()
        .header_len();
    // Entry 0 (tile 0/0/0): its offset moved inside the header.
    let mut b = sample.clone();
    let at = entry_at(&b, 0);
    b[at + 9..at + 17].copy_from_slice(&(header_len as u64 - 1).to_le_bytes());
    reseal(&mut b);
    assert_eq!(
        Container::parse(&b, &Limits::default()).unwrap_err(),
        ContainerError::Malformed("index entry of tile 0/0/0".into())
    );
    // A record too short for its four corner heights.
    let mut b = sample.clone();
    b[at + 17..at + 21].copy_from_slice(&31u32.to_le_bytes());
    reseal(&mut b);
    assert!(matches!(
        Container::parse(&b, &Limits::default()),
        Err(ContainerError::Malformed(_))
    ));
    // Entry 1 (tile 0/1/0) renamed to tile 0/0/0: indexed twice.
    let mut b = sample;
    let at = entry_at(&b, 1);
    b[at + 1..at + 5].copy_from_slice(&0u32.to_le_bytes());
    reseal(&mut b);
    assert_eq!(
        Container::parse(&b, &Limits::default()).unwrap_err(),
        ContainerError::Malformed("tile 0/0/0 indexed twice".into())
    );
}

#[test]
fn unknown_header_flags_are_refused() {
    // Offset 6 lies outside the header CRC: only this check sees a flipped bit there.
    let mut b = sample();
    b[6] = 1;
    assert_eq!(
        Container::parse(&b, &Limits::default()).unwrap_err(),
        ContainerError::Flags(1)
    );
    let mut b = sample();
    b[7] = 0x80;
    let e = Container::parse(&b, &Limits::default()).unwrap_err();
    assert_eq!(e, ContainerError::Flags(0x8000));
    assert!(e.to_string().contains("flags 0x8000"), "{e}");
}

/// The sample's tiles under `m` (the header's CRC made for it, as a buggy writer's is).
fn with_metadata(m: &Metadata) -> Result<Container, ContainerError> {
    let mut w = Writer::new();
    w.add(TileId { z: 0, x: 0, y: 0 }, [0.0; 4], b"x");
    Container::parse(&w.finish(m).unwrap(), &Limits::default())
}

#[test]
fn metadata_the_server_cannot_use_is_refused_naming_the_field() {
    type Edit = fn(&mut Metadata);
    let cases: [(Edit, &str); 17] = [
        (
            |m| m.tile_side = 8193,
            "tile_side 8193: this build meshes tiles",
        ),
        // A zoom announced and listing no tiles, which verify would have passed.
        (
            |m| m.max_zoom = 3,
            "available lists 3 zooms, but min_zoom 0 to max_zoom 3 are 4",
        ),
        (
            |m| m.available.push(Vec::new()),
            "available lists 4 zooms, but min_zoom 0 to max_zoom 2 are 3",
        ),
        (
            |m| m.available[2].clear(),
            "available lists no tiles at zoom 2, which max_zoom 2 announces",
        ),
        (
            |m| m.max_zoom = 200,
            "max_zoom 200 is deeper than the tiling's deepest zoom 28 (the geodetic scheme)",
        ),
        (|m| m.min_zoom = 3, "min_zoom 3 is past max_zoom 2"),
        (
            |m| m.bounds = [200.0, 100.0, -200.0, -100.0],
            "bounds [200.0",
        ),
        (|m| m.bounds = [-72.0, 44.0, -71.0, 95.0], "latitudes"),
        (|m| m.bounds = [-72.0, 45.0, -71.0, 44.0], "south is north"),
        (|m| m.step = 0.0, "step 0"),
        (|m| m.step = -1.0, "step -1"),
        (|m| m.precision = Some(-1.0), "precision -1"),
        (|m| m.height_range = [5.0, -5.0], "height_range [5, -5]"),
        (
            |m| m.source_height_range = Some([1.0, 0.0]),
            "source_height_range",
        ),
        (|m| m.source_size = [0, 0], "source_size [0, 0]"),
        (|m| m.tile_side = 256, "tile_side 256"),
        (|m| m.scheme = "bogus".into(), "scheme \"bogus\""),
    ];
    for (edit, says) in cases {
        let mut m = metadata();
        edit(&mut m);
        match with_metadata(&m) {
            Err(ContainerError::Metadata(e)) => assert!(e.contains(says), "{says}: {e}"),
            other => panic!("{says}: {other:?}"),
        }
    }
    // JSON cannot carry these (serde writes null, which does not parse back as a number),
    // but metadata built in memory can.
    let cases: [(Edit, &str); 4] = [
        (|m| m.bounds[2] = f64::NAN, "not finite"),
        (|m| m.step = f64::INFINITY, "step inf"),
        (|m| m.fill = f64::NEG_INFINITY, "fill -inf"),
        (|m| m.view.a = f64::NAN, "view"),
    ];
    for (edit, says) in cases {
        let mut m = metadata();
        edit(&mut m);
        let e = m.check().unwrap_err();
        assert!(e.contains(says), "{says}: {e}");
    }
}

/// What ingest writes for every scheme parses: across the antimeridian (west past east),
/// a local grid (rows counted down, so south is the larger), the poles, web mercator's
/// deepest zoom, and a local grid's.
#[test]
fn metadata_ingest_writes_is_accepted() {
    type Edit = fn(&mut Metadata);
    let cases: [Edit; 7] = [
        |m| m.bounds = [177.0, -19.0, -179.0, -16.0],
        |m| m.bounds = [-180.0, -90.0, 180.0, 90.0],
        |m| m.bounds = [-180.0, -90.000_000_000_5, 180.0, 90.0],
        |m| (m.scheme, m.max_zoom) = ("mercator".into(), 28),
        // A local grid's full resolution: 1201 samples a side at zoom 3 (256 · 2³ ≥ 1200).
        |m| *m = local_1201(),
        // 599 column steps, 299 row steps: zoom 2 (3 × 2 tiles).
        |m| {
            *m = local_1201();
            (m.source_size, m.max_zoom) = ([300, 600], 2);
            m.bounds = [0.0, 299.0, 599.0, 0.0];
        },
        |m| (m.precision, m.source_height_range) = (None, Some([115.0, 1908.0])),
    ];
    for (k, edit) in cases.into_iter().enumerate() {
        let mut m = metadata();
        edit(&mut m);
        // Ingest lists every zoom, within its tiles.
        m.available = every_tile(&m);
        assert!(with_metadata(&m).is_ok(), "case {k}: {m:?}");
    }
    // Past it there is nothing to code.
    let mut m = local_1201();
    m.max_zoom = 4;
    assert!(matches!(
        with_metadata(&m),
        Err(ContainerError::Metadata(e)) if e.contains("deepest zoom 3 (a local grid of 1201 × 1201 samples)")
    ));
}

/// A local 1201² dataset as ingest writes it: zooms 0 to 3, every tile listed.
fn local_1201() -> Metadata {
    let mut m = metadata();
    (m.scheme, m.max_zoom) = ("local".into(), 3);
    m.bounds = [0.0, 1200.0, 1200.0, 0.0];
    m.available = every_tile(&m);
    m
}

/// One range a zoom, the tiling's whole grid there.
fn every_tile(m: &Metadata) -> Vec<Vec<Availability>> {
    let tiling = m.tiling().unwrap();
    (m.min_zoom..=m.max_zoom)
        .map(|z| {
            let (nx, ny) = tiling.tiles_per_axis(z).unwrap();
            vec![Availability {
                start_x: 0,
                start_y: 0,
                end_x: nx - 1,
                end_y: ny - 1,
            }]
        })
        .collect()
}

/// A local dataset's tiles are placed by `source_size`: one that disagrees with its zooms,
/// tiles or bounds (a buggy writer, the CRC resealed) scaled every mesh or announced tiles
/// the tiling has not, and `info --verify` passed it.
#[test]
fn a_local_source_size_that_disagrees_with_the_dataset_is_refused() {
    let cases: [([usize; 2], &str); 4] = [
        (
            [2401, 2401],
            "source_size [2401, 2401]: max_zoom 3 is a local grid's full resolution when its \
             longer side is 1026 to 2049 samples (257-sample tiles), not 2401",
        ),
        ([1201, 65535], "longer side is 1026 to 2049 samples"),
        (
            [1201, 255],
            "available at zoom 1: tiles x 0–1, y 0–1 are outside its 1 × 2 tiles (x 0–0, y 0–1) \
             in a local grid of source_size [1201, 255]",
        ),
        // Same tiles, another width: only the bounds tell.
        (
            [1201, 1100],
            "bounds [0.0, 1200.0, 1200.0, 0.0]: source_size [1201, 1100] makes a local grid's \
             bounds [0.0, 1200.0, 1099.0, 0.0]",
        ),
    ];
    for (size, says) in cases {
        let mut m = local_1201();
        m.source_size = size;
        match with_metadata(&m) {
            Err(ContainerError::Metadata(e)) => assert!(e.contains(says), "{size:?}: {e}"),
            other => panic!("{size:?}: {other:?}"),
        }
    }
    // A world dataset's source_size is the source raster's, which places nothing.
    let mut m = metadata();
    m.source_size = [2401, 2401];
    assert!(with_metadata(&m).is_ok());
    // A world range past its zoom's tiles is refused too: mercator's zoom 0 is one tile.
    m.scheme = "mercator".into();
    match with_metadata(&m) {
        Err(ContainerError::Metadata(e)) => assert!(
            e.contains("available at zoom 0: tiles x 0–1, y 0–0 are outside its 1 × 1 tiles")
                && e.contains("the mercator scheme"),
            "{e}"
        ),
        other => panic!("{other:?}"),
    }
}

/// `vertical_datum` reads back; absent, null or a datum this build does not model (a newer
/// writer's) is "not recorded", so the dataset stays servable; a value that is no name is
/// refused, naming the field.
#[test]
fn vertical_datums_read_back_and_unknown_ones_are_not_recorded() {
    use crate::geo::VerticalDatum;
    let mut m = metadata();
    m.vertical_datum = Some(VerticalDatum::Egm96);
    let json = serde_json::to_value(&m).unwrap();
    assert_eq!(json["vertical_datum"], "egm96");
    let read: Metadata = serde_json::from_value(json.clone()).unwrap();
    assert_eq!(read, m);
    for (value, want) in [
        (
            serde_json::json!("ellipsoid"),
            Some(VerticalDatum::Ellipsoid),
        ),
        (serde_json::json!("egm2008"), None),
        (serde_json::Value::Null, None),
    ] {
        let mut j = json.clone();
        j["vertical_datum"] = value.clone();
        let read: Metadata = serde_json::from_value(j).unwrap();
        assert_eq!(read.vertical_datum, want, "{value}");
    }
    let mut j = json.clone();
    j.as_object_mut().unwrap().remove("vertical_datum");
    assert_eq!(
        serde_json::from_value::<Metadata>(j)
            .unwrap()
            .vertical_datum,
        None
    );
    let mut j = json;
    j["vertical_datum"] = serde_json::json!(96);
    let e = serde_json::from_value::<Metadata>(j)
        .unwrap_err()
        .to_string();
    assert!(e.contains("vertical_datum 96"), "{e}");
}
