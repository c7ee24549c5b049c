//! Frame decoding as `run` does it for folders: PGM/PPM, PNG and JPEG
//! bytes to a gray frame. A frame comes out whole or the image is refused
//! with a typed problem; nothing panics, nothing huge is allocated.
#![no_main]

use libfuzzer_sys::fuzz_target;
use reynoldsflow_fuzz::small_limit;
use reynoldsflow_host::io::image_file;

fuzz_target!(|data: &[u8]| {
    let limits = small_limit();
    if let Ok(gray) = image_file::decode_gray(data, limits) {
        let (w, h) = gray.size();
        assert!(w > 0 && h > 0);
        assert_eq!(gray.pixels.len(), w * h);
        assert!((w * h) as u64 <= limits.max_pixels());
    }
});
