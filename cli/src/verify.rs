//! `reynoldsflow verify`: a device's output against the representation
//! recomputed from the same input with the same settings — the check a
//! firmware team runs in CI. The recomputation is `run`'s own: the same
//! input reading, flags and pipeline, streaming RGB24 into a
//! [`Comparison`] instead of stdout, so a pass means the device wrote the
//! bytes `run` writes.

use std::path::PathBuf;

use super::captured::{Captured, CapturedFormat};
use super::compare::{Comparison, Difference, Outcome};
use super::limits::LimitArgs;
use super::progress::Progress;
use super::run::{
    EngineArgs, OutputArgs, RawInputArgs, count, install_interrupt_handler, progress_total,
};
use reynoldsflow_host::HostError;
use reynoldsflow_host::engine::Compute;
use reynoldsflow_host::limits::Limits;
use reynoldsflow_host::outputs::{OutputSpec, StreamFormat};
use reynoldsflow_host::pipeline::{self, Destination, Options};
use reynoldsflow_host::sequence::{self, InputSpec, Peeked};
use reynoldsflow_host::settings::Choice;

/// Shown by `reynoldsflow verify --help`.
pub const EXAMPLES: &str = "\
Examples:
  reynoldsflow verify clip.y4m device.rgb
      the device's raw RGB24 stream (what run clip.y4m --out - --format rgb24 writes)
  reynoldsflow verify frames/ device.y4m --scale fixed:8,32 --variant dc0
      a C444 Y4M capture (run --format y4m), with the settings the firmware uses
  reynoldsflow verify clip.mp4 device-pngs/ --tolerance 1
      a folder of PNGs (as run --out DIR writes them); bytes may differ by 1
  device-dump | reynoldsflow verify clip.y4m -
      the capture on stdin (Y4M by its header, raw RGB24 otherwise)

Output (stdout): a summary, then one line
  frames=N pixels_differing=N max_diff=N first_diff=frame:F,x:X,y:Y,channel:C|none \
expected_frames=N captured_frames=N tolerance=N result=pass|fail
  (frames count from 0: frame F is the result of input frames F and F+1; channels
  R, G, B, or Y, Cb, Cr for Y4M; with --tolerance above 0 also first_over_tolerance=...)

Exit status: 0 identical (or within --tolerance), 1 different, a wrong frame count
or an unreadable input or capture, 2 a bad command line.";

/// Arguments of `reynoldsflow verify`. The output flags of `run` that a
/// stream cannot carry (--no-rep, --viz, --npy, --flo, the file types) and
/// the frame flags (--step, --fps, --resize, --short-side) come with the
/// shared [`OutputArgs`]; they are hidden here and refused.
#[derive(Debug, clap::Args)]
#[command(
    mut_arg("no_rep", |a| a.hide(true)),
    mut_arg("viz", |a| a.hide(true)),
    mut_arg("npy", |a| a.hide(true)),
    mut_arg("flo", |a| a.hide(true)),
    mut_arg("npy_dtype", |a| a.hide(true)),
    mut_arg("image_format", |a| a.hide(true)),
    mut_arg("jpeg_quality", |a| a.hide(true)),
    mut_arg("jpeg_subsampling", |a| a.hide(true)),
    mut_arg("png_compression", |a| a.hide(true)),
    mut_arg("resize", |a| a.hide(true)),
    mut_arg("short_side", |a| a.hide(true)),
    mut_arg("step", |a| a.hide(true)),
    mut_arg("fps", |a| a.hide(true)),
)]
pub struct VerifyArgs {
    /// The frames the device was given: anything run reads (a video, a Y4M
    /// file, a folder or quoted glob of frames, or - for stdin: Y4M, or raw
    /// frames with --raw).
    #[arg(value_name = "INPUT")]
    pub input: PathBuf,
    /// What the device produced from them, one frame per consecutive pair:
    /// raw RGB24 frames, a C444 Y4M stream, or a folder of PNGs; - for stdin.
    #[arg(value_name = "CAPTURED")]
    pub captured: PathBuf,
    /// Format of CAPTURED [default: png-dir for a folder, y4m for a .y4m
    /// file, rgb24 for any other file; on stdin y4m when it starts with a
    /// Y4M header, rgb24 otherwise].
    #[arg(long, value_parser = super::values::choice::<CapturedFormat>(), value_name = "FORMAT")]
    pub captured_format: Option<CapturedFormat>,
    /// Pass when no byte differs by more than N (0 to 255); 0: only when
    /// identical.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub tolerance: u8,
    /// How INPUT is read.
    #[command(flatten)]
    pub raw: RawInputArgs,
    /// The computation, as run takes it.
    #[command(flatten)]
    pub engine: EngineArgs,
    /// The image and frame count, as run takes them.
    #[command(flatten)]
    pub output: OutputArgs,
    /// Input limits.
    #[command(flatten)]
    pub limits: LimitArgs,
}

