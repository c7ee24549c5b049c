//! `dataset`'s item-commit protocol from outside: after any rerun that
//! exits 0, every item holds exactly what `run` writes for its current
//! source and flags (nothing missing, nothing extra, no temp file), in
//! folders and in WebDataset shards alike, whatever happened in between.

mod run_support;

use std::collections::{BTreeMap, BTreeSet};
use std::ffi::{OsStr, OsString};
use std::fs;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::Duration;

use run_support::*;

const MANIFEST: &str = ".reynoldsflow-done";
const SIDES: [&str; 4] = ["hsv", "v_c", "v_d", "v_R"];

/// `reynoldsflow` with `base` then `flags`.
fn cmd(base: &[OsString], flags: &[&str]) -> Vec<OsString> {
    let mut a = base.to_vec();
    a.extend(flags.iter().map(OsString::from));
    a
}

/// An item folder's own files (top level, and its side-output folders),
/// path → bytes; the manifest is left out.
fn item_files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut files = BTreeMap::new();
    let Ok(entries) = fs::read_dir(dir) else {
        return files;
    };
    for e in entries.map(Result::unwrap) {
        let name = e.file_name().to_string_lossy().into_owned();
        let path = e.path();
        if path.is_file() && name != MANIFEST {
            files.insert(name, fs::read(&path).unwrap());
        } else if path.is_dir() && SIDES.contains(&name.as_str()) {
            for f in tree(&path) {
                files.insert(format!("{name}/{f}"), fs::read(path.join(&f)).unwrap());
            }
        }
    }
    files
}

/// What `run SRC --out T flags` writes.
fn run_output(src: &Path, flags: &[&str]) -> BTreeMap<String, Vec<u8>> {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("o");
    ok(&run(&cmd(&args!["run", src, "--out", out], flags)));
    item_files(&out)
}

/// `item` under DST equals `run`'s output for `src` with `flags`.
fn assert_item(dst_item: &Path, src: &Path, flags: &[&str]) {
    let (got, want) = (item_files(dst_item), run_output(src, flags));
    let names = |m: &BTreeMap<String, Vec<u8>>| m.keys().cloned().collect::<Vec<_>>();
    assert_eq!(
        names(&got),
        names(&want),
        "{} against run {}",
        dst_item.display(),
        src.display()
    );
    assert!(
        got == want,
        "{}: bytes differ from run's",
        dst_item.display()
    );
}

/// Hidden files and folders under `dir` other than manifests and the lock.
fn leftovers(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    fn walk(dir: &Path, found: &mut Vec<String>) {
        for e in fs::read_dir(dir).into_iter().flatten().flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') && name != MANIFEST {
                found.push(e.path().display().to_string());
            } else if e.path().is_dir() {
                walk(&e.path(), found);
            }
        }
    }
    walk(dir, &mut found);
    found
}

fn records(out: &Output) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn status_of(out: &Output, path_end: &str) -> String {
    records(out)
        .iter()
        .find(|r| r["path"].as_str().unwrap().ends_with(path_end))
        .unwrap_or_else(|| panic!("no record of {path_end}: {:?}", records(out)))["status"]
        .as_str()
        .unwrap()
        .to_owned()
}

fn clip(n: usize, shift: usize) -> Vec<u8> {
    let f: Vec<_> = (0..n).map(|t| moving_frame(32, 24, t + shift)).collect();
    y4m(&f, "420jpeg")
}

fn frames(dir: &Path, names: &[&str], shift: usize) {
    fs::create_dir_all(dir).unwrap();
    for (t, name) in names.iter().enumerate() {
        fs::write(dir.join(name), pgm(&moving_frame(32, 24, t + shift))).unwrap();
    }
}

/// Every member name of every tar in `dir`, by tar.
fn tar_members(dir: &Path) -> BTreeMap<String, Vec<(String, Vec<u8>)>> {
    let mut out = BTreeMap::new();
    for name in tree(dir).into_iter().filter(|n| n.ends_with(".tar")) {
        let mut archive = tar::Archive::new(fs::File::open(dir.join(&name)).unwrap());
        let mut members = Vec::new();
        for entry in archive.entries().unwrap() {
            let mut entry = entry.unwrap();
            let member = entry.path().unwrap().to_string_lossy().into_owned();
            let mut bytes = Vec::new();
            std::io::Read::read_to_end(&mut entry, &mut bytes).unwrap();
            members.push((member, bytes));
        }
        out.insert(name, members);
    }
    out
}

