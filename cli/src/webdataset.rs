//! `dataset SRC DST --webdataset`: the items' results as WebDataset
//! samples in tar shards ([`crate::shards`]) instead of folders.
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
//! finished when its samples are in one complete shard, made with the same
//! settings from the same source (`source_hash`, as the folders' manifests
//! record it); a rerun skips those. Samples of an item that changed, or
//! that left SRC, are cut out of this process's shards first
//! ([`shards::rewrite_without`]); in another process's shards they stop
//! the run. Keys never repeat: an item whose results would share one fails.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fs;
use std::path::Path;
use std::time::Instant;

use serde_json::{Value, json};

use crate::shards::{self, ShardNames, ShardWriter};
use reynoldsflow_host::HostError;
use reynoldsflow_host::dataset::{
    Item, ItemRunner, Outcome, Shard, StatusLog, commit, record, shard_key,
};
use reynoldsflow_host::pipeline::{self, Destination, Sample, SampleSink, Summary};
use reynoldsflow_host::sequence::input_error;

use super::dataset::{DatasetArgs, failure_line};
use super::progress::Progress;

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
    src: &'a Path,
    source: String,
    source_hash: String,
    settings: &'a Value,
    /// The keys so far, with the stem each came from.
    keys: HashMap<String, String>,
}

impl SampleSink for ItemSamples<'_> {
    fn sample(
        &mut self,
        stem: &str,
        frames: (usize, usize),
        sample: &Sample,
    ) -> Result<(), HostError> {
        let key = sample_key(self.rel, stem);
        if let Some(first) = self.keys.insert(key.clone(), stem.to_owned()) {
            return Err(input_error(
                self.src,
                format!(
                    "the results {first} and {stem} would share the WebDataset key {key} \
                     (a '.' in a stem becomes '_'); rename one of their frames"
                ),
            ));
        }
        for (path, bytes) in &sample.files {
            self.writer.append(&member_name(&key, stem, path), bytes)?;
        }
        let meta = json!({
            "key": key,
            "source": self.source,
            "source_frames": [frames.0, frames.1],
            "source_hash": self.source_hash,
            "motion": sample.motion,
            "settings": self.settings,
        });
        self.writer
            .append(&format!("{key}.json"), meta.to_string().as_bytes())
    }
}

/// What one item's samples in the complete shards of DST say.
#[derive(Default)]
struct Held {
    /// The shards holding its samples.
    tars: BTreeSet<String>,
    /// Its samples, and the input frames they used.
    samples: usize,
    frames: BTreeSet<usize>,
    /// Each sample's settings and source hash, as found.
    made_with: BTreeSet<(String, String)>,
    /// Its keys.
    keys: BTreeSet<String>,
}

