//! The evaluation protocol: which sequences are rendered, which methods run
//! on every frame pair, and the measures kept per pair. Sequences are
//! independent and run on a small pool of threads.

use std::time::{Duration, Instant};

use super::baselines::{HornSchunck, LucasKanade};
use super::metrics;
use super::scenes::{Pattern, Scenario, SceneSpec, Sequence};
use super::truth::{self, Pose};
use reynoldsflow_host::Flow;
use reynoldsflow_host::reference::{self, FloatFlow, FloatParams, FloatScaling};
use reynoldsflow_host::settings::Settings;
use reynoldsflow_host::{Gray, HostError, workers};

/// A flow estimate under evaluation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Method {
    /// Horn–Schunck ([`HornSchunck`]).
    HornSchunck,
    /// Lucas–Kanade ([`LucasKanade`]).
    LucasKanade,
    /// ReynoldsFlow `v_R = v_c + v_d`, float reference, SPEC defaults.
    RfVr,
    /// ReynoldsFlow's divergence-free part `v_d` alone.
    RfVd,
    /// ReynoldsFlow's curl-free part `v_c` alone.
    RfVc,
    /// `v_R` of the fixed-point core (a check of the float reference).
    RfVrFixed,
    /// `v_R` of the float reference at a smaller intensity scale (see
    /// [`EvalConfig::small_scale_divisor`]), λ scaled alike.
    RfVrSmallScale,
}

impl Method {
    /// Every method, in table order.
    pub const ALL: [Self; 7] = [
        Self::HornSchunck,
        Self::LucasKanade,
        Self::RfVr,
        Self::RfVd,
        Self::RfVc,
        Self::RfVrFixed,
        Self::RfVrSmallScale,
    ];

    /// Label in tables and legends.
    pub fn label(self) -> &'static str {
        match self {
            Self::HornSchunck => "HS",
            Self::LucasKanade => "LK",
            Self::RfVr => "RF v_R",
            Self::RfVd => "RF v_d",
            Self::RfVc => "RF v_c",
            Self::RfVrFixed => "RF v_R fixed",
            Self::RfVrSmallScale => "RF v_R small s",
        }
    }
}

/// What to evaluate.
#[derive(Clone, Debug, PartialEq)]
pub struct EvalConfig {
    /// Frame width.
    pub width: usize,
    /// Frame height.
    pub height: usize,
    /// Frames of the reference-level sequences (pairs = frames − 1), which
    /// give the tables and the temporal curves.
    pub frames: usize,
    /// Frames of the other levels' sequences (the magnitude sweep).
    pub sweep_frames: usize,
    /// Indices into [`Scenario::levels`] to sweep.
    pub levels: Vec<usize>,
    /// The level of the tables and the temporal plots.
    pub reference_level: usize,
    /// Sensor noise of the noisy variant (at the reference level), gray levels.
    pub noise_sigma: f64,
    /// Horn–Schunck settings.
    pub horn_schunck: HornSchunck,
    /// Lucas–Kanade settings.
    pub lucas_kanade: LucasKanade,
    /// [`Method::RfVrSmallScale`] runs at `s = (1/255) / d` and
    /// `λ = 1e-4 / d²` (the same λ in gray-level units).
    pub small_scale_divisor: f64,
}

impl EvalConfig {
    /// The full evaluation: 320 × 240, 6 frames at the reference level and 3
    /// at the others, every level, σ = 3 noise.
    pub fn full() -> Self {
        Self {
            width: 320,
            height: 240,
            frames: 6,
            sweep_frames: 3,
            levels: vec![0, 1, 2, 3],
            reference_level: 1,
            noise_sigma: 3.0,
            horn_schunck: HornSchunck::default(),
            lucas_kanade: LucasKanade::default(),
            small_scale_divisor: 100.0,
        }
    }

    /// A reduced run for tests: 96 × 72, 3 and 2 frames, two levels.
    pub fn quick() -> Self {
        Self {
            width: 96,
            height: 72,
            frames: 3,
            sweep_frames: 2,
            levels: vec![1, 2],
            ..Self::full()
        }
    }

    /// Every sequence of the evaluation: each pattern × scenario × level,
    /// clean, and the noisy variant at the reference level.
    pub fn sequences(&self) -> Vec<(SceneSpec, usize)> {
        let mut out = Vec::new();
        for pattern in Pattern::ALL {
            for scenario in Scenario::ALL {
                let levels = scenario.levels();
                let spec = |level_index: usize, noise_sigma: f64| SceneSpec {
                    pattern,
                    scenario,
                    level: levels[level_index],
                    noise_sigma,
                    frames: if level_index == self.reference_level {
                        self.frames
                    } else {
                        self.sweep_frames
                    },
                    width: self.width,
                    height: self.height,
                };
                for &li in &self.levels {
                    out.push((spec(li, 0.0), li));
                }
                out.push((
                    spec(self.reference_level, self.noise_sigma),
                    self.reference_level,
                ));
            }
        }
        out
    }
}