/// The shards of `dst` hold, for each `(item output path, source, flags)`,
/// exactly `run`'s files as members (`KEY.rep.png`, `KEY.hsv.png`, …,
/// and one `KEY.json` each), and nothing else; no member name repeats.
fn assert_shards(dst: &Path, items: &[(String, &Path, Vec<&str>)]) {
    let mut all = BTreeMap::new();
    for (tar, members) in tar_members(dst) {
        for (name, bytes) in members {
            assert!(
                all.insert(name.clone(), bytes).is_none(),
                "{tar}: member {name} twice"
            );
        }
    }
    let mut want = BTreeSet::new();
    for (rel, src, flags) in items {
        for (file, bytes) in run_output(src, flags) {
            let (dir, name) = file.rsplit_once('/').unwrap_or(("rep", &file));
            let (stem, ext) = name.rsplit_once('.').unwrap();
            let key = if rel.is_empty() {
                stem.replace('.', "_")
            } else {
                format!("{rel}/{}", stem.replace('.', "_"))
            };
            let member = format!("{key}.{dir}.{ext}");
            let got = all
                .get(&member)
                .unwrap_or_else(|| panic!("{member} missing: {:?}", all.keys()));
            assert!(got == &bytes, "{member} differs from run's");
            want.insert(member);
            want.insert(format!("{key}.json"));
        }
    }
    let extra: Vec<_> = all.keys().filter(|k| !want.contains(*k)).collect();
    assert!(extra.is_empty(), "members beyond the items': {extra:?}");
}

#[test]
fn f5_a_nested_item_named_like_a_side_folder_is_refused_whatever_the_flags() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("src");
    fs::create_dir_all(src.join("x")).unwrap();
    fs::write(src.join("x.y4m"), clip(4, 0)).unwrap();
    fs::write(src.join("x/hsv.y4m"), clip(4, 3)).unwrap();
    frames(&src.join("f/x"), &["a.pgm", "b.pgm", "c.pgm"], 0);
    frames(&src.join("f/x/v_R"), &["a.pgm", "b.pgm", "c.pgm"], 2);
    let dst = tmp.path().join("dst");
    let res = run(&args!["dataset", src, dst]);
    assert_eq!(res.status.code(), Some(1), "{}", stderr(&res));
    assert_eq!(status_of(&res, "x/hsv.y4m"), "failed");
    assert_eq!(status_of(&res, "f/x/v_R"), "failed");
    assert!(stderr(&res).contains("hsv"), "{}", stderr(&res));
    assert_item(&dst.join("x"), &src.join("x.y4m"), &[]);
    assert_item(&dst.join("f/x"), &src.join("f/x"), &[]);
    assert!(!dst.join("x/hsv").exists() && !dst.join("f/x/v_R").exists());
    // A first build shard by shard refuses it in its own shard too.
    let d5 = tmp.path().join("d5");
    let mut refused = 0;
    for i in 0..5 {
        let res = run(&args!["dataset", src, d5, "--shard", format!("{i}/5")]);
        refused += records(&res)
            .iter()
            .filter(|r| r["status"] == "failed")
            .count();
        assert_eq!(
            res.status.code().unwrap() == 1,
            records(&res).iter().any(|r| r["status"] == "failed")
        );
    }
    assert_eq!(refused, 2);
    assert_item(&d5.join("x"), &src.join("x.y4m"), &[]);
    assert_item(&d5.join("f/x"), &src.join("f/x"), &[]);
}

