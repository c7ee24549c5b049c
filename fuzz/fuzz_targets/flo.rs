//! The Middlebury `.flo` reader: arbitrary bytes are a field or an error;
//! a field read back encodes to the same bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use reynoldsflow_host::outputs::flo;

fuzz_target!(|data: &[u8]| {
    let Ok(field) = flo::decode(data) else {
        return;
    };
    assert_eq!(field.u.len(), field.width * field.height);
    assert_eq!(field.v.len(), field.u.len());
    // NaN payloads may change through f64; everything else round-trips.
    if field.u.iter().chain(&field.v).all(|x| !x.is_nan()) {
        let bytes = flo::encode(field.width, field.height, &field.u, &field.v)
            .expect("a decoded size encodes");
        assert_eq!(bytes, data);
    }
});
