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
//! **Resume.** An item is finished when its output folder holds the
//! manifest `.reynoldsflow-done`, written last and atomically ([`commit`]):
//! it records the settings, the source's identity by content (a hash of the
//! video file, or of every frame file and its name) and every output with
//! its size and hash. A rerun skips an item only when the manifest is whole
//! and all three match; anything else (a changed or replaced source, new
//! settings, an output missing, cut or edited, a manifest cut or altered)
//! redoes it (`force` redoes everything). A redo writes into a staging
//! folder and commits: the folder then holds exactly what the new settings
//! write, and the clean-up removes only the files the old manifest lists.
//!
//! **Paths.** Items that would share an output folder, or whose folder lies
//! in another item's side-output folder (`hsv/`, `v_c/`, `v_d/`, `v_R/`,
//! whatever the flags), are refused before anything runs
//! (by the front end, which sees every item: the CLI's `dataset`). Several
//! processes share one destination through [`Shard`]s, never by running
//! the same job twice.
//!
//! **Clusters.** A [`Shard`] takes its share of the items by a hash of
//! their paths, so `N` processes share one dataset and one destination;
//! each item's [`Record`] is one JSON line of a [`StatusLog`].

use std::collections::HashMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::json;

use crate::HostError;
use crate::engine::Compute;
use crate::limits::Limits;
use crate::outputs::{DirWriter, ImageFormat, OutputSpec};
use crate::pipeline::{self, Destination, Options, Summary};
use crate::sequence::folder::{FolderSource, is_frame_file};
use crate::sequence::sampled::FramePlan;
use crate::sequence::{self, FrameSource, InputSpec, input_error};
use crate::settings::{Setting, Settings};
use crate::stop::Stop;

pub mod commit;
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
    /// What each item's frames may be.
    pub limits: Limits,
    /// Set to stop: the item in work ends [`Outcome::Interrupted`].
    pub stop: Stop,
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
            stop: self.stop.clone(),
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

/// The manifest in each finished item's output folder.
pub const MARKER: &str = commit::MANIFEST;
use commit::MANIFEST;

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

/// Why each item of `all` may not run, or `None`: two items writing one
/// output folder would mix their outputs (the later is refused), and so
/// would an item whose folder lies in another's side-output folder
/// (`x/hsv.y4m` beside `x.y4m`, a frame folder `x/v_R/` in the frame folder
/// `x/`) when `sides` (folder mode: `hsv/`, `v_c/`, `v_d/`, `v_R/` are kept
/// for side outputs whatever the flags of this run or an earlier one; the
/// one inside is refused). Judged on every item, so that all shards agree;
/// `dst`: where the output folders go, for the messages.
pub fn clashes(all: &[Item], dst: &Path, sides: bool) -> Vec<Option<String>> {
    // The first item of each output folder.
    let mut first: HashMap<&Path, usize> = HashMap::with_capacity(all.len());
    for (i, item) in all.iter().enumerate() {
        first.entry(item.rel.as_path()).or_insert(i);
    }
    all.iter()
        .enumerate()
        .map(|(i, item)| {
            let folder = dst.join(&item.rel).display().to_string();
            let owner = first[item.rel.as_path()];
            if owner != i {
                return Some(format!(
                    "its output folder {folder} is also the output of {}; rename one",
                    all[owner].src.display()
                ));
            }
            let (owner, side) = side_folder_owner(&item.rel, &first).filter(|_| sides)?;
            Some(format!(
                "its output folder {folder} lies in {side}/, where {}'s {side} outputs go \
                 (hsv/, v_c/, v_d/ and v_R/ are kept for side outputs, whatever the flags); rename one",
                all[owner].src.display()
            ))
        })
        .collect()
}

/// The item of `first` (output folders to items' indices) whose
/// side-output folder holds the output folder `rel`, with that folder's
/// name.
fn side_folder_owner(rel: &Path, first: &HashMap<&Path, usize>) -> Option<(usize, &'static str)> {
    let mut child = rel;
    while let Some(parent) = child.parent() {
        if let Some(&owner) = first.get(parent) {
            let name = child.file_name().and_then(|n| n.to_str());
            if let Some(side) = commit::SIDE_FOLDERS.iter().find(|s| Some(**s) == name) {
                return Some((owner, side));
            }
        }
        child = parent;
    }
    None
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
    /// Not begun: the run was stopped by Ctrl-C before it came to this item.
    NotStarted,
}

