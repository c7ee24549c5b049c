//! `reynoldsflow dataset` end to end: the mirrored tree, bad files skipped
//! and reported, and resuming after a crash or a kill with no partial file
//! left behind.

mod run_support;

use std::ffi::OsStr;
use std::fs;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use run_support::*;

const MARKER: &str = ".reynoldsflow-done";

/// SRC: two Y4M videos (one nested), two frame folders (one nested in the
/// other), files that are neither, and (with ffmpeg) an MP4.
fn source_tree(root: &Path, with_ffmpeg: bool) {
    let f: Vec<_> = (0..5).map(|t| moving_frame(32, 24, t)).collect();
    fs::create_dir_all(root.join("a/b")).unwrap();
    fs::write(root.join("a/b/clip.y4m"), y4m(&f, "420jpeg")).unwrap();
    fs::write(root.join("a/short.y4m"), y4m(&f[..3], "444")).unwrap();
    let seq = root.join("seq1");
    fs::create_dir_all(seq.join("inner")).unwrap();
    for (i, name) in ["img2.pgm", "img10.pgm", "img1.pgm"].iter().enumerate() {
        fs::write(seq.join(name), pgm(&f[i])).unwrap();
    }
    fs::write(seq.join("labels.txt"), "walk\n").unwrap();
    fs::write(seq.join("inner/x1.png"), png_gray(&f[3])).unwrap();
    fs::write(seq.join("inner/x2.png"), png_gray(&f[4])).unwrap();
    fs::write(root.join("README"), "not a video").unwrap();
    if with_ffmpeg {
        let frames = root.join(".frames");
        write_pgms(&frames, &f);
        ffmpeg_encode(
            &frames,
            &root.join("a/movie.mp4"),
            &["-c:v", "mpeg4", "-q:v", "2"],
        );
        fs::remove_dir_all(frames).unwrap();
    }
}

fn expected_tree(with_ffmpeg: bool) -> Vec<String> {
    let mut files: Vec<String> = [
        "a/b/clip/.reynoldsflow-done",
        "a/b/clip/000000.png",
        "a/b/clip/000001.png",
        "a/b/clip/000002.png",
        "a/b/clip/000003.png",
        "a/short/.reynoldsflow-done",
        "a/short/000000.png",
        "a/short/000001.png",
        "seq1/.reynoldsflow-done",
        "seq1/img1.png",
        "seq1/img2.png",
        "seq1/inner/.reynoldsflow-done",
        "seq1/inner/x1.png",
    ]
    .map(String::from)
    .to_vec();
    if with_ffmpeg {
        files.extend(
            [
                "a/movie/.reynoldsflow-done",
                "a/movie/000000.png",
                "a/movie/000001.png",
                "a/movie/000002.png",
                "a/movie/000003.png",
            ]
            .map(String::from),
        );
    }
    files.sort();
    files
}

#[test]
fn mirrors_videos_and_frame_folders_and_skips_finished_items() {
    let ffmpeg = have_ffmpeg();
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    source_tree(&src, ffmpeg);
    let err = ok(&run(&args!["dataset", src, dst, "--threads", "2"]));
    let items = if ffmpeg { 5 } else { 4 };
    assert!(
        err.contains(&format!("{items} items: {items} done, 0 already finished")),
        "{err}"
    );
    assert_eq!(tree(&dst), expected_tree(ffmpeg));
    // Frame folders keep their stems; videos are numbered; same bytes as `run`.
    let single = tmp.path().join("single");
    ok(&run(&args!["run", src.join("seq1"), "--out", single]));
    for stem in ["img1", "img2"] {
        assert_eq!(
            fs::read(dst.join(format!("seq1/{stem}.png"))).unwrap(),
            fs::read(single.join(format!("{stem}.png"))).unwrap()
        );
    }
    let marker = fs::read_to_string(dst.join("a/b/clip").join(MARKER)).unwrap();
    assert!(
        marker.contains("\"frames\":5") && marker.contains("\"results\":4"),
        "{marker}"
    );

    // A rerun skips everything; other options redo everything; --force too.
    let err = ok(&run(&args!["dataset", src, dst]));
    assert!(
        err.contains(&format!("0 done, {items} already finished (skipped)")),
        "{err}"
    );
    let err = ok(&run(&args!["dataset", src, dst, "--keep-count"]));
    assert!(err.contains(&format!("{items} done, 0 already")), "{err}");
    assert!(
        dst.join("seq1/img10.png").is_file(),
        "--keep-count output for the last frame"
    );
    let err = ok(&run(&args!["dataset", src, dst, "--keep-count", "--force"]));
    assert!(err.contains(&format!("{items} done")), "{err}");

    // SRC a single video: DST/<stem>/.
    let one = tmp.path().join("one");
    ok(&run(&args!["dataset", src.join("a/short.y4m"), one]));
    assert_eq!(
        tree(&one),
        [
            "short/.reynoldsflow-done",
            "short/000000.png",
            "short/000001.png"
        ]
    );
}

