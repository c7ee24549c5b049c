//! Motion cues through the real engine: the drone is found where the scene
//! generator says it is, the regions do not depend on how the frame is cut
//! into tiles or strips, and a full list keeps the strongest.

use reynoldsflow_core::fixed::types::{U16F16, U32F32};
use reynoldsflow_core::{Config, Engine, FramePair, Params, Plan, RowStream, Sink};
use reynoldsflow_cues::{CueParams, Field, FrameLevel, MotionCues, Region, Threshold};
use reynoldsflow_demo::analysis::{Analysis, Cues, HEIGHT, MAX_CUES, WIDTH, cue_params};
use reynoldsflow_demo::scene::{Lighting, PixelBox, Scene, static_frame};

fn pixel_box(r: &Region) -> PixelBox {
    PixelBox {
        x_min: i32::from(r.x_min),
        y_min: i32::from(r.y_min),
        x_max: i32::from(r.x_max),
        y_max: i32::from(r.y_max),
    }
}

fn config() -> Config {
    Config::new(WIDTH, HEIGHT, Params::DEFAULT).unwrap()
}

/// The strongest cue's box is within 2 px (every side) of the drone's true
/// motion box in at least 90 % of the pairs where the drone is on screen,
/// with the camera shaking ±2 px and sensor noise: the demo's pipeline as
/// it runs (64-px tiles, one pass per pair).
#[test]
fn the_drone_is_found_within_two_pixels() {
    let scene = Scene::default();
    let mut analysis = Analysis::new().unwrap();
    let (mut pairs, mut found, mut top) = (0, 0, 0);
    let mut errors = Vec::new();
    let mut prev = scene.frame(0);
    for n in 0..90 {
        let next = scene.frame(n + 1);
        let regions = analysis.step(&prev, &next).unwrap().to_vec();
        prev = next;
        let truth = scene.motion_box(n);
        if !scene.drone_visible(n, 0) {
            // Off screen: the scene has nothing else above the 1-px floor.
            if !truth.inside(WIDTH, HEIGHT, -8) && n > 2 {
                assert!(regions.is_empty(), "pair {n}: {regions:?}");
            }
            continue;
        }
        pairs += 1;
        let error = regions
            .first()
            .map_or(i32::MAX, |r| pixel_box(r).max_side_error(truth));
        errors.push(error);
        top += usize::from(error <= 2);
        found += usize::from(
            regions
                .iter()
                .any(|r| pixel_box(r).max_side_error(truth) <= 2),
        );
    }
    errors.sort_unstable();
    let rate = top as f64 / pairs as f64;
    println!(
        "drone within 2 px: strongest cue {top}/{pairs} ({:.1} %), any cue {found}/{pairs}; \
         largest side error median {} px, 90th percentile {} px",
        100.0 * rate,
        errors[errors.len() / 2],
        errors[errors.len() * 9 / 10]
    );
    assert!(pairs >= 60, "the drone crosses for {pairs} pairs only");
    assert!(rate >= 0.9, "{top}/{pairs}");
}