/// The measures of one method on one frame pair. `None`: undefined (see
/// [`metrics`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measures {
    /// Dense AEPE, px.
    pub aepe: f64,
    /// Dense AAE, degrees.
    pub aae: f64,
    /// AEPE at the sparse points, px.
    pub aepe_sp: f64,
    /// Radial correlation at the sparse points.
    pub r_sp: Option<f64>,
    /// Angular cosine similarity at the sparse points.
    pub acs_sp: Option<f64>,
    /// Radial correlation over the dense interior.
    pub r_dense: Option<f64>,
    /// Angular cosine similarity over the dense interior.
    pub acs_dense: Option<f64>,
}

/// Everything kept of one frame pair.
#[derive(Clone, Debug, PartialEq)]
pub struct PairResult {
    /// Frame n of the pair `(n, n + 1)`.
    pub frame: usize,
    /// Per method, in [`Method::ALL`] order.
    pub measures: Vec<(Method, Measures)>,
    /// Mean `|v_c|` over the interior (SPEC defaults).
    pub mean_vc: f64,
    /// Mean `|v_d|` over the interior.
    pub mean_vd: f64,
    /// Mean true displacement over the interior, px.
    pub mean_truth: f64,
    /// Sparse points used.
    pub sparse_points: usize,
    /// `max |v_R(fixed) − v_R(float)|` over the frame, px.
    pub fixed_max_diff: f64,
}

/// One evaluated sequence.
#[derive(Clone, Debug)]
pub struct SequenceResult {
    /// What was rendered.
    pub spec: SceneSpec,
    /// Index into [`Scenario::levels`].
    pub level_index: usize,
    /// One entry per frame pair.
    pub pairs: Vec<PairResult>,
    /// Frames 0 and 1 and the representation of pair 0, kept for the
    /// clean reference-level sequences (illustrations).
    pub preview: Option<Preview>,
    /// Time spent per method.
    pub timings: Vec<(Method, Duration)>,
}

/// Pictures of a sequence's first pair.
#[derive(Clone, Debug)]
pub struct Preview {
    /// Frame 0.
    pub frame: Gray,
    /// ReynoldsFlow's representation of pair (0, 1), RGB8, per-frame min-max.
    pub representation: Vec<u8>,
}

