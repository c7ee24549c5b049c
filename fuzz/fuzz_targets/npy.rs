//! The `.npy` readers: 2-D float64 planes (`npy::decode`, what `pair`
//! writes) and (H, W, 2) vector fields (`decode_npy_xy`, what `run --npy`
//! writes). Arbitrary bytes are an array of the stated shape or an error.
#![no_main]

use libfuzzer_sys::fuzz_target;
use reynoldsflow_host::{io::npy, outputs};

fuzz_target!(|data: &[u8]| {
    if let Ok(array) = npy::decode(data) {
        assert_eq!(array.data.len(), array.height * array.width);
    }
    if let Ok((h, w, x, y)) = outputs::decode_npy_xy(data) {
        assert_eq!((x.len(), y.len()), (h * w, h * w));
    }
});
