//! The dataset container reader must turn any bytes into a container or an error, within
//! the limits it is given: never a panic or an allocation sized by a hostile header.
#![no_main]

use libfuzzer_sys::fuzz_target;
use zerotile_codec::container::{Container, Limits, TileRecord};

fuzz_target!(|data: &[u8]| {
    let limits = Limits {
        max_header_bytes: 1 << 20,
        max_record_bytes: 1 << 20,
    };
    let Ok(c) = Container::parse(data, &limits) else {
        return;
    };
    assert!(c.header_len() <= data.len());
    for (id, e) in c.tiles() {
        let (Ok(start), Ok(len)) = (usize::try_from(e.offset), usize::try_from(e.len)) else {
            continue;
        };
        if let Some(bytes) = start.checked_add(len).and_then(|end| data.get(start..end)) {
            // Checksums and lengths are checked; a bad record is an error, not a panic.
            let _ = TileRecord::parse(id, bytes, &e);
        }
    }
});
