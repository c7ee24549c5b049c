//! How many motion cues a STATIC scene produces when only the light
//! changes, for each threshold mode. Nothing moves, so every region is a
//! false one. The figures are printed (`cargo test -p reynoldsflow-demo
//! --test false_regions -- --nocapture`) and go in docs/firmware.md; the asserts
//! hold the claims made there.

use reynoldsflow_core::fixed::types::{U16F16, U32F32};
use reynoldsflow_core::{Config, Engine, FramePair, Params, Plan};
use reynoldsflow_cues::{CueParams, Field, Threshold};
use reynoldsflow_demo::analysis::{Cues, HEIGHT, WIDTH, cue_params};
use reynoldsflow_demo::scene::{Lighting, Scene, static_frame};

const FRAMES: usize = 24;
/// Pairs measured: the first few let the relative modes' reference settle.
const SETTLE: usize = 4;

#[derive(Debug, Default, Clone, Copy)]
struct Figures {
    /// Mean regions found per frame pair.
    per_frame: f64,
    /// Pairs with at least one region, of the pairs measured.
    frames_with: usize,
    /// Largest magnitude of the field over the measured pairs, px.
    peak: f64,
}

fn measure(frames: &[Vec<u8>], params: CueParams) -> Figures {
    let config = Config::new(WIDTH, HEIGHT, Params::DEFAULT).unwrap();
    let mut engine = Box::new(Engine::<78>::new());
    let plan = Plan::strips(config, Engine::<78>::MAX_TILE_WIDTH).unwrap();
    let mut cues = Box::new(Cues::new(&config, params).unwrap());
    let mut figures = Figures::default();
    let mut found = 0u32;
    for (n, pair) in frames.windows(2).enumerate() {
        let pair = FramePair::packed(&config, &pair[0], &pair[1]).unwrap();
        engine.run(&plan.bind(pair).unwrap(), &mut *cues);
        cues.end_frame();
        if n < SETTLE {
            continue;
        }
        let last = cues.last_frame();
        found += last.regions_found;
        figures.frames_with += usize::from(last.regions_found > 0);
        figures.peak = figures.peak.max(last.peak.to_num());
    }
    figures.per_frame = f64::from(found) / (frames.len() - 1 - SETTLE) as f64;
    figures
}

fn modes(field: Field) -> Vec<(&'static str, CueParams)> {
    let px = U32F32::from_num;
    let base = |threshold| CueParams {
        field,
        threshold,
        min_area: 1,
        smoothing: 1,
    };
    vec![
        ("absolute 1 px", base(Threshold::Absolute(px(1.0)))),
        ("absolute 0.25 px", base(Threshold::Absolute(px(0.25)))),
        (
            "mean x16, no floor",
            base(Threshold::MeanMultiple {
                k: U16F16::from_num(16),
                floor: U32F32::ZERO,
            }),
        ),
        (
            "peak x0.3, no floor",
            base(Threshold::PeakFraction {
                k: U16F16::from_num(0.3),
                floor: U32F32::ZERO,
            }),
        ),
        (
            "demo: peak x0.3, floor 1 px",
            CueParams {
                field,
                ..cue_params()
            },
        ),
    ]
}

fn lightings() -> Vec<(&'static str, Lighting)> {
    vec![
        ("constant (noise only)", Lighting::Constant),
        ("gain +2 %/frame", Lighting::Gain { rate: 0.02 }),
        ("gain +10 %/frame", Lighting::Gain { rate: 0.10 }),
        (
            "moving light 60 lv, 2 px/frame",
            Lighting::MovingLight {
                peak: 60.0,
                sigma: 10.0,
                speed: 2.0,
            },
        ),
        (
            "moving light 120 lv, 6 px/frame",
            Lighting::MovingLight {
                peak: 120.0,
                sigma: 6.0,
                speed: 6.0,
            },
        ),
    ]
}

/// The drone's own peak `|v_c|` in the shaking sequence, for scale.
fn drone_peak() -> f64 {
    let scene = Scene::default();
    let frames: Vec<Vec<u8>> = (28..36).map(|n| scene.frame(n)).collect();
    let params = CueParams {
        threshold: Threshold::Absolute(U32F32::ZERO),
        ..cue_params()
    };
    measure(&frames, params).peak
}

