use image::{ImageEncoder, ExtendedColorType};
use image::codecs::png::{PngEncoder, CompressionType, FilterType};
use std::time::Instant;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let img = image::open(&args[1]).unwrap().to_rgb8();
    let (w, h) = img.dimensions();
    let rgb = img.as_raw();
    let n = 20;
    let t = |name: &str, f: &dyn Fn() -> Vec<u8>| {
        let _ = f();
        let s = Instant::now();
        let mut len = 0;
        for _ in 0..n { len = f().len(); }
        println!("{name:28} {:7.2} ms {:8} B", s.elapsed().as_secs_f64() * 1e3 / n as f64, len);
    };
    for (cn, c) in [("fast", CompressionType::Fast), ("default", CompressionType::Default), ("best", CompressionType::Best)] {
        for (fname, f) in [("adaptive", FilterType::Adaptive), ("up", FilterType::Up), ("sub", FilterType::Sub), ("paeth", FilterType::Paeth)] {
            if cn == "best" && fname != "adaptive" { continue; }
            t(&format!("png {cn} {fname}"), &|| { let mut v = Vec::new(); PngEncoder::new_with_quality(&mut v, c, f).write_image(rgb, w, h, ExtendedColorType::Rgb8).unwrap(); v });
        }
    }
    t("image jpeg q95", &|| { let mut v = Vec::new(); image::codecs::jpeg::JpegEncoder::new_with_quality(&mut v, 95).write_image(rgb, w, h, ExtendedColorType::Rgb8).unwrap(); v });
    for (sn, s) in [("420", jpeg_encoder::SamplingFactor::R_4_2_0), ("444", jpeg_encoder::SamplingFactor::R_4_4_4)] {
        t(&format!("jpeg-encoder q95 {sn}"), &|| { let mut v = Vec::new(); let mut e = jpeg_encoder::Encoder::new(&mut v, 95); e.set_sampling_factor(s); e.encode(rgb, w as u16, h as u16, jpeg_encoder::ColorType::Rgb).unwrap(); v });
    }
}
