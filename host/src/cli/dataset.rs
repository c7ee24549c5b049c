//! `reynoldsflow dataset SRC DST`: every video and frame folder under SRC
//! to a folder of outputs under DST, same relative paths and stems, on all
//! cores, resumable.
//!
//! - A video `SRC/a/b/clip.mp4` (or `.y4m`, `.avi`, …) → `DST/a/b/clip/`,
//!   outputs named by frame index (`000000.png`, …).
//! - A frame folder `SRC/a/seq1/` (any folder directly holding PNG/JPEG/PGM
//!   files) → `DST/a/seq1/`, outputs named by the frames' stems.
//!
//! **Resume.** An item is finished when its output folder holds the marker
//! `.reynoldsflow-done`, written (atomically) after the item's last output.
//! It records the options; a rerun skips items whose marker matches the
//! current options and redoes the rest (`--force` redoes everything).
//! Every output file is written under a hidden temp name and renamed, so
//! no file under a final name is ever partial; the temp files a killed run
//! leaves are removed when its item is redone.
//!
//! **Failures.** A file that cannot be read or decoded is reported and
//! skipped; the other items go on. The summary lists each failure with its
//! reason, and the exit status is 1 if any item failed (0 otherwise).

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use super::progress::Progress;
use super::run::{EngineArgs, OutputArgs, count, install_interrupt_handler};
use crate::outputs::{DirWriter, OutputSpec};
use crate::pipeline::{self, Compute, Destination, Options, Summary};
use crate::sequence::folder::{FolderSource, is_frame_file};
use crate::sequence::{self, FrameSource, InputSpec, input_error};
use crate::{HostError, atomic};