#[test]
#[cfg_attr(
    not(feature = "crash-injection"),
    ignore = "the crash hook needs --features reynoldsflow-cli/crash-injection (scripts/test)"
)]
fn f6_no_temp_survives_a_resume_with_other_flags() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    fs::create_dir(&src).unwrap();
    fs::write(src.join("v.y4m"), clip(6, 0)).unwrap();
    let crashed = run_with(
        &args!["dataset", src, dst, "--viz", "--no-rep", "--threads", "1"],
        None,
        &[("REYNOLDSFLOW_ABORT_AFTER", OsStr::new("2"))],
    );
    assert!(!crashed.status.success());
    assert!(!leftovers(&dst).is_empty(), "the crash left no temp");
    ok(&run(&args!["dataset", src, dst]));
    assert_eq!(leftovers(&dst), Vec::<String>::new());
    assert_item(&dst.join("v"), &src.join("v.y4m"), &[]);
}

#[test]
#[cfg_attr(
    not(feature = "crash-injection"),
    ignore = "the crash hook needs --features reynoldsflow-cli/crash-injection (scripts/test)"
)]
fn f6_run_again_with_other_flags_leaves_no_temp() {
    let tmp = tempfile::tempdir().unwrap();
    let video = tmp.path().join("v.y4m");
    fs::write(&video, clip(6, 0)).unwrap();
    let out = tmp.path().join("out");
    let crashed = run_with(
        &args![
            "run",
            video,
            "--out",
            out,
            "--viz",
            "--no-rep",
            "--threads",
            "1"
        ],
        None,
        &[("REYNOLDSFLOW_ABORT_AFTER", OsStr::new("2"))],
    );
    assert!(!crashed.status.success());
    assert!(
        !temp_files(&out.join("hsv")).is_empty(),
        "the crash left no temp"
    );
    ok(&run(&args!["run", video, "--out", out]));
    assert_eq!(temp_files(&out), Vec::<String>::new());
}

#[test]
fn f7_names_up_to_name_max_are_written_in_run_and_dataset() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = tmp.path().join("src/seq");
    // 250-byte stems: the outputs' names are 254 bytes.
    let names: Vec<String> = (0..3)
        .map(|i| format!("{}{i}.pgm", "n".repeat(249)))
        .collect();
    frames(
        &seq,
        &names.iter().map(String::as_str).collect::<Vec<_>>(),
        0,
    );
    let out = tmp.path().join("out");
    ok(&run(&args!["run", seq, "--out", out]));
    assert_eq!(item_files(&out).len(), 2);
    let dst = tmp.path().join("dst");
    ok(&run(&args!["dataset", tmp.path().join("src"), dst]));
    assert_item(&dst.join("seq"), &seq, &[]);
}

#[test]
fn f8_webdataset_keys_never_repeat() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("src");
    frames(&src.join("s"), &["a.1.png.pgm", "a_1.png.pgm", "b.pgm"], 0);
    frames(&src.join("t"), &["a.1.pgm", "a_1.pgm", "b.pgm"], 0);
    let dst = tmp.path().join("dst");
    let res = run(&args!["dataset", src, dst, "--webdataset", "--keep-count"]);
    // Every member name once, whatever the outcome of each item.
    let mut seen = BTreeSet::new();
    for (tar, members) in tar_members(&dst) {
        for (name, _) in members {
            assert!(seen.insert(name.clone()), "{tar}: {name} twice");
        }
    }
    // An item whose stems would share a key is refused, named, exit 1.
    assert_eq!(res.status.code(), Some(1), "{}", stderr(&res));
    assert_eq!(status_of(&res, "/t"), "failed");
    let rec = records(&res);
    let t = rec
        .iter()
        .find(|r| r["path"].as_str().unwrap().ends_with("/t"))
        .unwrap();
    assert!(t["error"].as_str().unwrap().contains("a_1"), "{t}");
}

