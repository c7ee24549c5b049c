//! Any video `ffmpeg` can decode (MP4, AVI, MKV, MOV, WebM, …), through an
//! `ffmpeg` subprocess that writes the first video stream as 8-bit gray Y4M
//! to a pipe; frames are read from the pipe as they come, so memory stays
//! at a couple of frames whatever the video's length.
//!
//! The program is `ffmpeg` on `PATH`, or the one named by the environment
//! variable `REYNOLDSFLOW_FFMPEG`. Gray is ffmpeg's own conversion
//! (`-pix_fmt gray`: full-range luma).

use std::ffi::OsString;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::thread::JoinHandle;

use super::y4m::Y4mSource;
use super::{Frame, FrameSource, input_error};
use crate::HostError;
use crate::limits::Limits;

/// The environment variable that names the ffmpeg program.
pub const FFMPEG_ENV: &str = "REYNOLDSFLOW_FFMPEG";

/// How much of ffmpeg's error output is kept for the message.
const STDERR_KEEP: usize = 16 * 1024;

/// The ffmpeg program to run.
pub fn program() -> OsString {
    std::env::var_os(FFMPEG_ENV)
        .filter(|p| !p.is_empty())
        .unwrap_or_else(|| "ffmpeg".into())
}

/// A video decoded by an ffmpeg child process.
pub struct FfmpegSource {
    path: PathBuf,
    child: Child,
    stderr: Option<JoinHandle<String>>,
    y4m: Option<Y4mSource>,
    finished: bool,
}

impl FfmpegSource {
    /// Start ffmpeg on `path` and read the stream header, its frame size
    /// within `limits`.
    pub fn spawn(path: &Path, limits: Limits) -> Result<Self, HostError> {
        let program = program();
        // `file:` keeps names with a colon or a leading dash from being read as
        // protocols or options.
        let mut input = OsString::from("file:");
        input.push(path.as_os_str());
        let spawned = Command::new(&program)
            .args(["-nostdin", "-hide_banner", "-loglevel", "error", "-i"])
            .arg(&input)
            .args([
                "-map",
                "0:v:0",
                "-f",
                "yuv4mpegpipe",
                "-pix_fmt",
                "gray",
                "-",
            ])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn();
        let mut child = match spawned {
            Ok(child) => child,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(input_error(
                    path,
                    format!(
                        "not a Y4M file or frame folder; other video is decoded with ffmpeg, and '{}' was not found \
                         (install it, e.g. apt-get install ffmpeg, or set {FFMPEG_ENV})",
                        program.to_string_lossy()
                    ),
                ));
            }
            Err(e) => {
                return Err(input_error(
                    path,
                    format!("cannot start '{}': {e}", program.to_string_lossy()),
                ));
            }
        };
        let mut err_pipe = child.stderr.take().expect("stderr is piped");
        let stderr = std::thread::spawn(move || {
            // Keep the tail; the pipe is drained to the end so ffmpeg never blocks on it.
            let mut kept = Vec::new();
            let mut buf = [0u8; 4096];
            while let Ok(n) = err_pipe.read(&mut buf) {
                if n == 0 {
                    break;
                }
                kept.extend_from_slice(&buf[..n]);
                if kept.len() > 2 * STDERR_KEEP {
                    kept.drain(..kept.len() - STDERR_KEEP);
                }
            }
            String::from_utf8_lossy(&kept).into_owned()
        });
        let stdout = child.stdout.take().expect("stdout is piped");
        let mut source = Self {
            path: path.to_owned(),
            child,
            stderr: Some(stderr),
            y4m: None,
            finished: false,
        };
        match Y4mSource::new(
            path.to_owned(),
            Box::new(BufReader::new(stdout)),
            None,
            limits,
        ) {
            Ok(y4m) => source.y4m = Some(y4m),
            Err(e) => return Err(source.finish().err().unwrap_or(e)),
        }
        Ok(source)
    }

    /// Close the pipe and wait for ffmpeg: an error with ffmpeg's own last
    /// message when it failed.
    fn finish(&mut self) -> Result<(), HostError> {
        self.y4m = None; // close the pipe so ffmpeg cannot block on it
        self.finished = true;
        let status = self
            .child
            .wait()
            .map_err(|e| HostError::io(&self.path, e))?;
        let stderr = self
            .stderr
            .take()
            .and_then(|h| h.join().ok())
            .unwrap_or_default();
        if status.success() {
            return Ok(());
        }
        let last = stderr
            .lines()
            .map(str::trim)
            .rfind(|l| !l.is_empty())
            .unwrap_or("no message");
        Err(input_error(
            &self.path,
            format!("ffmpeg cannot decode it ({status}): {last}"),
        ))
    }

    /// ffmpeg's count of the video stream's frames, when the container
    /// states it (`ffprobe` next to ffmpeg, best effort).
    fn probe_count(&self) -> Option<usize> {
        let program = PathBuf::from(program());
        let probe = match program.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir.join("ffprobe"),
            _ => PathBuf::from("ffprobe"),
        };
        let mut input = OsString::from("file:");
        input.push(self.path.as_os_str());
        let out = Command::new(probe)
            .args(["-v", "error", "-select_streams", "v:0", "-show_entries"])
            .args([
                "stream=nb_frames",
                "-of",
                "default=nokey=1:noprint_wrappers=1",
            ])
            .arg(input)
            .stdin(Stdio::null())
            .stderr(Stdio::null())
            .output()
            .ok()?;
        String::from_utf8(out.stdout).ok()?.trim().parse().ok()
    }
}

impl FrameSource for FfmpegSource {
    fn next_frame(&mut self) -> Result<Option<Frame>, HostError> {
        let mut frame = Frame::empty();
        Ok(self.next_frame_into(&mut frame)?.then_some(frame))
    }

    fn next_frame_into(&mut self, frame: &mut Frame) -> Result<bool, HostError> {
        if self.finished {
            return Ok(false);
        }
        let y4m = self.y4m.as_mut().expect("open until finished");
        match y4m.next_frame_into(frame) {
            Ok(true) => Ok(true),
            // The end of the pipe: a clean end only if ffmpeg says so.
            Ok(false) => self.finish().map(|()| false),
            Err(e) => Err(self.finish().err().unwrap_or(e)),
        }
    }

    fn frame_count_hint(&self) -> Option<usize> {
        self.probe_count()
    }

    fn frame_rate(&self) -> Option<(u32, u32)> {
        self.y4m.as_ref().and_then(|y| y.frame_rate())
    }
}

impl Drop for FfmpegSource {
    fn drop(&mut self) {
        if !self.finished {
            // Stopped early (frame limit, error elsewhere): end ffmpeg now.
            self.y4m = None;
            let _ = self.child.kill();
            let _ = self.child.wait();
            if let Some(h) = self.stderr.take() {
                let _ = h.join();
            }
        }
    }
}
