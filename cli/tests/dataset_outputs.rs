//! `reynoldsflow dataset`: DST holds exactly what the settings write, for
//! the right source. No item's outputs meet another's; a redone item
//! keeps no file of older settings; an item whose source changed or whose
//! outputs were lost is redone; an unreadable sub-folder fails alone.

mod run_support;

use std::ffi::OsStr;
use std::fs;
use std::path::Path;
use std::time::{Duration, SystemTime};

use run_support::*;

const MARKER: &str = ".reynoldsflow-done";

fn clip(path: &Path, frames: usize, shift: usize) {
    let f: Vec<_> = (0..frames)
        .map(|t| moving_frame(32, 24, t + shift))
        .collect();
    fs::create_dir_all(path.parent().unwrap()).unwrap();
    fs::write(path, y4m(&f, "420jpeg")).unwrap();
}

/// The JSON-lines status records of a run's stdout, by source file name.
fn statuses(out: &std::process::Output) -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .map(|r| {
            let path = r["path"].as_str().unwrap();
            let name = Path::new(path).file_name().unwrap().to_string_lossy();
            (name.into_owned(), r["status"].as_str().unwrap().to_owned())
        })
        .collect();
    v.sort();
    v
}

/// Every file `run SRC --out` writes with `flags`, as (name, bytes).
fn run_files(tmp: &Path, src: &Path, flags: &[&str]) -> Vec<(String, Vec<u8>)> {
    let out = tmp.join("reference");
    let _ = fs::remove_dir_all(&out);
    let mut a = args!["run", src, "--out", out].to_vec();
    a.extend(flags.iter().map(|f| (*f).into()));
    ok(&run(&a));
    tree(&out)
        .into_iter()
        .map(|f| (f.clone(), fs::read(out.join(&f)).unwrap()))
        .collect()
}

/// The files of the output folder `dir` (its marker, and the folders of
/// other items below it, left out), as (name, bytes).
fn item_files(dir: &Path, nested: &[&str]) -> Vec<(String, Vec<u8>)> {
    tree(dir)
        .into_iter()
        .filter(|f| f != MARKER && !nested.iter().any(|n| f.starts_with(&format!("{n}/"))))
        .map(|f| (f.clone(), fs::read(dir.join(&f)).unwrap()))
        .collect()
}

/// The same files with the same bytes, reported by name.
#[track_caller]
fn assert_same(got: &[(String, Vec<u8>)], want: &[(String, Vec<u8>)], what: &str) {
    let names = |v: &[(String, Vec<u8>)]| v.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(got), names(want), "{what}: file names");
    for ((name, a), (_, b)) in got.iter().zip(want) {
        assert!(a == b, "{what}: {name} differs");
    }
}

fn dataset(src: &Path, dst: &Path, flags: &[&str]) -> std::process::Output {
    let mut a = args!["dataset", src, dst].to_vec();
    a.extend(flags.iter().map(|f| (*f).into()));
    run(&a)
}

#[test]
fn no_item_writes_where_another_writes_its_side_outputs() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    clip(&src.join("x.y4m"), 4, 0);
    clip(&src.join("x/hsv.y4m"), 4, 3);
    clip(&src.join("y.y4m"), 4, 1);
    clip(&src.join("y/v_R.y4m"), 4, 5);
    clip(&src.join("y/v_c.y4m"), 4, 7);

    // x/hsv.y4m, y/v_R.y4m and y/v_c.y4m are refused whatever the flags
    // (an earlier or later run may write those side folders); the rest done.
    for (flags, dst) in [
        (&["--viz"][..], dst.clone()),
        (&[][..], tmp.path().join("dst2")),
    ] {
        let res = dataset(&src, &dst, flags);
        let err = stderr(&res);
        assert_eq!(res.status.code(), Some(1), "{err}");
        assert!(
            err.contains("x/hsv.y4m: its output folder")
                && err.contains("x.y4m's hsv outputs go")
                && err.contains("y/v_R.y4m: its output folder")
                && err.contains("y/v_c.y4m: its output folder"),
            "{err}"
        );
        assert!(err.contains("3 of 5 items failed"), "{err}");
        assert_same(
            &item_files(&dst.join("x"), &[]),
            &run_files(tmp.path(), &src.join("x.y4m"), flags),
            "x",
        );
        assert_same(
            &item_files(&dst.join("y"), &[]),
            &run_files(tmp.path(), &src.join("y.y4m"), flags),
            "y",
        );
        assert!(!dst.join("y/v_R").exists() && !dst.join("y/v_c").exists());
    }
}

