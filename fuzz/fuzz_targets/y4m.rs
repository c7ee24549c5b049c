//! The Y4M reader on arbitrary bytes, delivered in arbitrary read sizes:
//! headers, chroma layouts, FRAME lines, truncation. Every frame it
//! returns has the header's size; nothing panics.
#![no_main]

use std::io::BufReader;

use libfuzzer_sys::fuzz_target;
use reynoldsflow_fuzz::{Chunked, small_limit};
use reynoldsflow_host::sequence::FrameSource;
use reynoldsflow_host::sequence::y4m::Y4mSource;

fuzz_target!(|data: &[u8]| {
    let limits = small_limit();
    let Some((&chunking, bytes)) = data.split_first() else {
        return;
    };
    let len = bytes.len() as u64;
    let reader = BufReader::new(Chunked::new(bytes.to_vec(), chunking));
    let Ok(mut source) = Y4mSource::new("fuzz.y4m".into(), Box::new(reader), Some(len), limits) else {
        return;
    };
    let (w, h) = (source.header().width, source.header().height);
    for _ in 0..64 {
        match source.next_frame() {
            Ok(Some(frame)) => assert_eq!(frame.gray.size(), (w, h)),
            Ok(None) | Err(_) => return,
        }
    }
});