/// A checked verification, ready to run.
#[derive(Debug)]
pub struct Plan {
    input: InputSpec,
    captured: PathBuf,
    format: Option<CapturedFormat>,
    compute: Compute,
    spec: OutputSpec,
    options: Options,
    limits: Limits,
    tolerance: u8,
}

/// Check the command line beyond what clap checks. Every failure here is a bad command line (exit status
/// 2), so that status 1 always means that the capture failed, or that it
/// or the input could not be read.
pub fn prepare(args: &VerifyArgs) -> Result<Plan, HostError> {
    let out = &args.output;
    let refused = [
        (out.no_rep, "--no-rep"),
        (out.viz, "--viz"),
        (out.npy.is_some(), "--npy"),
        (out.flo.is_some(), "--flo"),
        (out.npy_dtype.is_some(), "--npy-dtype"),
        (out.image_format.is_some(), "--image-format"),
        (out.jpeg_quality.is_some(), "--jpeg-quality"),
        (out.jpeg_subsampling.is_some(), "--jpeg-subsampling"),
        (out.png_compression.is_some(), "--png-compression"),
        (out.frames.resize.is_some(), "--resize"),
        (out.frames.short_side.is_some(), "--short-side"),
        (out.frames.step.is_some(), "--step"),
        (out.frames.fps.is_some(), "--fps"),
    ];
    if let Some((_, flag)) = refused.iter().find(|(given, _)| *given) {
        return Err(HostError::invalid(
            *flag,
            "does not apply to verify, which compares the --variant images (the stream, or DIR/STEM.png)",
        ));
    }
    let spec = out.spec();
    debug_assert!(spec.images_only());
    let stdin = |p: &PathBuf| p.as_os_str() == "-";
    if stdin(&args.input) && stdin(&args.captured) {
        return Err(HostError::invalid(
            "CAPTURED",
            "INPUT is already standard input (-); give the capture as a file or folder",
        ));
    }
    if stdin(&args.captured) && args.captured_format == Some(CapturedFormat::PngDir) {
        return Err(HostError::invalid(
            "--captured-format",
            "png-dir reads a folder, but CAPTURED is - (standard input)",
        ));
    }
    let compute = args.engine.compute.compute()?;
    let input = args.raw.input_spec(Some(&args.input))?;
    Ok(Plan {
        input,
        captured: args.captured.clone(),
        format: args.captured_format,
        compute,
        spec,
        options: out.options(&args.engine),
        limits: args.limits.limits(),
        tolerance: args.tolerance,
    })
}

/// Recompute and compare; print the report. `Ok` only when the capture
/// passes; otherwise an error saying why, naming the capture.
pub fn run(plan: &Plan) -> Result<(), HostError> {
    install_interrupt_handler();
    let input_name = sequence::display_name(&plan.input);
    let Some(mut source) = Peeked::new(sequence::open(&plan.input, plan.limits)?)? else {
        return Err(sequence::input_error(&input_name, "no frames"));
    };
    let (width, height) = source.size();
    let mut captured = Captured::open(&plan.captured, plan.format, (width, height), plan.limits)?;
    let progress = Progress::new(progress_total(&source, &plan.options), "frames");
    let mut comparison = Comparison::new(&mut captured, width, plan.tolerance);
    let summary = pipeline::process(
        &mut source,
        &plan.compute,
        Destination::Stream {
            spec: &plan.spec,
            format: StreamFormat::Rgb24,
            writer: &mut comparison,
        },
        plan.options.clone(),
        &mut || progress.inc(),
    );
    progress.finish();
    // An input that fails mid-way leaves nothing to judge the capture by.
    let summary = summary?;
    let outcome = comparison.finish();
    let report = Report {
        plan,
        input: &input_name,
        captured: &captured,
        size: (width, height),
        input_frames: summary.frames,
        outcome: &outcome,
    };
    println!("{}", report.summary());
    println!("{}", report.machine_line());
    let failure = report.failure();
    // A capture that could not be read whole: its own error says where.
    if let Some(e) = outcome.error {
        return Err(e);
    }
    match failure {
        None => Ok(()),
        Some(why) => Err(sequence::input_error(captured.name(), why)),
    }
}

/// What is printed about one verification.
struct Report<'a> {
    plan: &'a Plan,
    input: &'a str,
    captured: &'a Captured,
    size: (usize, usize),
    /// Input frames read.
    input_frames: usize,
    outcome: &'a Outcome,
}