/// An item's frames, as `dataset` reads them (a frame folder, or a video),
/// through `plan`, within `limits`.
pub fn open_item(
    src: &Path,
    frames: bool,
    plan: &FramePlan,
    limits: Limits,
) -> Result<Box<dyn FrameSource>, HostError> {
    let source: Box<dyn FrameSource> = if frames {
        Box::new(FolderSource::dir(src, limits)?)
    } else {
        sequence::open(
            &InputSpec::Path {
                path: src.to_owned(),
                raw: None,
            },
            limits,
        )?
    };
    plan.wrap(source, &src.display().to_string(), limits)
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
    /// What each item's frames may be.
    pub limits: Limits,
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
            limits: item.limits,
            fingerprint,
            settings,
            force,
        })
    }

    /// One item into the folder `out`: skipped when its manifest is whole
    /// and records this source (by content), these settings and every
    /// output as it is; else made anew in a staging folder and committed
    /// ([`commit`]), replacing exactly the files the old manifest lists.
    pub fn process(&self, item: &Item, out: &Path, on_output: &mut dyn FnMut()) -> Outcome {
        let result = (|| -> Result<Option<Summary>, HostError> {
            // Hashed before the source is read: a change while it is read is
            // seen by the next run.
            let source_hash = commit::source_hash(item)?;
            let old = commit::read(&out.join(MANIFEST));
            let journal = commit::read(&out.join(commit::JOURNAL));
            if !self.force
                && !out.join(commit::JOURNAL).exists()
                && let Some(manifest) = &old.whole
                && manifest.field("settings").as_str() == Some(self.fingerprint.as_str())
                && manifest.field("source_hash").as_str() == Some(source_hash.as_str())
                && manifest.intact(out)
            {
                commit::remove_staging(out)?;
                return Ok(None);
            }
            // The new settings meet the source before anything is removed.
            let mut source = open_item(&item.src, item.frames, &self.plan, self.limits)?;
            if out.is_dir() {
                commit::remove_staging(out)?;
                // Temp files of single writes an earlier run was killed in.
                for sub in std::iter::once("").chain(commit::SIDE_FOLDERS) {
                    crate::outputs::clean_stale_temps(&out.join(sub))?;
                }
            }
            let staging = out.join(commit::STAGING);
            let made = (|| {
                let dir = DirWriter::prepare(&staging, &self.spec)?
                    .recording()
                    .in_background(crate::outputs::WRITER_THREADS)?;
                let summary = pipeline::process(
                    &mut *source,
                    &self.compute,
                    Destination::Dir(&dir),
                    self.options.clone(),
                    on_output,
                )?;
                dir.flush()?;
                if summary.frames == 0 {
                    return Err(input_error(&item.src, "no frames"));
                }
                Ok((summary, dir.written()))
            })();
            let (summary, written) = match made {
                Ok(made) => made,
                Err(e) => {
                    // Best effort: the error that matters is `e`.
                    let _ = commit::remove_staging(out);
                    return Err(e);
                }
            };
            let mut header = json!({
                "reynoldsflow_dataset_item": 2,
                "source": item.src.display().to_string(),
                "source_hash": source_hash,
                "settings": self.fingerprint,
                "frames": summary.frames,
                "results": summary.results,
                "outputs": summary.outputs,
            });
            if let Some(used) = &summary.source_frames {
                header["source_frames"] = json!(used);
            }
            let files = written
                .into_iter()
                .map(|w| commit::Output {
                    path: w.path,
                    size: w.size,
                    hash: w.hash,
                })
                .collect();
            let mut previous = old.listed;
            previous.extend(journal.listed);
            commit::commit(out, &commit::Manifest { header, files }, &previous)?;
            Ok(Some(summary))
        })();
        match result {
            Ok(Some(summary)) => Outcome::Done(summary),
            Ok(None) => Outcome::Skipped,
            Err(_) if self.options.stop.is_stopped() => Outcome::Interrupted,
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
            if let Some(m) = commit::read(&out.join(MANIFEST)).whole {
                let count = |name| m.field(name).as_u64().map(|n| n as usize);
                (r.frames, r.outputs) = (count("frames"), count("outputs"));
                r.source_frames = m.field("source_frames").as_array().map(|v| {
                    v.iter()
                        .filter_map(|n| n.as_u64().map(|n| n as usize))
                        .collect()
                });
            }
        }
        Outcome::Failed(why) => (r.status, r.error) = (Status::Failed, Some(why.clone())),
        Outcome::Interrupted => r.status = Status::Interrupted,
        Outcome::NotStarted => r.status = Status::NotStarted,
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

#[cfg(test)]
mod tests {
    use super::*;

    fn item(src: &str, rel: &str, frames: bool) -> Item {
        Item {
            src: PathBuf::from(src),
            rel: PathBuf::from(rel),
            frames,
        }
    }

    #[test]
    fn clashes_refuse_a_shared_folder_and_a_folder_in_a_side_folder() {
        let all = [
            item("s/x.y4m", "x", false),
            item("s/x/hsv.y4m", "x/hsv", false),
            item("s/f", "f", true),
            item("s/f/v_R", "f/v_R", true),
            item("s/f/keep.y4m", "f/keep", false),
            item("s/x.mp4", "x", false),
        ];
        let found = clashes(&all, Path::new("d"), true);
        let refused: Vec<usize> = (0..all.len()).filter(|&i| found[i].is_some()).collect();
        assert_eq!(refused, [1, 3, 5], "{found:?}");
        assert!(
            found[1]
                .as_deref()
                .unwrap()
                .contains("lies in hsv/, where s/x.y4m's")
        );
        assert!(
            found[5]
                .as_deref()
                .unwrap()
                .contains("also the output of s/x.y4m")
        );
        // WebDataset writes no side folders: only the shared folder clashes.
        let found = clashes(&all, Path::new("d"), false);
        let refused: Vec<usize> = (0..all.len()).filter(|&i| found[i].is_some()).collect();
        assert_eq!(refused, [5], "{found:?}");
    }
}
