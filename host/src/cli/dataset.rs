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
//! It records the options, the source's stamp ([`source_stamp`]) and every
//! output file with its size; a rerun skips items whose marker matches the
//! current options and source and whose files are all there at those
//! sizes, and redoes the rest (`--force` redoes everything). A redo first
//! removes the files the old marker lists and any file named as one of the
//! item's results (what a killed run leaves), so the folder holds exactly
//! what the new settings write. Every output file is written under a hidden temp name
//! and renamed, so no file under a final name is ever partial; the temp
//! files a killed run leaves are removed when its item is redone.
//!
//! **Paths.** Items that would share an output folder, or whose folder is
//! another item's side-output folder (`hsv/`, `v_R/`, …), are refused
//! before anything runs. Several processes share one DST through
//! `--shard`, never by running the same command twice.
//!
//! **Failures.** A file that cannot be read or decoded is reported and
//! skipped; the other items go on. The summary lists each failure with its
//! reason, and the exit status is 1 if any item failed (0 otherwise).
//!
//! **Clusters.** `--shard I/N` takes the items of shard `I` ([`shard`]),
//! so `N` processes (a Slurm array, a Kubernetes Indexed Job) share one
//! dataset and one destination; `--files-from` takes the items from a
//! manifest; each item's [`Record`] goes to stdout or `--status FILE` as a
//! JSON line.

use std::collections::{HashMap, HashSet};
use std::fs;
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use super::progress::Progress;
use super::run::{EngineArgs, OutputArgs, count, install_interrupt_handler};
use super::shard::{self, Shard};
use super::status::{Record, Status, StatusLog};
use crate::outputs::{DirWriter, OutputSpec};
use crate::pipeline::{self, Compute, Destination, Options, Summary};
use crate::sequence::folder::{FolderSource, is_frame_file};
use crate::sequence::sampled::FramePlan;
use crate::sequence::{self, FrameSource, InputSpec, input_error};
use crate::{HostError, atomic, workers};