#[test]
fn a_redone_item_holds_exactly_what_the_new_settings_write() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    clip(&src.join("v.y4m"), 6, 0);
    // An item nested in v's output folder, and a file of the user's there.
    clip(&src.join("v/inner.y4m"), 3, 2);
    ok(&dataset(
        &src,
        &dst,
        &["--variant", "cd", "--viz", "--npy=v_R"],
    ));
    fs::write(dst.join("v/notes.txt"), "mine").unwrap();

    for flags in [
        &["--max-frames", "3"][..],
        &["--image-format", "jpg"],
        &["--step", "2", "--flo"],
        &["--keep-count", "--no-rep", "--npy=v_c"],
        &[],
    ] {
        let err = ok(&dataset(&src, &dst, flags));
        assert!(err.contains("2 items: 2 done"), "{flags:?}: {err}");
        let mut want = run_files(tmp.path(), &src.join("v.y4m"), flags);
        want.push(("notes.txt".into(), b"mine".to_vec()));
        want.sort();
        assert_same(
            &item_files(&dst.join("v"), &["inner"]),
            &want,
            &format!("{flags:?}"),
        );
        // Folders of outputs no longer asked for are gone too.
        for sub in ["hsv", "v_c", "v_d", "v_R"] {
            let asked = want.iter().any(|(f, _)| f.starts_with(&format!("{sub}/")));
            assert_eq!(dst.join("v").join(sub).exists(), asked, "{flags:?}: {sub}");
        }
        assert_same(
            &item_files(&dst.join("v/inner"), &[]),
            &run_files(tmp.path(), &src.join("v/inner.y4m"), flags),
            &format!("{flags:?} inner"),
        );
    }
}

#[test]
#[cfg_attr(
    not(feature = "crash-injection"),
    ignore = "the crash hook needs --features reynoldsflow-cli/crash-injection (scripts/test)"
)]
fn a_redo_after_a_crash_with_other_settings_leaves_nothing_of_the_crashed_run() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    clip(&src.join("v.y4m"), 8, 0);
    ok(&dataset(&src, &dst, &["--threads", "1"]));
    // Killed after 3 results of a redo with other settings...
    let res = run_with(
        &args![
            "dataset",
            src,
            dst,
            "--threads",
            "1",
            "--viz",
            "--image-format",
            "jpg"
        ],
        None,
        &[("REYNOLDSFLOW_ABORT_AFTER", OsStr::new("3"))],
    );
    assert!(!res.status.success(), "{}", stderr(&res));
    assert!(
        tree(&dst).iter().any(|f| f.ends_with(".jpg")),
        "{:?}",
        tree(&dst)
    );
    // ...then redone with a third: none of the first two runs' files is left.
    let flags = ["--threads", "1", "--npy=v_d", "--no-rep"];
    ok(&dataset(&src, &dst, &flags));
    assert_same(
        &item_files(&dst.join("v"), &[]),
        &run_files(tmp.path(), &src.join("v.y4m"), &flags),
        "v",
    );
    assert_eq!(
        fs::read_dir(dst.join("v")).unwrap().count(),
        2,
        "v_d/ and the marker: {:?}",
        tree(&dst)
    );
}

