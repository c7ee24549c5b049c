//! The accuracy corpus: named frame pairs, generated from fixed seeds, in the
//! families `FORMATS.md` found hard for 32-bit formats (tiny motions, worst
//! cases), generated scenes, and the shared conformance vectors. Mostly
//! 64×48 to 160×120, a few 320×240, so the whole corpus runs in seconds in
//! the test profile.

use std::f64::consts::PI;

use reynoldsflow_host::limits::Limits;
use reynoldsflow_host::reference::FloatFlow;
use reynoldsflow_host::{Flow, Gray, io::image_file, io::npy};

use crate::{Pattern, Rng, frame_pair, vector_cases, vectors_dir};

/// A group of the corpus: one row of docs/accuracy.md's table per
/// family and parameter set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Family {
    /// Changes of a few grey levels: ±1 at one or many pixels, a global +1,
    /// a flash beside a ±1 change, 0.02–0.05 px shifts, a ×1.004 gain.
    TinyMotions,
    /// Saturated inputs: black↔white, 0/255 checkerboards, stripes, steps,
    /// the maximisers of |Dn| and |X·Dn|.
    WorstCases,
    /// Translation, zoom, rotation and illumination of a texture; noise;
    /// odd and degenerate sizes.
    Scenes,
    /// The shared conformance vectors (`tests/vectors`).
    Vectors,
}

impl Family {
    pub const ALL: [Family; 4] = [
        Family::TinyMotions,
        Family::WorstCases,
        Family::Scenes,
        Family::Vectors,
    ];

    /// The name the accuracy table prints (and docs/accuracy.md's rows carry).
    pub fn name(self) -> &'static str {
        match self {
            Family::TinyMotions => "tiny motions",
            Family::WorstCases => "worst cases",
            Family::Scenes => "generated scenes",
            Family::Vectors => "shared vectors",
        }
    }
}

/// What the independent float64 implementation stored for a vector case
/// (at the SPEC defaults s = 1/255, λ = 1e-4, Fixed(k_d = 8, k_c = 32)).
pub struct Stored {
    pub flow: FloatFlow,
    /// `rep.png`: per-frame min–max.
    pub rep_minmax: Vec<u8>,
    /// `rep_fixed.png`: Fixed(8, 32).
    pub rep_fixed: Vec<u8>,
}

/// One named frame pair of the corpus.
pub struct Case {
    pub family: Family,
    pub name: String,
    pub prev: Gray,
    pub next: Gray,
    /// The stored float64 output, for the shared vectors.
    pub stored: Option<Stored>,
}

impl Case {
    fn new(family: Family, name: impl Into<String>, w: usize, h: usize, frames: Frames) -> Self {
        let (a, b) = frames;
        Self {
            family,
            name: name.into(),
            prev: Gray::new(w, h, a).expect("frame of w·h pixels"),
            next: Gray::new(w, h, b).expect("frame of w·h pixels"),
            stored: None,
        }
    }
}

type Frames = (Vec<u8>, Vec<u8>);

/// The whole corpus, in family order.
pub fn corpus() -> Vec<Case> {
    let mut cases = tiny_motions();
    cases.extend(worst_cases());
    cases.extend(scenes());
    cases.extend(vectors());
    cases
}

/// `f(x, y)` rounded half up and clamped to a byte, over `w × h`.
fn render(w: usize, h: usize, f: impl Fn(f64, f64) -> f64) -> Vec<u8> {
    (0..w * h)
        .map(|i| {
            (f((i % w) as f64, (i / w) as f64) + 0.5)
                .floor()
                .clamp(0.0, 255.0) as u8
        })
        .collect()
}

/// A textured checkerboard: soft 12-px squares under two oblique waves,
/// values in [18, 238] (so ±1 and ×1.1 changes stay unclamped).
fn texture(x: f64, y: f64) -> f64 {
    let checker = (4.0 * (PI * x / 12.0).sin() * (PI * y / 12.0).sin()).tanh();
    128.0
        + 30.0 * checker
        + 45.0 * (0.21 * x + 0.13 * y).sin()
        + 35.0 * (0.11 * x - 0.27 * y + 1.0).cos()
}

