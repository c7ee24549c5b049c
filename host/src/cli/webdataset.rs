//! `dataset SRC DST --webdataset`: the items' results as WebDataset
//! samples in tar shards ([`crate::outputs::shards`]) instead of folders.
//!
//! A sample's key is `<item path>/<result stem>` (the item's output path
//! relative to DST, `/`-separated, and the stem `dataset` names its files
//! by, with any `.` in the stem made `_`, since WebDataset splits a member
//! name at its first dot); its members are the files `dataset` writes for
//! that result, renamed `KEY.rep.png` (or `.jpg`), `KEY.hsv.png`,
//! `KEY.v_c.npy`, `KEY.v_R.flo`, …, byte for byte the same, and
//! `KEY.json`: `key`, `source` (the item's path relative to SRC, as
//! `--shard` hashes it), `source_frames` (the input indices of its two
//! frames), `motion` (the mean `|v_R|`, as the Python `motion_score`) and
//! `settings` (every option that shapes the bytes).
//!
//! Items run one after another, in their order, each on every thread, so
//! the shards' contents depend on the items and options alone. An item is
//! finished when its samples are in a complete shard with the same
//! settings; a rerun skips those. A shard holding items of this run made
//! with other settings stops the run (use another DST, or `--force`, which
//! removes this shard's tars first).

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::Path;
use std::sync::atomic::Ordering;
use std::time::Instant;

use serde_json::{Value, json};

use super::dataset::{DatasetArgs, Item, ItemRunner, Outcome, failure_line, record, shard_key};
use super::progress::Progress;
use super::run::{EngineArgs, OutputArgs};
use super::shard::Shard;
use super::status::StatusLog;
use super::values::ScaleArg;
use crate::HostError;
use crate::outputs::shards::{self, ShardNames, ShardWriter};
use crate::outputs::{ImageFormat, OutputSpec};
use crate::pipeline::{self, Destination, Sample, SampleSink, Summary};
use crate::sequence::input_error;
use crate::sequence::sampled::FramePlan;

/// `--shard-size` when not given: 1 GB.
pub const DEFAULT_SHARD_SIZE: u64 = 1_000_000_000;

/// Parse `--shard-size`: bytes, with an optional suffix k, M, G (powers of
/// 1000) or Ki, Mi, Gi (powers of 1024); at least 1.
pub fn parse_bytes(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let split = t.find(|c: char| !c.is_ascii_digit()).unwrap_or(t.len());
    let (digits, suffix) = t.split_at(split);
    let unit: u64 = match suffix.trim() {
        "" => 1,
        "k" | "K" | "kB" | "KB" => 1_000,
        "M" | "MB" => 1_000_000,
        "G" | "GB" => 1_000_000_000,
        "Ki" | "KiB" => 1 << 10,
        "Mi" | "MiB" => 1 << 20,
        "Gi" | "GiB" => 1 << 30,
        _ => 0,
    };
    match digits.parse::<u64>().ok().and_then(|n| n.checked_mul(unit)) {
        Some(n) if n >= 1 => Ok(n),
        _ => Err(
            "expected a number of bytes, at least 1, with an optional suffix k, M, G or Ki, Mi, Gi (e.g. 500M)"
                .to_owned(),
        ),
    }
}

/// The options that shape a sample's bytes, as its `KEY.json` records them.
pub fn settings(
    engine: &EngineArgs,
    spec: &OutputSpec,
    output: &OutputArgs,
    plan: &FramePlan,
) -> Value {
    let c = &engine.compute;
    let scale = match c.scale {
        ScaleArg::MinMax => "minmax".to_owned(),
        ScaleArg::Fixed { k_d, k_c } => format!("fixed:{k_d},{k_c}"),
    };
    let names = |fields: &[crate::outputs::Field]| -> Vec<&str> {
        fields.iter().map(|f| f.name()).collect()
    };
    json!({
        "engine": c.engine.name(),
        "scale": scale,
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
        "keep_count": output.keep_count,
        "max_frames": output.max_frames,
        "frames": plan.describe(),
    })
}

/// A sample's member name: `[DIR/]STEM.EXT` of a result's files as
/// `KEY.rep.EXT` (top level) or `KEY.DIR.EXT`.
fn member_name(key: &str, stem: &str, path: &Path) -> String {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    let ext = name.strip_prefix(stem).unwrap_or(name);
    let kind = path
        .parent()
        .and_then(|p| p.to_str())
        .filter(|p| !p.is_empty())
        .unwrap_or("rep");
    format!("{key}.{kind}{ext}")
}

/// The key of the result `stem` of the item whose output path is `rel`.
fn sample_key(rel: &Path, stem: &str) -> String {
    let stem = stem.replace('.', "_");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    parts.push(stem);
    parts.join("/")
}