#[test]
fn a_bad_file_is_reported_and_skipped_and_the_exit_status_says_so() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    source_tree(&src, false);
    let f: Vec<_> = (0..3).map(|t| moving_frame(32, 24, t)).collect();
    let mut cut = y4m(&f, "mono");
    cut.truncate(cut.len() - 10);
    fs::write(src.join("a/cut.y4m"), cut).unwrap();
    fs::write(src.join("a/deep.y4m"), b"YUV4MPEG2 W4 H4 C444p12\n").unwrap();
    fs::create_dir(src.join("broken")).unwrap();
    fs::write(src.join("broken/f1.png"), b"\x89PNG\r\n\x1a\ngarbage").unwrap();
    fs::write(src.join("broken/f2.png"), png_gray(&f[0])).unwrap();
    // A video and a frame folder that would share an output folder.
    fs::write(src.join("seq1.y4m"), y4m(&f, "mono")).unwrap();
    let res = run(&args!["dataset", src, dst]);
    let err = stderr(&res);
    println!("{err}");
    assert_eq!(res.status.code(), Some(1), "{err}");
    assert!(
        err.contains("8 items: 4 done, 0 already finished (skipped), 4 failed"),
        "{err}"
    );
    assert!(err.contains("cut.y4m: truncated: frame 2"), "{err}");
    assert!(
        err.contains("deep.y4m: colour space C444p12 has 12-bit samples"),
        "{err}"
    );
    assert!(err.contains("f1.png: cannot decode"), "{err}");
    assert!(
        err.contains("seq1.y4m: its output folder") && err.contains("also the output of"),
        "{err}"
    );
    assert!(
        err.lines()
            .last()
            .unwrap()
            .starts_with("reynoldsflow: error: dataset: 4 of 8 items failed"),
        "{err}"
    );
    // The good items are complete; failed ones have no marker and no temp file.
    for good in ["a/b/clip", "a/short", "seq1", "seq1/inner"] {
        assert!(dst.join(good).join(MARKER).is_file(), "{good}");
    }
    assert!(!dst.join("a/cut").join(MARKER).exists());
    assert!(temp_files(&dst).is_empty());
}

#[test]
#[cfg_attr(
    not(feature = "crash-injection"),
    ignore = "the crash hook needs --features reynoldsflow-cli/crash-injection (scripts/test)"
)]
fn resumes_after_a_crash_mid_write_with_no_partial_file_left() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    source_tree(&src, false);
    let reference = tmp.path().join("reference");
    ok(&run(&args!["dataset", src, reference, "--threads", "1"]));

    // Crash after 5 results: one item finished, one half done with a temp file.
    let res = run_with(
        &args!["dataset", src, dst, "--threads", "1"],
        None,
        &[("REYNOLDSFLOW_ABORT_AFTER", OsStr::new("5"))],
    );
    assert!(!res.status.success(), "{}", stderr(&res));
    let leftovers = temp_files(&dst);
    assert_eq!(leftovers.len(), 1, "{:?}", tree(&dst));
    let markers = tree(&dst).iter().filter(|p| p.ends_with(MARKER)).count();
    assert!((1..4).contains(&markers), "{:?}", tree(&dst));

    let err = ok(&run(&args!["dataset", src, dst, "--threads", "1"]));
    assert!(
        err.contains(&format!("{markers} already finished (skipped)")),
        "{err}"
    );
    assert!(temp_files(&dst).is_empty(), "{:?}", tree(&dst));
    assert_eq!(tree(&dst), tree(&reference));
    for file in tree(&dst).iter().filter(|f| f.ends_with(".png")) {
        assert_eq!(
            fs::read(dst.join(file)).unwrap(),
            fs::read(reference.join(file)).unwrap(),
            "{file}"
        );
    }
}

