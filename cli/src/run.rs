//! `reynoldsflow run`: a whole frame sequence to one output per
//! consecutive frame pair (SPEC §5), streamed, on all cores.

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::{LazyLock, Once};
use std::time::Instant;

use reynoldsflow_core::IntensityScale;

use super::progress::Progress;
use super::values::choice;
use reynoldsflow_host::HostError;
use reynoldsflow_host::dataset::ItemSettings;
use reynoldsflow_host::engine::Compute;
use reynoldsflow_host::limits::Limits;
use reynoldsflow_host::outputs::{
    self, DEFAULT_JPEG_QUALITY, DirWriter, Fields, ImageFormat, ImageFormatName, JpegSubsampling,
    NpyDtype, OutputSpec, PngCompression, StreamFormat, Variant,
};
use reynoldsflow_host::pipeline::{self, Destination, Options, Summary};
use reynoldsflow_host::sequence::sampled::{self, FramePlan, FrameSize, Rate};
use reynoldsflow_host::sequence::{self, FrameSource, InputSpec};
use reynoldsflow_host::settings::{self, EngineKind, ScaleArg, Settings, TileSize};
use reynoldsflow_host::stop::Stop;

/// Examples shown by `reynoldsflow run --help`.
pub const EXAMPLES: &str = "\
Examples:
  reynoldsflow run
      the built-in demo sequence (a rolling ball, a panning camera) into reynoldsflow-out/
  reynoldsflow run clip.mp4 --out flows/
      any video ffmpeg decodes: flows/000000.png, flows/000001.png, ...
  reynoldsflow run frames/ --out reps/ --keep-count
      a folder of PNG/JPEG/PGM frames (natural order); reps/<frame stem>.png, one per frame
  reynoldsflow run 'frames/img_*.jpg' --out out/ --viz --npy --flo
      also out/hsv/*.png (colour wheel of v_R), out/{v_c,v_d,v_R}/*.npy, out/v_R/*.flo
  reynoldsflow run clip.y4m --variant dc0 --scale fixed:8,32 --out ablation/
      the [|v_d|, 0, f] variant with constant gains
  cat frames.gray | reynoldsflow run - --raw 640x480 --out out/
      raw 8-bit gray frames on stdin
  reynoldsflow run clip.mp4 --out - --format y4m | ffmpeg -i - -c:v libx264 rep.mp4
      stream the representation into an encoder";

/// The engine and its parameters (shared by `pair`, `run` and `dataset`).
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Computation")]
pub struct ComputeArgs {
    /// Engine: the fixed-point core, or the float64 reference.
    #[arg(long, value_parser = choice::<EngineKind>(), default_value = settings::DEFAULT_ENGINE.name())]
    pub engine: EngineKind,
    /// Magnitudes to bytes: per-frame min-max, or fixed gains KD (|v_d|)
    /// and KC (|v_c|), the same for every frame; the fixed engine rounds
    /// gains to 1/65536.
    #[arg(long, value_name = "minmax|fixed:KD,KC", default_value = settings::DEFAULT_SCALE.to_string(), value_parser = settings::parse_scale)]
    pub scale: ScaleArg,
    /// Intensity scale s (f = pixel * s) as an exact ratio or decimal,
    /// 6144/2^32 <= s <= 1.
    #[arg(long, value_name = "S", default_value = intensity_scale_text(settings::DEFAULT_INTENSITY_SCALE), value_parser = settings::parse_intensity_scale)]
    pub intensity_scale: IntensityScale,
    /// Tikhonov term lambda of the 2x2 solve (the fixed engine rounds it
    /// to 2^-32).
    #[arg(long, value_name = "L", default_value = format!("{:e}", settings::DEFAULT_LAMBDA), value_parser = settings::parse_lambda)]
    pub lambda: f64,
    /// Tile size for the fixed engine (any, up to the frame); default:
    /// full-height strips as wide as the frame, up to 1280 columns. Every
    /// tiling gives the same output.
    #[arg(long, value_name = "TWxTH", value_parser = settings::parse_tile)]
    pub tile: Option<TileSize>,
}

/// `N/D` of an intensity scale, as `--intensity-scale` reads it.
fn intensity_scale_text(s: reynoldsflow_core::IntensityScale) -> String {
    format!("{}/{}", s.num(), s.den())
}

impl ComputeArgs {
    /// These flags as the library's settings (the rest at their defaults).
    pub fn settings(&self) -> Settings {
        Settings {
            engine: self.engine,
            scale: self.scale,
            intensity_scale: self.intensity_scale,
            lambda: self.lambda,
            tile: self.tile,
            ..Settings::default()
        }
    }

    /// The checked computation.
    pub fn compute(&self) -> Result<Compute, HostError> {
        self.settings().compute()
    }
}

/// The computation and how many workers run it (shared by `run` and `dataset`).
#[derive(Debug, clap::Args)]
pub struct EngineArgs {
    /// The engine and its parameters.
    #[command(flatten)]
    pub compute: ComputeArgs,
    /// Worker threads [default: all cores]. The output does not depend on it.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1024), help_heading = "Computation")]
    pub threads: Option<u32>,
}

impl EngineArgs {
    /// These flags as the library's settings.
    pub fn settings(&self) -> Settings {
        Settings {
            threads: self.threads.map(|n| n as usize),
            ..self.compute.settings()
        }
    }

    /// `--threads`, or every core.
    pub fn threads(&self) -> usize {
        self.settings().threads()
    }
}

/// What to write per result (shared by `run` and `dataset`).
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Outputs")]
pub struct OutputArgs {
    /// The image of each result, DIR/STEM.png: dc = [|v_d|, |v_c|, f]
    /// (the ReynoldsFlow representation); dc0 = [|v_d|, 0, f]; cd =
    /// [|v_c|, |v_d|, f]; hsv = colour wheel of v_R.
    #[arg(long, value_parser = choice::<Variant>(), default_value = settings::DEFAULT_VARIANT.name())]
    pub variant: Variant,
    /// Do not write DIR/STEM.png (only the other outputs asked for).
    #[arg(long)]
    pub no_rep: bool,
    /// Also write DIR/hsv/STEM.png: the Middlebury colour wheel of
    /// v_R = v_c + v_d (hue = direction, saturation = length).
    #[arg(long)]
    pub viz: bool,
    /// Colour-wheel radius in pixels for hsv images [default: each frame's
    /// longest vector].
    #[arg(long, value_name = "PX", value_parser = parse_positive)]
    pub hsv_max: Option<f64>,
    /// Also write fields as DIR/FIELD/STEM.npy: float64, shape
    /// (H, W, 2), last axis (x, y) in pixels. FIELDS: comma-separated
    /// v_c, v_d, v_R [default: all three].
    #[arg(long, value_name = "FIELDS", num_args = 0..=1, require_equals = true,
          default_missing_value = "v_c,v_d,v_R", value_parser = outputs::parse_field_list)]
    pub npy: Option<Fields>,
    /// Element type of the --npy files: f64 (float64, as computed), f32 or
    /// f16, each value rounded to nearest (ties to even) from the float64
    /// field [default: f64].
    #[arg(long, value_parser = choice::<NpyDtype>(), value_name = "f16|f32|f64", requires = "npy")]
    pub npy_dtype: Option<NpyDtype>,
    /// How images are stored: png (lossless, STEM.png) or jpg (baseline
    /// JPEG, lossy, STEM.jpg; --jpeg-quality) [default: png].
    #[arg(long, value_parser = choice::<ImageFormatName>(), value_name = "png|jpg")]
    pub image_format: Option<ImageFormatName>,
    /// JPEG quality, 1 to 100, with --image-format jpg [default: 95].
    #[arg(long, value_name = "Q", value_parser = clap::value_parser!(u8).range(1..=100), requires = "image_format")]
    pub jpeg_quality: Option<u8>,
    /// JPEG chroma sampling, with --image-format jpg: 444 (full-resolution
    /// colour: each pixel keeps its own three channels, as the
    /// representation's channels mean different things) or 420 (colour at
    /// half resolution both ways: about 2/3 the bytes and faster, colour
    /// edges blurred over 2x2 pixels) [default: 444].
    #[arg(long, value_name = "444|420", value_parser = choice::<JpegSubsampling>(), requires = "image_format")]
    pub jpeg_subsampling: Option<JpegSubsampling>,
    /// PNG compression, lossless at every setting: fast (fdeflate, the
    /// PNG-tuned DEFLATE), default (zlib's default level) or best (zlib's
    /// best); at 640x480 fast is an order of magnitude faster than default,
    /// the files about as small (docs/PERFORMANCE.md) [default: fast].
    #[arg(long, value_name = "fast|default|best", value_parser = choice::<PngCompression>())]
    pub png_compression: Option<PngCompression>,
    /// Also write fields as Middlebury .flo (f32 u, v) in
    /// DIR/FIELD/STEM.flo [default: v_R].
    #[arg(long, value_name = "FIELDS", num_args = 0..=1, require_equals = true,
          default_missing_value = "v_R", value_parser = outputs::parse_field_list)]
    pub flo: Option<Fields>,
    /// N outputs for N frames: the last frame gets a copy of the last
    /// result, so every frame has one (label files stay aligned).
    #[arg(long)]
    pub keep_count: bool,
    /// Read at most N frames of each input (with --step or --fps: use at
    /// most N of the frames they pick).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_frames: Option<u64>,
    /// Which frames make pairs, and their size.
    #[command(flatten)]
    pub frames: FrameArgs,
}

/// `--step`, `--fps`, `--resize`, `--short-side`: which frames make pairs
/// and at what size (shared by `run` and `dataset`).
#[derive(Debug, Default, clap::Args)]
#[command(next_help_heading = "Frames (applied before the pairs are formed)")]
pub struct FrameArgs {
    /// Resize every frame to WxH before its pairs: area averaging down,
    /// bilinear up (integers only, the same bytes on every machine;
    /// docs/resample.md).
    #[arg(long, value_name = "WxH", value_parser = sampled::parse_resize, conflicts_with = "short_side")]
    pub resize: Option<FrameSize>,
    /// Resize every frame so its shorter side is N (even), the longer one
    /// keeping the aspect, rounded to the nearest even size (1920x1080 at
    /// 224: 398x224); the resampler of --resize.
    #[arg(long, value_name = "N", value_parser = sampled::parse_short_side)]
    pub short_side: Option<FrameSize>,
    /// Use frames 0, K, 2K, ... only: pairs (0, K), (K, 2K), ...; each
    /// result is named PREV_NEXT after the stems of both its frames.
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u64).range(1..), conflicts_with = "fps")]
    pub step: Option<u64>,
    /// Use F frames per second of the input's own rate (Y4M header, or
    /// ffmpeg's for other video; an error for inputs without one, such as
    /// frame folders): frame floor(k * rate / F) for k = 0, 1, ...; every
    /// frame when F is at or above the rate. F: a decimal or a ratio
    /// (10, 29.97, 30000/1001). Results are named PREV_NEXT as with --step.
    #[arg(long, value_name = "F", value_parser = sampled::parse_rate)]
    pub fps: Option<Rate>,
}

impl FrameArgs {
    /// The plan these flags make.
    pub fn plan(&self) -> FramePlan {
        FramePlan::new(self.step, self.fps, self.resize.or(self.short_side))
    }
}

fn parse_positive(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err("expected a positive number of pixels (e.g. 2.5)".to_owned()),
    }
}

impl OutputArgs {
    /// The output spec.
    pub fn spec(&self) -> OutputSpec {
        OutputSpec {
            variant: self.variant,
            rep: !self.no_rep,
            viz: self.viz,
            npy: self.npy.clone().map(|f| f.0).unwrap_or_default(),
            flo: self.flo.clone().map(|f| f.0).unwrap_or_default(),
            hsv_max: self.hsv_max,
            npy_dtype: self.npy_dtype.unwrap_or_default(),
            image_format: match self.image_format {
                None | Some(ImageFormatName::Png) => ImageFormat::Png {
                    compression: self.png_compression.unwrap_or_default(),
                },
                Some(ImageFormatName::Jpg) => ImageFormat::Jpeg {
                    quality: self.jpeg_quality.unwrap_or(DEFAULT_JPEG_QUALITY),
                    subsampling: self.jpeg_subsampling.unwrap_or_default(),
                },
            },
        }
    }

    /// What `dataset` makes of each item with these flags and `engine`'s,
    /// its frames read within `limits`, stopped by Ctrl-C.
    pub fn item_settings(&self, engine: &EngineArgs, limits: Limits) -> ItemSettings {
        let spec = self.spec();
        ItemSettings {
            settings: Settings {
                variant: spec.variant,
                hsv_max: spec.hsv_max,
                ..engine.settings()
            },
            spec,
            keep_count: self.keep_count,
            max_frames: self.max_frames,
            plan: self.frames.plan(),
            limits,
            stop: interrupt_token(),
        }
    }

    /// Pipeline options on `engine`'s threads, stopped by Ctrl-C.
    pub fn options(&self, engine: &EngineArgs) -> Options {
        // The options do not read input: no limits apply.
        self.item_settings(engine, Limits::default())
            .options(engine.threads())
    }

    /// The checks of the file-type flags beyond clap's (a bad command
    /// line, exit status 2): `to_stdout` for `--out -`.
    pub fn check_types(&self, to_stdout: bool) -> Result<(), HostError> {
        if to_stdout
            && let Some(flag) = [
                (self.image_format.is_some(), "--image-format"),
                (self.npy_dtype.is_some(), "--npy-dtype"),
            ]
            .iter()
            .find_map(|(given, flag)| given.then_some(*flag))
        {
            return Err(HostError::invalid(
                flag,
                "applies to files in an output folder; --out - streams raw frames",
            ));
        }
        let jpeg = self.image_format == Some(ImageFormatName::Jpg);
        for (given, flag) in [
            (self.jpeg_quality.is_some(), "--jpeg-quality"),
            (self.jpeg_subsampling.is_some(), "--jpeg-subsampling"),
        ] {
            if given && !jpeg {
                return Err(HostError::invalid(
                    flag,
                    "applies to --image-format jpg only",
                ));
            }
        }
        if self.png_compression.is_some() && (jpeg || to_stdout) {
            return Err(HostError::invalid(
                "--png-compression",
                "applies to PNG files only (--image-format png, the default)",
            ));
        }
        Ok(())
    }
}

/// Arguments of `reynoldsflow run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// A video (Y4M, or anything ffmpeg decodes: MP4, AVI, MKV, ...), a
    /// folder or quoted glob of PNG/JPEG/PGM frames, or - for stdin (Y4M,
    /// or raw frames with --raw). None: the built-in demo sequence.
    #[arg(value_name = "INPUT")]
    pub input: Option<PathBuf>,
    /// Output folder (created if missing), or - for a stream on stdout.
    #[arg(long, short, value_name = "DIR|-", default_value = "reynoldsflow-out")]
    pub out: PathBuf,
    /// Stream format of --out - [default: rgb24]: raw RGB8 frames back to
    /// back (e.g. ffmpeg -f rawvideo -pix_fmt rgb24 -s WxH -i -, or NumPy),
    /// or Y4M C444 for any Y4M reader or encoder.
    #[arg(long, value_parser = choice::<StreamFormat>())]
    pub format: Option<StreamFormat>,
    /// How INPUT is read.
    #[command(flatten)]
    pub raw: RawInputArgs,
    /// The computation.
    #[command(flatten)]
    pub engine: EngineArgs,
    /// The outputs.
    #[command(flatten)]
    pub output: OutputArgs,
    /// Input limits.
    #[command(flatten)]
    pub limits: super::limits::LimitArgs,
}

/// `--raw` (shared by `run` and `verify`, which must read INPUT the same way).
#[derive(Debug, clap::Args)]
pub struct RawInputArgs {
    /// INPUT holds raw 8-bit gray frames of this size, back to back.
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub raw: Option<(usize, usize)>,
}

impl RawInputArgs {
    /// What INPUT names: `None` is the built-in demo, `-` standard input.
    pub fn input_spec(&self, input: Option<&Path>) -> Result<InputSpec, HostError> {
        Ok(match input {
            None => {
                if self.raw.is_some() {
                    return Err(HostError::invalid(
                        "--raw",
                        "needs INPUT (a file, or - for stdin)",
                    ));
                }
                InputSpec::Demo
            }
            Some(p) if p.as_os_str() == "-" => InputSpec::Stdin { raw: self.raw },
            Some(p) => InputSpec::Path {
                path: p.to_owned(),
                raw: self.raw,
            },
        })
    }
}

fn parse_size(s: &str) -> Result<(usize, usize), String> {
    settings::parse_tile(s)
        .map(|t| (t.width, t.height))
        .map_err(|_| "expected WxH with both sides at least 1 (e.g. 640x480)".to_owned())
}

/// The command's stop token: set by Ctrl-C (and SIGTERM) once
/// [`install_interrupt_handler`] has run, and given to every operation
/// the command starts.
pub fn interrupt_token() -> Stop {
    static STOP: LazyLock<Stop> = LazyLock::new(Stop::new);
    STOP.clone()
}

/// Stop cleanly on Ctrl-C (and SIGTERM): [`interrupt_token`] is set, so
/// pairs in flight finish and no new one starts; a second Ctrl-C ends the
/// process at once.
pub fn install_interrupt_handler() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let stop = interrupt_token();
        // Without a handler the default (immediate exit) stays: still no partial file
        // under a final name, only hidden temps that the next run removes.
        let _ = ctrlc::set_handler(move || {
            if stop.stop() {
                std::process::exit(130);
            }
        });
    });
}

/// `n` with its unit, singular or plural.
pub fn count(n: usize, unit: &str) -> String {
    format!("{n} {unit}{}", if n == 1 { "" } else { "s" })
}

/// Run the subcommand.
pub fn run(args: &RunArgs) -> Result<(), HostError> {
    let limits = args.limits.limits();
    let compute = args.engine.compute.compute()?;
    let spec = args.output.spec();
    let to_stdout = args.out.as_os_str() == "-";
    if !spec.writes_anything() {
        return Err(HostError::invalid(
            "--no-rep",
            "nothing left to write; add --viz, --npy or --flo",
        ));
    }
    if to_stdout && !spec.images_only() {
        return Err(HostError::invalid(
            "--out -",
            "a stream carries the --variant images only; --viz, --npy, --flo and --no-rep need an output folder",
        ));
    }
    if to_stdout && std::io::IsTerminal::is_terminal(&io::stdout()) {
        return Err(HostError::invalid(
            "--out -",
            "stdout is a terminal; pipe the stream into a program (e.g. | ffmpeg -i - out.mp4) or give an output folder",
        ));
    }
    if args.format.is_some() && !to_stdout {
        return Err(HostError::invalid(
            "--format",
            "applies to --out - (a stream on stdout) only",
        ));
    }
    let input = args.raw.input_spec(args.input.as_deref())?;
    install_interrupt_handler();
    let started = Instant::now();
    let name = sequence::display_name(&input);
    let mut source =
        args.output
            .frames
            .plan()
            .wrap(sequence::open(&input, limits)?, &name, limits)?;
    let options = args.output.options(&args.engine);
    let progress = Progress::new(progress_total(&*source, &options), "results");
    let mut tick = || progress.inc();

    let (summary, place) = if to_stdout {
        let mut writer = stream_writer();
        let dest = Destination::Stream {
            spec: &spec,
            format: args.format.unwrap_or_default(),
            writer: &mut *writer,
        };
        let summary = pipeline::process(&mut *source, &compute, dest, options, &mut tick);
        (summary, "stdout".to_owned())
    } else {
        let dir = DirWriter::prepare(&args.out, &spec)?.in_background(outputs::WRITER_THREADS)?;
        let summary = pipeline::process(
            &mut *source,
            &compute,
            Destination::Dir(&dir),
            options,
            &mut tick,
        );
        (summary, format!("{}/", args.out.display()))
    };
    progress.finish();
    let summary = summary?;
    report(
        &summary,
        &name,
        &place,
        &compute,
        &spec,
        started.elapsed().as_secs_f64(),
    )?;
    if input == InputSpec::Demo {
        eprintln!(
            "reynoldsflow: that was the built-in demo; on your footage: reynoldsflow run VIDEO|FRAME_FOLDER --out DIR (see reynoldsflow run --help)"
        );
    }
    Ok(())
}

/// How many results a run of `source` delivers, when the source knows its
/// length and a progress bar is shown (for the bar only).
pub(super) fn progress_total(source: &dyn FrameSource, options: &Options) -> Option<u64> {
    Progress::enabled()
        .then(|| source.frame_count_hint())
        .flatten()
        .map(|n| {
            let n = options.max_frames.map_or(n, |m| n.min(m));
            (n + usize::from(options.keep_count)).saturating_sub(1) as u64
        })
}

/// Standard output for the stream: its file descriptor written directly
/// where it can be duplicated. `io::Stdout` is line-buffered, so each
/// frame went out as two writes, split at its last `\n` byte, after a
/// search of the whole frame for it.
fn stream_writer() -> Box<dyn Write + Send> {
    use std::os::fd::AsFd;
    match io::stdout().as_fd().try_clone_to_owned() {
        Ok(fd) => Box::new(io::BufWriter::new(std::fs::File::from(fd))),
        Err(_) => Box::new(io::BufWriter::new(io::stdout())),
    }
}

fn report(
    summary: &Summary,
    name: &str,
    place: &str,
    compute: &Compute,
    spec: &OutputSpec,
    seconds: f64,
) -> Result<(), HostError> {
    if summary.stream_closed {
        eprintln!(
            "reynoldsflow: the reader of stdout closed it after {}; stopped",
            count(summary.outputs, "output")
        );
        return Ok(());
    }
    if summary.frames == 0 {
        return Err(sequence::input_error(name, "no frames"));
    }
    let size = summary
        .size
        .map_or(String::new(), |(w, h)| format!(" of {w}x{h}"));
    let engine = compute.engine().name();
    if summary.results == 0 {
        eprintln!(
            "reynoldsflow: {name}: 1 frame{size}, so no result (a result needs a pair of frames); nothing written"
        );
        return Ok(());
    }
    let repeated = if summary.outputs > summary.results {
        " (last repeated for --keep-count)"
    } else {
        ""
    };
    eprintln!(
        "reynoldsflow: {} from {}{size} of {name} -> {place}{repeated} in {seconds:.2} s ({:.1} pairs/s; {engine} engine, variant {})",
        count(summary.outputs, "output"),
        count(summary.frames, "frame"),
        summary.results as f64 / seconds.max(1e-9),
        spec.variant.name()
    );
    Ok(())
}
