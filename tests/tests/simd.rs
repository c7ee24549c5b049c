//! The engine pass compiled for the CPU's widest instructions (AVX2 on
//! x86-64, chosen at run time) against the baseline compilation: identical
//! fields, magnitudes and bytes, on the shared vectors and on generated
//! pairs of every pattern, sizes, tilings, parameters and both scalings.
//!
//! `scripts/test` sets `REYNOLDSFLOW_REQUIRE_AVX2=1` on a CPU with AVX2, so
//! there the comparison cannot silently be baseline against itself.

use fixed::types::{U16F16, U32F32};
use reynoldsflow_core::{IntensityScale, Params, Scaling};
use reynoldsflow_host::internals::bytes::{self, Isa};
use reynoldsflow_host::internals::compute_fixed_on;
use reynoldsflow_host::limits::Limits;
use reynoldsflow_host::{Gray, io::image_file};
use reynoldsflow_tests::{Pattern, frame_pair, vector_cases, vectors_dir};

const SCALINGS: [Scaling; 2] = [
    Scaling::PerFrameMinMax,
    Scaling::Fixed {
        k_d: U16F16::lit("8"),
        k_c: U16F16::lit("32"),
    },
];

/// Both compilations on one pair; panics on the first difference.
fn same_on_both(
    what: &str,
    prev: &Gray,
    next: &Gray,
    params: Params,
    tile: Option<(usize, usize)>,
) {
    for scaling in SCALINGS {
        let run = |isa| compute_fixed_on(isa, prev, next, params, tile, scaling).unwrap();
        let (best, portable) = (run(Isa::Best), run(Isa::Portable));
        assert!(
            best == portable,
            "{what}, tile {tile:?}, {scaling:?}: {} and portable differ",
            bytes::best_name()
        );
    }
}

#[test]
fn the_cpu_has_what_the_suite_requires() {
    let required = std::env::var_os("REYNOLDSFLOW_REQUIRE_AVX2").is_some_and(|v| v == "1");
    println!(
        "engine pass compared: {} against portable",
        bytes::best_name()
    );
    if required {
        assert_eq!(bytes::best_name(), "avx2", "AVX2 required but not detected");
    }
}

#[test]
fn simd_and_portable_agree_on_the_vectors() {
    for case in vector_cases() {
        let dir = vectors_dir().join(&case);
        let f0 = image_file::read_gray(&dir.join("f0.pgm"), Limits::default()).unwrap();
        let f1 = image_file::read_gray(&dir.join("f1.pgm"), Limits::default()).unwrap();
        same_on_both(&case, &f0, &f1, Params::DEFAULT, None);
    }
}

#[test]
fn simd_and_portable_agree_on_generated_pairs() {
    let params = [
        Params::DEFAULT,
        // The largest admissible κ and a large λ: the widest intermediates.
        Params {
            scale: IntensityScale::new(1, 1 << 18).unwrap(),
            lambda: U32F32::from_bits(1),
        },
        Params {
            scale: IntensityScale::new(1, 16).unwrap(),
            lambda: U32F32::from_num(0.01),
        },
    ];
    let mut pairs = 0;
    for (p, pattern) in Pattern::ALL.into_iter().enumerate() {
        for (k, (w, h)) in [(1, 1), (9, 4), (37, 23), (150, 40), (300, 17)]
            .into_iter()
            .enumerate()
        {
            let seed = (p * 10 + k) as u64;
            let (a, b) = frame_pair(pattern, w, h, seed);
            let (a, b) = (Gray::new(w, h, a).unwrap(), Gray::new(w, h, b).unwrap());
            let what = format!("{pattern:?} {w}x{h} seed {seed}");
            for params in params {
                same_on_both(&what, &a, &b, params, None);
            }
            same_on_both(&what, &a, &b, Params::DEFAULT, Some((17, 9)));
            pairs += 1;
        }
    }
    println!(
        "{pairs} generated pairs identical on {}",
        bytes::best_name()
    );
}