#[test]
fn resumes_after_being_killed() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    // Enough work that the kill lands mid-run: 3 clips of 30 frames.
    let f: Vec<_> = (0..30).map(|t| moving_frame(96, 64, t)).collect();
    fs::create_dir(&src).unwrap();
    for name in ["c1.y4m", "c2.y4m", "c3.y4m"] {
        fs::write(src.join(name), y4m(&f, "420jpeg")).unwrap();
    }
    let mut child = Command::new(BIN)
        .args([
            OsStr::new("dataset"),
            src.as_os_str(),
            dst.as_os_str(),
            OsStr::new("--threads"),
            OsStr::new("1"),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let killed = kill_when(&mut child, Duration::from_secs(60), || {
        tree(&dst).iter().any(|p| p.ends_with(".png"))
    });
    let done_at_kill = tree(&dst).iter().filter(|p| p.ends_with(MARKER)).count();
    println!(
        "killed mid-run: {killed}; items finished at the kill: {done_at_kill}; files: {}",
        tree(&dst).len()
    );
    // Whatever the kill left, every PNG under its final name decodes whole.
    for file in tree(&dst).iter().filter(|f| f.ends_with(".png")) {
        rgb(&dst.join(file));
    }
    let err = ok(&run(&args!["dataset", src, dst]));
    assert!(err.contains("3 items"), "{err}");
    assert!(temp_files(&dst).is_empty(), "{:?}", tree(&dst));
    for clip in ["c1", "c2", "c3"] {
        let pngs = tree(&dst.join(clip))
            .iter()
            .filter(|f| f.ends_with(".png"))
            .count();
        assert_eq!(pngs, 29, "{clip}");
        assert!(dst.join(clip).join(MARKER).is_file());
    }
}

#[test]
fn dataset_usage_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let empty = tmp.path().join("empty");
    fs::create_dir(&empty).unwrap();
    let res = run(&args!["dataset", empty, tmp.path().join("dst")]);
    let err = stderr(&res);
    assert_eq!(res.status.code(), Some(1));
    assert!(
        err.contains("empty: no videos or frame folders found"),
        "{err}"
    );
    let res = run(&args![
        "dataset",
        tmp.path().join("missing"),
        tmp.path().join("dst")
    ]);
    assert_eq!(res.status.code(), Some(1));
    assert!(
        stderr(&res).contains("missing: No such file"),
        "{}",
        stderr(&res)
    );
    let res = run(&args!["dataset", empty]);
    assert_eq!(res.status.code(), Some(2));
    assert!(stderr(&res).contains("DST"), "{}", stderr(&res));
}

/// The JSON-lines status records of a run's stdout.
fn records(out: &std::process::Output) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l}: {e}")))
        .collect()
}

/// Twelve small Y4M clips and a frame folder.
fn many_items(src: &Path) {
    let f: Vec<_> = (0..4).map(|t| moving_frame(24, 16, t)).collect();
    fs::create_dir_all(src.join("class/seq")).unwrap();
    for i in 0..12 {
        fs::write(src.join(format!("class/clip{i}.y4m")), y4m(&f, "mono")).unwrap();
    }
    for (i, g) in f.iter().enumerate() {
        fs::write(src.join(format!("class/seq/f{i}.pgm")), pgm(g)).unwrap();
    }
}

