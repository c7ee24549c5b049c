//! `reynoldsflow dataset`: DST holds exactly what the settings write, for
//! the right source. An unreadable sub-folder fails alone.

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

fn dataset(src: &Path, dst: &Path, flags: &[&str]) -> std::process::Output {
    let mut a = args!["dataset", src, dst].to_vec();
    a.extend(flags.iter().map(|f| (*f).into()));
    run(&a)
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
