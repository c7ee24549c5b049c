//! The seed corpus of the fuzz targets (`fuzz/corpus/<target>/<name>`):
//! small valid inputs of every kind each reader accepts, plus near misses
//! (huge headers, truncation), so a short fuzzing run starts deep in the
//! parsers. The files are committed; this test makes them and checks the
//! committed ones match (`REYNOLDSFLOW_WRITE_SEEDS=1` rewrites them).

use std::collections::BTreeMap;
use std::fs;
use std::path::Path;

use image::codecs::jpeg::JpegEncoder;
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};
use reynoldsflow_host::limits::Limits;
use reynoldsflow_host::outputs::{encode_npy_xy, flo};
use reynoldsflow_host::{io::image_file, io::npy};

/// `target/name` → bytes.
type Seeds = BTreeMap<String, Vec<u8>>;

fn put(seeds: &mut Seeds, target: &str, name: &str, bytes: &[u8]) {
    seeds.insert(format!("{target}/{name}"), bytes.to_vec());
}

/// A small textured frame.
fn texture(w: usize, h: usize, t: usize, channels: usize) -> Vec<u8> {
    (0..w * h * channels)
        .map(|i| {
            let (p, c) = (i / channels, i % channels);
            ((p % w * 37 + p / w * 11 + 5 * t + 70 * c) % 251) as u8
        })
        .collect()
}

fn y4m_seeds(seeds: &mut Seeds) {
    // First byte: the read-size pattern of the target's reader.
    let layouts = [
        ("", 8),
        (" C420jpeg", 8),
        (" C420paldv", 8),
        (" C420mpeg2", 8),
        (" C422", 12),
        (" C411", 6),
        (" C444", 18),
        (" C444alpha", 27),
        (" Cmono", 0),
        (" C420p10", 8),
    ];
    for (i, (c, extra)) in layouts.iter().enumerate() {
        let mut bytes = vec![i as u8 * 17];
        bytes.extend(format!("YUV4MPEG2 W3 H3 F30000:1001 Ip A1:1{c} XYSCSS=420JPEG\n").bytes());
        for t in 0..2 {
            bytes.extend(b"FRAME\n");
            bytes.extend(texture(3, 3, t, 1));
            bytes.extend(vec![128; *extra]);
        }
        put(seeds, "y4m", &format!("layout{i}"), &bytes);
    }
    let mut truncated = vec![3];
    truncated.extend(b"YUV4MPEG2 W8 H2 Cmono\nFRAME Ixyz\n");
    truncated.extend(texture(8, 2, 0, 1));
    truncated.extend(b"FRAME\n\x01\x02");
    put(seeds, "y4m", "truncated", &truncated);
    put(
        seeds,
        "y4m",
        "huge",
        b"\x00YUV4MPEG2 W100000 H100000 C420jpeg\nFRAME\n",
    );
}

fn raw_seeds(seeds: &mut Seeds) {
    for (i, (w, h, frames)) in [(3u16, 2u16, 3usize), (1, 1, 5), (17, 4, 2), (5, 5, 0)]
        .into_iter()
        .enumerate()
    {
        let mut bytes = [w.to_le_bytes(), h.to_le_bytes()].concat();
        bytes.push(i as u8 * 29);
        for t in 0..frames {
            bytes.extend(texture(w.into(), h.into(), t, 1));
        }
        if i == 2 {
            bytes.extend([1, 2, 3]);
        }
        put(seeds, "raw", &format!("raw{i}"), &bytes);
    }
    put(seeds, "raw", "huge", &[0xa0, 0x86, 0xa0, 0x86, 0, 1, 2, 3]);
}

fn image_seeds(seeds: &mut Seeds) {
    let (w, h) = (6u32, 4u32);
    let gray = texture(6, 4, 0, 1);
    put(
        seeds,
        "image",
        "p5.pgm",
        &[b"P5\n# comment\n6 4\n255\n".as_slice(), &gray].concat(),
    );
    let ascii: String = gray.iter().map(|p| format!("{p} ")).collect();
    put(
        seeds,
        "image",
        "p2.pgm",
        format!("P2 6 4 255\n{ascii}\n").as_bytes(),
    );
    put(
        seeds,
        "image",
        "p6.ppm",
        &[b"P6 6 4 255\n".as_slice(), &texture(6, 4, 0, 3)].concat(),
    );
    put(
        seeds,
        "image",
        "p5-16bit.pgm",
        &[b"P5 2 1 65535\n".as_slice(), &[1, 2, 3, 4]].concat(),
    );
    put(
        seeds,
        "image",
        "p7.pam",
        &[
            b"P7\nWIDTH 2\nHEIGHT 1\nDEPTH 1\nMAXVAL 255\nTUPLTYPE GRAYSCALE\nENDHDR\n".as_slice(),
            &[7, 9],
        ]
        .concat(),
    );
    put(
        seeds,
        "image",
        "huge.pgm",
        b"P5 100000 100000 255\n\x00\x01",
    );
    for (name, color, channels) in [
        ("l8.png", ExtendedColorType::L8, 1),
        ("la8.png", ExtendedColorType::La8, 2),
        ("rgb8.png", ExtendedColorType::Rgb8, 3),
        ("rgba8.png", ExtendedColorType::Rgba8, 4),
        ("l16.png", ExtendedColorType::L16, 2),
    ] {
        let mut png = Vec::new();
        PngEncoder::new(&mut png)
            .write_image(&texture(6, 4, 0, channels), w, h, color)
            .unwrap();
        put(seeds, "image", name, &png);
    }
    put(
        seeds,
        "image",
        "rep.png",
        &image_file::encode_png(6, 4, &texture(6, 4, 1, 3)).unwrap(),
    );
    for (name, color, channels) in [
        ("gray.jpg", ExtendedColorType::L8, 1),
        ("rgb.jpg", ExtendedColorType::Rgb8, 3),
    ] {
        let mut jpeg = Vec::new();
        JpegEncoder::new_with_quality(&mut jpeg, 90)
            .write_image(&texture(16, 9, 0, channels), 16, 9, color)
            .unwrap();
        put(seeds, "image", name, &jpeg);
    }
}