#[test]
fn two_concurrent_shards_make_the_unsharded_run_between_them() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst, whole) = (
        tmp.path().join("src"),
        tmp.path().join("dst"),
        tmp.path().join("whole"),
    );
    many_items(&src);
    let all = run(&args!["dataset", src, whole, "--threads", "1"]);
    ok(&all);
    let statuses: Vec<_> = records(&all).iter().map(|r| r["status"].clone()).collect();
    assert_eq!(statuses.len(), 13);
    assert!(statuses.iter().all(|s| s == "done"), "{statuses:?}");

    let shard = |i: u32| {
        Command::new(BIN)
            .args([
                OsStr::new("dataset"),
                src.as_os_str(),
                dst.as_os_str(),
                OsStr::new("--threads"),
                OsStr::new("1"),
                OsStr::new("--shard"),
                OsStr::new(&format!("{i}/2")),
            ])
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env_remove("JOB_COMPLETION_INDEX")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (a, b) = (shard(0), shard(1));
    let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    ok(&a);
    ok(&b);
    let paths = |out| -> Vec<String> {
        records(out)
            .iter()
            .map(|r| r["path"].as_str().unwrap().to_owned())
            .collect()
    };
    let (pa, pb) = (paths(&a), paths(&b));
    assert!(!pa.is_empty() && !pb.is_empty(), "{pa:?} {pb:?}");
    assert!(
        pa.iter().all(|p| !pb.contains(p)),
        "disjoint: {pa:?} {pb:?}"
    );
    assert_eq!(pa.len() + pb.len(), 13);
    assert!(
        stderr(&a).contains("(shard 0/2 of 13 items)"),
        "{}",
        stderr(&a)
    );
    // The union, file for file and byte for byte (markers included).
    assert_eq!(tree(&dst), tree(&whole));
    for file in tree(&dst) {
        assert_eq!(
            fs::read(dst.join(&file)).unwrap(),
            fs::read(whole.join(&file)).unwrap(),
            "{file}"
        );
    }
    // A rerun of either shard skips everything.
    let again = run(&args!["dataset", src, dst, "--shard", "1/2"]);
    ok(&again);
    let again = records(&again);
    assert_eq!(again.len(), pb.len());
    for r in &again {
        assert_eq!(r["status"], "skipped", "{r}");
        assert_eq!(r["frames"], 4, "{r}");
        assert_eq!(r["error"], serde_json::Value::Null);
    }
}

#[test]
#[cfg_attr(
    not(feature = "crash-injection"),
    ignore = "the crash hook needs --features reynoldsflow-cli/crash-injection (scripts/test)"
)]
fn a_killed_shard_rerun_leaves_no_partial_file() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst, whole) = (
        tmp.path().join("src"),
        tmp.path().join("dst"),
        tmp.path().join("whole"),
    );
    many_items(&src);
    ok(&run(&args!["dataset", src, whole, "--threads", "1"]));
    // Crash mid-write after 4 results: one item done, one with a temp file.
    let res = run_with(
        &args!["dataset", src, dst, "--threads", "1", "--shard", "0/2"],
        None,
        &[("REYNOLDSFLOW_ABORT_AFTER", OsStr::new("4"))],
    );
    assert!(!res.status.success());
    assert_eq!(temp_files(&dst).len(), 1, "{:?}", tree(&dst));
    let status = tmp.path().join("status.jsonl");
    for i in 0..2 {
        ok(&run(&args![
            "dataset",
            src,
            dst,
            "--threads",
            "1",
            "--shard",
            format!("{i}/2"),
            "--status",
            status
        ]));
    }
    assert!(temp_files(&dst).is_empty(), "{:?}", tree(&dst));
    assert_eq!(tree(&dst), tree(&whole));
    for file in tree(&dst).iter().filter(|f| f.ends_with(".png")) {
        assert_eq!(
            fs::read(dst.join(file)).unwrap(),
            fs::read(whole.join(file)).unwrap()
        );
    }
    // Both shards appended to one status file: one whole record per item.
    let text = fs::read_to_string(&status).unwrap();
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 13);
    assert_eq!(lines.iter().filter(|r| r["status"] == "skipped").count(), 1);
}