#[test]
fn f9_webdataset_reruns_redo_changed_sources() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    fs::create_dir(&src).unwrap();
    fs::write(src.join("v.y4m"), clip(5, 0)).unwrap();
    frames(&src.join("seq"), &["f0.pgm", "f1.pgm", "f2.pgm"], 0);
    ok(&run(&args!["dataset", src, dst, "--webdataset"]));
    fs::write(src.join("v.y4m"), clip(5, 7)).unwrap();
    fs::write(src.join("seq/f3.pgm"), pgm(&moving_frame(32, 24, 9))).unwrap();
    let res = run(&args!["dataset", src, dst, "--webdataset"]);
    ok(&res);
    assert_eq!(status_of(&res, "v.y4m"), "done");
    assert_eq!(status_of(&res, "seq"), "done");
    assert_shards(
        &dst,
        &[
            ("v".into(), &src.join("v.y4m"), vec![]),
            ("seq".into(), &src.join("seq"), vec![]),
        ],
    );
    // A rerun with nothing changed skips both and keeps the bytes.
    let before = tar_members(&dst);
    let res = run(&args!["dataset", src, dst, "--webdataset"]);
    ok(&res);
    assert_eq!(status_of(&res, "v.y4m"), "skipped");
    assert_eq!(tar_members(&dst), before);
}

#[test]
#[cfg_attr(
    not(feature = "crash-injection"),
    ignore = "the crash hook needs --features reynoldsflow-cli/crash-injection (scripts/test)"
)]
fn f10_frames_renamed_after_a_kill_leave_nothing_of_the_old_names() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    let names = ["f0.pgm", "f1.pgm", "f2.pgm", "f3.pgm", "f4.pgm", "f5.pgm"];
    frames(&src.join("seq"), &names, 0);
    let crashed = run_with(
        &args!["dataset", src, dst, "--threads", "1"],
        None,
        &[("REYNOLDSFLOW_ABORT_AFTER", OsStr::new("3"))],
    );
    assert!(!crashed.status.success());
    for n in names {
        fs::rename(
            src.join("seq").join(n),
            src.join("seq").join(format!("g{n}")),
        )
        .unwrap();
    }
    ok(&run(&args!["dataset", src, dst]));
    assert_item(&dst.join("seq"), &src.join("seq"), &[]);
    assert_eq!(leftovers(&dst), Vec::<String>::new());
}

#[test]
fn f11_a_manifest_cut_at_a_line_end_is_not_trusted() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    fs::create_dir(&src).unwrap();
    fs::write(src.join("v.y4m"), clip(6, 0)).unwrap();
    ok(&run(&args!["dataset", src, dst]));
    let manifest = dst.join("v").join(MANIFEST);
    let text = fs::read_to_string(&manifest).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let cut: String = lines[..lines.len() - 2]
        .iter()
        .map(|l| format!("{l}\n"))
        .collect();
    fs::write(&manifest, cut).unwrap();
    fs::remove_file(dst.join("v/000003.png")).unwrap();
    fs::remove_file(dst.join("v/000004.png")).unwrap();
    let res = run(&args!["dataset", src, dst]);
    ok(&res);
    assert_eq!(status_of(&res, "v.y4m"), "done");
    assert_item(&dst.join("v"), &src.join("v.y4m"), &[]);
    // An output edited in place (same size) is seen too.
    let png = dst.join("v/000001.png");
    let mut bytes = fs::read(&png).unwrap();
    let last = bytes.len() - 20;
    bytes[last] ^= 1;
    fs::write(&png, bytes).unwrap();
    let res = run(&args!["dataset", src, dst]);
    assert_eq!(status_of(&res, "v.y4m"), "done");
    assert_item(&dst.join("v"), &src.join("v.y4m"), &[]);
}

#[test]
fn f12_frame_names_that_are_not_utf8_are_refused_in_run_and_dataset() {
    use std::os::unix::ffi::OsStrExt;
    let tmp = tempfile::tempdir().unwrap();
    let seq = tmp.path().join("src/seq");
    frames(&seq, &["f0.pgm", "f1.pgm"], 0);
    let odd = seq.join(OsStr::from_bytes(b"f\xff2.pgm"));
    fs::write(&odd, pgm(&moving_frame(32, 24, 2))).unwrap();
    let res = run(&args!["run", seq, "--out", tmp.path().join("out")]);
    assert!(
        !res.status.success(),
        "run accepted a folder it reads in part"
    );
    assert!(stderr(&res).contains("UTF-8"), "{}", stderr(&res));
    let res = run(&args![
        "dataset",
        tmp.path().join("src"),
        tmp.path().join("dst")
    ]);
    assert_eq!(res.status.code(), Some(1), "{}", stderr(&res));
    assert_eq!(status_of(&res, "seq"), "failed");
    assert!(
        records(&res)[0]["error"]
            .as_str()
            .unwrap()
            .contains("UTF-8")
    );
}

