//! Datasets: every video and frame folder under a source tree to a folder
//! of outputs under a destination, same relative paths and stems,
//! resumable (what `reynoldsflow dataset` and Python's `convert` and
//! `files_from` run).
//!
//! - A video `SRC/a/b/clip.mp4` (or `.y4m`, `.avi`, …) → `DST/a/b/clip/`,
//!   outputs named by frame index (`000000.png`, …).
//! - A frame folder `SRC/a/seq1/` (any folder directly holding PNG/JPEG/PGM
//!   files) → `DST/a/seq1/`, outputs named by the frames' stems.
//!
//! **Resume.** An item is finished when its output folder holds the marker
//! `.reynoldsflow-done`, written (atomically) after the item's last output.
//! It records the settings, the source's stamp (size and modification time) and every
//! output file with its size; a rerun skips items whose marker matches the
//! current settings and source and whose files are all there at those
//! sizes, and redoes the rest (`force` redoes everything). A redo first
//! removes the files the old marker lists and any file named as one of the
//! item's results (what a killed run leaves), so the folder holds exactly
//! what the new settings write. Every output file is written under a hidden
//! temp name and renamed, so no file under a final name is ever partial;
//! the temp files a killed run leaves are removed when its item is redone.
//!
//! **Paths.** Items that would share an output folder, or whose folder is
//! another item's side-output folder (`hsv/`, `v_R/`, …), are refused
//! before anything runs (by the front end, which sees every item). Several
//! processes share one destination through [`Shard`]s, never by running
//! the same job twice.
//!
//! **Clusters.** A [`Shard`] takes its share of the items by a hash of
//! their paths, so `N` processes share one dataset and one destination;
//! each item's [`Record`] is one JSON line of a [`StatusLog`].

use std::collections::HashSet;
use std::fs;
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::Instant;

use serde_json::json;

use crate::outputs::{DirWriter, ImageFormat, OutputSpec};
use crate::pipeline::{self, Compute, Destination, Options, Summary};
use crate::sequence::folder::{FolderSource, is_frame_file};
use crate::sequence::sampled::FramePlan;
use crate::sequence::{self, FrameSource, InputSpec, input_error};
use crate::settings::{Setting, Settings};
use crate::{HostError, atomic};

pub mod shard;
pub mod status;

pub use shard::Shard;
pub use status::{Record, Status, StatusLog};

/// What every item of a dataset is made with, as a front end sets it.
#[derive(Clone, Debug)]
pub struct ItemSettings {
    /// The computation (its variant and colour-wheel radius are `spec`'s).
    pub settings: Settings,
    /// What each result writes.
    pub spec: OutputSpec,
    /// N outputs for N frames (the last result repeated).
    pub keep_count: bool,
    /// Read at most this many frames of each item.
    pub max_frames: Option<u64>,
    /// Which frames make pairs, at what size.
    pub plan: FramePlan,
}

impl ItemSettings {
    /// The pipeline's options on `threads` workers.
    pub fn options(&self, threads: usize) -> Options {
        Options {
            threads,
            keep_count: self.keep_count,
            max_frames: self.max_frames.map(|n| n as usize),
            pair_names: self.plan.picks(),
            record_frames: false,
        }
    }

    /// The settings as WebDataset samples record them (`KEY.json`).
    pub fn describe(&self) -> serde_json::Value {
        let (c, spec) = (&self.settings, &self.spec);
        let names = |fields: &[crate::outputs::Field]| -> Vec<&str> {
            fields.iter().map(|f| f.name()).collect()
        };
        json!({
            "engine": c.engine.name(),
            "scale": c.scale.to_string(),
            "intensity_scale": format!("{}/{}", c.intensity_scale.num(), c.intensity_scale.den()),
            "lambda": c.lambda,
            "tile": c.tile.map(|t| format!("{}x{}", t.width, t.height)),
            "variant": spec.variant.name(),
            "rep": spec.rep,
            "viz": spec.viz,
            "hsv_max": spec.hsv_max,
            "npy": names(&spec.npy),
            "npy_dtype": spec.npy_dtype.name(),
            "flo": names(&spec.flo),
            "image_format": spec.image_format.extension(),
            "jpeg_quality": match spec.image_format {
                ImageFormat::Jpeg { quality, .. } => Some(quality),
                ImageFormat::Png { .. } => None,
            },
            "jpeg_subsampling": match spec.image_format {
                ImageFormat::Jpeg { subsampling, .. } => Some(subsampling.name()),
                ImageFormat::Png { .. } => None,
            },
            "png_compression": match spec.image_format {
                ImageFormat::Png { compression } => Some(compression.name()),
                ImageFormat::Jpeg { .. } => None,
            },
            "keep_count": self.keep_count,
            "max_frames": self.max_frames,
            "frames": self.plan.describe(),
        })
    }
}

/// The completion marker in each finished item's output folder.
pub const MARKER: &str = ".reynoldsflow-done";

/// File extensions taken as videos (decoded natively for `.y4m`, by ffmpeg
/// otherwise), compared case-insensitively.
pub const VIDEO_EXTENSIONS: [&str; 18] = [
    "y4m", "mp4", "m4v", "mov", "avi", "mkv", "webm", "mpg", "mpeg", "mpe", "ts", "mts", "m2ts",
    "wmv", "flv", "ogv", "3gp", "gif",
];

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
        return Err(HostError::setting(
            Setting::FilesFrom,
            format!(
                "lists paths relative to the source, which must then be a folder: {} is not",
                src.display()
            ),
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
pub enum Outcome {
    /// Computed and marked finished.
    Done(Summary),
    /// Already finished with the same settings.
    Skipped,
    /// Refused or failed: why.
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
    /// The checked computation.
    pub compute: Compute,
    /// What each result writes.
    pub spec: OutputSpec,
    /// How the pipeline runs each item.
    pub options: Options,
    /// Which frames make pairs, at what size.
    pub plan: FramePlan,
    fingerprint: String,
    /// The settings as WebDataset samples record them.
    pub settings: serde_json::Value,
    /// Redo finished items.
    pub force: bool,
}

impl ItemRunner {
    /// Check the options; each item runs on `threads` workers.
    pub fn new(item: &ItemSettings, threads: usize, force: bool) -> Result<Self, HostError> {
        let compute = item.settings.compute()?;
        let spec = item.spec.clone();
        if !spec.writes_anything() {
            return Err(HostError::setting(
                Setting::Rep,
                "nothing left to write: no representation image, and no colour wheel, .npy or .flo asked for",
            ));
        }
        let plan = item.plan;
        let mut fingerprint = format!(
            "{} {:?} scale={:?} s={}/{} lambda={} keep_count={} max_frames={:?}",
            spec.describe(),
            compute.engine(),
            item.settings.scale,
            item.settings.intensity_scale.num(),
            item.settings.intensity_scale.den(),
            item.settings.lambda,
            item.keep_count,
            item.max_frames
        );
        // Only with --step, --fps, --resize or --short-side, so that
        // markers made before them still match.
        if !plan.is_identity() {
            fingerprint += &format!(" {}", plan.describe());
        }
        let mut options = item.options(threads);
        options.record_frames = plan.picks();
        let settings = item.describe();
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
    pub fn process(&self, item: &Item, out: &Path, on_output: &mut dyn FnMut()) -> Outcome {
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
pub fn record(item: &Item, out: &Path, outcome: &Outcome, seconds: f64) -> Record {
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
    settings: &ItemSettings,
    force: bool,
) -> Result<Record, HostError> {
    let runner = ItemRunner::new(settings, settings.settings.threads(), force)?;
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