/// Examples shown by `reynoldsflow dataset --help`.
pub const EXAMPLES: &str = "\
Examples:
  reynoldsflow dataset videos/ reps/
      videos/a/clip.mp4 -> reps/a/clip/000000.png ...; videos/b/seq1/*.png -> reps/b/seq1/*.png
  reynoldsflow dataset UCF101/ UCF101-reynolds/ --keep-count --threads 8
      one representation per frame, 8 cores; rerun the same command to resume
  reynoldsflow dataset clips/ fields/ --no-rep --npy=v_R --flo
      fields only: fields/<clip>/v_R/<stem>.npy and .flo

Videos (mp4, avi, mkv, mov, webm, y4m, ...) become DST/<path>/<video stem>/000000.png, ...;
folders holding PNG/JPEG/PGM frames become DST/<path>/ with the frames' stems.
Resume: an item is finished when DST/<item>/.reynoldsflow-done exists (written last, with
the options); a rerun skips finished items made with the same options and redoes the rest.
Files are written under hidden temp names and renamed, so none is ever partial.
A bad file is reported and skipped; the exit status is 1 if any item failed.";

/// The completion marker in each finished item's output folder.
pub const MARKER: &str = ".reynoldsflow-done";

/// File extensions taken as videos (decoded natively for `.y4m`, by ffmpeg
/// otherwise), compared case-insensitively.
pub const VIDEO_EXTENSIONS: [&str; 18] = [
    "y4m", "mp4", "m4v", "mov", "avi", "mkv", "webm", "mpg", "mpeg", "mpe", "ts", "mts", "m2ts",
    "wmv", "flv", "ogv", "3gp", "gif",
];

/// Arguments of `reynoldsflow dataset`.
#[derive(Debug, clap::Args)]
pub struct DatasetArgs {
    /// Source: a folder tree of videos and frame folders (or one video).
    #[arg(value_name = "SRC")]
    pub src: PathBuf,
    /// Destination folder (created if missing), mirroring SRC.
    #[arg(value_name = "DST")]
    pub dst: PathBuf,
    /// Redo items that are already finished.
    #[arg(long)]
    pub force: bool,
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

/// One video or frame folder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Item {
    /// The video file or frame folder.
    pub src: PathBuf,
    /// Output folder relative to DST.
    pub rel: PathBuf,
    /// A frame folder (else a video).
    pub frames: bool,
}

fn is_video(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| VIDEO_EXTENSIONS.iter().any(|v| e.eq_ignore_ascii_case(v)))
}

/// Every item under `src`, sorted by output path; `skip` (the destination,
/// when it lies inside the source) is not searched.
pub fn discover(src: &Path, skip: Option<&Path>) -> Result<Vec<Item>, HostError> {
    let meta = fs::metadata(src).map_err(|e| HostError::io(src, e))?;
    let mut items = Vec::new();
    if meta.is_file() {
        let stem = src.file_stem().unwrap_or(src.as_os_str());
        items.push(Item {
            src: src.to_owned(),
            rel: PathBuf::from(stem),
            frames: false,
        });
        return Ok(items);
    }
    walk(src, Path::new(""), skip, &mut items)?;
    items.sort_by(|a, b| a.rel.cmp(&b.rel));
    Ok(items)
}

fn walk(
    dir: &Path,
    rel: &Path,
    skip: Option<&Path>,
    items: &mut Vec<Item>,
) -> Result<(), HostError> {
    if skip.is_some_and(|s| fs::canonicalize(dir).is_ok_and(|d| d == s)) {
        return Ok(());
    }
    let mut has_frames = false;
    let mut entries: Vec<_> = fs::read_dir(dir)
        .map_err(|e| HostError::io(dir, e))?
        .filter_map(Result::ok)
        .collect();
    entries.sort_by_key(|e| e.file_name());
    for entry in entries {
        let name = entry.file_name();
        if name.to_string_lossy().starts_with('.') {
            continue;
        }
        let path = entry.path();
        let Ok(kind) = entry.file_type() else {
            continue;
        };
        if kind.is_dir() {
            walk(&path, &rel.join(&name), skip, items)?;
        } else if path.is_file() {
            if is_frame_file(&path) {
                has_frames = true;
            } else if is_video(&path) {
                let stem = path.file_stem().unwrap_or(&name);
                items.push(Item {
                    src: path.clone(),
                    rel: rel.join(stem),
                    frames: false,
                });
            }
        }
    }
    if has_frames {
        items.push(Item {
            src: dir.to_owned(),
            rel: rel.to_owned(),
            frames: true,
        });
    }
    Ok(())
}

/// How an item ended.
enum Outcome {
    Done(Summary),
    Skipped,
    Failed(String),
    /// Stopped by Ctrl-C before it was finished.
    Interrupted,
}

/// The marker's text: what was made, and with which options.
fn marker_text(item: &Item, summary: &Summary, options: &str) -> String {
    format!(
        "reynoldsflow dataset item\nsource: {}\nframes: {}\nresults: {}\noutputs: {}\noptions: {options}\n",
        item.src.display(),
        summary.frames,
        summary.results,
        summary.outputs
    )
}

/// The options line of a marker, when the item is finished.
fn finished_with(out: &Path) -> Option<String> {
    let text = fs::read_to_string(out.join(MARKER)).ok()?;
    text.lines()
        .find_map(|l| l.strip_prefix("options: "))
        .map(str::to_owned)
}

/// Settings shared by every item.
struct Shared<'a> {
    dst: &'a Path,
    compute: &'a Compute,
    spec: &'a OutputSpec,
    options: Options,
    fingerprint: String,
    force: bool,
}

fn process_item(item: &Item, shared: &Shared<'_>, on_output: &mut dyn FnMut()) -> Outcome {
    let out = shared.dst.join(&item.rel);
    if !shared.force && finished_with(&out).as_deref() == Some(shared.fingerprint.as_str()) {
        return Outcome::Skipped;
    }
    let result = (|| -> Result<Summary, HostError> {
        let marker = out.join(MARKER);
        if marker.exists() {
            fs::remove_file(&marker).map_err(|e| HostError::io(&marker, e))?;
        }
        let mut source: Box<dyn FrameSource> = if item.frames {
            Box::new(FolderSource::dir(&item.src)?)
        } else {
            sequence::open(&InputSpec::Path {
                path: item.src.clone(),
                raw: None,
            })?
        };
        let dir = DirWriter::prepare(&out, shared.spec)?;
        let summary = pipeline::process(
            &mut *source,
            shared.compute,
            Destination::Dir(&dir),
            shared.options,
            on_output,
        )?;
        if summary.frames == 0 {
            return Err(input_error(&item.src, "no frames"));
        }
        atomic::write_file(
            &marker,
            marker_text(item, &summary, &shared.fingerprint).as_bytes(),
        )?;
        Ok(summary)
    })();
    match result {
        Ok(summary) => Outcome::Done(summary),
        Err(_) if pipeline::INTERRUPTED.load(Ordering::SeqCst) => Outcome::Interrupted,
        Err(e) => Outcome::Failed(e.to_string()),
    }
}

/// `reynoldsflow: failed: <file>: <reason>`, naming the file once.
fn failure_line(item: &Item, why: &str) -> String {
    let src = item.src.display().to_string();
    if why.starts_with(&src) {
        format!("reynoldsflow: failed: {why}")
    } else {
        format!("reynoldsflow: failed: {src}: {why}")
    }
}

/// Run the subcommand.
pub fn run(args: &DatasetArgs) -> Result<(), HostError> {
    args.limits.apply();
    let compute = args.engine.compute.compute()?;
    let spec = args.output.spec();
    if !spec.writes_anything() {
        return Err(HostError::invalid(
            "--no-rep",
            "nothing left to write; add --viz, --npy or --flo",
        ));
    }
    if args.dst.exists() && !args.dst.is_dir() {
        return Err(input_error(
            &args.dst,
            "destination exists and is not a folder",
        ));
    }
    fs::create_dir_all(&args.dst).map_err(|e| {
        HostError::io(
            &args.dst,
            std::io::Error::new(e.kind(), format!("cannot create the destination: {e}")),
        )
    })?;
    let skip = fs::canonicalize(&args.dst).ok();
    let items = discover(&args.src, skip.as_deref())?;
    if items.is_empty() {
        return Err(input_error(
            &args.src,
            "no videos or frame folders found (videos by extension: mp4, avi, y4m, ...; frames: png, jpg, pgm, ...)",
        ));
    }
    install_interrupt_handler();
    let started = Instant::now();
    let threads = args.engine.threads();
    let workers = threads.min(items.len()).max(1);
    let shared = Shared {
        dst: &args.dst,
        compute: &compute,
        spec: &spec,
        options: args.output.options(threads.div_ceil(workers)),
        fingerprint: format!(
            "{} {:?} scale={:?} s={}/{} lambda={} keep_count={} max_frames={:?}",
            spec.describe(),
            compute.engine(),
            args.engine.compute.scale,
            args.engine.compute.intensity_scale.num(),
            args.engine.compute.intensity_scale.den(),
            args.engine.compute.lambda,
            args.output.keep_count,
            args.output.max_frames
        ),
        force: args.force,
    };

    // Two items writing one folder would mix their outputs: refuse the later one.
    let mut outcomes: Vec<Option<Outcome>> = Vec::new();
    for (i, item) in items.iter().enumerate() {
        let clash = items[..i].iter().find(|o| o.rel == item.rel);
        outcomes.push(clash.map(|o| {
            Outcome::Failed(format!(
                "its output folder {} is also the output of {}; rename one",
                args.dst.join(&item.rel).display(),
                o.src.display()
            ))
        }));
    }
    let todo: Vec<usize> = (0..items.len())
        .filter(|&i| outcomes[i].is_none())
        .collect();

    let progress = Progress::new(Some(items.len() as u64), "items");
    let frames_done = AtomicUsize::new(0);
    let next = AtomicUsize::new(0);
    let results = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                loop {
                    if pipeline::INTERRUPTED.load(Ordering::SeqCst) {
                        return;
                    }
                    let Some(&i) = todo.get(next.fetch_add(1, Ordering::SeqCst)) else {
                        return;
                    };
                    let mut tick = || {
                        let n = frames_done.fetch_add(1, Ordering::Relaxed) + 1;
                        let rate = n as f64 / started.elapsed().as_secs_f64().max(1e-9);
                        progress.message(format!("{n} results, {rate:.1}/s"));
                    };
                    let outcome = process_item(&items[i], &shared, &mut tick);
                    if let Outcome::Failed(why) = &outcome
                        && Progress::enabled()
                    {
                        progress.println(&failure_line(&items[i], why));
                    }
                    progress.inc();
                    results
                        .lock()
                        .expect("no panics holding it")
                        .push((i, outcome));
                }
            });
        }
    });
    progress.finish();
    for (i, outcome) in results.into_inner().expect("workers are done") {
        outcomes[i] = Some(outcome);
    }

    let seconds = started.elapsed().as_secs_f64();
    let (mut done, mut skipped, mut frames, mut outputs) = (0, 0, 0, 0);
    let mut failures = Vec::new();
    let mut not_started = 0;
    for (item, outcome) in items.iter().zip(&outcomes) {
        match outcome {
            Some(Outcome::Done(s)) => {
                done += 1;
                frames += s.frames;
                outputs += s.outputs;
            }
            Some(Outcome::Skipped) => skipped += 1,
            Some(Outcome::Failed(why)) => failures.push((item, why)),
            Some(Outcome::Interrupted) | None => not_started += 1,
        }
    }
    eprintln!(
        "reynoldsflow: dataset {} -> {}: {}: {done} done, {skipped} already finished (skipped), {} failed{}; {} and {} in {seconds:.2} s ({:.1} frames/s)",
        args.src.display(),
        args.dst.display(),
        count(items.len(), "item"),
        failures.len(),
        if not_started > 0 {
            format!(", {not_started} unfinished (interrupted)")
        } else {
            String::new()
        },
        count(frames, "frame"),
        count(outputs, "output"),
        frames as f64 / seconds.max(1e-9)
    );
    for (item, why) in &failures {
        eprintln!("{}", failure_line(item, why));
    }
    if pipeline::INTERRUPTED.load(Ordering::SeqCst) {
        return Err(HostError::io(
            &args.dst,
            std::io::Error::new(
                std::io::ErrorKind::Interrupted,
                "interrupted; rerun the same command to finish the unfinished items",
            ),
        ));
    }
    if !failures.is_empty() {
        return Err(HostError::invalid(
            "dataset",
            format!(
                "{} of {} failed (listed above); the rest are done",
                failures.len(),
                count(items.len(), "item")
            ),
        ));
    }
    Ok(())
}