/// One item's samples into the open shard.
struct ItemSamples<'a> {
    writer: &'a mut ShardWriter,
    rel: &'a Path,
    source: String,
    settings: &'a Value,
}

impl SampleSink for ItemSamples<'_> {
    fn sample(
        &mut self,
        stem: &str,
        frames: (usize, usize),
        sample: &Sample,
    ) -> Result<(), HostError> {
        let key = sample_key(self.rel, stem);
        for (path, bytes) in &sample.files {
            self.writer.append(&member_name(&key, stem, path), bytes)?;
        }
        let meta = json!({
            "key": key,
            "source": self.source,
            "source_frames": [frames.0, frames.1],
            "motion": sample.motion,
            "settings": self.settings,
        });
        self.writer
            .append(&format!("{key}.json"), meta.to_string().as_bytes())
    }
}

/// What the complete shards in DST already hold of each item (by its
/// source key): the shard, samples and frames of the items made with the
/// current settings, and the items made with others.
#[derive(Default)]
struct Existing {
    done: BTreeMap<String, (String, usize, BTreeSet<usize>)>,
    other: BTreeMap<String, String>,
}

fn existing(dst: &Path, settings: &Value) -> Result<Existing, HostError> {
    let mut found = Existing::default();
    let mut names: Vec<String> = fs::read_dir(dst)
        .map_err(|e| HostError::io(dst, e))?
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| shards::is_shard_name(n))
        .collect();
    names.sort();
    for name in names {
        let path = dst.join(&name);
        for (member, bytes) in shards::json_members(&path)? {
            let meta: Value = serde_json::from_slice(&bytes)
                .map_err(|e| input_error(&path, format!("{member}: {e}")))?;
            let Some(source) = meta["source"].as_str() else {
                continue;
            };
            if &meta["settings"] == settings {
                let entry = found
                    .done
                    .entry(source.to_owned())
                    .or_insert_with(|| (name.clone(), 0, BTreeSet::new()));
                entry.1 += 1;
                for f in meta["source_frames"].as_array().into_iter().flatten() {
                    entry.2.extend(f.as_u64().map(|f| f as usize));
                }
            } else {
                found.other.insert(source.to_owned(), name.clone());
            }
        }
    }
    Ok(found)
}

/// A `--webdataset` run of one shard's items.
pub(super) struct Shards<'a> {
    pub(super) args: &'a DatasetArgs,
    pub(super) shard: Shard,
    pub(super) runner: &'a ItemRunner,
    pub(super) log: &'a StatusLog,
    pub(super) items: &'a [Item],
    pub(super) started: Instant,
}

