//! The portable min–max byte step: each pixel's kept magnitudes and its
//! `fⁿ` byte to its three RGB bytes, in the core's batches.

use reynoldsflow_core::{ByteScale, FlowPixel, rgb_batch};

/// Pixels per batch of the min–max byte step ([`rgb_batch`]).
const BYTE_BATCH: usize = reynoldsflow_core::RGB_BATCH;

/// The second step of per-frame min–max: each pixel's kept magnitudes and
/// its `fⁿ` byte (`luma`: the frame itself, the B channel unchanged) to its
/// three RGB bytes, once the frame's scales are known. Compiled for each
/// ISA by [`super::kept_to_bytes`].
#[inline(always)]
pub(crate) fn bytes_from_kept(
    [m_d, m_c]: [&[f32]; 2],
    luma: &[u8],
    rgb: &mut [u8],
    scales: &[ByteScale; 2],
) {
    let [scale_d, scale_c] = scales;
    let pixels = luma.len().min(m_d.len()).min(m_c.len());
    let (m_d, m_c, luma) = (&m_d[..pixels], &m_c[..pixels], &luma[..pixels]);
    let out = rgb.as_chunks_mut::<3>().0;
    let (batches, rest) = out.as_chunks_mut::<BYTE_BATCH>();
    let inputs = m_d
        .as_chunks::<BYTE_BATCH>()
        .0
        .iter()
        .zip(m_c.as_chunks::<BYTE_BATCH>().0)
        .zip(luma.as_chunks::<BYTE_BATCH>().0);
    let whole = batches.len().min(pixels / BYTE_BATCH);
    for (out, ((m_d, m_c), luma)) in batches.iter_mut().zip(inputs) {
        rgb_batch([m_d, m_c], luma, [scale_d, scale_c], out);
    }
    let start = whole * BYTE_BATCH;
    let tail = m_d[start..].iter().zip(&m_c[start..]).zip(&luma[start..]);
    for (out, ((&m_d, &m_c), &luma)) in rest.iter_mut().zip(tail) {
        let pixel = FlowPixel {
            m_d,
            m_c,
            luma,
            ..FlowPixel::default()
        };
        *out = reynoldsflow_core::rgb(&pixel, scale_d, scale_c);
    }
}