/// Examples shown by `reynoldsflow dataset --help`.
pub const EXAMPLES: &str = "\
Examples:
  reynoldsflow dataset videos/ reps/
      videos/a/clip.mp4 -> reps/a/clip/000000.png ...; videos/b/seq1/*.png -> reps/b/seq1/*.png
  reynoldsflow dataset UCF101/ UCF101-reynolds/ --keep-count --threads 8
      one representation per frame, 8 cores; rerun the same command to resume
  reynoldsflow dataset clips/ fields/ --no-rep --npy=v_R --flo
      fields only: fields/<clip>/v_R/<stem>.npy and .flo
  reynoldsflow dataset videos/ reps/ --shard 3/8 --status reps/status.jsonl
      the items of shard 3 of 8 (by a hash of each item's path); 8 such processes share one DST
  reynoldsflow dataset videos/ reps/ --files-from todo.txt
      only the videos and frame folders listed (one path relative to SRC per line)

Videos (mp4, avi, mkv, mov, webm, y4m, ...) become DST/<path>/<video stem>/000000.png, ...;
folders holding PNG/JPEG/PGM frames become DST/<path>/ with the frames' stems.
Resume: an item is finished when DST/<item>/.reynoldsflow-done (written last) records the same
options and source (size and modification time) and its files are all there at their sizes;
a rerun skips finished items and redoes the rest, removing the files of earlier settings first.
Files are written under hidden temp names and renamed, so none is ever partial.
Items sharing an output path (x/hsv.y4m beside x.y4m --viz) are refused. To run several
processes on one DST, give each its --shard I/N.
A bad file is reported and skipped; the exit status is 1 if any item failed.
One JSON line per item on stdout (or --status FILE): path, output, status, frames, outputs,
seconds, error. In a Slurm job array (--array=0-7) the shard comes from SLURM_ARRAY_TASK_*;
in a Kubernetes Indexed Job from JOB_COMPLETION_INDEX with --shards N.";

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
    /// Take only the items of shard I of N (0 <= I < N), chosen by a hash
    /// of each item's path relative to SRC [default: from a Slurm job
    /// array's or a Kubernetes Indexed Job's variables, else all items].
    #[arg(long, value_name = "I/N", value_parser = shard::parse_shard, conflicts_with = "shards", help_heading = "Clusters")]
    pub shard: Option<Shard>,
    /// The number of shards N, the index I coming from the scheduler
    /// (JOB_COMPLETION_INDEX of a Kubernetes Indexed Job, or SLURM_ARRAY_TASK_ID).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..), help_heading = "Clusters")]
    pub shards: Option<u64>,
    /// Take the items from LIST (- for stdin): one video or frame folder
    /// per line, relative to SRC; empty lines and lines starting with #
    /// are ignored.
    #[arg(long, value_name = "LIST", help_heading = "Clusters")]
    pub files_from: Option<PathBuf>,
    /// Append the JSON-lines status records to FILE instead of stdout.
    #[arg(long, value_name = "FILE", help_heading = "Clusters")]
    pub status: Option<PathBuf>,
    /// Write WebDataset shards instead of folders: DST/shard-NNNNNN.tar
    /// (shard-IIII-NNNNNN.tar with --shard I/N), one sample per result:
    /// KEY.rep.png (or .jpg), KEY.FIELD.npy / .flo as asked, and
    /// KEY.json (source path, source frames, motion score, settings); KEY
    /// is ITEM/STEM (the item's output path, the result's stem). Items
    /// run one after another, each on every thread; a rerun skips the
    /// items already in complete shards.
    #[arg(long, help_heading = "WebDataset")]
    pub webdataset: bool,
    /// Close a shard once it holds BYTES or more, between items (an item's
    /// samples are never split across shards): an integer with an optional
    /// suffix k, M, G (powers of 1000) or Ki, Mi, Gi (powers of 1024)
    /// [default: 1G].
    #[arg(long, value_name = "BYTES", value_parser = super::webdataset::parse_bytes,
          requires = "webdataset", help_heading = "WebDataset")]
    pub shard_size: Option<u64>,
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
    let listing = match fs::read_dir(dir) {
        Ok(listing) => listing,
        Err(e) if rel.as_os_str().is_empty() => return Err(HostError::io(dir, e)),
        // A sub-folder that cannot be listed is an item that fails when it
        // is opened (with this error), not the end of the whole job.
        Err(_) => {
            items.push(Item {
                src: dir.to_owned(),
                rel: rel.to_owned(),
                frames: true,
            });
            return Ok(());
        }
    };
    let mut entries: Vec<_> = listing.filter_map(Result::ok).collect();
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

/// The items listed in `list` (`-`: stdin), one path relative to `src` per
/// line (or absolute, inside `src`); blank lines and lines starting with
/// `#` are skipped. See [`listed`].
pub fn manifest(src: &Path, list: &Path) -> Result<Vec<Item>, HostError> {
    let text = if list.as_os_str() == "-" {
        std::io::read_to_string(std::io::stdin()).map_err(|e| HostError::io("stdin", e))?
    } else {
        fs::read_to_string(list).map_err(|e| HostError::io(list, e))?
    };
    let lines = text
        .lines()
        .map(|line| line.trim_end_matches('\r'))
        .enumerate()
        .filter(|(_, line)| !line.trim().is_empty() && !line.starts_with('#'))
        .map(|(n, line)| (format!("line {}", n + 1), Path::new(line)));
    listed(src, list, lines)
}

/// The items of `paths` (each with the label its problems name, and
/// relative to `src` or absolute inside it), sorted by output path like
/// [`discover`]'s; `origin` is where the list came from. A folder is a
/// frame folder, anything else a video; a path that does not exist becomes
/// an item that fails when it is opened.
pub fn listed<'a>(
    src: &Path,
    origin: &Path,
    paths: impl IntoIterator<Item = (String, &'a Path)>,
) -> Result<Vec<Item>, HostError> {
    if !src.is_dir() {
        return Err(input_error(
            src,
            "--files-from lists paths relative to SRC, so SRC must be a folder",
        ));
    }
    let mut items = Vec::new();
    for (label, path) in paths {
        let problem =
            |problem: &str| input_error(origin, format!("{label}: {}: {problem}", path.display()));
        let rel = if path.is_absolute() {
            path.strip_prefix(src)
                .map_err(|_| problem("not inside SRC"))?
        } else {
            path
        };
        let rel: PathBuf = rel
            .components()
            .filter(|c| !matches!(c, std::path::Component::CurDir))
            .collect();
        if rel.as_os_str().is_empty()
            || rel
                .components()
                .any(|c| !matches!(c, std::path::Component::Normal(_)))
        {
            return Err(problem("expected a path inside SRC (no '..')"));
        }
        let full = src.join(&rel);
        let frames = full.is_dir();
        let out = if frames {
            rel.clone()
        } else {
            let stem = rel.file_stem().unwrap_or(rel.as_os_str());
            rel.parent().unwrap_or(Path::new("")).join(stem)
        };
        items.push(Item {
            src: full,
            rel: out,
            frames,
        });
    }
    items.sort_by(|a, b| a.rel.cmp(&b.rel).then_with(|| a.src.cmp(&b.src)));
    items.dedup();
    Ok(items)
}

/// The key an item is sharded by: its source path relative to `src`, with
/// `/` separators (the file name when SRC is the item itself).
pub fn shard_key(src: &Path, item: &Item) -> String {
    let rel = item
        .src
        .strip_prefix(src)
        .ok()
        .filter(|r| !r.as_os_str().is_empty())
        .or_else(|| item.src.file_name().map(Path::new))
        .unwrap_or(&item.src);
    rel.components()
        .map(|c| c.as_os_str().to_string_lossy())
        .collect::<Vec<_>>()
        .join("/")
}

/// How an item ended.
pub(super) enum Outcome {
    Done(Summary),
    Skipped,
    Failed(String),
    /// Stopped by Ctrl-C before it was finished.
    Interrupted,
}

/// The marker's text: what was made, from which source (its stamp, see
/// [`source_stamp`]), with which options (and, when `--step` or `--fps`
/// picked them, the input frames used), and every file with its size.
fn marker_text(
    item: &Item,
    summary: &Summary,
    options: &str,
    stamp: &str,
    files: &[(PathBuf, u64)],
) -> String {
    let mut text = format!(
        "reynoldsflow dataset item\nsource: {}\nsource_stamp: {stamp}\nframes: {}\nresults: {}\noutputs: {}\noptions: {options}\n",
        item.src.display(),
        summary.frames,
        summary.results,
        summary.outputs
    );
    if let Some(used) = &summary.source_frames {
        let list: Vec<String> = used.iter().map(usize::to_string).collect();
        text += &format!("source_frames: {}\n", list.join(" "));
    }
    for (path, size) in files {
        text += &format!("file: {size} {}\n", path.display());
    }
    text
}

/// A finished item's marker: its source stamp, options line, frames and
/// outputs, and its files with their sizes.
struct Marker {
    stamp: Option<String>,
    options: String,
    frames: Option<usize>,
    outputs: Option<usize>,
    source_frames: Option<Vec<usize>>,
    files: Vec<(u64, PathBuf)>,
}

impl Marker {
    /// Whether every file the marker lists is in `out` at its size.
    fn intact(&self, out: &Path) -> bool {
        self.files.iter().all(|(size, rel)| {
            fs::metadata(out.join(rel)).is_ok_and(|m| m.is_file() && m.len() == *size)
        })
    }
}

fn finished(out: &Path) -> Option<Marker> {
    let text = fs::read_to_string(out.join(MARKER)).ok()?;
    let field = |name: &str| text.lines().find_map(|l| l.strip_prefix(name));
    Some(Marker {
        stamp: field("source_stamp: ").map(str::to_owned),
        options: field("options: ")?.to_owned(),
        frames: field("frames: ").and_then(|v| v.parse().ok()),
        outputs: field("outputs: ").and_then(|v| v.parse().ok()),
        source_frames: field("source_frames: ").map(|v| {
            v.split_whitespace()
                .filter_map(|n| n.parse().ok())
                .collect()
        }),
        files: text
            .lines()
            .filter_map(|l| l.strip_prefix("file: ")?.split_once(' '))
            .filter_map(|(size, path)| Some((size.parse().ok()?, PathBuf::from(path))))
            .collect(),
    })
}

/// What an item's outputs were made from: a video's size and modification
/// time (nanoseconds since 1970); a frame folder's number of frame files,
/// their bytes, and a digest (FNV-1a) of each one's name, size and
/// modification time. A rerun redoes an item whose stamp differs.
fn source_stamp(item: &Item) -> Result<String, HostError> {
    let stat = |path: &Path| -> Result<(u64, u128), HostError> {
        let meta = fs::metadata(path).map_err(|e| HostError::io(path, e))?;
        let mtime = meta
            .modified()
            .ok()
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map_or(0, |d| d.as_nanos());
        Ok((meta.len(), mtime))
    };
    if !item.frames {
        let (size, mtime) = stat(&item.src)?;
        return Ok(format!("size={size} mtime_ns={mtime}"));
    }
    let fnv = |hash: u64, bytes: &[u8]| {
        bytes.iter().fold(hash, |h, &b| {
            (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
        })
    };
    let files = crate::sequence::folder::list(&item.src, |name| is_frame_file(Path::new(name)))?;
    let (mut bytes, mut digest) = (0, 0xcbf2_9ce4_8422_2325);
    for file in &files {
        let (size, mtime) = stat(file)?;
        let name = file.file_name().unwrap_or_default().as_encoded_bytes();
        digest = fnv(
            fnv(fnv(digest, name), &size.to_le_bytes()),
            &mtime.to_le_bytes(),
        );
        bytes += size;
    }
    Ok(format!(
        "frames={} bytes={bytes} digest={digest:016x}",
        files.len()
    ))
}

/// The sub-folders of an item's folder its side outputs go to, under any
/// settings, with the extensions of their files; `""`: the folder itself.
const OUTPUT_FOLDERS: [(&str, [&str; 2]); 5] = [
    ("", ["png", "jpg"]),
    ("hsv", ["png", "jpg"]),
    ("v_c", ["npy", "flo"]),
    ("v_d", ["npy", "flo"]),
    ("v_R", ["npy", "flo"]),
];

/// Whether `stem` names a result of `item` under some settings: a frame's
/// stem (a video's frames are numbered, `000000`, …; a frame folder's are
/// its files' stems) or two of them joined by `_` (`--step`, `--fps`).
fn result_stems(item: &Item) -> impl Fn(&str) -> bool + use<> {
    let frames: Option<HashSet<String>> = item.frames.then(|| {
        crate::sequence::folder::list(&item.src, |name| is_frame_file(Path::new(name)))
            .unwrap_or_default()
            .iter()
            .filter_map(|f| Some(f.file_stem()?.to_str()?.to_owned()))
            .collect()
    });
    let frame = move |s: &str| match &frames {
        Some(stems) => stems.contains(s),
        None => s.len() >= 6 && s.bytes().all(|b| b.is_ascii_digit()),
    };
    move |stem: &str| {
        frame(stem)
            || stem
                .match_indices('_')
                .any(|(i, _)| frame(&stem[..i]) && frame(&stem[i + 1..]))
    }
}

/// Remove what earlier runs made in `out`: the files `old`'s marker lists,
/// and every file named as one of `item`'s results (in the folder, as an
/// image; in `hsv/`, `v_c/`, `v_d/`, `v_R/`, as their files), which a run
/// killed before its marker leaves; then the marker, then those
/// sub-folders left empty. Nothing else (a folder of an item inside, or
/// files of other names) is touched. Files first: a kill in between leaves
/// a marker whose files are missing, which is redone.
fn remove_earlier_outputs(out: &Path, old: Option<&Marker>, item: &Item) -> Result<(), HostError> {
    for (_, rel) in old.iter().flat_map(|m| &m.files) {
        // Only paths inside the folder, as this tool writes them.
        if rel.components().next().is_some()
            && rel.components().all(|c| matches!(c, Component::Normal(_)))
        {
            remove_if_present(&out.join(rel))?;
        }
    }
    let is_result = result_stems(item);
    for (sub, extensions) in OUTPUT_FOLDERS {
        let dir = out.join(sub);
        let Ok(entries) = fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let name = entry.file_name();
            let Some((stem, ext)) = name.to_str().and_then(|n| n.rsplit_once('.')) else {
                continue;
            };
            if extensions.contains(&ext)
                && is_result(stem)
                && entry.file_type().is_ok_and(|t| t.is_file())
            {
                remove_if_present(&entry.path())?;
            }
        }
    }
    remove_if_present(&out.join(MARKER))?;
    for (sub, _) in &OUTPUT_FOLDERS[1..] {
        // Fails, as it should, unless the folder is empty.
        let _ = fs::remove_dir(out.join(sub));
    }
    Ok(())
}

/// Remove the file `path`; one already gone is fine.
fn remove_if_present(path: &Path) -> Result<(), HostError> {
    match fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(HostError::io(path, e)),
        _ => Ok(()),
    }
}

/// An item's frames, as `dataset` reads them (a frame folder, or a video),
/// through `plan`.
pub fn open_item(
    src: &Path,
    frames: bool,
    plan: &FramePlan,
) -> Result<Box<dyn FrameSource>, HostError> {
    let source: Box<dyn FrameSource> = if frames {
        Box::new(FolderSource::dir(src)?)
    } else {
        sequence::open(&InputSpec::Path {
            path: src.to_owned(),
            raw: None,
        })?
    };
    plan.wrap(source, &src.display().to_string())
}

/// What every item is made with: checked once, shared by the workers.
pub struct ItemRunner {
    pub(super) compute: Compute,
    pub(super) spec: OutputSpec,
    pub(super) options: Options,
    pub(super) plan: FramePlan,
    fingerprint: String,
    /// The settings as WebDataset samples record them.
    pub(super) settings: serde_json::Value,
    pub(super) force: bool,
}

impl ItemRunner {
    /// Check the options; each item runs on `threads` workers.
    pub fn new(
        engine: &EngineArgs,
        output: &OutputArgs,
        threads: usize,
        force: bool,
    ) -> Result<Self, HostError> {
        let compute = engine.compute.compute()?;
        let spec = output.spec();
        if !spec.writes_anything() {
            return Err(HostError::invalid(
                "--no-rep",
                "nothing left to write; add --viz, --npy or --flo",
            ));
        }
        let plan = output.frames.plan();
        let mut fingerprint = format!(
            "{} {:?} scale={:?} s={}/{} lambda={} keep_count={} max_frames={:?}",
            spec.describe(),
            compute.engine(),
            engine.compute.scale,
            engine.compute.intensity_scale.num(),
            engine.compute.intensity_scale.den(),
            engine.compute.lambda,
            output.keep_count,
            output.max_frames
        );
        // Only with --step, --fps, --resize or --short-side, so that
        // markers made before them still match.
        if !plan.is_identity() {
            fingerprint += &format!(" {}", plan.describe());
        }
        let mut options = output.options(threads);
        options.record_frames = plan.picks();
        let settings = super::webdataset::settings(engine, &spec, output, &plan);
        Ok(Self {
            compute,
            spec,
            options,
            plan,
            fingerprint,
            settings,
            force,
        })
    }

    /// One item into the folder `out`: skipped when finished from the same
    /// source with these options and all its files there, else made anew
    /// (what earlier runs left removed first), then marked finished.
    fn process(&self, item: &Item, out: &Path, on_output: &mut dyn FnMut()) -> Outcome {
        // Taken before the source is read: a change while it is read is
        // seen by the next run.
        let stamp = source_stamp(item).ok();
        let old = finished(out);
        if !self.force
            && let (Some(marker), Some(stamp)) = (&old, &stamp)
            && marker.options == self.fingerprint
            && marker.stamp.as_ref() == Some(stamp)
            && marker.intact(out)
        {
            return Outcome::Skipped;
        }
        let result = (|| -> Result<Summary, HostError> {
            if out.is_dir() {
                remove_earlier_outputs(out, old.as_ref(), item)?;
            }
            let mut source = open_item(&item.src, item.frames, &self.plan)?;
            let dir = DirWriter::prepare(out, &self.spec)?
                .recording()
                .in_background(crate::outputs::WRITER_THREADS)?;
            let summary = pipeline::process(
                &mut *source,
                &self.compute,
                Destination::Dir(&dir),
                self.options,
                on_output,
            )?;
            if summary.frames == 0 {
                return Err(input_error(&item.src, "no frames"));
            }
            // A source whose stamp could not be taken is never skipped.
            let stamp = stamp.as_deref().unwrap_or("unknown");
            let text = marker_text(item, &summary, &self.fingerprint, stamp, &dir.written());
            atomic::write_file(&out.join(MARKER), text.as_bytes())?;
            Ok(summary)
        })();
        match result {
            Ok(summary) => Outcome::Done(summary),
            Err(_) if pipeline::INTERRUPTED.load(Ordering::SeqCst) => Outcome::Interrupted,
            Err(e) => Outcome::Failed(e.to_string()),
        }
    }
}

/// The status record of `item`, written to `out`.
pub(super) fn record(item: &Item, out: &Path, outcome: &Outcome, seconds: f64) -> Record {
    let mut r = Record {
        path: item.src.display().to_string(),
        output: out.display().to_string(),
        status: Status::Done,
        frames: None,
        outputs: None,
        seconds,
        error: None,
        source_frames: None,
    };
    match outcome {
        Outcome::Done(s) => {
            (r.frames, r.outputs) = (Some(s.frames), Some(s.outputs));
            r.source_frames = s.source_frames.clone();
        }
        Outcome::Skipped => {
            r.status = Status::Skipped;
            if let Some(m) = finished(out) {
                (r.frames, r.outputs) = (m.frames, m.outputs);
                r.source_frames = m.source_frames;
            }
        }
        Outcome::Failed(why) => (r.status, r.error) = (Status::Failed, Some(why.clone())),
        Outcome::Interrupted => r.status = Status::Interrupted,
    }
    r
}

/// One video or frame folder `src` into the folder `out`, exactly as
/// `dataset` makes each item (same files, same marker: resumable, and
/// skipped when finished with the same options). Bad options are an
/// error; a bad input is a record with status `failed`.
pub fn convert(
    src: &Path,
    out: &Path,
    engine: &EngineArgs,
    output: &OutputArgs,
    force: bool,
) -> Result<Record, HostError> {
    let runner = ItemRunner::new(engine, output, engine.threads(), force)?;
    let item = Item {
        src: src.to_owned(),
        rel: PathBuf::new(),
        frames: src.is_dir(),
    };
    let started = Instant::now();
    let outcome = runner.process(&item, out, &mut || {});
    Ok(record(
        &item,
        out,
        &outcome,
        started.elapsed().as_secs_f64(),
    ))
}

/// `reynoldsflow: failed: <file>: <reason>`, naming the file once.
pub(super) fn failure_line(item: &Item, why: &str) -> String {
    let src = item.src.display().to_string();
    if why.starts_with(&src) {
        format!("reynoldsflow: failed: {why}")
    } else {
        format!("reynoldsflow: failed: {src}: {why}")
    }
}

/// The checks of the flags beyond clap's (a bad command line, exit status 2).
pub fn check(args: &DatasetArgs) -> Result<(), HostError> {
    args.output.check_types(false)
}

/// `--shard`, else the scheduler's, else every item.
fn which_shard(args: &DatasetArgs) -> Result<Shard, HostError> {
    if let Some(shard) = args.shard {
        return Ok(shard);
    }
    match Shard::from_scheduler(|name| std::env::var(name).ok(), args.shards)? {
        Some((shard, from)) => {
            eprintln!(
                "reynoldsflow: shard {}/{} from {from} (--shard 0/1 takes every item)",
                shard.index, shard.count
            );
            Ok(shard)
        }
        None => Ok(Shard::ALL),
    }
}

/// Run the subcommand: check, find the items, run them, report.
pub fn run(args: &DatasetArgs) -> Result<(), HostError> {
    args.limits.apply();
    let shard = which_shard(args)?;
    let threads = args.engine.threads();
    // Checked before anything is created; the workers' share is set below.
    let checked = ItemRunner::new(&args.engine, &args.output, threads, args.force)?;
    // The sub-folders each item's side outputs go to (WebDataset: none).
    let sides = if args.webdataset {
        Vec::new()
    } else {
        checked.spec.subdirs()
    };
    let log = prepare_destination(args)?;
    let all = find_items(args)?;
    let (items, mut outcomes) = shard_items(args, shard, &all, &sides);
    for (item, outcome) in items.iter().zip(&outcomes) {
        if let Some(outcome) = outcome {
            log.write(&record(item, &args.dst.join(&item.rel), outcome, 0.0))?;
        }
    }
    let todo: Vec<usize> = (0..items.len())
        .filter(|&i| outcomes[i].is_none())
        .collect();

    install_interrupt_handler();
    let started = Instant::now();
    let (results, log_error) = if args.webdataset {
        // One item at a time, on every thread: samples go into shards in order.
        let runner = ItemRunner::new(&args.engine, &args.output, threads, args.force)?;
        let shards = super::webdataset::Shards {
            args,
            shard,
            runner: &runner,
            log: &log,
            items: &items,
            started,
        };
        shards.run(&todo)?
    } else {
        let workers = threads.min(todo.len()).max(1);
        let runner = ItemRunner::new(
            &args.engine,
            &args.output,
            threads.div_ceil(workers),
            args.force,
        )?;
        let run = ItemsRun {
            args,
            runner: &runner,
            log: &log,
            items: &items,
            started,
        };
        run.on_workers(&todo, workers)
    };
    for (i, outcome) in results {
        outcomes[i] = Some(outcome);
    }
    let failures = report(args, shard, all.len(), &items, &outcomes, started);
    if pipeline::INTERRUPTED.load(Ordering::SeqCst) {
        return Err(HostError::io(
            &args.dst,
            std::io::Error::new(
                std::io::ErrorKind::Interrupted,
                "interrupted; rerun the same command to finish the unfinished items",
            ),
        ));
    }
    if let Some(e) = log_error {
        return Err(e);
    }
    if failures > 0 {
        return Err(HostError::invalid(
            "dataset",
            format!(
                "{failures} of {} failed (listed above); the rest are done",
                count(items.len(), "item")
            ),
        ));
    }
    Ok(())
}

/// The destination folder, created, and the status log opened.
fn prepare_destination(args: &DatasetArgs) -> Result<StatusLog, HostError> {
    if args.dst.exists() && !args.dst.is_dir() {
        return Err(input_error(
            &args.dst,
            "destination exists and is not a folder",
        ));
    }
    let log = StatusLog::open(args.status.as_deref())?;
    fs::create_dir_all(&args.dst).map_err(|e| {
        HostError::io(
            &args.dst,
            std::io::Error::new(e.kind(), format!("cannot create the destination: {e}")),
        )
    })?;
    Ok(log)
}

/// Every item of the dataset (the manifest's, or those found under SRC);
/// none is an error.
fn find_items(args: &DatasetArgs) -> Result<Vec<Item>, HostError> {
    let skip = fs::canonicalize(&args.dst).ok();
    let all = match &args.files_from {
        Some(list) => manifest(&args.src, list)?,
        None => discover(&args.src, skip.as_deref())?,
    };
    if all.is_empty() {
        return Err(input_error(
            args.files_from.as_deref().unwrap_or(&args.src),
            "no videos or frame folders found (videos by extension: mp4, avi, y4m, ...; frames: png, jpg, pgm, ...)",
        ));
    }
    Ok(all)
}

/// The items of `shard`, each with its outcome already decided (`Some`:
/// it clashes with another item) or still to run (`None`); `sides`: the
/// sub-folders of an item's folder its side outputs go to.
fn shard_items(
    args: &DatasetArgs,
    shard: Shard,
    all: &[Item],
    sides: &[&str],
) -> (Vec<Item>, Vec<Option<Outcome>>) {
    // Two items writing one folder would mix their outputs: refuse the later
    // one, judged on every item so that all shards agree. So would an item
    // whose folder is another's side-output folder (`x/hsv.y4m` beside
    // `x.y4m --viz`): refuse the one inside.
    let by_folder: HashMap<&Path, &Item> = all.iter().rev().map(|o| (o.rel.as_path(), o)).collect();
    let mut items = Vec::new();
    let mut outcomes: Vec<Option<Outcome>> = Vec::new();
    for (i, item) in all.iter().enumerate() {
        if !shard.contains(&shard_key(&args.src, item)) {
            continue;
        }
        let folder = args.dst.join(&item.rel).display().to_string();
        let clash = all[..i].iter().find(|o| o.rel == item.rel).map(|o| {
            format!(
                "its output folder {folder} is also the output of {}; rename one",
                o.src.display()
            )
        });
        let side = || {
            let (parent, name) = (item.rel.parent()?, item.rel.file_name()?.to_str()?);
            let side = sides.iter().find(|s| **s == name)?;
            let owner = by_folder.get(parent)?;
            let what = if *side == "hsv" {
                "--viz images".to_owned()
            } else {
                format!("{side} fields (--npy, --flo)")
            };
            Some(format!(
                "its output folder {folder} is where {}'s {what} go; rename one",
                owner.src.display()
            ))
        };
        outcomes.push(clash.or_else(side).map(Outcome::Failed));
        items.push(item.clone());
    }
    (items, outcomes)
}

/// What the workers of one `dataset` run share.
struct ItemsRun<'a> {
    args: &'a DatasetArgs,
    runner: &'a ItemRunner,
    log: &'a StatusLog,
    items: &'a [Item],
    started: Instant,
}

impl ItemsRun<'_> {
    /// The items `todo` (indices into `items`) on `workers` threads, taken
    /// in order until none is left or the run is interrupted: every
    /// outcome, and the first status-log error.
    fn on_workers(
        &self,
        todo: &[usize],
        workers: usize,
    ) -> (Vec<(usize, Outcome)>, Option<HostError>) {
        let progress = Progress::new(Some(self.items.len() as u64), "items");
        let frames_done = AtomicUsize::new(0);
        let log_error = Mutex::new(None);
        let outcomes = workers::map_indices(
            workers,
            todo.len(),
            || (),
            |(), k| {
                let interrupted = pipeline::INTERRUPTED.load(Ordering::SeqCst);
                (!interrupted).then(|| {
                    (
                        todo[k],
                        self.one(todo[k], &progress, &frames_done, &log_error),
                    )
                })
            },
        );
        progress.finish();
        (
            outcomes.into_iter().flatten().collect(),
            log_error.into_inner().expect("workers are done"),
        )
    }

    /// Item `i`: run, logged, shown.
    fn one(
        &self,
        i: usize,
        progress: &Progress,
        frames_done: &AtomicUsize,
        log_error: &Mutex<Option<HostError>>,
    ) -> Outcome {
        let mut tick = || {
            let n = frames_done.fetch_add(1, Ordering::Relaxed) + 1;
            let rate = n as f64 / self.started.elapsed().as_secs_f64().max(1e-9);
            progress.message(format!("{n} results, {rate:.1}/s"));
        };
        let item = &self.items[i];
        let item_started = Instant::now();
        let out = self.args.dst.join(&item.rel);
        let outcome = self.runner.process(item, &out, &mut tick);
        let seconds = item_started.elapsed().as_secs_f64();
        if let Err(e) = self.log.write(&record(item, &out, &outcome, seconds)) {
            log_error
                .lock()
                .expect("no panics holding it")
                .get_or_insert(e);
        }
        if let Outcome::Failed(why) = &outcome
            && Progress::enabled()
        {
            progress.println(&failure_line(item, why));
        }
        progress.inc();
        outcome
    }
}

/// The closing summary line and one line per failure, on stderr; returns
/// the number of failures.
fn report(
    args: &DatasetArgs,
    shard: Shard,
    found: usize,
    items: &[Item],
    outcomes: &[Option<Outcome>],
    started: Instant,
) -> usize {
    let seconds = started.elapsed().as_secs_f64();
    let (mut done, mut skipped, mut frames, mut outputs) = (0, 0, 0, 0);
    let mut failures = Vec::new();
    let mut not_started = 0;
    for (item, outcome) in items.iter().zip(outcomes) {
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
    let share = if shard == Shard::ALL {
        String::new()
    } else {
        format!(
            " (shard {}/{} of {})",
            shard.index,
            shard.count,
            count(found, "item")
        )
    };
    eprintln!(
        "reynoldsflow: dataset {} -> {}{share}: {}: {done} done, {skipped} already finished (skipped), {} failed{}; {} and {} in {seconds:.2} s ({:.1} frames/s)",
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
    failures.len()
}
