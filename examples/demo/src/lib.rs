//! Find a tiny drone: ReynoldsFlow and its on-device motion cues on a
//! synthetic sky, drawn with embedded-graphics.
//!
//! - [`scene`]: the sky, the clouds, the shaking camera and the drone, with
//!   the drone's true box computed analytically;
//! - [`analysis`]: one pass of the core's tiled engine per frame pair into
//!   the display views and the motion cues;
//! - [`draw`]: the 320 × 240 dashboard, generic over any
//!   `DrawTarget<Color = Rgb565>`;
//! - [`render_sequence`]: headless PNG frames through
//!   embedded-graphics-simulator (no SDL).

use std::fmt;
use std::path::{Path, PathBuf};

use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics_simulator::{OutputSettingsBuilder, SimulatorDisplay};
use reynoldsflow_core::Error;
use reynoldsflow_cues::{CueError, Region};

pub mod analysis;
pub mod draw;
pub mod scene;

use analysis::Analysis;
use draw::{Dashboard, SCREEN, draw_dashboard};
use scene::{PixelBox, Scene};

/// Why the demo stopped.
#[derive(Debug)]
pub enum DemoError {
    /// The core refused a size or buffer.
    Core(Error),
    /// The cue grid does not fit the frame.
    Cues(CueError),
    /// Writing a PNG failed.
    Png(String),
    /// A command-line argument was not understood.
    Usage(String),
}

impl fmt::Display for DemoError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DemoError::Core(e) => write!(f, "core: {e}"),
            DemoError::Cues(e) => write!(f, "cues: {e}"),
            DemoError::Png(e) => write!(f, "png: {e}"),
            DemoError::Usage(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for DemoError {}

impl From<Error> for DemoError {
    fn from(e: Error) -> Self {
        DemoError::Core(e)
    }
}

impl From<CueError> for DemoError {
    fn from(e: CueError) -> Self {
        DemoError::Cues(e)
    }
}

/// One frame of the sequence as drawn.
#[derive(Clone, Debug)]
pub struct FrameReport {
    /// Frame number `n` (the pair `(n, n + 1)`).
    pub index: usize,
    /// The cues, strongest first.
    pub regions: Vec<Region>,
    /// The drone's true motion box in this pair.
    pub truth: PixelBox,
    /// Whether the drone is fully on screen in both frames.
    pub drone_visible: bool,
    /// Where the PNG went, when one was written.
    pub path: Option<PathBuf>,
}

/// Draw frames `start .. start + count` of the default scene onto `display`
/// one after another, calling `each` after each frame is drawn.
pub fn run_sequence(
    start: usize,
    count: usize,
    display: &mut SimulatorDisplay<Rgb565>,
    mut each: impl FnMut(&SimulatorDisplay<Rgb565>, FrameReport) -> Result<(), DemoError>,
) -> Result<(), DemoError> {
    let scene = Scene::default();
    let mut analysis = Analysis::new()?;
    let mut prev = scene.frame(start);
    analysis.prime(&prev, &scene.frame(start + 1))?;
    for index in start..start + count {
        let next = scene.frame(index + 1);
        let regions = analysis.step(&prev, &next)?.to_vec();
        let last = analysis.cues().last_frame();
        let panels = analysis.panels();
        let dash = Dashboard {
            index,
            frame: &panels.frame,
            representation: &panels.representation,
            direction: &panels.direction,
            regions: &regions,
            level: last.level,
            found: last.regions_found,
        };
        // The simulator's display never fails to draw.
        let Ok(()) = draw_dashboard(display, &dash);
        let report = FrameReport {
            index,
            regions,
            truth: scene.motion_box(index),
            drone_visible: scene.drone_visible(index, 0),
            path: None,
        };
        each(display, report)?;
        prev = next;
    }
    Ok(())
}

/// Render frames `start .. start + count` as `out/frame-NNNN.png`
/// (320 × 240, one PNG pixel per display pixel), headless.
pub fn render_sequence(
    start: usize,
    count: usize,
    out: &Path,
) -> Result<Vec<FrameReport>, DemoError> {
    std::fs::create_dir_all(out).map_err(|e| DemoError::Png(format!("{}: {e}", out.display())))?;
    let settings = OutputSettingsBuilder::new().scale(1).build();
    let mut display = SimulatorDisplay::<Rgb565>::new(SCREEN);
    let mut reports = Vec::with_capacity(count);
    run_sequence(start, count, &mut display, |display, mut report| {
        let path = out.join(format!("frame-{:04}.png", report.index));
        display
            .to_rgb_output_image(&settings)
            .save_png(&path)
            .map_err(|e| DemoError::Png(format!("{}: {e}", path.display())))?;
        report.path = Some(path);
        reports.push(report);
        Ok(())
    })?;
    Ok(reports)
}
