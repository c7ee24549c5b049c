//! Does libjpeg-turbo (bundled, its default accurate integer DCT, quality 95)
//! give the same bytes on every build? Encodes one fixed 640x480 RGB image at
//! 4:4:4 and 4:2:0 with it and with `jpeg-encoder` (the host's encoder), writes
//! tj-444.jpg and tj-420.jpg, and prints sizes, FNV-1a hashes and ms a frame
//! over REPS encodings (the first argument, 1 by default).
use std::time::Instant;
fn image(w: usize, h: usize) -> Vec<u8> {
    let mut s: u32 = 12345;
    let mut v = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for x in 0..w {
            for c in 0..3 {
                s = s.wrapping_mul(1664525).wrapping_add(1013904223);
                let smooth = ((x * (c + 1) + y * 2) % 256) as u32;
                v.push(((smooth * 3 + (s >> 24) % 64) / 4) as u8);
            }
        }
    }
    v
}
fn fnv(b: &[u8]) -> u64 {
    b.iter().fold(0xcbf29ce484222325u64, |h, &x| {
        (h ^ x as u64).wrapping_mul(0x100000001b3)
    })
}
fn main() {
    let (w, h) = (640usize, 480usize);
    let rgb = image(w, h);
    let reps: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(1);
    for (name, ss, js) in [
        (
            "444",
            turbojpeg::Subsamp::None,
            jpeg_encoder::SamplingFactor::R_4_4_4,
        ),
        (
            "420",
            turbojpeg::Subsamp::Sub2x2,
            jpeg_encoder::SamplingFactor::R_4_2_0,
        ),
    ] {
        let mut c = turbojpeg::Compressor::new().unwrap();
        c.set_quality(95).unwrap();
        c.set_subsamp(ss).unwrap();
        let img = turbojpeg::Image {
            pixels: &rgb[..],
            width: w,
            pitch: 3 * w,
            height: h,
            format: turbojpeg::PixelFormat::RGB,
        };
        let t = Instant::now();
        let mut out = Vec::new();
        for _ in 0..reps {
            out = c.compress_to_vec(img).unwrap();
        }
        let tj = t.elapsed().as_secs_f64() * 1e3 / reps as f64;
        std::fs::write(format!("tj-{name}.jpg"), &out).unwrap();
        let t = Instant::now();
        let mut je = Vec::new();
        for _ in 0..reps {
            je = Vec::new();
            let mut e = jpeg_encoder::Encoder::new(&mut je, 95);
            e.set_sampling_factor(js);
            e.encode(&rgb, w as u16, h as u16, jpeg_encoder::ColorType::Rgb)
                .unwrap();
        }
        let jt = t.elapsed().as_secs_f64() * 1e3 / reps as f64;
        println!("{name}: turbojpeg {} bytes fnv {:016x} {tj:.2} ms | jpeg-encoder {} bytes fnv {:016x} {jt:.2} ms", out.len(), fnv(&out), je.len(), fnv(&je));
    }
}
