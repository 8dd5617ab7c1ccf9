//! The quantized-mesh decoder (the independent reader the tests check our writer with) must
//! turn any bytes into a tile or an error.
#![no_main]

use libfuzzer_sys::fuzz_target;
use zerotile_codec::formats::quantized_mesh::decode;

fuzz_target!(|data: &[u8]| {
    if let Ok(qm) = decode(data) {
        let n = qm.u.len();
        assert_eq!(n, qm.v.len());
        assert_eq!(n, qm.height.len());
        assert!(qm.triangles.iter().flatten().all(|&i| (i as usize) < n));
    }
});