/// What the complete shards in DST hold of each item (by its source key);
/// `mine`: whether a shard name is this process's. A damaged shard of this
/// process (cut short, unreadable) is removed: its items are redone.
fn existing(dst: &Path, mine: &ShardNames) -> Result<BTreeMap<String, Held>, HostError> {
    let mut found: BTreeMap<String, Held> = BTreeMap::new();
    let mut names: Vec<String> = fs::read_dir(dst)
        .map_err(|e| HostError::io(dst, e))?
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| shards::is_shard_name(n))
        .collect();
    names.sort();
    for name in names {
        let path = dst.join(&name);
        let members = match shards::is_whole(&path) {
            true => shards::json_members(&path),
            false => Err(input_error(&path, "cut short")),
        };
        let members = match members {
            Ok(members) => members,
            Err(e) if mine.seq_of(&name).is_some() => {
                eprintln!("reynoldsflow: {e}: removed, its items are made again");
                fs::remove_file(&path).map_err(|e| HostError::io(&path, e))?;
                continue;
            }
            Err(e) => return Err(e),
        };
        for (member, bytes) in members {
            let meta: Value = serde_json::from_slice(&bytes)
                .map_err(|e| input_error(&path, format!("{member}: {e}")))?;
            let Some(source) = meta["source"].as_str() else {
                continue;
            };
            let held = found.entry(source.to_owned()).or_default();
            held.tars.insert(name.clone());
            held.samples += 1;
            for f in meta["source_frames"].as_array().into_iter().flatten() {
                held.frames.extend(f.as_u64().map(|f| f as usize));
            }
            held.made_with.insert((
                meta["settings"].to_string(),
                meta["source_hash"].as_str().unwrap_or("").to_owned(),
            ));
            held.keys.insert(shards::key_of(&member).to_owned());
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
        let found = existing(&args.dst, &names)?;
        let keys: Vec<String> = todo
            .iter()
            .map(|&i| shard_key(&args.src, &self.items[i]))
            .collect();
        // Each item's source by content, taken before it is read.
        let hashes: Vec<Result<String, HostError>> = todo
            .iter()
            .map(|&i| commit::source_hash(&self.items[i]))
            .collect();
        let settings = runner.settings.to_string();
        let current = |key: &str, hash: &Result<String, HostError>| -> bool {
            let (Some(held), Ok(hash)) = (found.get(key), hash) else {
                return false;
            };
            held.tars.len() == 1
                && held.made_with.len() == 1
                && held.made_with.contains(&(settings.clone(), hash.clone()))
        };
        // Samples that are not current (another source, other settings, an
        // item no longer in SRC) go from this process's shards; in another
        // process's, they stop the run.
        let position: HashMap<&str, usize> = keys
            .iter()
            .enumerate()
            .map(|(k, key)| (key.as_str(), k))
            .collect();
        let mut stale_keys: BTreeSet<String> = BTreeSet::new();
        for (source, held) in &found {
            let fresh = match position.get(source.as_str()) {
                Some(&k) => current(source, &hashes[k]),
                // Not an item of this run: kept unless SRC was searched and
                // it is gone from this process's share.
                None => args.files_from.is_some() || !self.shard.contains(source),
            };
            if fresh {
                continue;
            }
            if let Some(tar) = held.tars.iter().find(|t| names.seq_of(t).is_none()) {
                return Err(input_error(
                    args.dst.join(tar),
                    format!(
                        "holds samples of {source} made with other options or from another source; \
                         write into another DST, or rerun that shard's process first"
                    ),
                ));
            }
            stale_keys.extend(held.keys.iter().cloned());
        }
        if !stale_keys.is_empty() {
            let tars: BTreeSet<&String> = found
                .values()
                .filter(|h| h.keys.iter().any(|k| stale_keys.contains(k)))
                .flat_map(|h| &h.tars)
                .collect();
            for tar in tars {
                shards::rewrite_without(&args.dst.join(tar), |key| stale_keys.contains(key))?;
            }
        }
        let mut writer = ShardWriter::new(
            &args.dst,
            names,
            args.shard_size.unwrap_or(DEFAULT_SHARD_SIZE),
        )?;
        let progress = Progress::new(Some(self.items.len() as u64), "items");
        let mut results = Vec::new();
        let mut log_error = None;
        let mut results_done = 0usize;
        for ((&i, key), hash) in todo.iter().zip(&keys).zip(hashes) {
            if self.runner.options.stop.is_stopped() {
                break;
            }
            let item = &self.items[i];
            let item_started = Instant::now();
            let held = found.get(key).filter(|_| current(key, &hash));
            let (outcome, rec) = match (held, hash) {
                (Some(held), _) => {
                    let tar = held.tars.first().expect("one shard");
                    let mut r = record(item, &args.dst.join(tar), &Outcome::Skipped, 0.0);
                    (r.frames, r.outputs) = (Some(held.frames.len()), Some(held.samples));
                    r.source_frames = runner
                        .plan
                        .picks()
                        .then(|| held.frames.iter().copied().collect());
                    (Outcome::Skipped, r)
                }
                (None, Err(e)) => {
                    let outcome = Outcome::Failed(e.to_string());
                    let r = record(item, &args.dst, &outcome, 0.0);
                    (outcome, r)
                }
                (None, Ok(hash)) => {
                    let tar = args.dst.join(writer.current_name());
                    let mut tick = || {
                        results_done += 1;
                        let rate =
                            results_done as f64 / self.started.elapsed().as_secs_f64().max(1e-9);
                        progress.message(format!("{results_done} results, {rate:.1}/s"));
                    };
                    let outcome = self.one(item, key.clone(), hash, &mut writer, &mut tick);
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
        source_hash: String,
        writer: &mut ShardWriter,
        on_output: &mut dyn FnMut(),
    ) -> Outcome {
        let runner = self.runner;
        writer.begin_item();
        let result = (|| -> Result<Summary, HostError> {
            if item.rel.to_str().is_none() {
                return Err(input_error(
                    &item.src,
                    "the path is not UTF-8, and WebDataset keys are text; rename it",
                ));
            }
            let mut frames = reynoldsflow_host::dataset::open_item(
                &item.src,
                item.frames,
                &runner.plan,
                runner.limits,
            )?;
            let mut sink = ItemSamples {
                writer: &mut *writer,
                rel: &item.rel,
                src: &item.src,
                source,
                source_hash,
                settings: &runner.settings,
                keys: HashMap::new(),
            };
            let summary = pipeline::process(
                &mut *frames,
                &runner.compute,
                Destination::Samples {
                    spec: &runner.spec,
                    sink: &mut sink,
                },
                runner.options.clone(),
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
            Err(_) if runner.options.stop.is_stopped() => Outcome::Interrupted,
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
