//! The crash tests' hook, compiled only with the test-only
//! `crash-injection` feature (never in a shipped binary): a process that
//! dies in the middle of writing a result, as a kill would leave it.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The environment variable of the crash test hook: after this many
/// results have been written, the next write leaves a partial temp file
/// and the process aborts, as a kill in the middle of a write would.
pub const ABORT_AFTER_ENV: &str = "REYNOLDSFLOW_ABORT_AFTER";

/// Results written by this process (for [`ABORT_AFTER_ENV`]).
static WRITTEN: AtomicUsize = AtomicUsize::new(0);

/// Called before each result is written: past the limit, leave half of its
/// first file under a temp name and abort.
pub(crate) fn abort_hook(dir: &Path, files: &[(PathBuf, Vec<u8>)]) {
    let Some(limit) = std::env::var(ABORT_AFTER_ENV)
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
    else {
        return;
    };
    if WRITTEN.fetch_add(1, Ordering::SeqCst) < limit {
        return;
    }
    if let Some((rel, bytes)) = files.first() {
        let path = dir.join(rel);
        let parent = path.parent().unwrap_or(dir);
        if let Ok(tmp) = crate::io::atomic::temp_builder().tempfile_in(parent) {
            let _ = tmp.as_file().write_all(&bytes[..bytes.len() / 2]);
            let _ = tmp.keep();
        }
    }
    eprintln!("reynoldsflow: {ABORT_AFTER_ENV}={limit}: aborting");
    std::process::abort();
}