impl SequenceResult {
    /// Mean of a measure over the pairs; `None` if undefined on every pair.
    pub fn mean(&self, method: Method, pick: impl Fn(&Measures) -> Option<f64>) -> Option<f64> {
        let values: Vec<f64> = self
            .pairs
            .iter()
            .filter_map(|p| p.measures.iter().find(|(m, _)| *m == method))
            .filter_map(|(_, m)| pick(m))
            .collect();
        (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
    }

    /// Is this the noisy variant?
    pub fn noisy(&self) -> bool {
        self.spec.noise_sigma > 0.0
    }
}

/// Run every sequence of `config`, in parallel on every core; results in
/// [`EvalConfig::sequences`] order.
pub fn run_all(config: &EvalConfig) -> Result<Vec<SequenceResult>, HostError> {
    let sequences = config.sequences();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    workers::map_indices(
        cores,
        sequences.len(),
        || (),
        |(), i| {
            let (spec, level_index) = sequences[i];
            evaluate_sequence(config, spec, level_index, i as u64)
        },
    )
    .into_iter()
    .collect()
}

/// The vectors of `flow` at `idx`.
fn gather(flow: &Flow, idx: &[usize]) -> Vec<[f64; 2]> {
    idx.iter().map(|&i| flow.at(i)).collect()
}

/// Render and evaluate one sequence.
fn evaluate_sequence(
    config: &EvalConfig,
    spec: SceneSpec,
    level_index: usize,
    seed: u64,
) -> Result<SequenceResult, HostError> {
    let seq: Sequence = spec.render(0x5eed_0000 + seed);
    let (w, h) = (spec.width, spec.height);
    let centre = spec.centre();
    let interior = truth::interior(w, h);
    let mut timings: Vec<(Method, Duration)> =
        Method::ALL.iter().map(|&m| (m, Duration::ZERO)).collect();
    let mut clock = |m: Method, since: Instant| {
        if let Some(t) = timings.iter_mut().find(|(k, _)| *k == m) {
            t.1 += since.elapsed();
        }
    };
    // The fixed engine as every front end holds it, at the SPEC's defaults.
    let fixed_engine = Settings::default().compute()?;
    let small = FloatParams {
        intensity_scale: 1.0 / 255.0 / config.small_scale_divisor,
        lambda: 1e-4 / config.small_scale_divisor.powi(2),
    };

    let mut pairs = Vec::new();
    let mut preview = None;
    for n in 0..spec.frames - 1 {
        let (prev, next) = (&seq.frames[n], &seq.frames[n + 1]);
        let truth = truth::flow_between(&seq.poses[n], &seq.poses[n + 1], w, h);

        let t = Instant::now();
        let hs = config.horn_schunck.compute(prev, next);
        clock(Method::HornSchunck, t);
        let t = Instant::now();
        let lk = config.lucas_kanade.compute(prev, next);
        clock(Method::LucasKanade, t);
        let t = Instant::now();
        let rf: FloatFlow = reference::compute(prev, next, &FloatParams::default())?;
        clock(Method::RfVr, t);
        let t = Instant::now();
        let fixed = fixed_engine.pair(prev, next)?;
        clock(Method::RfVrFixed, t);
        let t = Instant::now();
        let rf_small = reference::compute(prev, next, &small)?;
        clock(Method::RfVrSmallScale, t);

        let vr = rf.v_r();
        let fixed_vr = fixed.planes.v_r();
        let fixed_max_diff = (0..w * h)
            .map(|i| (fixed_vr.u[i] - vr.u[i]).hypot(fixed_vr.v[i] - vr.v[i]))
            .fold(0.0, f64::max);
        let estimates = [
            (Method::HornSchunck, hs),
            (Method::LucasKanade, lk),
            (Method::RfVr, vr),
            (Method::RfVd, rf.v_d.clone()),
            (Method::RfVc, rf.v_c.clone()),
            (Method::RfVrFixed, fixed_vr),
            (Method::RfVrSmallScale, rf_small.v_r()),
        ];

        let sparse = sparse_points(&spec, &seq.poses[n]);
        let offsets = |idx: &[usize]| -> Vec<[f64; 2]> {
            idx.iter()
                .map(|&i| [(i % w) as f64 - centre[0], (i / w) as f64 - centre[1]])
                .collect()
        };
        let (off_sp, off_dense) = (offsets(&sparse), offsets(&interior));
        let (gt_sp, gt_dense) = (gather(&truth, &sparse), gather(&truth, &interior));
        let measures = estimates
            .iter()
            .map(|(m, flow)| {
                let (e_sp, e_dense) = (gather(flow, &sparse), gather(flow, &interior));
                let aepe_sp = if sparse.is_empty() {
                    f64::NAN
                } else {
                    metrics::aepe(&e_sp, &gt_sp)
                };
                (
                    *m,
                    Measures {
                        aepe: metrics::aepe(&e_dense, &gt_dense),
                        aae: metrics::aae_degrees(&e_dense, &gt_dense),
                        aepe_sp,
                        r_sp: metrics::radial_correlation(&e_sp, &gt_sp, &off_sp),
                        acs_sp: metrics::acs(&e_sp, &gt_sp),
                        r_dense: metrics::radial_correlation(&e_dense, &gt_dense, &off_dense),
                        acs_dense: metrics::acs(&e_dense, &gt_dense),
                    },
                )
            })
            .collect();
        let (m_d, m_c) = rf.magnitudes();
        let mean_over =
            |m: &[f64]| interior.iter().map(|&i| m[i]).sum::<f64>() / interior.len() as f64;
        pairs.push(PairResult {
            frame: n,
            measures,
            mean_vc: mean_over(&m_c),
            mean_vd: mean_over(&m_d),
            mean_truth: metrics::mean_magnitude(&gt_dense),
            sparse_points: sparse.len(),
            fixed_max_diff,
        });
        if n == 0 && spec.noise_sigma == 0.0 && level_index == config.reference_level {
            preview = Some(Preview {
                frame: prev.clone(),
                representation: reference::representation(&rf, prev, FloatScaling::PerFrameMinMax),
            });
        }
    }
    // v_d and v_c come with v_R's computation.
    let rf_time = timings
        .iter()
        .find(|(m, _)| *m == Method::RfVr)
        .map(|t| t.1);
    for (m, t) in &mut timings {
        if matches!(m, Method::RfVd | Method::RfVc) {
            *t = rf_time.unwrap_or_default();
        }
    }
    Ok(SequenceResult {
        spec,
        level_index,
        pairs,
        preview,
        timings,
    })
}

/// The sparse points of frame n: the checkerboard's inner corners where
/// the pose puts them, or a 12 × 11 grid for the texture.
fn sparse_points(spec: &SceneSpec, pose: &Pose) -> Vec<usize> {
    let positions: Vec<[f64; 2]> = match spec.pattern {
        Pattern::Checkerboard => spec
            .board_corners()
            .into_iter()
            .map(|p| pose.to_image(p))
            .collect(),
        Pattern::Texture => truth::grid_positions(12, 11, spec.width, spec.height),
    };
    truth::sparse_pixels(&positions, spec.width, spec.height)
}