impl Shards<'_> {
    /// The items `todo` (indices into `items`), in order, into this
    /// shard's tars: every outcome, and the first status-log error.
    #[allow(clippy::type_complexity)]
    pub(super) fn run(
        &self,
        todo: &[usize],
    ) -> Result<(Vec<(usize, Outcome)>, Option<HostError>), HostError> {
        let (args, runner) = (self.args, self.runner);
        let names = ShardNames::new(self.shard.index, self.shard.count);
        if runner.force {
            remove_shards(&args.dst, &names)?;
        }
        let mut writer = ShardWriter::new(
            &args.dst,
            names,
            args.shard_size.unwrap_or(DEFAULT_SHARD_SIZE),
        )?;
        let found = if runner.force {
            Existing::default()
        } else {
            existing(&args.dst, &runner.settings)?
        };
        let keys: Vec<String> = todo
            .iter()
            .map(|&i| shard_key(&args.src, &self.items[i]))
            .collect();
        if let Some((key, tar)) = keys
            .iter()
            .filter(|k| !found.done.contains_key(*k))
            .find_map(|k| found.other.get_key_value(k))
        {
            return Err(input_error(
                args.dst.join(tar),
                format!(
                    "holds samples of {key} made with other options; write into another DST, \
                     or pass --force to remove this shard's tars and redo its items"
                ),
            ));
        }
        let progress = Progress::new(Some(self.items.len() as u64), "items");
        let mut results = Vec::new();
        let mut log_error = None;
        let mut results_done = 0usize;
        for (&i, key) in todo.iter().zip(&keys) {
            if pipeline::INTERRUPTED.load(Ordering::SeqCst) {
                break;
            }
            let item = &self.items[i];
            let item_started = Instant::now();
            let (outcome, rec) = match found.done.get(key) {
                Some((tar, samples, frames)) => {
                    let mut r = record(item, &args.dst.join(tar), &Outcome::Skipped, 0.0);
                    (r.frames, r.outputs) = (Some(frames.len()), Some(*samples));
                    r.source_frames = runner
                        .plan
                        .picks()
                        .then(|| frames.iter().copied().collect());
                    (Outcome::Skipped, r)
                }
                None => {
                    let tar = args.dst.join(writer.current_name());
                    let mut tick = || {
                        results_done += 1;
                        let rate =
                            results_done as f64 / self.started.elapsed().as_secs_f64().max(1e-9);
                        progress.message(format!("{results_done} results, {rate:.1}/s"));
                    };
                    let outcome = self.one(item, key.clone(), &mut writer, &mut tick);
                    let seconds = item_started.elapsed().as_secs_f64();
                    let tar = match &outcome {
                        Outcome::Done(_) => tar,
                        _ => args.dst.clone(),
                    };
                    let r = record(item, &tar, &outcome, seconds);
                    (outcome, r)
                }
            };
            if let Err(e) = self.log.write(&rec) {
                log_error.get_or_insert(e);
            }
            if let Outcome::Failed(why) = &outcome
                && Progress::enabled()
            {
                progress.println(&failure_line(item, why));
            }
            progress.inc();
            results.push((i, outcome));
        }
        progress.finish();
        // The items before an interruption or an error are complete: keep them.
        writer.finish()?;
        Ok((results, log_error))
    }

    /// One item into the open shard: its samples, or none of them.
    fn one(
        &self,
        item: &Item,
        source: String,
        writer: &mut ShardWriter,
        on_output: &mut dyn FnMut(),
    ) -> Outcome {
        let runner = self.runner;
        writer.begin_item();
        let result = (|| -> Result<Summary, HostError> {
            let mut frames = super::dataset::open_item(&item.src, item.frames, &runner.plan)?;
            let mut sink = ItemSamples {
                writer: &mut *writer,
                rel: &item.rel,
                source,
                settings: &runner.settings,
            };
            let summary = pipeline::process(
                &mut *frames,
                &runner.compute,
                Destination::Samples {
                    spec: &runner.spec,
                    sink: &mut sink,
                },
                runner.options,
                on_output,
            )?;
            if summary.frames == 0 {
                return Err(input_error(&item.src, "no frames"));
            }
            Ok(summary)
        })();
        let ended = match result {
            Ok(summary) => writer.end_item().map(|_| summary),
            Err(e) => Err(writer.rollback().err().unwrap_or(e)),
        };
        match ended {
            Ok(summary) => Outcome::Done(summary),
            Err(_) if pipeline::INTERRUPTED.load(Ordering::SeqCst) => Outcome::Interrupted,
            Err(e) => Outcome::Failed(e.to_string()),
        }
    }
}

/// `--force`: this shard's complete tars go.
fn remove_shards(dst: &Path, names: &ShardNames) -> Result<(), HostError> {
    let Ok(entries) = fs::read_dir(dst) else {
        return Ok(());
    };
    for entry in entries.flatten() {
        if let Some(name) = entry.file_name().to_str()
            && names.seq_of(name).is_some()
        {
            fs::remove_file(entry.path()).map_err(|e| HostError::io(entry.path(), e))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    #[test]
    fn members_are_named_by_key_and_kind() {
        let key = sample_key(Path::new("a/b/clip"), "000003");
        assert_eq!(key, "a/b/clip/000003");
        assert_eq!(
            member_name(&key, "000003", Path::new("000003.png")),
            "a/b/clip/000003.rep.png"
        );
        assert_eq!(
            member_name(&key, "000003", &PathBuf::from("v_R").join("000003.npy")),
            "a/b/clip/000003.v_R.npy"
        );
        assert_eq!(
            member_name(&key, "000003", &PathBuf::from("hsv").join("000003.jpg")),
            "a/b/clip/000003.hsv.jpg"
        );
        let dotted = sample_key(Path::new("seq.v2"), "img.001");
        assert_eq!(dotted, "seq.v2/img_001");
        assert_eq!(
            member_name(&dotted, "img.001", Path::new("img.001.png")),
            "seq.v2/img_001.rep.png"
        );
        assert_eq!(sample_key(Path::new(""), "f1"), "f1");
    }

    #[test]
    fn shard_sizes_take_si_and_binary_suffixes() {
        assert_eq!(parse_bytes("1000"), Ok(1000));
        assert_eq!(parse_bytes("500M"), Ok(500_000_000));
        assert_eq!(parse_bytes("1G"), Ok(1_000_000_000));
        assert_eq!(parse_bytes("64Ki"), Ok(65_536));
        assert_eq!(parse_bytes("2 MiB"), Ok(2 << 20));
        for bad in ["0", "", "1.5G", "10X", "-1", "99999999999999999999G"] {
            assert!(parse_bytes(bad).is_err(), "{bad}");
        }
    }
}