#[test]
fn a_source_replaced_with_the_same_size_and_time_is_redone() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    fs::create_dir(&src).unwrap();
    let video = src.join("v.y4m");
    fs::write(&video, clip(5, 0)).unwrap();
    ok(&run(&args!["dataset", src, dst]));
    let mtime = fs::metadata(&video).unwrap().modified().unwrap();
    fs::write(&video, clip(5, 4)).unwrap();
    fs::File::options()
        .write(true)
        .open(&video)
        .unwrap()
        .set_modified(mtime)
        .unwrap();
    let res = run(&args!["dataset", src, dst]);
    ok(&res);
    assert_eq!(status_of(&res, "v.y4m"), "done");
    assert_item(&dst.join("v"), &video, &[]);
}

#[test]
fn new_settings_are_checked_before_anything_is_removed() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    frames(&src.join("seq"), &["f0.pgm", "f1.pgm", "f2.pgm"], 0);
    ok(&run(&args!["dataset", src, dst]));
    let before = item_files(&dst.join("seq"));
    let res = run(&args!["dataset", src, dst, "--fps", "5"]);
    assert_eq!(res.status.code(), Some(1), "{}", stderr(&res));
    assert_eq!(item_files(&dst.join("seq")), before);
    let res = run(&args!["dataset", src, dst]);
    ok(&res);
    assert_eq!(status_of(&res, "seq"), "skipped");
}

#[test]
fn after_sigint_every_item_has_a_record() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    fs::create_dir(&src).unwrap();
    let f: Vec<_> = (0..30).map(|t| moving_frame(96, 64, t)).collect();
    for i in 0..6 {
        fs::write(src.join(format!("c{i}.y4m")), y4m(&f, "420jpeg")).unwrap();
    }
    let status = tmp.path().join("status.jsonl");
    let mut child = Command::new(BIN)
        .args(args![
            "dataset",
            src,
            dst,
            "--threads",
            "1",
            "--status",
            status
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = kill_when_signal(&mut child, || {
        tree(&dst).iter().any(|p| p.ends_with(".png"))
    });
    let code = child.wait().unwrap();
    let text = fs::read_to_string(&status).unwrap();
    let statuses: Vec<String> = text
        .lines()
        .map(|l| {
            serde_json::from_str::<serde_json::Value>(l).unwrap()["status"]
                .as_str()
                .unwrap()
                .to_owned()
        })
        .collect();
    assert_eq!(statuses.len(), 6, "{text}");
    if started {
        assert!(!code.success());
        assert!(statuses.iter().any(|s| s == "not-started"), "{text}");
    }
}

/// SIGINT to `child` once `ready`; whether it was sent before the child ended.
fn kill_when_signal(child: &mut std::process::Child, mut ready: impl FnMut() -> bool) -> bool {
    let started = std::time::Instant::now();
    loop {
        if ready() {
            let pid = i32::try_from(child.id()).unwrap();
            // SAFETY: kill(2) on our own child.
            unsafe { libc::kill(pid, libc::SIGINT) };
            return true;
        }
        if child.try_wait().unwrap().is_some() || started.elapsed() > Duration::from_secs(60) {
            return false;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn a_second_unsharded_run_on_one_dst_is_refused_naming_shard() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    fs::create_dir(&src).unwrap();
    fs::write(src.join("v.y4m"), clip(4, 0)).unwrap();
    fs::create_dir(&dst).unwrap();
    // The lock a run with --shard holds (shared): an unsharded run is
    // refused, changing nothing; another shard runs beside it.
    let lock = fs::File::open(&dst).unwrap();
    lock.lock_shared().unwrap();
    let res = run(&args!["dataset", src, dst]);
    assert!(!res.status.success());
    assert!(stderr(&res).contains("--shard"), "{}", stderr(&res));
    assert!(!dst.join("v").exists());
    ok(&run(&args!["dataset", src, dst, "--shard", "0/2"]));
    ok(&run(&args!["dataset", src, dst, "--shard", "1/2"]));
    drop(lock);
    // The lock an unsharded run holds (exclusive): every other run is refused.
    let lock = fs::File::open(&dst).unwrap();
    lock.lock().unwrap();
    assert!(
        !run(&args!["dataset", src, dst, "--shard", "0/2"])
            .status
            .success()
    );
    drop(lock);
    ok(&run(&args!["dataset", src, dst]));
}

/// A small fixed-seed generator (xorshift64*).
struct Rng(u64);

impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 33) as usize % n
    }
}

