//! Headers claiming huge frames are refused from the header alone: a clear
//! error, little memory, little CPU. `--max-pixels` sets the limit, and
//! `--help` states its default.

use std::ffi::OsString;
use std::fs;

mod child_support;
mod run_support;

use child_support::run_measured;
use run_support::{BIN, moving_frame, ok, pgm, run, stderr, tree};

/// A PNG whose IHDR claims `w × h` gray pixels, followed by a little data.
fn png_header(w: u32, h: u32) -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut crc = !0u32;
        for &b in bytes {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = (crc >> 1) ^ (0xedb8_8320 & (crc & 1).wrapping_neg());
            }
        }
        !crc
    }
    let chunk = |kind: &[u8], data: &[u8]| {
        let mut c = (data.len() as u32).to_be_bytes().to_vec();
        let body = [kind, data].concat();
        c.extend(&body);
        c.extend(crc32(&body).to_be_bytes());
        c
    };
    let ihdr = [&w.to_be_bytes()[..], &h.to_be_bytes(), &[8, 0, 0, 0, 0]].concat();
    // A zlib stream of a few zero rows: valid data, far too short.
    let idat = [0x78, 0x9c, 0x63, 0x60, 0x00, 0x00, 0x00, 0x02, 0x00, 0x01];
    [
        b"\x89PNG\r\n\x1a\n".to_vec(),
        chunk(b"IHDR", &ihdr),
        chunk(b"IDAT", &idat),
        chunk(b"IEND", &[]),
    ]
    .concat()
}

fn os(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Vec<OsString> {
    args.iter().map(|a| a.as_ref().to_owned()).collect()
}

#[test]
fn huge_headers_are_refused_from_the_header_in_little_memory() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let y4m = d.join("huge.y4m");
    let mut bytes = b"YUV4MPEG2 W100000 H100000 F25:1 C420jpeg\nFRAME\n".to_vec();
    bytes.extend(vec![7u8; 1 << 16]);
    fs::write(&y4m, &bytes).unwrap();
    for (name, bytes) in [
        (
            "pgm",
            [b"P5\n100000 100000\n255\n".as_slice(), &[7; 1 << 16]].concat(),
        ),
        ("png", png_header(100_000, 100_000)),
    ] {
        let folder = d.join(name);
        fs::create_dir(&folder).unwrap();
        fs::write(folder.join(format!("f0.{name}")), &bytes).unwrap();
        fs::write(folder.join(format!("f1.{name}")), &bytes).unwrap();
    }
    let cases: [(&str, Vec<OsString>); 4] = [
        ("y4m", os(&[&"run", &y4m, &"--out", &d.join("o1")])),
        (
            "pgm",
            os(&[&"run", &d.join("pgm"), &"--out", &d.join("o2")]),
        ),
        (
            "png",
            os(&[&"run", &d.join("png"), &"--out", &d.join("o3")]),
        ),
        (
            "png pair",
            os(&[
                &"pair",
                &d.join("png/f0.png"),
                &d.join("png/f1.png"),
                &"--out",
                &d.join("o4"),
            ]),
        ),
    ];
    for (what, args) in cases {
        let m = run_measured(BIN, &args);
        println!(
            "{what}: 100000x100000 refused: peak RSS {:.1} MiB, CPU {:.3} s",
            m.max_rss_kib as f64 / 1024.0,
            m.cpu_seconds
        );
        assert_eq!(m.status.code(), Some(1), "{what}: {}", m.stderr);
        assert!(
            m.stderr.contains(
                "100000x100000 (10000000000 pixels) exceeds the limit of 67108864 pixels"
            ) && m.stderr.contains("--max-pixels")
                && m.stderr.lines().count() == 1,
            "{what}: {}",
            m.stderr
        );
        assert!(
            m.max_rss_kib < 50 * 1024,
            "{what}: peak RSS {} KiB",
            m.max_rss_kib
        );
        // CPU time, not wall time: unaffected by other loads on the machine.
        assert!(m.cpu_seconds < 0.5, "{what}: {} s of CPU", m.cpu_seconds);
    }
    for out in ["o1", "o2", "o3", "o4"] {
        assert!(
            tree(&d.join(out)).is_empty(),
            "{out}: {:?}",
            tree(&d.join(out))
        );
    }
}

#[test]
fn max_pixels_sets_the_limit_and_help_states_the_default() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    fs::create_dir(&frames).unwrap();
    for t in 0..2 {
        fs::write(
            frames.join(format!("f{t}.pgm")),
            pgm(&moving_frame(64, 48, t)),
        )
        .unwrap();
    }
    let out = dir.path().join("out");
    let limited = run(&args![
        "run",
        &frames,
        "--out",
        &out,
        "--max-pixels",
        "3071"
    ]);
    assert_eq!(limited.status.code(), Some(1));
    let err = stderr(&limited);
    assert!(
        err.contains("f0.pgm: frame size 64x48 (3072 pixels) exceeds the limit of 3071 pixels"),
        "{err}"
    );
    ok(&run(&args![
        "run",
        &frames,
        "--out",
        &out,
        "--max-pixels",
        "3072"
    ]));
    assert_eq!(tree(&out), ["f0.png"]);
    let raw = run(&args![
        "run",
        "-",
        "--raw",
        "64x48",
        "--out",
        &out,
        "--max-pixels",
        "100"
    ]);
    assert!(
        stderr(&raw).contains(
            "--max-pixels: stdin: frame size 64x48 (3072 pixels) exceeds the limit of 100 pixels"
        ),
        "{}",
        stderr(&raw)
    );
    for sub in ["run", "dataset", "pair"] {
        let help = String::from_utf8(run(&args![sub, "--help"]).stdout).unwrap();
        assert!(
            help.contains("--max-pixels <N>") && help.contains("[default: 67108864]"),
            "{sub}: {help}"
        );
    }
    let zero = run(&args!["run", "--max-pixels", "0"]);
    assert_eq!(zero.status.code(), Some(2));
}