/// Low-frequency waves only: a smooth texture for sub-pixel shifts.
fn smooth(x: f64, y: f64) -> f64 {
    128.0 + 60.0 * (0.09 * x + 0.05 * y).sin() + 50.0 * (0.07 * x - 0.11 * y + 0.5).cos()
}

/// Uniform noise in `[lo, hi]`.
fn noise(n: usize, lo: u8, hi: u8, rng: &mut Rng) -> Vec<u8> {
    let span = u64::from(hi - lo) + 1;
    (0..n).map(|_| lo + (rng.next_u64() % span) as u8).collect()
}

/// `frame` with `±1` (random sign) at a `fraction` of its pixels.
fn plus_minus_one(frame: &[u8], fraction: f64, rng: &mut Rng) -> Vec<u8> {
    frame
        .iter()
        .map(|&p| match rng.unit() < fraction {
            false => p,
            true if rng.next_u64() & 1 == 0 => p + 1,
            true => p - 1,
        })
        .collect()
}

fn tiny_motions() -> Vec<Case> {
    let case = |name: &str, w, h, frames| Case::new(Family::TinyMotions, name, w, h, frames);
    let mut rng = Rng::new(12);
    let mut out = Vec::new();

    let (w, h) = (64, 48);
    let flat = vec![100u8; w * h];
    let mut next = flat.clone();
    next[24 * w + 31] += 1;
    out.push(case("+1 at one pixel, flat", w, h, (flat, next)));
    let tex = render(w, h, texture);
    let mut next = tex.clone();
    next[20 * w + 40] -= 1;
    out.push(case("-1 at one pixel, texture", w, h, (tex, next)));

    let (w, h) = (160, 120);
    let tex = render(w, h, texture);
    let next = plus_minus_one(&tex, 0.03, &mut rng);
    out.push(case(
        "±1 at 3 % of pixels, texture",
        w,
        h,
        (tex.clone(), next),
    ));
    let speckle = noise(64 * 48, 1, 254, &mut rng);
    let next = plus_minus_one(&speckle, 0.2, &mut rng);
    out.push(case("±1 at 20 % of pixels, noise", 64, 48, (speckle, next)));
    let next = tex.iter().map(|p| p + 1).collect();
    out.push(case("global +1, texture", w, h, (tex.clone(), next)));
    let speckle = noise(64 * 48, 1, 254, &mut rng);
    let next = speckle.iter().map(|p| p - 1).collect();
    out.push(case("global -1, noise", 64, 48, (speckle, next)));

    // A flat black patch (X = 0 inside) flashing to white in its middle,
    // beside texture with ±1 changes: a per-frame exponent from max|d|
    // would be set by the flash and lose the ±1 detail.
    let patch = |x: usize, y: usize| x < 56 && (20..100).contains(&y);
    let flash = |x: usize, y: usize| (12..44).contains(&x) && (36..84).contains(&y);
    let prev: Vec<u8> = (0..w * h)
        .map(|i| if patch(i % w, i / w) { 0 } else { tex[i] })
        .collect();
    let mut next = plus_minus_one(&tex, 0.05, &mut rng);
    for (i, p) in next.iter_mut().enumerate() {
        if patch(i % w, i / w) {
            *p = if flash(i % w, i / w) { 255 } else { 0 };
        }
    }
    out.push(case(
        "flash in a flat patch beside ±1 on texture",
        w,
        h,
        (prev, next),
    ));

    for (dx, dy) in [(0.02, 0.0), (0.0, 0.035), (0.05, -0.05)] {
        let frames = (
            render(w, h, smooth),
            render(w, h, |x, y| smooth(x - dx, y - dy)),
        );
        out.push(case(
            &format!("shift ({dx}, {dy}) px, smooth"),
            w,
            h,
            frames,
        ));
    }
    let next = render(w, h, |x, y| texture(x, y) * 1.004);
    out.push(case(
        "gain ×1.004, texture",
        w,
        h,
        (render(w, h, texture), next),
    ));
    out
}

