//! Atomic file output: each file is written whole to a temp file in its
//! destination directory, then renamed over the final name, so a reader
//! never sees a partial file and a failure leaves nothing behind.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use tempfile::NamedTempFile;

use crate::HostError;

/// Temp files are named `.rfXXXXXX.tmp` (13 bytes), whatever the final
/// name: a temp fits wherever its file's name fits (NAME_MAX), and every
/// hidden `.tmp` name is one [`crate::outputs::clean_stale_temps`] removes.
pub fn temp_builder() -> tempfile::Builder<'static, 'static> {
    let mut builder = tempfile::Builder::new();
    builder.prefix(".rf").suffix(".tmp").rand_bytes(6);
    builder
}

/// A temp file in `path`'s directory holding `bytes`, flushed to disk, to
/// be renamed to `path`. Dropped without renaming, it is deleted.
fn stage(path: &Path, bytes: &[u8]) -> Result<NamedTempFile, HostError> {
    let dir = parent_dir(path);
    let mut builder = temp_builder();
    // tempfile creates 0600 files; ask for 0666 so the umask gives the
    // permissions an ordinary file would have once renamed.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder
        .tempfile_in(dir)
        .map_err(|e| HostError::io(dir, e))?;
    // Errors name the file being made, not its hidden temp (which the drop removes).
    let failed = |e| HostError::io(path, e);
    tmp.write_all(bytes).map_err(failed)?;
    // Flush before the rename, so a crash cannot expose an empty file under the final name.
    tmp.as_file().sync_all().map_err(failed)?;
    Ok(tmp)
}

/// The directory a file path lives in (`.` for a bare name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Write `bytes` to `path` atomically. The directory must exist.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), HostError> {
    let tmp = stage(path, bytes)?;
    tmp.persist(path)
        .map_err(|e| HostError::io(path, e.error))?;
    Ok(())
}

/// Write every `(file name, bytes)` into `dir` (created if missing): all
/// files are staged first and renamed only when every one is complete, so
/// a failure while writing leaves `dir` as it was (a directory this call
/// created is removed again).
pub fn write_files(dir: &Path, files: &[(&str, &[u8])]) -> Result<(), HostError> {
    let created = !dir.exists();
    fs::create_dir_all(dir).map_err(|e| HostError::io(dir, e))?;
    let staged: Result<Vec<(NamedTempFile, PathBuf)>, HostError> = files
        .iter()
        .map(|&(name, bytes)| {
            // Staged beside its final name (the same directory, for the rename).
            let path = dir.join(name);
            Ok((stage(&path, bytes)?, path))
        })
        .collect();
    let staged = match staged {
        Ok(staged) => staged,
        Err(e) => {
            if created {
                // Best effort: the error that matters is `e`.
                let _ = fs::remove_dir(dir);
            }
            return Err(e);
        }
    };
    for (tmp, path) in staged {
        tmp.persist(&path)
            .map_err(|e| HostError::io(&path, e.error))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_whole_files_and_leaves_no_temps() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("a/b");
        write_files(&out, &[("x.bin", b"hello"), ("y.bin", b"world")]).unwrap();
        assert_eq!(fs::read(out.join("x.bin")).unwrap(), b"hello");
        write_file(&out.join("x.bin"), b"again").unwrap();
        assert_eq!(fs::read(out.join("x.bin")).unwrap(), b"again");
        let mut names: Vec<_> = fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        assert_eq!(names, ["x.bin", "y.bin"]);
    }

    #[test]
    fn a_failed_batch_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("new");
        // A name with a directory part that does not exist fails to stage.
        let err = write_files(&out, &[("ok.bin", b"1"), ("missing/bad.bin", b"2")]);
        assert!(err.is_err());
        assert!(!out.exists(), "the directory this call created is removed");
    }
}
