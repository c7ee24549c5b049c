//! `dataset --webdataset`: tar shards whose members are byte for byte the
//! files `dataset` writes, split between items, resumable, shared by
//! concurrent `--shard` processes, and whole after a SIGKILL and a rerun.

mod run_support;

use std::collections::BTreeMap;
use std::ffi::OsStr;
use std::fs;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use run_support::*;

/// Y4M clips (one nested), a frame folder with a dotted stem, a text file.
fn source_tree(root: &Path, clips: usize, frames: usize) {
    source_tree_of(root, clips, frames, (40, 24));
}

/// [`source_tree`] with frames of `size`.
fn source_tree_of(root: &Path, clips: usize, frames: usize, size: (usize, usize)) {
    let f: Vec<_> = (0..frames)
        .map(|t| moving_frame(size.0, size.1, t))
        .collect();
    fs::create_dir_all(root.join("class_a")).unwrap();
    fs::create_dir_all(root.join("class_b/seq")).unwrap();
    // (FNV-1a modulo 2 is the parity of the odd bytes of the path: these
    // names alternate between the shards of 2.)
    for i in 0..clips {
        fs::write(
            root.join(format!("class_a/clip{i}.y4m")),
            y4m(&f, "420jpeg"),
        )
        .unwrap();
    }
    for (i, g) in f.iter().take(4).enumerate() {
        fs::write(root.join(format!("class_b/seq/img.{i:03}.pgm")), pgm(g)).unwrap();
    }
    fs::write(root.join("notes.txt"), "not a video").unwrap();
}

/// `(tar, member) -> bytes` of every member of every tar.
type Members = BTreeMap<(String, String), Vec<u8>>;
/// `tar -> member names` in the order the tar holds them.
type MemberOrder = BTreeMap<String, Vec<String>>;

/// Every member of every `*.tar` in `dir`, and the member order of each tar.
fn shards(dir: &Path) -> (Members, MemberOrder) {
    let mut members = BTreeMap::new();
    let mut order = BTreeMap::new();
    for name in tree(dir).into_iter().filter(|n| n.ends_with(".tar")) {
        let mut archive = tar::Archive::new(fs::File::open(dir.join(&name)).unwrap());
        let mut names = Vec::new();
        for entry in archive.entries().unwrap() {
            let mut entry = entry.unwrap();
            let header = entry.header();
            assert_eq!(header.mtime().unwrap(), 0);
            assert_eq!(header.mode().unwrap(), 0o644);
            let member = entry.path().unwrap().to_string_lossy().into_owned();
            let mut bytes = Vec::new();
            std::io::Read::read_to_end(&mut entry, &mut bytes).unwrap();
            names.push(member.clone());
            members.insert((name.clone(), member), bytes);
        }
        order.insert(name, names);
    }
    (members, order)
}

/// The members alone, whatever tar holds them.
fn samples(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    shards(dir)
        .0
        .into_iter()
        .map(|((_, member), bytes)| (member, bytes))
        .collect()
}

fn records(out: &std::process::Output) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

