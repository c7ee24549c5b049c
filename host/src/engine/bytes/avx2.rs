//! The second step of per-frame min–max (each pixel's kept magnitudes and
//! its `fⁿ` byte to its three RGB bytes) in AVX2 lanes, 32 pixels a step:
//! the same bytes as [`bytes_from_kept`], which takes the last pixels.
//! Runs only in the AVX2 compilation of `dispatch`, which calls it where
//! the CPU has AVX2 (`multiversion`'s `target_cfg`); tested against the
//! portable step in `engine::lane`'s tests and `tests/tests/simd.rs`.
//!
//! Written with intrinsics: compiled from the portable step, the
//! interleaving of the three channels took some 100 shuffles, blends and
//! inserts for 32 pixels (5.3 instructions a pixel in all); here nine byte
//! shuffles, six ORs and three lane moves (2.5 in all, `valgrind
//! --tool=callgrind` of `reynoldsflow run`). The loads and stores go
//! through `bytemuck` casts of arrays, so there is no `unsafe` here.

use std::arch::x86_64::{
    __m256, __m256i, _mm256_add_ps, _mm256_cvttps_epi32, _mm256_min_ps, _mm256_mul_ps,
    _mm256_or_si256, _mm256_packs_epi32, _mm256_packus_epi16, _mm256_permute2x128_si256,
    _mm256_permutevar8x32_epi32, _mm256_set1_ps, _mm256_setr_epi32, _mm256_shuffle_epi8,
    _mm256_sub_ps,
};

use reynoldsflow_core::ByteScale;

use super::portable::bytes_from_kept;

/// Pixels a step: four vectors of eight magnitudes per channel, one of 32
/// bytes of `fⁿ`, three of 32 output bytes.
const STEP: usize = 32;

/// [`bytes_from_kept`] with AVX2: whole steps of [`STEP`] pixels in lanes,
/// the rest by the portable step.
#[target_feature(enable = "avx2")]
pub(crate) fn kept_to_bytes(
    [m_d, m_c]: [&[f32]; 2],
    luma: &[u8],
    rgb: &mut [u8],
    scales: &[ByteScale; 2],
) {
    let pixels = luma.len().min(m_d.len()).min(m_c.len()).min(rgb.len() / 3);
    let whole = pixels / STEP * STEP;
    let [map_d, map_c] = scales.map(|scale| scale.parts().map(|v| _mm256_set1_ps(v)));
    let masks = interleave_masks();
    let (outputs, _) = rgb[..3 * whole].as_chunks_mut::<{ 3 * STEP }>();
    let inputs = (m_d[..whole].as_chunks::<STEP>().0.iter())
        .zip(m_c[..whole].as_chunks::<STEP>().0)
        .zip(luma[..whole].as_chunks::<STEP>().0);
    for (out, ((m_d, m_c), luma)) in outputs.iter_mut().zip(inputs) {
        let red = channel_bytes(m_d, map_d);
        let green = channel_bytes(m_c, map_c);
        let blue: __m256i = bytemuck::cast(*luma);
        let chunks: [[u8; STEP]; 3] = interleave([red, green, blue], &masks).map(bytemuck::cast);
        *out = bytemuck::cast(chunks);
    }
    bytes_from_kept(
        [&m_d[whole..], &m_c[whole..]],
        &luma[whole..pixels],
        &mut rgb[3 * whole..],
        scales,
    );
}

/// The bytes of 32 magnitudes, in order, by `[offset, gain]`: `t = (m −
/// offset) · gain + ½` (three roundings, as `ByteScale::byte`), then
/// `min(255, t)` with the constant first, so a NaN stays NaN, truncated
/// (a NaN or any `t < −2³¹` becomes `i32::MIN`), then narrowed with
/// saturation, which takes every negative value (and so `i32::MIN`) to 0:
/// the byte of `t` clamped to `[0, 255]`, NaN to 0, as `fpu::byte`.
#[target_feature(enable = "avx2")]
fn channel_bytes(m: &[f32; STEP], [offset, gain]: [__m256; 2]) -> __m256i {
    let quarters: [[f32; 8]; 4] = bytemuck::cast(*m);
    let [a, b, c, d] = quarters.map(|q| {
        let t = _mm256_add_ps(
            _mm256_mul_ps(_mm256_sub_ps(bytemuck::cast(q), offset), gain),
            _mm256_set1_ps(0.5),
        );
        _mm256_cvttps_epi32(_mm256_min_ps(_mm256_set1_ps(255.0), t))
    });
    // Within each 128-bit half: 16-bit words of [a, b] and [c, d], then
    // bytes of both: the half holds pixels (as 4-byte groups) 0, 2, 4, 6 of
    // the eight groups, the upper half 1, 3, 5, 7; the permutation puts
    // them in order.
    let bytes = _mm256_packus_epi16(_mm256_packs_epi32(a, b), _mm256_packs_epi32(c, d));
    _mm256_permutevar8x32_epi32(bytes, _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7))
}

/// Byte shuffles for [`interleave`]: `[chunk][channel]`, the same in both
/// 128-bit halves: byte `j` of chunk `k` is output byte `16k + j` of the
/// half's 16 pixels, channel `(16k + j) mod 3` of pixel `(16k + j) / 3`;
/// the other channels' shuffles give 0 there (index with the top bit set).
fn interleave_masks() -> [[__m256i; 3]; 3] {
    std::array::from_fn(|chunk| {
        std::array::from_fn(|channel| {
            let mask: [u8; 32] = std::array::from_fn(|i| {
                let at = 16 * chunk + i % 16;
                if at % 3 == channel {
                    (at / 3) as u8
                } else {
                    0x80
                }
            });
            bytemuck::cast(mask)
        })
    })
}

/// Three channels of 32 bytes each to 96 bytes `R G B R G B …`: within
/// each 128-bit half (16 pixels) three 16-byte chunks by byte shuffles,
/// then the halves' chunks put in order (the lower half's pixels first).
#[target_feature(enable = "avx2")]
fn interleave(channels: [__m256i; 3], masks: &[[__m256i; 3]; 3]) -> [__m256i; 3] {
    // Written out, not by closures: LLVM left a closure here out of line
    // in some builds of the host (twice the instructions of the step).
    let [r, g, b] = channels;
    let [[r0, g0, b0], [r1, g1, b1], [r2, g2, b2]] = *masks;
    let (r0, g0, b0) = (
        _mm256_shuffle_epi8(r, r0),
        _mm256_shuffle_epi8(g, g0),
        _mm256_shuffle_epi8(b, b0),
    );
    let (r1, g1, b1) = (
        _mm256_shuffle_epi8(r, r1),
        _mm256_shuffle_epi8(g, g1),
        _mm256_shuffle_epi8(b, b1),
    );
    let (r2, g2, b2) = (
        _mm256_shuffle_epi8(r, r2),
        _mm256_shuffle_epi8(g, g2),
        _mm256_shuffle_epi8(b, b2),
    );
    let c0 = _mm256_or_si256(_mm256_or_si256(r0, g0), b0);
    let c1 = _mm256_or_si256(_mm256_or_si256(r1, g1), b1);
    let c2 = _mm256_or_si256(_mm256_or_si256(r2, g2), b2);
    [
        _mm256_permute2x128_si256::<0x20>(c0, c1),
        _mm256_permute2x128_si256::<0x30>(c2, c0),
        _mm256_permute2x128_si256::<0x31>(c1, c2),
    ]
}
