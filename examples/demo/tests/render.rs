//! The demo renders headless, and its PNGs show what they should: 320 × 240,
//! not one flat colour, and the first cue's magenta box around the drone in
//! the frame panel exactly when the drone is on screen.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::process::Command;

use embedded_graphics::pixelcolor::Rgb888;
use embedded_graphics::prelude::*;
use embedded_graphics_simulator::SimulatorDisplay;
use reynoldsflow_demo::draw::{PANEL, SCREEN};
use reynoldsflow_demo::render_sequence;
use reynoldsflow_demo::scene::PixelBox;

fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn load(path: &Path) -> SimulatorDisplay<Rgb888> {
    SimulatorDisplay::load_png(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The first cue's colour (Rgb565 magenta, 31/0/31, as the PNG's RGB888).
fn is_box(c: Rgb888) -> bool {
    c.r() >= 250 && c.g() <= 8 && c.b() >= 250
}

/// Magenta pixels of the frame panel (top-left quarter).
fn box_pixels(image: &SimulatorDisplay<Rgb888>) -> Vec<(i32, i32)> {
    let mut out = Vec::new();
    for y in 0..PANEL.height as i32 {
        for x in 0..PANEL.width as i32 {
            if is_box(image.get_pixel(Point::new(x, y))) {
                out.push((x, y));
            }
        }
    }
    out
}

/// The frame panel shows the cue's box: every pixel of the rectangle 1 px
/// outside `cue` is magenta, and no magenta pixel lies anywhere but on it
/// or on its "1" label (4 × 6 px, right of the box).
fn assert_box_drawn(pixels: &[(i32, i32)], cue: PixelBox, what: &str) {
    let set: HashSet<(i32, i32)> = pixels.iter().copied().collect();
    let (x0, y0, x1, y1) = (cue.x_min - 1, cue.y_min - 1, cue.x_max + 1, cue.y_max + 1);
    let on_panel = |&(x, y): &(i32, i32)| {
        x >= 0 && y >= 0 && x < PANEL.width as i32 && y < PANEL.height as i32
    };
    let perimeter: Vec<(i32, i32)> = (x0..=x1)
        .flat_map(|x| [(x, y0), (x, y1)])
        .chain((y0..=y1).flat_map(|y| [(x0, y), (x1, y)]))
        .filter(on_panel)
        .collect();
    let missing: Vec<_> = perimeter.iter().filter(|p| !set.contains(p)).collect();
    assert!(
        missing.is_empty(),
        "{what}: box {cue:?} not drawn at {missing:?}"
    );
    let label =
        |&(x, y): &(i32, i32)| (x1 + 2..=x1 + 6).contains(&x) && (y0 - 1..=y0 + 5).contains(&y);
    for p in pixels {
        assert!(
            perimeter.contains(p) || label(p),
            "{what}: stray magenta at {p:?}"
        );
    }
}

#[test]
fn rendered_frames_show_the_drone_boxed() {
    // Frames 28..34 (drone mid-sky) and 80..82 (drone gone).
    let dir = out_dir("render");
    let mut reports = render_sequence(28, 6, &dir).unwrap();
    reports.extend(render_sequence(80, 2, &dir).unwrap());
    let mut boxed = 0;
    for r in &reports {
        let path = r.path.as_ref().unwrap();
        assert_eq!(
            path.file_name().unwrap(),
            format!("frame-{:04}.png", r.index).as_str()
        );
        let image = load(path);
        assert_eq!(image.size(), SCREEN, "{}", path.display());
        // Not a flat image: many colours in each image panel, and text on
        // the black list panel.
        for (px, py, least) in [(0, 0, 8), (160, 0, 8), (0, 120, 8), (160, 120, 2)] {
            let colors: HashSet<Rgb888> = (0..PANEL.height as i32)
                .flat_map(|y| (0..PANEL.width as i32).map(move |x| (x, y)))
                .map(|(x, y)| image.get_pixel(Point::new(px + x, py + y)))
                .collect();
            assert!(
                colors.len() >= least,
                "{}: panel at {px},{py} has {} colours",
                path.display(),
                colors.len()
            );
        }
        let pixels = box_pixels(&image);
        if r.drone_visible {
            // The PNG shows the strongest cue's box ...
            let cue = r
                .regions
                .first()
                .expect("a cue while the drone is on screen");
            let cue_box = PixelBox {
                x_min: cue.x_min.into(),
                y_min: cue.y_min.into(),
                x_max: cue.x_max.into(),
                y_max: cue.y_max.into(),
            };
            assert_box_drawn(&pixels, cue_box, &path.display().to_string());
            // ... and that box is around the drone: each side within 2 px
            // of the true box, so the drawn rectangle within 3 px.
            boxed += usize::from(cue_box.max_side_error(r.truth) <= 2);
        } else {
            assert!(r.regions.is_empty(), "frame {}: {:?}", r.index, r.regions);
            assert!(
                pixels.is_empty(),
                "{}: a box without a drone",
                path.display()
            );
        }
    }
    // (the detection test measures the rate over the whole crossing).
    assert!(boxed >= 5, "only {boxed} of 6 frames with the drone boxed");
}

#[test]
fn the_binary_writes_a_numbered_sequence() {
    let dir = out_dir("cli");
    let status = Command::new(env!("CARGO_BIN_EXE_reynoldsflow-demo"))
        .args(["--frames", "3", "--start", "40", "--out"])
        .arg(&dir)
        .status()
        .unwrap();
    assert!(status.success());
    for n in 40..43 {
        let image = load(&dir.join(format!("frame-{n:04}.png")));
        assert_eq!(image.size(), SCREEN);
        assert!(!box_pixels(&image).is_empty(), "frame {n}: no cue box");
    }
    assert!(!dir.join("frame-0043.png").exists());
    let bad = Command::new(env!("CARGO_BIN_EXE_reynoldsflow-demo"))
        .args(["--frames", "many"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--frames needs a number"));
}
