//! One pass of the core's tiled engine per frame pair, into four sinks at
//! once: the gray frame, the representation and the direction view as
//! RGB565 panels, and the motion cues. Memory as on a small board: 64-px
//! tiles (a 19 KiB engine) and a 9.9 KiB cue grid.

use reynoldsflow_core::fixed::types::{U16F16, U32F32};
use reynoldsflow_core::{ByteScale, Config, Engine, FramePair, Params, Plan, PreviousFrameMinMax};
use reynoldsflow_cues::{
    CueParams, Field, MotionCues, Region, Rgb565Sink, Threshold, View, grid_cells,
};

use crate::DemoError;

/// Frame width, px (a quarter of the 320 × 240 screen).
pub const WIDTH: usize = 160;
/// Frame height, px.
pub const HEIGHT: usize = 120;
/// Engine window columns: tiles of up to 64 columns.
pub const COLS: usize = 78;
/// Cue cell side, px.
pub const CELL: usize = 8;
/// Cue grid columns.
pub const GRID_W: usize = grid_cells(WIDTH, CELL);
/// Cue grid rows.
pub const GRID_H: usize = grid_cells(HEIGHT, CELL);
/// Cues kept per frame.
pub const MAX_CUES: usize = 4;

/// The demo's motion-cue sink.
pub type Cues = MotionCues<CELL, GRID_W, GRID_H, MAX_CUES>;

/// The demo's cue settings: `|v_c|` (smooth, so a few-pixel object gives
/// one compact blob; `|v_d|` is dominated by sensor noise on the flat sky),
/// above 0.3 of the frames' peak averaged over frames with weight ½, and
/// never below 1 px (the shaking sky alone peaks near 0.6 px here, the
/// drone near 9 px), so a frame without the drone gives no cue.
pub const fn cue_params() -> CueParams {
    CueParams {
        field: Field::CurlFree,
        threshold: Threshold::PeakFraction {
            k: U16F16::from_bits(0x4CCD),      // 0.3
            floor: U32F32::from_bits(1 << 32), // 1 px
        },
        min_area: 1,
        smoothing: 1,
    }
}

/// The three RGB565 panels of a frame, `WIDTH × HEIGHT` each.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Panels {
    /// The gray frame `fⁿ`.
    pub frame: Vec<u16>,
    /// The representation `[|v_d|, |v_c|, fⁿ]`.
    pub representation: Vec<u16>,
    /// Direction of `v_c` as hue, `|v_c|` as value (full at the cue level).
    pub direction: Vec<u16>,
}

/// The per-frame analysis: engine, cues and the streaming byte scales.
pub struct Analysis {
    config: Config,
    engine: Box<Engine<COLS>>,
    plan: Plan,
    cues: Box<Cues>,
    scales: PreviousFrameMinMax,
    panels: Panels,
}

impl Analysis {
    /// For `WIDTH × HEIGHT` frames with the demo's cue settings.
    pub fn new() -> Result<Self, DemoError> {
        Self::with_params(cue_params())
    }

    /// With other cue settings.
    pub fn with_params(params: CueParams) -> Result<Self, DemoError> {
        let config = Config::new(WIDTH, HEIGHT, Params::DEFAULT)?;
        let plan = Plan::strips(config, Engine::<COLS>::MAX_TILE_WIDTH)?;
        let cues = Box::new(Cues::new(&config, params)?);
        let flat = ByteScale::fixed(U16F16::ZERO);
        let plane = || vec![0u16; WIDTH * HEIGHT];
        Ok(Self {
            config,
            engine: Box::new(Engine::new()),
            plan,
            cues,
            scales: PreviousFrameMinMax::new(flat, flat),
            panels: Panels {
                frame: plane(),
                representation: plane(),
                direction: plane(),
            },
        })
    }

    /// Run a pair once only to learn its levels (byte scales and the cue
    /// reference), so the first shown frame is not drawn blind.
    pub fn prime(&mut self, prev: &[u8], next: &[u8]) -> Result<(), DemoError> {
        let job = self
            .plan
            .bind(FramePair::packed(&self.config, prev, next)?)?;
        let mut sinks = (self.scales.tracker(), &mut *self.cues);
        self.engine.run(&job, &mut sinks);
        self.scales.end_frame();
        self.cues.end_frame();
        Ok(())
    }

    /// Analyse the pair `(fⁿ, fⁿ⁺¹)` in one pass; returns the cues.
    pub fn step(&mut self, prev: &[u8], next: &[u8]) -> Result<&[Region], DemoError> {
        let job = self
            .plan
            .bind(FramePair::packed(&self.config, prev, next)?)?;
        let (scale_d, scale_c) = self.scales.scales();
        // Direction view: full brightness at the cue level and above, so
        // what the cues see stands out and the background still shows.
        let cue_scale = ByteScale::min_max(0.0, self.cues.level().to_num());
        let Panels {
            frame,
            representation,
            direction,
        } = &mut self.panels;
        let luma = Rgb565Sink::new(&self.config, frame, View::Luma)?;
        let repr = Rgb565Sink::new(
            &self.config,
            representation,
            View::Representation { scale_d, scale_c },
        )?;
        let dir = Rgb565Sink::new(
            &self.config,
            direction,
            View::Direction {
                field: Field::CurlFree,
                scale: cue_scale,
            },
        )?;
        let mut sinks = (
            luma,
            (repr, (dir, (&mut *self.cues, self.scales.tracker()))),
        );
        self.engine.run(&job, &mut sinks);
        self.scales.end_frame();
        Ok(self.cues.end_frame())
    }

    /// The panels of the last pair.
    pub fn panels(&self) -> &Panels {
        &self.panels
    }

    /// The cue sink (its last regions and frame level).
    pub fn cues(&self) -> &Cues {
        &self.cues
    }
}
