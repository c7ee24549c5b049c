//! The raw-stream reader (`--raw WxH`): any frame size (in or out of the
//! limit), any bytes in any read sizes. Whole frames come out in order, a
//! partial one is an error, nothing panics.
#![no_main]

use libfuzzer_sys::fuzz_target;
use reynoldsflow_fuzz::{Chunked, small_limit};
use reynoldsflow_host::sequence::FrameSource;
use reynoldsflow_host::sequence::raw::RawSource;

fuzz_target!(|data: &[u8]| {
    let limits = small_limit();
    let [w0, w1, h0, h1, chunking, rest @ ..] = data else {
        return;
    };
    // Sizes from 0 to 65535 per side: tiny ones stream, huge ones are refused.
    let width = usize::from(u16::from_le_bytes([*w0, *w1]));
    let height = usize::from(u16::from_le_bytes([*h0, *h1]));
    let Ok(mut source) = RawSource::new(
        "fuzz.raw".into(),
        Box::new(Chunked::new(rest.to_vec(), *chunking)),
        width,
        height,
        limits,
    ) else {
        return;
    };
    source.set_total_bytes(Some(rest.len() as u64));
    let size = width * height;
    let mut at = 0;
    loop {
        match source.next_frame() {
            Ok(Some(frame)) => {
                assert_eq!(frame.gray.pixels, rest[at..at + size]);
                at += size;
            }
            Ok(None) => {
                assert_eq!(at, rest.len(), "a clean end only after the last byte");
                return;
            }
            Err(_) => {
                assert!(rest.len() - at < size, "an error only on a partial frame");
                return;
            }
        }
    }
});