fn worst_cases() -> Vec<Case> {
    let case = |name: &str, w, h, frames| Case::new(Family::WorstCases, name, w, h, frames);
    let (w, h) = (64, 48);
    let n = w * h;
    let pattern = |f: &dyn Fn(usize, usize) -> bool| -> Vec<u8> {
        (0..n)
            .map(|i| if f(i % w, i / w) { 255 } else { 0 })
            .collect()
    };
    let invert = |v: &[u8]| v.iter().map(|p| 255 - p).collect::<Vec<_>>();
    let mut out = vec![
        case("black → white", w, h, (vec![0; n], vec![255; n])),
        case("white → black", w, h, (vec![255; n], vec![0; n])),
    ];
    for k in 1..=3 {
        let board = pattern(&|x, y| (x / k + y / k) % 2 == 1);
        out.push(case(
            &format!("{k}-px checkerboard, flipping"),
            w,
            h,
            (board.clone(), invert(&board)),
        ));
        out.push(case(
            &format!("{k}-px checkerboard, static"),
            w,
            h,
            (board.clone(), board),
        ));
        let stripes = |shift: usize| pattern(&|x, _| ((x + shift) / k) % 2 == 1);
        out.push(case(
            &format!("{k}-px vertical stripes, moving 1 px"),
            w,
            h,
            (stripes(0), stripes(1)),
        ));
    }
    let rows = pattern(&|_, y| (y / 2) % 2 == 1);
    out.push(case(
        "2-px horizontal stripes, flipping",
        w,
        h,
        (rows.clone(), invert(&rows)),
    ));
    // Periodic frames at 160×120 (min–max bytes of a 3-px board are fragile).
    let (bw, bh) = (160, 120);
    let board: Vec<u8> = (0..bw * bh)
        .map(|i| {
            if (i % bw / 3 + i / bw / 3) % 2 == 1 {
                255
            } else {
                0
            }
        })
        .collect();
    out.push(case(
        "3-px checkerboard, flipping, 160×120",
        bw,
        bh,
        (board.clone(), invert(&board)),
    ));
    let step = |e: usize| pattern(&|x, _| x >= e);
    out.push(case(
        "vertical step, moving 1 px",
        w,
        h,
        (step(32), step(33)),
    ));
    let diagonal = |e: usize| pattern(&|x, y| x + y >= e);
    out.push(case(
        "diagonal step, moving 2 px",
        w,
        h,
        (diagonal(50), diagonal(52)),
    ));
    // Straight oblique edges at full contrast: the rank-one structure
    // tensor at which a rounded 2×2 solve loses the most (its condition
    // number is largest there), at three slopes.
    for (name, a, b, e) in [
        ("oblique step 1:2, moving 1 px", 1, 2, 64),
        ("oblique step 2:3, moving 1 px", 2, 3, 120),
        ("oblique step 1:3, moving 2 px", 1, 3, 80),
    ] {
        let edge = |e: usize| pattern(&move |x, y| a * x + b * y >= e);
        out.push(case(name, w, h, (edge(e), edge(e + a + b))));
    }
    out.push(case(
        "step appearing on black",
        w,
        h,
        (vec![0; n], step(32)),
    ));
    for objective in [Objective::Dn, Objective::XDn] {
        let at = |den: f64| maximiser(w, h, 1.0 / den, objective);
        let (a, b) = (at(255.0), at(1024.0));
        let name = |scales: &str| format!("maximiser of {} at s = {scales}", objective.name());
        if a == b {
            // The same frames maximise at both scales: one copy.
            out.push(case(&name("1/255 and 1/1024"), w, h, a));
        } else {
            out.push(case(&name("1/255"), w, h, a));
            out.push(case(&name("1/1024"), w, h, b));
        }
    }
    out
}

/// What [`maximiser`] makes large at the frame's centre pixel.
#[derive(Clone, Copy)]
enum Objective {
    /// The residual `|Dn|`.
    Dn,
    /// The structure-sum operand `|X·Dn|`.
    XDn,
}