/// The settings the randomized test moves between.
const FLAG_SETS: [&[&str]; 7] = [
    &[],
    &["--viz"],
    &["--npy=v_R", "--npy-dtype", "f16"],
    &["--keep-count"],
    &["--image-format", "jpg"],
    &["--step", "2"],
    &["--no-rep", "--flo", "--viz"],
];

/// The items of `src`: (output path, source, refused in folder mode).
fn current_items(src: &Path) -> Vec<(String, std::path::PathBuf, bool)> {
    let mut items = Vec::new();
    for f in tree(src) {
        let rel = f.as_str();
        if let Some(stem) = rel.strip_suffix(".y4m") {
            items.push((stem.to_owned(), src.join(rel), false));
        } else if let Some((dir, _)) = rel.rsplit_once('/')
            && rel.ends_with(".pgm")
            && !items.iter().any(|(r, _, _)| r == dir)
        {
            items.push((dir.to_owned(), src.join(dir), false));
        }
    }
    let folders: Vec<String> = items.iter().map(|i| i.0.clone()).collect();
    for item in &mut items {
        let mut child = Path::new(&item.0);
        while let Some(parent) = child.parent() {
            let name = child.file_name().unwrap().to_str().unwrap();
            if folders.iter().any(|f| Path::new(f) == parent) && SIDES.contains(&name) {
                item.2 = true;
            }
            child = parent;
        }
    }
    items
}

/// The bytes of a source (a video, or a frame folder's files by name).
fn source_bytes(src: &Path) -> Vec<u8> {
    if src.is_file() {
        return fs::read(src).unwrap();
    }
    let mut all = Vec::new();
    for f in tree(src).into_iter().filter(|f| !f.contains('/')) {
        all.extend(f.as_bytes());
        all.extend(fs::read(src.join(&f)).unwrap());
    }
    all
}