#[test]
fn the_shard_comes_from_slurm_or_kubernetes_variables() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("src");
    many_items(&src);
    let items = |out: &std::process::Output| -> Vec<String> {
        let mut v: Vec<String> = records(out)
            .iter()
            .map(|r| r["path"].as_str().unwrap().to_owned())
            .collect();
        v.sort();
        v
    };
    let by_flag = run(&args![
        "dataset",
        src,
        tmp.path().join("a"),
        "--shard",
        "1/3"
    ]);
    let slurm = run_with(
        &args!["dataset", src, tmp.path().join("b")],
        None,
        &[
            ("SLURM_ARRAY_TASK_ID", OsStr::new("2")),
            ("SLURM_ARRAY_TASK_MIN", OsStr::new("1")),
            ("SLURM_ARRAY_TASK_COUNT", OsStr::new("3")),
        ],
    );
    let k8s = run_with(
        &args!["dataset", src, tmp.path().join("c"), "--shards", "3"],
        None,
        &[("JOB_COMPLETION_INDEX", OsStr::new("1"))],
    );
    assert!(
        stderr(&slurm).contains("from Slurm array task 2"),
        "{}",
        stderr(&slurm)
    );
    assert!(stderr(&k8s).contains("Kubernetes completion index 1 of 3"));
    assert!(!items(&by_flag).is_empty());
    assert_eq!(items(&slurm), items(&by_flag));
    assert_eq!(items(&k8s), items(&by_flag));
    // The count is needed with a Kubernetes index; an index must be below it.
    let res = run_with(
        &args!["dataset", src, tmp.path().join("d")],
        None,
        &[("JOB_COMPLETION_INDEX", OsStr::new("1"))],
    );
    assert_eq!(res.status.code(), Some(1));
    assert!(stderr(&res).contains("--shards N"), "{}", stderr(&res));
    let res = run(&args![
        "dataset",
        src,
        tmp.path().join("e"),
        "--shard",
        "3/3"
    ]);
    assert_eq!(res.status.code(), Some(2));
    assert!(
        stderr(&res).contains("not below the count"),
        "{}",
        stderr(&res)
    );
}

#[test]
fn files_from_takes_the_listed_items_only() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    many_items(&src);
    let list = tmp.path().join("todo.txt");
    fs::write(
        &list,
        format!(
            "# two clips, the frames, a missing file\nclass/clip3.y4m\n\n{}\nclass/seq\nclass/gone.y4m\n",
            src.join("class/clip7.y4m").display()
        ),
    )
    .unwrap();
    let res = run(&args!["dataset", src, dst, "--files-from", list]);
    assert_eq!(res.status.code(), Some(1), "{}", stderr(&res));
    let mut got: Vec<(String, String)> = records(&res)
        .iter()
        .map(|r| {
            (
                r["output"].as_str().unwrap().to_owned(),
                r["status"].as_str().unwrap().to_owned(),
            )
        })
        .collect();
    got.sort();
    let out = |rel: &str| dst.join(rel).display().to_string();
    assert_eq!(
        got,
        [
            (out("class/clip3"), "done".to_owned()),
            (out("class/clip7"), "done".to_owned()),
            (out("class/gone"), "failed".to_owned()),
            (out("class/seq"), "done".to_owned()),
        ]
    );
    assert!(stderr(&res).contains("4 items: 3 done"), "{}", stderr(&res));
    // Three outputs and a marker each.
    assert_eq!(tree(&dst).len(), 3 * 4);
    // A path outside SRC is refused before anything runs.
    fs::write(&list, "../elsewhere.y4m\n").unwrap();
    let res = run(&args![
        "dataset",
        src,
        tmp.path().join("x"),
        "--files-from",
        list
    ]);
    assert_eq!(res.status.code(), Some(1));
    assert!(
        stderr(&res).contains("line 1: ../elsewhere.y4m"),
        "{}",
        stderr(&res)
    );
    // A list needs a folder to be relative to; the message names the flag.
    let clip = src.join("class/clip3.y4m");
    let res = run(&args![
        "dataset",
        &clip,
        tmp.path().join("y"),
        "--files-from",
        list
    ]);
    assert_eq!(res.status.code(), Some(1));
    assert!(
        stderr(&res).contains(&format!(
            "--files-from: lists paths relative to the source, which must then be a folder: {} is not",
            clip.display()
        )),
        "{}",
        stderr(&res)
    );
}
