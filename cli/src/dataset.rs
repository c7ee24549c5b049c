//! `reynoldsflow dataset SRC DST`: every video and frame folder under SRC
//! to a folder of outputs under DST, on all cores, resumable
//! ([`reynoldsflow_host::dataset`] makes each item).
//!
//! **Failures.** A file that cannot be read or decoded is reported and
//! skipped; the other items go on. The summary lists each failure with its
//! reason, and the exit status is 1 if any item failed (0 otherwise).
//!
//! **Clusters.** `--shard I/N` takes the items of shard `I`, so `N`
//! processes (a Slurm array, a Kubernetes Indexed Job) share one dataset
//! and one destination; `--files-from` takes the items from a manifest;
//! each item's record goes to stdout or `--status FILE` as a JSON line.

use std::fs;
use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use reynoldsflow_host::dataset::{
    Item, ItemRunner, ItemSettings, Outcome, Shard, StatusLog, clashes, discover, manifest, record,
    shard::parse_shard, shard_key,
};
use reynoldsflow_host::sequence::input_error;
use reynoldsflow_host::{HostError, workers};

use super::progress::Progress;
use super::run::{EngineArgs, OutputArgs, count, install_interrupt_handler, interrupt_token};

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
options, the same source (by a hash of its content) and every output (size and hash) as they are;
a rerun skips finished items and redoes the rest into a staging folder, then replaces the old files.
After a run that exits 0, every item holds exactly what `run` writes for it, and no temp file.
Items sharing an output path, or inside another item's hsv/, v_c/, v_d/, v_R/, are refused.
To run several processes on one DST, give each its --shard I/N (each share of DST is locked).
A bad file is reported and skipped; the exit status is 1 if any item failed.
One JSON line per item on stdout (or --status FILE): path, output, status, frames, outputs,
seconds, error. In a Slurm job array (--array=0-7) the shard comes from SLURM_ARRAY_TASK_*;
in a Kubernetes Indexed Job from JOB_COMPLETION_INDEX with --shards N.";

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
    #[arg(long, value_name = "I/N", value_parser = parse_shard, conflicts_with = "shards", help_heading = "Clusters")]
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
    /// KEY.json (source path and hash, source frames, motion score,
    /// settings); KEY is ITEM/STEM (the item's output path, the result's
    /// stem). Items run one after another, each on every thread; a rerun
    /// skips the items already in complete shards from the same source
    /// and settings, and cuts the samples of changed items out first.
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

impl DatasetArgs {
    /// What every item is made with.
    pub fn item_settings(&self) -> ItemSettings {
        self.output
            .item_settings(&self.engine, self.limits.limits())
    }
}

/// `reynoldsflow: failed: <file>: <reason>`, naming the file once.
pub(crate) fn failure_line(item: &Item, why: &str) -> String {
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
    match super::scheduler::from_scheduler(|name| std::env::var(name).ok(), args.shards)? {
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
    let shard = which_shard(args)?;
    let threads = args.engine.threads();
    // Checked before anything is created; the workers' share is set below.
    let item_settings = args.item_settings();
    ItemRunner::new(&item_settings, threads, args.force)?;
    // Folders: no item's folder may lie in another's side-output folder.
    let sides = !args.webdataset;
    let log = prepare_destination(args)?;
    let _lock = lock_destination(args)?;
    let all = find_items(args)?;
    let (items, mut outcomes) = shard_items(args, shard, &all, sides);
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
        let runner = ItemRunner::new(&item_settings, threads, args.force)?;
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
        let runner = ItemRunner::new(&item_settings, threads.div_ceil(workers), args.force)?;
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
    // Stopped before their turn (Ctrl-C): a record each all the same.
    for (item, outcome) in items.iter().zip(&mut outcomes) {
        if outcome.is_none() {
            let not_started = Outcome::NotStarted;
            let r = record(item, &args.dst.join(&item.rel), &not_started, 0.0);
            if let Err(e) = log.write(&r) {
                eprintln!("reynoldsflow: {e}");
            }
            *outcome = Some(not_started);
        }
    }
    let failures = report(args, shard, all.len(), &items, &outcomes, started);
    if interrupt_token().is_stopped() {
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

/// The advisory lock on the folder DST, held until the run ends: shared
/// with `--shard` (the shares never meet), exclusive without. A second
/// unsharded run, or an unsharded run beside sharded ones, is refused,
/// naming `--shard`, instead of redoing the items the other is making.
fn lock_destination(args: &DatasetArgs) -> Result<fs::File, HostError> {
    let dst = &args.dst;
    let folder = fs::File::open(dst).map_err(|e| HostError::io(dst, e))?;
    let locked = if args.shard.is_some() || args.shards.is_some() || which_is_scheduled() {
        folder.try_lock_shared()
    } else {
        folder.try_lock()
    };
    match locked {
        Ok(()) => Ok(folder),
        Err(fs::TryLockError::WouldBlock) => Err(HostError::invalid(
            "--shard",
            format!(
                "another `reynoldsflow dataset` is writing into {} without --shard (or this run \
                 has none and others are); to run several processes on one DST, give each its own --shard I/N",
                dst.display()
            ),
        )),
        Err(fs::TryLockError::Error(e)) => Err(HostError::io(dst, e)),
    }
}

/// Whether a scheduler's variables give this process a shard.
fn which_is_scheduled() -> bool {
    ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"]
        .iter()
        .any(|v| std::env::var_os(v).is_some())
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
/// it clashes with another item, [`clashes`]) or still to run (`None`);
/// `sides`: whether items write side-output folders (folders, not
/// WebDataset).
fn shard_items(
    args: &DatasetArgs,
    shard: Shard,
    all: &[Item],
    sides: bool,
) -> (Vec<Item>, Vec<Option<Outcome>>) {
    all.iter()
        .zip(clashes(all, &args.dst, sides))
        .filter(|(item, _)| shard.contains(&shard_key(&args.src, item)))
        .map(|(item, clash)| (item.clone(), clash.map(Outcome::Failed)))
        .unzip()
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
                let interrupted = interrupt_token().is_stopped();
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
            Some(Outcome::Interrupted | Outcome::NotStarted) | None => not_started += 1,
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