#[test]
fn any_sequence_of_edits_kills_and_reruns_ends_in_runs_output() {
    let seed: u64 = std::env::var("REYNOLDSFLOW_DATASET_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5eed_2026);
    let steps: usize = std::env::var("REYNOLDSFLOW_DATASET_STEPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(300);
    println!("seed {seed} (REYNOLDSFLOW_DATASET_SEED={seed} reruns this sequence), {steps} steps");
    let mut rng = Rng(seed | 1);
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    let video = |n: usize, shift: usize| {
        let f: Vec<_> = (0..n).map(|t| moving_frame(16, 12, t + shift)).collect();
        y4m(&f, "420jpeg")
    };
    let frame = |shift: usize| pgm(&moving_frame(16, 12, shift));
    fs::create_dir_all(src.join("d/seq2")).unwrap();
    fs::create_dir_all(src.join("a")).unwrap();
    fs::write(src.join("a.y4m"), video(4, 0)).unwrap();
    fs::write(src.join("a/n.y4m"), video(3, 1)).unwrap();
    fs::write(src.join("a/hsv.y4m"), video(3, 2)).unwrap();
    fs::write(src.join("d/b.y4m"), video(5, 3)).unwrap();
    for (i, name) in ["f0.pgm", "f1.pgm", "f2.pgm"].iter().enumerate() {
        fs::write(src.join("seq").join(name), frame(i)).ok();
        fs::create_dir_all(src.join("seq")).unwrap();
        fs::write(src.join("seq").join(name), frame(i)).unwrap();
        fs::write(src.join("d/seq2").join(name), frame(i + 4)).unwrap();
    }
    let mut flags: &[&str] = &[];
    let mut webdataset = false;
    let mut cache: BTreeMap<(Vec<u8>, String), BTreeMap<String, Vec<u8>>> = BTreeMap::new();
    let mut checked = 0;
    for step in 0..steps {
        let items = current_items(&src);
        let sources: Vec<String> = tree(&src);
        let op = rng.below(10);
        let what = match op {
            // Edit a source file's content.
            0 => {
                let f = &sources[rng.below(sources.len())];
                let shift = rng.below(20);
                let bytes = if f.ends_with(".y4m") {
                    video(3 + rng.below(3), shift)
                } else {
                    frame(shift)
                };
                fs::write(src.join(f), bytes).unwrap();
                format!("edit {f}")
            }
            // Replace with the same size and modification time.
            1 => {
                let f = &sources[rng.below(sources.len())];
                let path = src.join(f);
                let meta = fs::metadata(&path).unwrap();
                let shift = 20 + rng.below(20);
                let bytes = if f.ends_with(".y4m") {
                    let n = (meta.len() as usize - 36) / (6 + 16 * 12 * 3 / 2);
                    video(n.max(1), shift)
                } else {
                    frame(shift)
                };
                if bytes.len() as u64 == meta.len() {
                    fs::write(&path, bytes).unwrap();
                    fs::File::options()
                        .write(true)
                        .open(&path)
                        .unwrap()
                        .set_modified(meta.modified().unwrap())
                        .unwrap();
                }
                format!("replace {f} (same size and time)")
            }
            // Rename a source (a video, or a frame in its folder).
            2 => {
                let f = &sources[rng.below(sources.len())];
                let (dir, name) = f.rsplit_once('/').unwrap_or(("", f));
                let to = format!("{}{}r{name}", dir, if dir.is_empty() { "" } else { "/" });
                if !src.join(&to).exists() && to.len() < 40 {
                    fs::rename(src.join(f), src.join(&to)).unwrap();
                }
                format!("rename {f} -> {to}")
            }
            // Delete a source; or create one.
            3 => {
                let f = &sources[rng.below(sources.len())];
                let frames_left = f.rsplit_once('/').map_or(0, |(d, _)| {
                    sources
                        .iter()
                        .filter(|s| s.ends_with(".pgm") && s.rsplit_once('/').unwrap().0 == d)
                        .count()
                });
                if sources.len() > 4 && (f.ends_with(".y4m") || frames_left > 3) {
                    fs::remove_file(src.join(f)).unwrap();
                    format!("delete {f}")
                } else {
                    let name = format!("new{}.y4m", rng.below(3));
                    fs::write(src.join(&name), video(3, rng.below(9))).unwrap();
                    format!("create {name}")
                }
            }
            // Delete an output file.
            4 => {
                let outs: Vec<String> = tree(&dst).into_iter().collect();
                if outs.is_empty() {
                    "delete no output".into()
                } else {
                    let f = &outs[rng.below(outs.len())];
                    fs::remove_file(dst.join(f)).unwrap();
                    format!("delete output {f}")
                }
            }
            // Cut or corrupt a manifest.
            5 => {
                let m: Vec<String> = tree(&dst)
                    .into_iter()
                    .filter(|f| f.ends_with(MANIFEST))
                    .collect();
                if m.is_empty() {
                    "no manifest".into()
                } else {
                    let f = &m[rng.below(m.len())];
                    let mut bytes = fs::read(dst.join(f)).unwrap();
                    let at = rng.below(bytes.len());
                    if rng.below(2) == 0 {
                        bytes.truncate(at);
                    } else {
                        bytes[at] ^= 1 << rng.below(8);
                    }
                    fs::write(dst.join(f), bytes).unwrap();
                    format!("damage {f} at {at}")
                }
            }
            // SIGKILL mid-run.
            6 => {
                let mut a = args!["dataset", src, dst, "--threads", "1"].to_vec();
                if webdataset {
                    a.push("--webdataset".into());
                }
                let mut child = Command::new(BIN)
                    .args(cmd(&a, flags))
                    .env_remove("SLURM_ARRAY_TASK_ID")
                    .env_remove("JOB_COMPLETION_INDEX")
                    .stdout(Stdio::null())
                    .stderr(Stdio::null())
                    .spawn()
                    .unwrap();
                std::thread::sleep(Duration::from_millis(rng.below(60) as u64));
                let _ = child.kill();
                child.wait().unwrap();
                "kill mid-run".into()
            }
            7 => {
                flags = FLAG_SETS[rng.below(FLAG_SETS.len())];
                format!("settings {flags:?}")
            }
            8 => {
                webdataset = !webdataset;
                format!("webdataset {webdataset}")
            }
            _ => "rerun".into(),
        };
        if op < 7 && rng.below(3) != 0 {
            continue;
        }
        // Rerun, and check.
        let mut a = args!["dataset", src, dst].to_vec();
        if webdataset {
            a.push("--webdataset".into());
        }
        let res = run(&cmd(&a, flags));
        let items = current_items(&src)
            .into_iter()
            .chain(items.into_iter().take(0))
            .collect::<Vec<_>>();
        let refused = |i: &(String, std::path::PathBuf, bool)| i.2 && !webdataset;
        let failed: Vec<String> = records(&res)
            .iter()
            .filter(|r| r["status"] != "done" && r["status"] != "skipped")
            .map(|r| r["path"].as_str().unwrap().to_owned())
            .collect();
        let expected: Vec<String> = items
            .iter()
            .filter(|i| refused(i))
            .map(|i| i.1.display().to_string())
            .collect();
        let context = format!(
            "seed {seed}, step {step} ({what}), flags {flags:?}, webdataset {webdataset}: {}",
            stderr(&res)
        );
        assert_eq!(failed, expected, "{context}");
        assert_eq!(res.status.success(), expected.is_empty(), "{context}");
        let mut want = |src: &Path| -> BTreeMap<String, Vec<u8>> {
            cache
                .entry((source_bytes(src), flags.join(" ")))
                .or_insert_with(|| run_output(src, flags))
                .clone()
        };
        if webdataset {
            let hidden: Vec<String> = fs::read_dir(&dst)
                .unwrap()
                .flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with('.'))
                .collect();
            assert!(hidden.is_empty(), "{context}: {hidden:?}");
            let all = tar_members(&dst);
            let mut members: BTreeMap<String, Vec<u8>> = BTreeMap::new();
            for (_, list) in all {
                for (name, bytes) in list {
                    assert!(
                        members.insert(name.clone(), bytes).is_none(),
                        "{context}: {name} twice"
                    );
                }
            }
            let mut expected_members = BTreeSet::new();
            for (rel, src, _) in &items {
                for (file, bytes) in want(src) {
                    let (dir, name) = file.rsplit_once('/').unwrap_or(("rep", &file));
                    let (stem, ext) = name.rsplit_once('.').unwrap();
                    let key = format!("{rel}/{stem}");
                    let member = format!("{key}.{dir}.{ext}");
                    assert!(members.get(&member) == Some(&bytes), "{context}: {member}");
                    expected_members.insert(member);
                    expected_members.insert(format!("{key}.json"));
                }
            }
            let extra: Vec<&String> = members
                .keys()
                .filter(|k| !expected_members.contains(*k))
                .collect();
            assert!(extra.is_empty(), "{context}: extra members {extra:?}");
        } else {
            for item in items.iter().filter(|i| !refused(i)) {
                let dir = dst.join(&item.0);
                let got = item_files(&dir);
                let want = want(&item.1);
                assert_eq!(
                    got.keys().collect::<Vec<_>>(),
                    want.keys().collect::<Vec<_>>(),
                    "{context}: {}",
                    item.0
                );
                assert!(got == want, "{context}: {} bytes", item.0);
                let hidden: Vec<String> = fs::read_dir(&dir)
                    .unwrap()
                    .flatten()
                    .map(|e| e.file_name().to_string_lossy().into_owned())
                    .filter(|n| n.starts_with('.') && n != MANIFEST)
                    .collect();
                assert!(hidden.is_empty(), "{context}: {} holds {hidden:?}", item.0);
                for side in SIDES {
                    assert!(temp_files(&dir.join(side)).is_empty(), "{context}");
                }
            }
        }
        checked += 1;
    }
    println!("{checked} reruns checked");
    assert!(checked > steps / 4, "{checked}");
}