type Row = Vec<(&'static str, Figures)>;

/// Measure every lighting under every mode of `field`; print a table.
fn print_table(field: Field, noise: f64) -> Vec<(&'static str, Lighting, Row)> {
    println!("\nField {field:?}:\n");
    println!(
        "| lighting | peak px | {} |",
        modes(field)
            .iter()
            .map(|(name, _)| *name)
            .collect::<Vec<_>>()
            .join(" | ")
    );
    println!("|---|---|{}", "---|".repeat(modes(field).len()));
    let mut table = Vec::new();
    for (light_name, lighting) in lightings() {
        let frames: Vec<Vec<u8>> = (0..FRAMES)
            .map(|n| static_frame(WIDTH, HEIGHT, n, lighting, noise))
            .collect();
        let row: Vec<(&str, Figures)> = modes(field)
            .into_iter()
            .map(|(name, params)| (name, measure(&frames, params)))
            .collect();
        let cells: Vec<String> = row
            .iter()
            .map(|(_, f)| {
                format!(
                    "{:.2} ({}/{})",
                    f.per_frame,
                    f.frames_with,
                    FRAMES - 1 - SETTLE
                )
            })
            .collect();
        println!(
            "| {light_name} | {:.3} | {} |",
            row[0].1.peak,
            cells.join(" | ")
        );
        table.push((light_name, lighting, row));
    }
    table
}

#[test]
fn false_regions_under_changing_light() {
    let noise = Scene::default().noise;
    let drone = drone_peak();
    println!(
        "\nFalse motion cues on a static {WIDTH}x{HEIGHT} textured scene, \
         8-px cells, sensor noise ±{noise} levels, {} pairs after {SETTLE} to settle.",
        FRAMES - 1 - SETTLE
    );
    println!(
        "For scale: the 5x3-px drone's peak |v_c| in the shaking sequence is {drone:.2} px.\n"
    );
    let table = print_table(Field::CurlFree, noise);
    println!("\nCells: false regions per frame (frames with any, of frames measured).");

    // What docs/firmware.md claims, held here.
    let all = FRAMES - 1 - SETTLE;
    for (light, lighting, row) in &table {
        let get = |name: &str| row.iter().find(|(n, _)| *n == name).unwrap().1;
        let strong_light = matches!(lighting, Lighting::MovingLight { peak, .. } if *peak > 100.0);
        if strong_light {
            // A bright light sweeping fast is motion, of light: |v_c| reaches
            // a drone's order of magnitude and every mode flags it.
            for (name, f) in row {
                assert_eq!(f.frames_with, all, "{light}: {name}");
            }
            assert!(get("absolute 1 px").peak * 4.0 > drone, "{light}");
            continue;
        }
        // Otherwise the demo's settings and an absolute 1-px level give no
        // false cue, and the response stays well below the drone's.
        assert_eq!(get("absolute 1 px").frames_with, 0, "{light}");
        assert_eq!(get("demo: peak x0.3, floor 1 px").frames_with, 0, "{light}");
        assert!(get("absolute 1 px").peak * 4.0 < drone, "{light}");
        // A level relative to the peak, without a floor, always finds the
        // strongest response, whatever it is: a region in every frame.
        assert_eq!(get("peak x0.3, no floor").frames_with, all, "{light}");
        // A level relative to the mean scales with a global gain: none.
        if let Lighting::Gain { .. } = lighting {
            assert_eq!(get("mean x16, no floor").frames_with, 0, "{light}");
        }
    }
    // Without noise or light change the field is exactly zero: no region
    // in any mode (a zero magnitude is never above a level).
    let still: Vec<Vec<u8>> = (0..6)
        .map(|n| static_frame(WIDTH, HEIGHT, n, Lighting::Constant, 0.0))
        .collect();
    for (name, params) in modes(Field::CurlFree)
        .into_iter()
        .chain(modes(Field::DivergenceFree))
    {
        let f = measure(&still, params);
        assert_eq!((f.frames_with, f.peak), (0, 0.0), "{name}");
    }
    // For comparison (printed, not asserted): |v_d|, dominated by sensor
    // noise on the texture (SPEC §7: v_d is not a displacement).
    print_table(Field::DivergenceFree, noise);
}
