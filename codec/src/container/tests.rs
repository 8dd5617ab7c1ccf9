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
        fill: 0.0,
        view: ViewParams { a: 50.0, b: 0.0 },
        available: vec![vec![Availability {
            start_x: 0,
            start_y: 0,
            end_x: 1,
            end_y: 0,
        }]],
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
    assert!(Container::parse(&bytes, &Limits::default()).is_err());
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