impl Report<'_> {
    /// The human-readable line.
    fn summary(&self) -> String {
        let o = self.outcome;
        let t = &o.tally;
        let verdict = match (o.passed(), t.pixels_differing) {
            (true, 0) => "PASS (identical)",
            (true, _) => "PASS (within tolerance)",
            (false, _) => "FAIL",
        };
        let engine = self.plan.compute.engine().name();
        let (w, h) = self.size;
        let mut line = format!(
            "reynoldsflow verify: {verdict}: {} ({}) against {} recomputed ({engine} engine, variant {}): \
             {} of {w}x{h} compared, {}",
            self.captured.name().display(),
            self.captured.format().name(),
            self.input,
            self.plan.spec.variant.name(),
            count(t.frames, "frame"),
            differ(t.pixels_differing),
        );
        if t.pixels_differing > 0 {
            line += &format!(
                " (largest difference {}, tolerance {})",
                t.max_diff, self.plan.tolerance
            );
        }
        if let Some(d) = &t.first {
            line += &format!("; first at {}", self.place(d));
        }
        if let Some(d) = t
            .first_over
            .as_ref()
            .filter(|&d| Some(d) != t.first.as_ref())
        {
            line += &format!("; first beyond the tolerance at {}", self.place(d));
        }
        if o.error.is_some() {
            line += &format!(
                "; frame {} of the capture cannot be read (the error follows)",
                o.captured_frames
            );
        } else if o.captured_frames != o.expected_frames {
            line += &format!("; {}", self.count_mismatch());
        }
        line
    }

    /// `frame 7, x 10, y 4, channel G (expected 120, captured 123)`, and
    /// the frame's file for a folder of PNGs.
    fn place(&self, d: &Difference) -> String {
        let file = self
            .captured
            .frame_file(d.frame)
            .and_then(|p| p.file_name())
            .map_or(String::new(), |n| format!(" ({})", n.to_string_lossy()));
        format!(
            "frame {}{file}, x {}, y {}, channel {} (expected {}, captured {})",
            d.frame,
            d.x,
            d.y,
            self.channel(d),
            d.expected,
            d.captured
        )
    }

    fn channel(&self, d: &Difference) -> &'static str {
        self.captured.format().layout().channels()[d.channel]
    }

    /// `frame:F,x:X,y:Y,channel:C`, or `none`.
    fn machine_place(&self, d: Option<&Difference>) -> String {
        d.map_or("none".to_owned(), |d| {
            format!(
                "frame:{},x:{},y:{},channel:{}",
                d.frame,
                d.x,
                d.y,
                self.channel(d)
            )
        })
    }

    /// The line for scripts: `key=value` fields, separated by spaces.
    fn machine_line(&self) -> String {
        let o = self.outcome;
        let t = &o.tally;
        let mut line = format!(
            "frames={} pixels_differing={} max_diff={} first_diff={} expected_frames={} captured_frames={} tolerance={}",
            t.frames,
            t.pixels_differing,
            t.max_diff,
            self.machine_place(t.first.as_ref()),
            o.expected_frames,
            o.captured_frames,
            self.plan.tolerance,
        );
        if self.plan.tolerance > 0 {
            line += &format!(
                " first_over_tolerance={}",
                self.machine_place(t.first_over.as_ref())
            );
        }
        line += if o.passed() {
            " result=pass"
        } else {
            " result=fail"
        };
        line
    }

    /// "the captured stream has 38 frames, the input gives 39 (...)".
    fn count_mismatch(&self) -> String {
        let o = self.outcome;
        let what = match self.captured.format() {
            CapturedFormat::PngDir => "the captured folder has",
            CapturedFormat::Rgb24 | CapturedFormat::Y4m => "the captured stream has",
        };
        let unit = match self.captured.format() {
            CapturedFormat::PngDir => "PNG frame",
            CapturedFormat::Rgb24 | CapturedFormat::Y4m => "frame",
        };
        let why = match (self.input_frames, self.plan.options.keep_count) {
            (1, _) => "1 input frame: no pair, so no result".to_owned(),
            (n, true) => format!("{n} input frames, with --keep-count"),
            (n, false) => format!("{n} input frames, one result per consecutive pair"),
        };
        format!(
            "{what} {}, the input gives {} ({why})",
            count(o.captured_frames, unit),
            o.expected_frames
        )
    }

    /// Why the capture fails (after it was read whole), if it does.
    fn failure(&self) -> Option<String> {
        let o = self.outcome;
        let t = &o.tally;
        let mut why = Vec::new();
        if o.captured_frames != o.expected_frames {
            why.push(self.count_mismatch());
        }
        if let Some(d) = &t.first_over {
            let beyond = match self.plan.tolerance {
                0 => String::new(),
                n => format!(" by more than --tolerance {n}"),
            };
            why.push(format!(
                "{} from the recomputed representation{beyond} (largest difference {}); first at {}",
                differ(t.pixels_over_tolerance),
                t.max_diff,
                self.place(d)
            ));
        }
        (!why.is_empty()).then(|| why.join("; "))
    }
}

/// "1 pixel differs", "3 pixels differ".
fn differ(pixels: u64) -> String {
    match pixels {
        1 => "1 pixel differs".to_owned(),
        n => format!("{n} pixels differ"),
    }
}