impl Objective {
    fn name(self) -> &'static str {
        match self {
            Objective::Dn => "|Dn|",
            Objective::XDn => "|X·Dn|",
        }
    }
}

/// A square correlation kernel, offsets `−r..=r` (SPEC §2).
#[derive(Clone)]
struct Kernel {
    r: isize,
    w: Vec<f64>,
}

impl Kernel {
    fn new<const N: usize>(rows: [[f64; N]; N]) -> Self {
        Self {
            r: N as isize / 2,
            w: rows.iter().flatten().copied().collect(),
        }
    }

    fn zero(r: isize) -> Self {
        let side = (2 * r + 1) as usize;
        Self {
            r,
            w: vec![0.0; side * side],
        }
    }

    fn at(&self, dx: isize, dy: isize) -> f64 {
        match dx.abs() <= self.r && dy.abs() <= self.r {
            true => self.w[((dy + self.r) * (2 * self.r + 1) + dx + self.r) as usize],
            false => 0.0,
        }
    }

    fn add(&mut self, dx: isize, dy: isize, v: f64) {
        let i = ((dy + self.r) * (2 * self.r + 1) + dx + self.r) as usize;
        self.w[i] += v;
    }

    /// The kernel of `self ⋆ (other ⋆ g)`.
    fn then(&self, other: &Kernel) -> Kernel {
        let mut out = Kernel::zero(self.r + other.r);
        for ay in -self.r..=self.r {
            for ax in -self.r..=self.r {
                for by in -other.r..=other.r {
                    for bx in -other.r..=other.r {
                        out.add(ax + bx, ay + by, self.at(ax, ay) * other.at(bx, by));
                    }
                }
            }
        }
        out
    }

    fn minus(&self, other: &Kernel) -> Kernel {
        let mut out = Kernel::zero(self.r.max(other.r));
        for dy in -out.r..=out.r {
            for dx in -out.r..=out.r {
                out.add(dx, dy, self.at(dx, dy) - other.at(dx, dy));
            }
        }
        out
    }
}

/// The kernels that make the residual `D` (SPEC §3.7) at one pixel a
/// linear function of the temporal difference `δp` around it.
struct Residual {
    /// `G ⋆ (Kbx − Box ⋆ Sobx)`, `G ⋆ (Kby − Box ⋆ Soby)` (radius 4).
    kvx: Kernel,
    kvy: Kernel,
    /// Their central-difference divergence (radius 5).
    kdiv: Kernel,
    sobx: Kernel,
    soby: Kernel,
}

impl Residual {
    fn new() -> Self {
        let t = 1.0 / 3.0;
        let kbx = Kernel::new([[-t, 0., t], [-4. * t, 0., 4. * t], [-t, 0., t]]);
        let kby = Kernel::new([[-t, -4. * t, -t], [0.; 3], [t, 4. * t, t]]);
        let sobx = Kernel::new([[-1., 0., 1.], [-2., 0., 2.], [-1., 0., 1.]]);
        let soby = Kernel::new([[-1., -2., -1.], [0.; 3], [1., 2., 1.]]);
        let boxk = Kernel::new([[1.; 3]; 3]);
        let g = [1., 4., 6., 4., 1.].map(|v: f64| v / 16.);
        let gk = Kernel::new(g.map(|gy| g.map(|gx| gy * gx)));
        let kvx = gk.then(&kbx.minus(&boxk.then(&sobx)));
        let kvy = gk.then(&kby.minus(&boxk.then(&soby)));
        let mut kdiv = Kernel::zero(kvx.r + 1);
        for dy in -kvx.r..=kvx.r {
            for dx in -kvx.r..=kvx.r {
                // div(c) = (vx(c + x̂) − vx(c − x̂))/2 + (vy(c + ŷ) − vy(c − ŷ))/2.
                kdiv.add(dx + 1, dy, kvx.at(dx, dy) / 2.);
                kdiv.add(dx - 1, dy, -kvx.at(dx, dy) / 2.);
                kdiv.add(dx, dy + 1, kvy.at(dx, dy) / 2.);
                kdiv.add(dx, dy - 1, -kvy.at(dx, dy) / 2.);
            }
        }
        Self {
            kvx,
            kvy,
            kdiv,
            sobx,
            soby,
        }
    }