/// Regions and frame levels of a sequence of pairs, the sink fed by `run`.
fn cue_sequence(
    frames: &[Vec<u8>],
    params: CueParams,
    mut run: impl FnMut(&FramePair<'_>, &mut Cues),
) -> Vec<(Vec<Region>, FrameLevel)> {
    let config = config();
    let mut cues = Box::new(Cues::new(&config, params).unwrap());
    frames
        .windows(2)
        .map(|pair| {
            let pair = FramePair::packed(&config, &pair[0], &pair[1]).unwrap();
            run(&pair, &mut cues);
            let regions = cues.end_frame().to_vec();
            (regions, *cues.last_frame())
        })
        .collect()
}

fn tiled<const COLS: usize>(
    frames: &[Vec<u8>],
    params: CueParams,
    tile: (usize, usize),
) -> Vec<(Vec<Region>, FrameLevel)> {
    let mut engine = Box::new(Engine::<COLS>::new());
    let plan = Plan::new(config(), tile.0, tile.1).unwrap();
    cue_sequence(frames, params, |pair, cues| {
        engine.run(&plan.bind(*pair).unwrap(), cues)
    })
}

/// Rows pushed to several column strips (one engine each), every row to
/// every strip, as a camera would: the sink sees the strips interleaved.
fn streamed(
    frames: &[Vec<u8>],
    params: CueParams,
    widths: &[usize],
) -> Vec<(Vec<Region>, FrameLevel)> {
    assert_eq!(widths.iter().sum::<usize>(), WIDTH);
    let mut engines: Vec<Box<Engine<78>>> =
        widths.iter().map(|_| Box::new(Engine::new())).collect();
    let config = config();
    cue_sequence(frames, params, |pair, cues| {
        let mut x = 0;
        let mut streams: Vec<RowStream<&mut Engine<78>>> = engines
            .iter_mut()
            .zip(widths)
            .map(|(engine, &w)| {
                x += w;
                RowStream::new(engine, config, x - w, w).unwrap()
            })
            .collect();
        for y in 0..HEIGHT {
            let (p, n) = (
                pair.prev().clamped_row(y as isize),
                pair.next().clamped_row(y as isize),
            );
            for stream in &mut streams {
                stream.push(p, n, &mut *cues).unwrap();
            }
        }
    })
}

/// Low enough that the list overflows (more regions than `MAX_CUES`).
const DENSE_K: f64 = 1.5;

#[test]
fn regions_are_identical_across_tilings_and_strips() {
    let scene = Scene::default();
    // Drone and clouds under shake, then a static scene under a moving light.
    let drone: Vec<Vec<u8>> = (30..36).map(|n| scene.frame(n)).collect();
    let light = Lighting::MovingLight {
        peak: 120.0,
        sigma: 6.0,
        speed: 6.0,
    };
    let lit: Vec<Vec<u8>> = (0..4)
        .map(|n| static_frame(WIDTH, HEIGHT, n, light, 1.5))
        .collect();
    let dense = CueParams {
        // A low level so that many regions, merges and a full list occur.
        threshold: Threshold::MeanMultiple {
            k: U16F16::from_num(DENSE_K),
            floor: U32F32::ZERO,
        },
        min_area: 1,
        ..cue_params()
    };
    let modes = [
        ("demo", cue_params()),
        ("dense", dense),
        (
            "v_d",
            CueParams {
                field: Field::DivergenceFree,
                ..dense
            },
        ),
    ];
    let mut busiest = 0;
    for (name, params) in modes {
        for frames in [&drone, &lit] {
            let whole = tiled::<174>(frames, params, (WIDTH, HEIGHT));
            let busy = whole.iter().map(|(_, l)| l.regions_found).max().unwrap();
            println!("{name}: up to {busy} regions a frame");
            busiest = busiest.max(busy);
            let check = |other: Vec<(Vec<Region>, FrameLevel)>, how: &str| {
                assert!(other == whole, "{name}: {how} differs from the whole frame");
            };
            check(tiled::<15>(frames, params, (1, HEIGHT)), "1-px strips");
            check(tiled::<15>(frames, params, (1, 7)), "1x7 tiles");
            check(tiled::<21>(frames, params, (7, 5)), "7x5 tiles");
            check(tiled::<78>(frames, params, (64, 64)), "64x64 tiles");
            check(tiled::<174>(frames, params, (WIDTH, 1)), "1-row tiles");
            check(tiled::<174>(frames, params, (33, 120)), "33-px strips");
            check(
                streamed(frames, params, &[WIDTH - 64 - 64, 64, 64]),
                "rows in 3 strips",
            );
            check(
                streamed(frames, params, &[1, 63, 1, 64, 31]),
                "rows in 5 strips",
            );
        }
    }
    // The comparison covered lists cut to capacity.
    assert!(busiest as usize > MAX_CUES, "{busiest}");
}

/// More regions than capacity: the list keeps the strongest, exactly the
/// head of what a larger list holds, and counts all of them.
#[test]
fn a_full_list_keeps_the_strongest() {
    // Eight dark squares of different contrast, each moving 2 px right, on
    // a flat, noiseless sky.
    let frame = |n: usize| -> Vec<u8> {
        let mut f = vec![150u8; WIDTH * HEIGHT];
        for k in 0..8 {
            let (x0, y0) = (10 + 36 * (k % 4) + 2 * n, 20 + 50 * (k / 4));
            let gray = (100 - 12 * k) as u8;
            for y in y0..y0 + 4 {
                for x in x0..x0 + 4 {
                    f[y * WIDTH + x] = gray;
                }
            }
        }
        f
    };
    let frames = [frame(0), frame(1)];
    let params = CueParams {
        threshold: Threshold::Absolute(U32F32::from_num(0.5)),
        ..cue_params()
    };
    let config = config();
    let mut engine = Box::new(Engine::<78>::new());
    let plan = Plan::new(config, 20, 30).unwrap();
    let job = plan
        .bind(FramePair::packed(&config, &frames[0], &frames[1]).unwrap())
        .unwrap();
    let mut small = Box::new(MotionCues::<8, 20, 15, 3>::new(&config, params).unwrap());
    let mut large = Box::new(MotionCues::<8, 20, 15, 16>::new(&config, params).unwrap());
    engine.run(&job, &mut (&mut *small, &mut *large));
    let (small_list, large_list) = (small.end_frame().to_vec(), large.end_frame().to_vec());
    assert_eq!(large_list.len(), 8, "{large_list:?}");
    assert_eq!(small.last_frame().regions_found, 8);
    assert_eq!(small_list[..], large_list[..3]);
    assert!(large_list.windows(2).all(|w| w[0].peak >= w[1].peak));
    // The strongest are the darkest squares, k = 7, 6, 5 (x = 10 + 36 · 3,
    // 10 + 36 · 2, 10 + 36 · 1 in the lower row), each box around its square.
    let lefts: Vec<u16> = small_list.iter().map(|r| r.x_min).collect();
    for (r, x) in small_list.iter().zip([118, 82, 46]) {
        assert!(
            (x - 4..=x).contains(&(r.x_min as usize)) && r.y_min >= 64,
            "{lefts:?}: {r:?}"
        );
        assert!(r.width() >= 6 && r.width() <= 14, "{r:?}");
    }
}

/// The cue sink costs nothing to the representation: the RGB bytes of a
/// pair are the same with and without it in the tuple.
#[test]
fn cues_compose_with_the_rgb_sink() {
    let scene = Scene::default();
    let (prev, next) = (scene.frame(30), scene.frame(31));
    let config = config();
    let mut engine = Box::new(Engine::<78>::new());
    let plan = Plan::strips(config, Engine::<78>::MAX_TILE_WIDTH).unwrap();
    let job = plan
        .bind(FramePair::packed(&config, &prev, &next).unwrap())
        .unwrap();
    let scaling = reynoldsflow_core::Scaling::PerFrameMinMax;
    let mut alone = vec![0u8; WIDTH * HEIGHT * 3];
    reynoldsflow_core::represent(&mut engine, &job, scaling, &mut alone, ()).unwrap();
    let mut with = vec![0u8; WIDTH * HEIGHT * 3];
    let mut cues = Box::new(Cues::new(&config, cue_params()).unwrap());
    reynoldsflow_core::represent(&mut engine, &job, scaling, &mut with, &mut *cues).unwrap();
    assert_eq!(alone, with);
    assert_eq!(cues.last_frame().pixels, 0);
    cues.end_frame();
    assert_eq!(cues.last_frame().pixels as usize, WIDTH * HEIGHT);
    assert!(!cues.regions().is_empty());
    // The sink trait object works too.
    let _: &mut dyn Sink = &mut *cues;
}