#[test]
fn members_are_the_files_dataset_writes_byte_for_byte() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, files, wds) = (
        tmp.path().join("src"),
        tmp.path().join("files"),
        tmp.path().join("wds"),
    );
    source_tree(&src, 3, 5);
    let flags = ["--npy=v_R", "--npy-dtype", "f32", "--flo", "--keep-count"];
    let mut a = args!["dataset", src, files].to_vec();
    a.extend(flags.iter().map(std::ffi::OsString::from));
    ok(&run(&a));
    let mut a = args!["dataset", src, wds, "--webdataset", "--threads", "2"].to_vec();
    a.extend(flags.iter().map(std::ffi::OsString::from));
    let res = run(&a);
    let err = ok(&res);
    assert!(err.contains("4 items: 4 done"), "{err}");
    assert_eq!(tree(&wds), ["shard-000000.tar"]);
    let members = samples(&wds);
    // Each result: rep.png, v_R.npy, v_R.flo, json; 5 + 5 + 5 + 4 outputs (keep-count).
    assert_eq!(members.len(), 4 * 19);
    let mut pngs = 0;
    for file in tree(&files) {
        if file.ends_with(".reynoldsflow-done") {
            continue;
        }
        let path = Path::new(&file);
        let (dir, name) = (
            path.parent().unwrap(),
            path.file_name().unwrap().to_str().unwrap(),
        );
        // files/ITEM/STEM.png, files/ITEM/v_R/STEM.npy
        let (item, kind) = match dir.file_name().and_then(|n| n.to_str()) {
            Some("v_R") => (dir.parent().unwrap(), "v_R"),
            _ => (dir, "rep"),
        };
        let (stem, ext) = name.rsplit_once('.').unwrap();
        let key = format!("{}/{}", item.display(), stem.replace('.', "_"));
        let member = format!("{key}.{kind}.{ext}");
        let bytes = members
            .get(&member)
            .unwrap_or_else(|| panic!("{member} missing; members: {:?}", members.keys()));
        assert_eq!(bytes, &fs::read(files.join(&file)).unwrap(), "{member}");
        pngs += usize::from(ext == "png");
        let meta: serde_json::Value =
            serde_json::from_slice(&members[&format!("{key}.json")]).unwrap();
        assert_eq!(meta["key"], key);
        assert!(meta["motion"].as_f64().unwrap() > 0.0, "{meta}");
        assert_eq!(meta["settings"]["npy_dtype"], "f32");
        assert_eq!(meta["source_frames"].as_array().unwrap().len(), 2);
    }
    assert_eq!(pngs, 19);
    let seq: serde_json::Value =
        serde_json::from_slice(&members["class_b/seq/img_001.json"]).unwrap();
    assert_eq!(seq["source"], "class_b/seq");
    assert_eq!(seq["source_frames"], serde_json::json!([1, 2]));
    let clip: serde_json::Value =
        serde_json::from_slice(&members["class_a/clip0/000004.json"]).unwrap();
    assert_eq!(clip["source"], "class_a/clip0.y4m");
    assert_eq!(clip["source_frames"], serde_json::json!([3, 4]));
    for r in records(&res) {
        assert_eq!(r["status"], "done");
        assert!(
            r["output"]
                .as_str()
                .unwrap()
                .ends_with("wds/shard-000000.tar"),
            "{r}"
        );
    }
    // A rerun skips every item and leaves the shard as it was.
    let before = fs::read(wds.join("shard-000000.tar")).unwrap();
    let mut a = args!["dataset", src, wds, "--webdataset"].to_vec();
    a.extend(flags.iter().map(std::ffi::OsString::from));
    let again = run(&a);
    let err = ok(&again);
    assert!(err.contains("0 done, 4 already finished"), "{err}");
    let statuses: Vec<_> = records(&again)
        .iter()
        .map(|r| r["outputs"].clone())
        .collect();
    assert_eq!(
        statuses.iter().map(|o| o.as_u64().unwrap()).sum::<u64>(),
        19
    );
    assert_eq!(tree(&wds), ["shard-000000.tar"]);
    assert_eq!(fs::read(wds.join("shard-000000.tar")).unwrap(), before);
    // Other options redo every item: its samples made before go from the shard.
    let err = ok(&run(&args!["dataset", src, wds, "--webdataset"]));
    assert!(err.contains("4 done"), "{err}");
    assert_eq!(samples(&wds).len(), 2 * (4 + 4 + 4 + 3));
    // --force redoes them again, to the same samples.
    let redone = samples(&wds);
    ok(&run(&args!["dataset", src, wds, "--webdataset", "--force"]));
    assert_eq!(samples(&wds), redone);
    assert_eq!(samples(&wds).len(), 2 * (4 + 4 + 4 + 3));
}

#[test]
fn shards_close_between_items_and_failed_items_leave_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    source_tree(&src, 5, 4);
    let f: Vec<_> = (0..3).map(|t| moving_frame(40, 24, t)).collect();
    let mut cut = y4m(&f, "mono");
    cut.truncate(cut.len() - 10);
    fs::write(src.join("class_a/cut.y4m"), cut).unwrap();
    let res = run(&args![
        "dataset",
        src,
        dst,
        "--webdataset",
        "--shard-size",
        "8k"
    ]);
    assert_eq!(res.status.code(), Some(1), "{}", stderr(&res));
    assert!(
        stderr(&res).contains("cut.y4m: truncated"),
        "{}",
        stderr(&res)
    );
    let (members, order) = shards(&dst);
    assert!(order.len() >= 3, "{order:?}");
    assert!(
        members.keys().all(|(_, m)| !m.contains("cut")),
        "{:?}",
        members.keys()
    );
    // Each item lies whole in one shard.
    let mut home: BTreeMap<String, &str> = BTreeMap::new();
    for (tar, m) in members.keys() {
        let item = m.rsplit_once('/').unwrap().0.to_owned();
        let at = home.entry(item.clone()).or_insert(tar);
        assert_eq!(*at, tar.as_str(), "{item} is split");
    }
    assert_eq!(home.len(), 6);
    for (tar, names) in &order {
        assert!(names.last().unwrap().ends_with(".json"), "{tar}");
    }
    assert!(temp_files(&dst).is_empty());
    let failed: Vec<_> = records(&res)
        .into_iter()
        .filter(|r| r["status"] == "failed")
        .collect();
    assert_eq!(failed.len(), 1);
}