    /// `X` (Sobel x of `p0` at the centre) and the weights `w` with
    /// `D/s = Σ_u w(u)·δp(c + u)`, for the 3×3 of `p0` around `c` given
    /// by `centre(dx, dy)`:
    /// `w = −[u = 0] − (sX/8)·Kvx − (sY/8)·Kvy − s·p0(c)·Kdiv`.
    fn weights(&self, s: f64, centre: impl Fn(isize, isize) -> f64) -> (f64, Kernel) {
        let sobel = |k: &Kernel| -> f64 {
            (-1..=1)
                .flat_map(|dy| (-1..=1).map(move |dx| (dx, dy)))
                .map(|(dx, dy)| k.at(dx, dy) * centre(dx, dy))
                .sum()
        };
        let (x, y) = (sobel(&self.sobx), sobel(&self.soby));
        let mut w = Kernel::zero(self.kdiv.r);
        for dy in -w.r..=w.r {
            for dx in -w.r..=w.r {
                let identity = f64::from(u8::from(dx == 0 && dy == 0));
                let v = -identity
                    - s * x / 8. * self.kvx.at(dx, dy)
                    - s * y / 8. * self.kvy.at(dx, dy)
                    - s * centre(0, 0) * self.kdiv.at(dx, dy);
                w.add(dx, dy, v);
            }
        }
        (x, w)
    }
}

/// Frames that make `|Dn|` or `|X·Dn|` as large as any 0/255 centre allows
/// at the frame's centre pixel, for intensity scale `s`.
///
/// With `p0`'s 3×3 around the centre fixed (it sets `X`, `Y`, `p0(c)`),
/// `D` is linear in `δp` ([`Residual::weights`]). Outside the 3×3, `p0`
/// is free, so `δp = ±255` with the sign of `w`; inside, `δp` goes to the
/// end of `[−p0, 255 − p0]` that `w`'s sign favours. Every 0/255 3×3
/// (512 of them) is tried and the best one written into a static grey
/// frame.
fn maximiser(w: usize, h: usize, s: f64, objective: Objective) -> Frames {
    let residual = Residual::new();
    let centre_of = |bits: u32| {
        move |dx: isize, dy: isize| f64::from((bits >> ((dy + 1) * 3 + dx + 1)) & 1) * 255.
    };
    let inside = |dx: isize, dy: isize| dx.abs() <= 1 && dy.abs() <= 1;
    // Best (objective, 3×3 bits, sign of D).
    let mut best = (f64::NEG_INFINITY, 0u32, 1.0);
    for bits in 0u32..512 {
        let p0 = centre_of(bits);
        let (x, wk) = residual.weights(s, p0);
        let (mut hi, mut lo) = (0.0f64, 0.0f64);
        for dy in -wk.r..=wk.r {
            for dx in -wk.r..=wk.r {
                let (dmin, dmax) = match inside(dx, dy) {
                    true => (-p0(dx, dy), 255. - p0(dx, dy)),
                    false => (-255., 255.),
                };
                let wu = wk.at(dx, dy);
                hi += (wu * dmin).max(wu * dmax);
                lo += (wu * dmin).min(wu * dmax);
            }
        }
        let (d, sign) = if hi >= -lo { (hi, 1.0) } else { (-lo, -1.0) };
        let value = match objective {
            Objective::Dn => d,
            Objective::XDn => d * x.abs(),
        };
        if value > best.0 {
            best = (value, bits, sign);
        }
    }
    let (_, bits, sign) = best;
    let p0 = centre_of(bits);
    let (_, wk) = residual.weights(s, p0);
    let (mut prev, mut next) = (vec![128u8; w * h], vec![128u8; w * h]);
    let (cx, cy) = ((w / 2) as isize, (h / 2) as isize);
    for dy in -wk.r..=wk.r {
        for dx in -wk.r..=wk.r {
            let wu = sign * wk.at(dx, dy);
            let (a, b) = match inside(dx, dy) {
                true => {
                    let a = p0(dx, dy) as u8;
                    (a, if wu > 0.0 { 255 } else { 0 })
                }
                false if wu > 0.0 => (0, 255),
                false if wu < 0.0 => (255, 0),
                false => (128, 128),
            };
            let i = (cy + dy) as usize * w + (cx + dx) as usize;
            prev[i] = a;
            next[i] = b;
        }
    }
    (prev, next)
}