#[test]
fn a_changed_source_or_a_lost_output_is_redone() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    for name in ["v", "w", "same"] {
        clip(&src.join(format!("{name}.y4m")), 6, name.len());
    }
    let frames = src.join("seq");
    fs::create_dir_all(&frames).unwrap();
    for t in 0..3 {
        fs::write(
            frames.join(format!("f{t}.pgm")),
            pgm(&moving_frame(32, 24, t)),
        )
        .unwrap();
    }
    ok(&dataset(&src, &dst, &[]));

    // v: new content of the same size (and a later modification time).
    clip(&src.join("v.y4m"), 6, 9);
    let later = SystemTime::now() + Duration::from_secs(10);
    fs::File::options()
        .write(true)
        .open(src.join("v.y4m"))
        .unwrap()
        .set_modified(later)
        .unwrap();
    // w: one output deleted, one truncated.
    fs::remove_file(dst.join("w/000002.png")).unwrap();
    let cut = fs::read(dst.join("w/000001.png")).unwrap();
    fs::write(dst.join("w/000001.png"), &cut[..20]).unwrap();
    // seq: a frame added.
    fs::write(frames.join("f3.pgm"), pgm(&moving_frame(32, 24, 3))).unwrap();

    let res = dataset(&src, &dst, &[]);
    ok(&res);
    assert_eq!(
        statuses(&res),
        [
            ("same.y4m".into(), "skipped".into()),
            ("seq".into(), "done".into()),
            ("v.y4m".into(), "done".into()),
            ("w.y4m".into(), "done".into()),
        ]
    );
    for name in ["v", "w", "same"] {
        let src = src.join(format!("{name}.y4m"));
        assert_same(
            &item_files(&dst.join(name), &[]),
            &run_files(tmp.path(), &src, &[]),
            name,
        );
    }
    assert_same(
        &item_files(&dst.join("seq"), &[]),
        &run_files(tmp.path(), &frames, &[]),
        "seq",
    );
    let res = dataset(&src, &dst, &[]);
    assert!(
        statuses(&res).iter().all(|(_, s)| s == "skipped"),
        "{:?}",
        statuses(&res)
    );
}

#[test]
fn an_unreadable_sub_folder_fails_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, dst) = (tmp.path().join("src"), tmp.path().join("dst"));
    clip(&src.join("a.y4m"), 3, 0);
    clip(&src.join("z.y4m"), 3, 1);
    // A folder no reader may list, even root: its path is longer than
    // PATH_MAX, made one step at a time relative to its parent.
    too_long_a_path(&src.join("b"));
    let res = dataset(&src, &dst, &[]);
    let err = stderr(&res);
    assert_eq!(res.status.code(), Some(1), "{err}");
    assert!(err.contains("2 done") && err.contains("1 failed"), "{err}");
    assert!(err.contains("File name too long"), "{err}");
    let st = statuses(&res);
    assert_eq!(
        st.iter().filter(|(_, s)| s == "failed").count(),
        1,
        "{st:?}"
    );
    assert!(dst.join("a").join(MARKER).is_file() && dst.join("z").join(MARKER).is_file());
}

/// Folders below `root` to a depth whose path exceeds PATH_MAX (4096).
fn too_long_a_path(root: &Path) {
    use std::ffi::CString;
    use std::os::unix::ffi::OsStrExt;
    fs::create_dir_all(root).unwrap();
    let name = CString::new("d".repeat(200)).unwrap();
    let root = CString::new(root.as_os_str().as_bytes()).unwrap();
    // SAFETY: plain syscalls on C strings that outlive them; each fd is closed.
    unsafe {
        let mut fd = libc::open(root.as_ptr(), libc::O_RDONLY | libc::O_DIRECTORY);
        assert!(fd >= 0);
        for _ in 0..25 {
            assert_eq!(libc::mkdirat(fd, name.as_ptr(), 0o755), 0);
            let next = libc::openat(fd, name.as_ptr(), libc::O_RDONLY | libc::O_DIRECTORY);
            assert!(next >= 0);
            libc::close(fd);
            fd = next;
        }
        libc::close(fd);
    }
}