fn field_seeds(seeds: &mut Seeds) {
    let u: Vec<f64> = (0..6).map(|i| f64::from(i) * 0.5 - 1.0).collect();
    let v: Vec<f64> = (0..6).map(|i| f64::from(i) * -0.25).collect();
    put(seeds, "flo", "3x2.flo", &flo::encode(3, 2, &u, &v).unwrap());
    put(
        seeds,
        "flo",
        "0x0.flo",
        &flo::encode(0, 0, &[], &[]).unwrap(),
    );
    let mut huge = flo::encode(1, 1, &[0.0], &[0.0]).unwrap();
    huge[4..12].copy_from_slice(&[0xff, 0xff, 0xff, 0x7f, 0xff, 0xff, 0xff, 0x7f]);
    put(seeds, "flo", "huge.flo", &huge);
    put(seeds, "npy", "plane.npy", &npy::encode(2, 3, &u));
    put(
        seeds,
        "npy",
        "field.npy",
        &encode_npy_xy(3, 1, &u[..3], &v[..3]),
    );
    // NumPy's own spellings: Fortran order, big-endian, and a huge shape.
    let header = |dict: &str| {
        let mut h = format!("{dict}\n").into_bytes();
        let pad = (64 - (10 + h.len()) % 64) % 64;
        h.splice(h.len() - 1..h.len() - 1, std::iter::repeat_n(b' ', pad));
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend((h.len() as u16).to_le_bytes());
        out.extend(h);
        out
    };
    let le: Vec<u8> = u.iter().flat_map(|x| x.to_le_bytes()).collect();
    let be: Vec<u8> = u.iter().flat_map(|x| x.to_be_bytes()).collect();
    let fortran = header("{'descr': '<f8', 'fortran_order': True, 'shape': (2, 3), }");
    put(seeds, "npy", "fortran.npy", &[fortran, le.clone()].concat());
    let big = header("{'descr': '>f8', 'fortran_order': False, 'shape': (3, 2), }");
    put(seeds, "npy", "big-endian.npy", &[big, be].concat());
    let huge =
        header("{'descr': '<f8', 'fortran_order': False, 'shape': (4294967296, 4294967296), }");
    put(seeds, "npy", "huge.npy", &[huge, le].concat());
}

fn core_seeds(seeds: &mut Seeds) {
    // `arbitrary` reads any bytes: a spread of lengths and patterns.
    let mut state = 0x9e37_79b9u32;
    for (i, len) in [16usize, 40, 64, 96, 128, 256].into_iter().enumerate() {
        let bytes: Vec<u8> = (0..len)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                state as u8
            })
            .collect();
        put(seeds, "core", &format!("random{i}"), &bytes);
    }
    put(seeds, "core", "zeros", &[0; 64]);
    put(seeds, "core", "ones", &[0xff; 64]);
}

fn seeds() -> Seeds {
    let mut seeds = Seeds::new();
    y4m_seeds(&mut seeds);
    raw_seeds(&mut seeds);
    image_seeds(&mut seeds);
    field_seeds(&mut seeds);
    core_seeds(&mut seeds);
    seeds
}

/// The committed corpus holds what this file makes (and, beside it,
/// inputs that once failed a target, kept as they were found); with
/// `REYNOLDSFLOW_WRITE_SEEDS=1` it (re)writes the generated ones.
#[test]
fn the_committed_seed_corpus_is_the_generated_one() {
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus");
    let seeds = seeds();
    if std::env::var("REYNOLDSFLOW_WRITE_SEEDS").is_ok_and(|v| v == "1") {
        for (rel, bytes) in &seeds {
            let path = corpus.join(rel);
            fs::create_dir_all(path.parent().unwrap()).unwrap();
            fs::write(path, bytes).unwrap();
        }
    }
    for (rel, bytes) in &seeds {
        let committed = fs::read(corpus.join(rel)).unwrap_or_else(|e| {
            panic!("fuzz/corpus/{rel}: {e} (REYNOLDSFLOW_WRITE_SEEDS=1 writes it)")
        });
        assert!(
            committed == *bytes,
            "fuzz/corpus/{rel} differs from its generator"
        );
    }
    // Each reader accepts its valid seeds (a seed the reader refuses would
    // start the fuzzer nowhere).
    for name in [
        "p5.pgm",
        "p2.pgm",
        "p6.ppm",
        "l8.png",
        "rgba8.png",
        "gray.jpg",
        "rgb.jpg",
    ] {
        image_file::decode_gray(&seeds[&format!("image/{name}")], Limits::default()).unwrap();
    }
    flo::decode(&seeds["flo/3x2.flo"]).unwrap();
    for name in ["plane.npy", "fortran.npy", "big-endian.npy"] {
        npy::decode(&seeds[&format!("npy/{name}")]).unwrap();
    }
}