fn scenes() -> Vec<Case> {
    let case = |name: &str, w, h, frames| Case::new(Family::Scenes, name, w, h, frames);
    let mut out = Vec::new();
    for (w, h) in [(64, 48), (320, 240)] {
        let (cx, cy) = (w as f64 / 2.0, h as f64 / 2.0);
        let prev = render(w, h, texture);
        let moves: [(&str, Vec<u8>); 4] = [
            (
                "translation (1.3, -0.6) px",
                render(w, h, |x, y| texture(x - 1.3, y + 0.6)),
            ),
            (
                "zoom ×1.03",
                render(w, h, |x, y| {
                    texture(cx + (x - cx) / 1.03, cy + (y - cy) / 1.03)
                }),
            ),
            (
                "rotation 2°",
                render(w, h, |x, y| {
                    let (sin, cos) = (-2f64).to_radians().sin_cos();
                    let (u, v) = (x - cx, y - cy);
                    texture(cx + cos * u - sin * v, cy + sin * u + cos * v)
                }),
            ),
            (
                "illumination ×1.08 + 6",
                render(w, h, |x, y| texture(x, y) * 1.08 + 6.0),
            ),
        ];
        for (name, next) in moves {
            out.push(case(
                &format!("{name}, {w}×{h}"),
                w,
                h,
                (prev.clone(), next),
            ));
        }
    }
    for (pattern, w, h, seed) in [
        (Pattern::Random, 64, 48, 1),
        (Pattern::Shifted, 160, 120, 2),
        (Pattern::Smooth, 160, 120, 3),
    ] {
        let name = format!("{pattern:?} (lib::Pattern), {w}×{h}");
        out.push(case(&name, w, h, frame_pair(pattern, w, h, seed)));
    }
    // Odd and degenerate sizes, where most reads are clamped at the border.
    for (k, (w, h)) in [(1, 1), (2, 3), (7, 1), (1, 9), (5, 17), (33, 6), (13, 13)]
        .into_iter()
        .enumerate()
    {
        for pattern in [Pattern::Random, Pattern::SaturatedEdge] {
            let name = format!("{pattern:?} (lib::Pattern), {w}×{h}");
            out.push(case(&name, w, h, frame_pair(pattern, w, h, 100 + k as u64)));
        }
    }
    out
}

fn vectors() -> Vec<Case> {
    vector_cases()
        .into_iter()
        .map(|name| {
            let dir = vectors_dir().join(&name);
            let prev =
                image_file::read_gray(&dir.join("f0.pgm"), Limits::default()).expect("f0.pgm");
            let next =
                image_file::read_gray(&dir.join("f1.pgm"), Limits::default()).expect("f1.pgm");
            let plane = |p: &str| {
                npy::read(&dir.join(format!("{p}.npy")))
                    .unwrap_or_else(|e| panic!("{name}/{p}.npy: {e}"))
                    .data
            };
            let rep = |p: &str| {
                image_file::read_rgb8(&dir.join(p), Limits::default())
                    .unwrap_or_else(|e| panic!("{name}/{p}: {e}"))
                    .bytes
            };
            let stored = Stored {
                flow: FloatFlow {
                    v_c: Flow::from_parts(prev.width, prev.height, plane("vcx"), plane("vcy")),
                    v_d: Flow::from_parts(prev.width, prev.height, plane("vdx"), plane("vdy")),
                },
                rep_minmax: rep("rep.png"),
                rep_fixed: rep("rep_fixed.png"),
            };
            Case {
                family: Family::Vectors,
                name,
                prev,
                next,
                stored: Some(stored),
            }
        })
        .collect()
}