fn shard_process(src: &Path, dst: &Path, extra: &[&str]) -> Command {
    let mut cmd = Command::new(BIN);
    cmd.args([OsStr::new("dataset"), src.as_os_str(), dst.as_os_str()])
        .args(["--webdataset", "--threads", "1"])
        .args(extra)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .env_remove("REYNOLDSFLOW_ABORT_AFTER")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    cmd
}

#[test]
fn two_concurrent_shards_write_one_dst_between_them() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst, whole) = (
        tmp.path().join("src"),
        tmp.path().join("dst"),
        tmp.path().join("whole"),
    );
    source_tree(&src, 10, 4);
    ok(&shard_process(&src, &whole, &["--shard-size", "20k"])
        .output()
        .unwrap());
    let a = shard_process(&src, &dst, &["--shard", "0/2", "--shard-size", "20k"])
        .spawn()
        .unwrap();
    let b = shard_process(&src, &dst, &["--shard", "1/2", "--shard-size", "20k"])
        .spawn()
        .unwrap();
    let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    ok(&a);
    ok(&b);
    let names = tree(&dst);
    assert!(
        names.iter().any(|n| n.starts_with("shard-0000-")),
        "{names:?}"
    );
    assert!(
        names.iter().any(|n| n.starts_with("shard-0001-")),
        "{names:?}"
    );
    assert!(
        names.iter().all(|n| n.starts_with("shard-000")),
        "{names:?}"
    );
    let (pa, pb) = (records(&a), records(&b));
    assert_eq!(pa.len() + pb.len(), 11);
    for r in pa.iter().chain(&pb) {
        assert_eq!(r["status"], "done", "{r}");
    }
    // Between them, the unsharded run's samples, byte for byte.
    assert_eq!(samples(&dst), samples(&whole));
}

#[test]
fn a_sigkill_mid_shard_then_a_rerun_gives_the_same_shards() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst, whole) = (
        tmp.path().join("src"),
        tmp.path().join("dst"),
        tmp.path().join("whole"),
    );
    // Enough work that the kill lands inside a later shard.
    source_tree_of(&src, 12, 16, (160, 120));
    let size = ["--shard-size", "300k"];
    ok(&shard_process(&src, &whole, &size).output().unwrap());
    let uninterrupted = shards(&whole);
    assert!(uninterrupted.1.len() >= 4, "{:?}", uninterrupted.1.keys());

    let mut child = shard_process(&src, &dst, &size)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let killed = kill_when(&mut child, Duration::from_secs(120), || {
        let complete = tree(&dst).iter().filter(|n| n.ends_with(".tar")).count();
        complete >= 1 && !temp_files(&dst).is_empty()
    });
    let left = tree(&dst);
    println!("killed mid-shard: {killed}; left: {left:?}");
    assert!(killed, "the run ended before it could be killed mid-shard");
    // Only complete shards under final names; the one being written is a temp.
    assert!(!temp_files(&dst).is_empty(), "{left:?}");
    for name in left.iter().filter(|n| n.ends_with(".tar")) {
        assert_eq!(
            fs::read(dst.join(name)).unwrap(),
            fs::read(whole.join(name)).unwrap(),
            "{name}: a shard complete at the kill is the uninterrupted run's"
        );
    }
    let res = shard_process(&src, &dst, &size).output().unwrap();
    let err = ok(&res);
    assert!(err.contains("already finished (skipped)"), "{err}");
    assert!(temp_files(&dst).is_empty(), "{:?}", tree(&dst));
    assert_eq!(tree(&dst), tree(&whole));
    for name in tree(&dst) {
        assert_eq!(
            fs::read(dst.join(&name)).unwrap(),
            fs::read(whole.join(&name)).unwrap(),
            "{name}"
        );
    }
}

#[test]
fn webdataset_usage_errors_exit_2() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("src");
    source_tree(&src, 1, 3);
    for (flags, word) in [
        (vec!["--shard-size", "1k"], "--webdataset"),
        (vec!["--webdataset", "--shard-size", "0"], "--shard-size"),
        (vec!["--webdataset", "--shard-size", "1.5G"], "--shard-size"),
    ] {
        let mut a = args!["dataset", src, tmp.path().join("dst")].to_vec();
        a.extend(flags.iter().map(std::ffi::OsString::from));
        let res = run(&a);
        assert_eq!(res.status.code(), Some(2), "{flags:?}: {}", stderr(&res));
        assert!(stderr(&res).contains(word), "{}", stderr(&res));
    }
}
