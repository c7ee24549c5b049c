//! `reynoldsflow dataset`: DST holds exactly what the settings write, for
//! the right source. No item's outputs meet another's; an unreadable
//! sub-folder fails alone.

mod run_support;

use std::fs;
use std::path::Path;

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

    // --viz: x's hsv/ is its own; x/hsv.y4m is refused, the rest done.
    let res = dataset(&src, &dst, &["--viz"]);
    let err = stderr(&res);
    assert_eq!(res.status.code(), Some(1), "{err}");
    assert!(
        err.contains("x/hsv.y4m: its output folder")
            && err.contains("x.y4m's --viz images go")
            && err.contains("--viz"),
        "{err}"
    );
    assert_same(
        &item_files(&dst.join("x"), &[]),
        &run_files(tmp.path(), &src.join("x.y4m"), &["--viz"]),
        "x",
    );
    assert!(
        dst.join("y/v_R").join(MARKER).is_file(),
        "no clash without --npy"
    );

    // --npy=v_R: y/v_R.y4m is refused; y/v_c.y4m is not (v_c is not written).
    let dst2 = tmp.path().join("dst2");
    let res = dataset(&src, &dst2, &["--npy=v_R"]);
    let err = stderr(&res);
    assert_eq!(res.status.code(), Some(1), "{err}");
    assert!(err.contains("y/v_R.y4m: its output folder"), "{err}");
    assert!(!err.contains("v_c.y4m"), "{err}");
    assert!(err.contains("1 of 5 items failed"), "{err}");
    assert_same(
        &item_files(&dst2.join("y"), &["v_c"]),
        &run_files(tmp.path(), &src.join("y.y4m"), &["--npy=v_R"]),
        "y",
    );
    assert!(dst2.join("y/v_c").join(MARKER).is_file());
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
