//! Fault injection on `reynoldsflow dataset`: the destination fills up,
//! turns read-only or vanishes mid-run; an input disappears or is
//! truncated while being read; SIGINT, SIGTERM and SIGKILL mid-run. Each
//! time: a clear message, a non-zero exit, no partial or corrupt file
//! under a final name (every file left is byte-identical to the same file
//! of an undisturbed run), and a rerun of the same command that completes
//! the tree to exactly the undisturbed bytes.

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::fs;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

mod child_support;
mod run_support;

use child_support::{Tmpfs, signal, stop, wait_measured};
use run_support::{BIN, moving_frame, pgm, y4m};

/// Frame size of the test inputs: small enough for a quick reference run,
/// large enough that a run lasts while the fault is injected.
const W: usize = 96;
const H: usize = 64;

/// Every file under `dir` with its bytes, by relative path.
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    run_support::tree(dir)
        .into_iter()
        .map(|rel| {
            let bytes = fs::read(dir.join(&rel)).unwrap();
            (rel, bytes)
        })
        .collect()
}

/// A temp file, or anything in an item's staging folder or journal (what
/// a run that could not clean up leaves; the next run removes it).
fn is_temp(rel: &str) -> bool {
    rel.split('/')
        .any(|c| c.starts_with('.') && c != ".reynoldsflow-done")
}

/// `clips` Y4M videos of `frames` frames each in `src`.
fn video_tree(src: &Path, clips: usize, frames: usize) {
    fs::create_dir_all(src).unwrap();
    for c in 0..clips {
        let seq: Vec<_> = (0..frames).map(|t| moving_frame(W, H, t + 3 * c)).collect();
        fs::write(src.join(format!("clip{c}.y4m")), y4m(&seq, "420jpeg")).unwrap();
    }
}

fn dataset_args(src: &Path, dst: &Path, threads: u32) -> Vec<OsString> {
    vec![
        "dataset".into(),
        src.into(),
        dst.into(),
        "--threads".into(),
        threads.to_string().into(),
    ]
}

fn spawn(args: &[OsString]) -> Child {
    Command::new(BIN)
        .args(args)
        .env_remove("REYNOLDSFLOW_FFMPEG")
        .env_remove("REYNOLDSFLOW_ABORT_AFTER")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start reynoldsflow")
}

/// Run to the end: exit status and stderr.
fn finish(child: Child) -> (ExitStatus, String) {
    let m = wait_measured(child);
    (m.status, m.stderr)
}

/// The files an undisturbed run of the same command makes.
fn undisturbed(src: &Path, threads: u32) -> BTreeMap<String, Vec<u8>> {
    let dst = tempfile::tempdir().unwrap();
    let (status, err) = finish(spawn(&dataset_args(src, dst.path(), threads)));
    assert!(status.success(), "undisturbed run: {err}");
    let made = files(dst.path());
    assert!(made.len() > 10, "{:?}", made.keys());
    made
}

