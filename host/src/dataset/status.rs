//! One machine-readable status record per dataset item, as a JSON line:
//! what `dataset` prints on stdout (or appends to `--status FILE`) and what
//! the Python `convert` returns, so a scheduler's logs can be collected and
//! queried (`jq 'select(.status == "failed")'`).

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde_json::json;

use crate::HostError;

/// How an item ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// Computed and marked finished.
    Done,
    /// Already finished with the same options.
    Skipped,
    /// Could not be read, decoded or written; `error` says why.
    Failed,
    /// Stopped by Ctrl-C (or SIGTERM) before it was finished.
    Interrupted,
    /// Not begun: the run was stopped by Ctrl-C (or SIGTERM) first.
    NotStarted,
}

impl Status {
    /// The name in the record.
    pub fn name(self) -> &'static str {
        match self {
            Status::Done => "done",
            Status::Skipped => "skipped",
            Status::Failed => "failed",
            Status::Interrupted => "interrupted",
            Status::NotStarted => "not-started",
        }
    }
}

/// The record of one item.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    /// The video file or frame folder.
    pub path: String,
    /// Its output folder.
    pub output: String,
    /// How it ended.
    pub status: Status,
    /// Frames read (for a skipped item: as its marker records).
    pub frames: Option<usize>,
    /// Outputs written (likewise).
    pub outputs: Option<usize>,
    /// Wall time spent on it.
    pub seconds: f64,
    /// Why it failed.
    pub error: Option<String>,
    /// With `--step` or `--fps`: the input index of every frame used, in
    /// order (result `i` came from frames `i` and `i + 1` of this list);
    /// absent from the JSON otherwise.
    pub source_frames: Option<Vec<usize>>,
}

impl Record {
    /// The record as one line of JSON (no newline).
    pub fn json(&self) -> String {
        let mut record = json!({
            "path": self.path,
            "output": self.output,
            "status": self.status.name(),
            "frames": self.frames,
            "outputs": self.outputs,
            "seconds": (self.seconds * 1e3).round() / 1e3,
            "error": self.error,
        });
        if let Some(used) = &self.source_frames {
            record["source_frames"] = json!(used);
        }
        record.to_string()
    }
}

/// Where records go: stdout, or a file opened for appending, written one
/// whole line per `write` call so processes sharing the file (shards of
/// one dataset) never interleave within a line.
pub struct StatusLog {
    /// The file and its path, for errors.
    file: Option<(Mutex<File>, PathBuf)>,
}

impl StatusLog {
    /// Records on stdout (`None` or `-`), or appended to `path`.
    pub fn open(path: Option<&Path>) -> Result<Self, HostError> {
        let file = match path {
            None => None,
            Some(p) if p.as_os_str() == "-" => None,
            Some(p) => Some((
                Mutex::new(
                    OpenOptions::new()
                        .create(true)
                        .append(true)
                        .open(p)
                        .map_err(|e| HostError::io(p, e))?,
                ),
                p.to_owned(),
            )),
        };
        Ok(Self { file })
    }

    /// Write one record.
    pub fn write(&self, record: &Record) -> Result<(), HostError> {
        let line = format!("{}\n", record.json());
        match &self.file {
            Some((f, path)) => f
                .lock()
                .expect("no panics holding it")
                .write_all(line.as_bytes())
                .map_err(|e| HostError::io(path, e)),
            // A closed stdout (e.g. `| head`) must not fail the dataset.
            None => {
                let _ = std::io::stdout().lock().write_all(line.as_bytes());
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_is_one_line_of_json_with_every_field() {
        let record = Record {
            path: "src/a \"b\".mp4".to_owned(),
            output: "dst/a \"b\"".to_owned(),
            status: Status::Failed,
            frames: None,
            outputs: Some(3),
            seconds: 0.123_456,
            error: Some("truncated:\nframe 2".to_owned()),
            source_frames: None,
        };
        let line = record.json();
        assert!(!line.contains('\n'), "{line}");
        let v: serde_json::Value = serde_json::from_str(&line).unwrap();
        assert_eq!(v["path"], "src/a \"b\".mp4");
        assert_eq!(v["status"], "failed");
        assert_eq!(v["frames"], serde_json::Value::Null);
        assert_eq!(v["outputs"], 3);
        assert_eq!(v["seconds"], 0.123);
        assert_eq!(v["error"], "truncated:\nframe 2");
    }
}