/// Wait until `dst` holds `n` whole PNGs (staged ones count: an item's
/// files are committed together at its end); the run must still be going.
fn wait_for_outputs(child: &mut Child, dst: &Path, n: usize) {
    let start = Instant::now();
    loop {
        let done = run_support::tree(dst)
            .iter()
            .filter(|p| p.ends_with(".png"))
            .count();
        if done >= n {
            return;
        }
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the run ended ({status}) before the fault could be injected");
        }
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "no outputs appear"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// No partial or corrupt file: every file under a final name is the
/// undisturbed run's file of that name, byte for byte (so also its size);
/// hidden temp files only if `temps_allowed` (a SIGKILL cannot clean up).
/// Returns how many final files were left.
fn assert_nothing_partial(
    dst: &Path,
    reference: &BTreeMap<String, Vec<u8>>,
    temps_allowed: bool,
) -> usize {
    let mut kept = 0;
    for (rel, bytes) in files(dst) {
        if is_temp(&rel) {
            assert!(temps_allowed, "a temp file was left: {rel}");
            continue;
        }
        let want = reference
            .get(&rel)
            .unwrap_or_else(|| panic!("{rel}: not a file of the undisturbed run"));
        assert_eq!(bytes.len(), want.len(), "{rel}: size");
        assert!(
            bytes == *want,
            "{rel}: bytes differ from the undisturbed run"
        );
        kept += 1;
    }
    kept
}

fn modified(path: &Path) -> std::time::SystemTime {
    fs::metadata(path).unwrap().modified().unwrap()
}

/// Put a source file back as it was, its modification time included (a
/// dataset marker records it: a changed time is a changed source).
fn restore(path: &Path, bytes: &[u8], time: std::time::SystemTime) {
    fs::write(path, bytes).unwrap();
    fs::File::options()
        .write(true)
        .open(path)
        .unwrap()
        .set_modified(time)
        .unwrap();
}

/// The rerun of the same command completes the tree to the undisturbed bytes.
fn assert_rerun_completes(
    src: &Path,
    dst: &Path,
    threads: u32,
    reference: &BTreeMap<String, Vec<u8>>,
) {
    let (status, err) = finish(spawn(&dataset_args(src, dst, threads)));
    assert!(status.success(), "rerun: {err}");
    let made = files(dst);
    assert_eq!(
        made.keys().collect::<Vec<_>>(),
        reference.keys().collect::<Vec<_>>(),
        "rerun: names"
    );
    assert!(
        made == *reference,
        "rerun: bytes differ from the undisturbed run"
    );
}

/// Bytes a set of files takes on tmpfs (whole pages).
fn pages(files: &BTreeMap<String, Vec<u8>>) -> u64 {
    files
        .values()
        .map(|b| (b.len() as u64).div_ceil(4096).max(1) * 4096)
        .sum()
}

#[test]
fn a_destination_that_fills_up() {
    let work = tempfile::tempdir().unwrap();
    let src = work.path().join("src");
    video_tree(&src, 3, 12);
    let reference = undisturbed(&src, 1);
    let disk = Tmpfs::mount(&work.path().join("disk"), pages(&reference) / 2);
    let dst = disk.dir.join("dst");
    let (status, err) = finish(spawn(&dataset_args(&src, &dst, 1)));
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(err.contains("No space left on device"), "{err}");
    assert!(err.contains("rerun") || err.contains("failed"), "{err}");
    let kept = assert_nothing_partial(&dst, &reference, false);
    assert!(
        kept > 0 && kept < reference.len(),
        "{kept} of {} files",
        reference.len()
    );
    disk.remount(&format!("rw,size={}", 4 * pages(&reference)))
        .unwrap();
    assert_rerun_completes(&src, &dst, 1, &reference);
}

#[test]
fn a_destination_that_turns_read_only() {
    let work = tempfile::tempdir().unwrap();
    let src = work.path().join("src");
    video_tree(&src, 2, 40);
    let reference = undisturbed(&src, 1);
    let disk = Tmpfs::mount(&work.path().join("disk"), 4 * pages(&reference));
    let dst = disk.dir.join("dst");
    let mut child = spawn(&dataset_args(&src, &dst, 1));
    wait_for_outputs(&mut child, &dst, 5);
    // tmpfs refuses `ro` (EBUSY) while a file is open for writing: retry
    // until it lands between two writes.
    let start = Instant::now();
    while let Err(e) = disk.remount("ro") {
        assert!(start.elapsed() < Duration::from_secs(60), "remount ro: {e}");
        assert!(child.try_wait().unwrap().is_none(), "the run ended first");
    }
    let (status, err) = finish(child);
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(err.contains("Read-only file system"), "{err}");
    // A read-only folder keeps the staged files it could not remove (the
    // rerun does); no final name holds a file of the unfinished item.
    let kept = assert_nothing_partial(&dst, &reference, true);
    assert!(kept < reference.len(), "{kept}");
    disk.remount("rw").unwrap();
    assert_rerun_completes(&src, &dst, 1, &reference);
}

#[test]
fn a_destination_that_vanishes() {
    let work = tempfile::tempdir().unwrap();
    let src = work.path().join("src");
    video_tree(&src, 1, 60);
    let reference = undisturbed(&src, 1);
    let dst = work.path().join("dst");
    let mut child = spawn(&dataset_args(&src, &dst, 1));
    wait_for_outputs(&mut child, &dst, 5);
    // Stopped while its destination goes, so it cannot finish first on a
    // busy machine, nor create files during the removal.
    stop(child.id());
    fs::remove_dir_all(&dst).unwrap();
    signal(child.id(), libc::SIGCONT);
    let (status, err) = finish(child);
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(err.contains("No such file or directory"), "{err}");
    assert_nothing_partial(&dst, &reference, false);
    assert_rerun_completes(&src, &dst, 1, &reference);
}

/// A frame folder of `n` PGM frames.
fn frame_folder(dir: &Path, n: usize) -> Vec<(PathBuf, Vec<u8>)> {
    fs::create_dir_all(dir).unwrap();
    (0..n)
        .map(|t| {
            let path = dir.join(format!("f{t:03}.pgm"));
            let bytes = pgm(&moving_frame(W, H, t));
            fs::write(&path, &bytes).unwrap();
            (path, bytes)
        })
        .collect()
}

#[test]
fn an_input_that_disappears_while_read() {
    let work = tempfile::tempdir().unwrap();
    let src = work.path().join("src");
    let frames = frame_folder(&src.join("seq"), 60);
    let times: Vec<_> = frames.iter().map(|(p, _)| modified(p)).collect();
    let reference = undisturbed(&src, 1);
    let dst = work.path().join("dst");
    let mut child = spawn(&dataset_args(&src, &dst, 1));
    wait_for_outputs(&mut child, &dst, 5);
    for (path, _) in &frames[30..] {
        fs::remove_file(path).unwrap();
    }
    let (status, err) = finish(child);
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(
        err.contains("seq/f030.pgm: No such file or directory"),
        "names the missing frame: {err}"
    );
    let kept = assert_nothing_partial(&dst, &reference, false);
    // The item failed: none of its files is committed, and none partial.
    assert_eq!(kept, 0, "a failed item committed files");
    for ((path, bytes), time) in frames.iter().zip(times).skip(30) {
        restore(path, bytes, time);
    }
    assert_rerun_completes(&src, &dst, 1, &reference);
}

#[test]
fn an_input_truncated_while_read() {
    let work = tempfile::tempdir().unwrap();
    let src = work.path().join("src");
    video_tree(&src, 1, 60);
    let clip = src.join("clip0.y4m");
    let whole = fs::read(&clip).unwrap();
    let time = modified(&clip);
    let reference = undisturbed(&src, 1);
    let dst = work.path().join("dst");
    let mut child = spawn(&dataset_args(&src, &dst, 1));
    wait_for_outputs(&mut child, &dst, 5);
    // Cut exactly after frame 40: what is left is a valid, shorter video,
    // so only the length the file had when opened tells the truncation.
    let header = whole.iter().position(|&b| b == b'\n').unwrap() + 1;
    let frame = 6 + W * H + 2 * W.div_ceil(2) * H.div_ceil(2);
    fs::OpenOptions::new()
        .write(true)
        .open(&clip)
        .unwrap()
        .set_len((header + 40 * frame) as u64)
        .unwrap();
    let (status, err) = finish(child);
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(
        err.contains("clip0.y4m: the input ends after frame 40")
            && err.contains("truncated while being read"),
        "{err}"
    );
    let kept = assert_nothing_partial(&dst, &reference, false);
    // The item failed: none of its files is committed, and none partial.
    assert_eq!(kept, 0, "a failed item committed files");
    restore(&clip, &whole, time);
    assert_rerun_completes(&src, &dst, 1, &reference);
}

/// Signal `sig` mid-run; returns the status and stderr.
fn signalled(sig: libc::c_int) -> (ExitStatus, String, PathBuf, tempfile::TempDir) {
    let work = tempfile::tempdir().unwrap();
    let src = work.path().join("src");
    video_tree(&src, 4, 30);
    let dst = work.path().join("dst");
    let mut child = spawn(&dataset_args(&src, &dst, 2));
    wait_for_outputs(&mut child, &dst, 5);
    signal(child.id(), sig);
    let (status, err) = finish(child);
    (status, err, dst, work)
}

fn stops_cleanly_on(sig: libc::c_int) {
    let (status, err, dst, work) = signalled(sig);
    let src = work.path().join("src");
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(
        err.contains("interrupted; rerun the same command to finish the unfinished items"),
        "{err}"
    );
    let reference = undisturbed(&src, 2);
    let kept = assert_nothing_partial(&dst, &reference, false);
    assert!(kept < reference.len(), "{kept}");
    assert_rerun_completes(&src, &dst, 2, &reference);
}

#[test]
fn sigint_mid_dataset() {
    stops_cleanly_on(libc::SIGINT);
}

#[test]
fn sigterm_mid_dataset() {
    stops_cleanly_on(libc::SIGTERM);
}

#[test]
fn sigkill_mid_dataset() {
    let (status, _, dst, work) = signalled(libc::SIGKILL);
    assert_eq!(status.signal(), Some(libc::SIGKILL));
    let reference = undisturbed(&work.path().join("src"), 2);
    // Nothing can clean up after SIGKILL: hidden temps may stay (the rerun
    // removes them), but no final name holds a partial file.
    let kept = assert_nothing_partial(&dst, &reference, true);
    assert!(kept < reference.len(), "{kept}");
    assert_rerun_completes(&work.path().join("src"), &dst, 2, &reference);
}
