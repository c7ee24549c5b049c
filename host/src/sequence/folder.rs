//! A folder of frames, or a glob pattern of them: PNG, JPEG and PGM/PPM
//! files in natural order of their names (`f2` before `f10`), each decoded
//! as it is needed. Other files (labels, notes) are ignored. Frames must all
//! have the size of the first; colour frames become BT.601 luma.

use std::fs;
use std::path::{Path, PathBuf};

use super::{Frame, FrameSource, input_error, natural};
use crate::limits::Limits;
use crate::{HostError, io::image_file};

/// File extensions read as frames (compared case-insensitively).
pub const FRAME_EXTENSIONS: [&str; 6] = ["png", "jpg", "jpeg", "pgm", "ppm", "pnm"];

/// Whether `path` names a frame file by its extension.
pub fn is_frame_file(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| FRAME_EXTENSIONS.iter().any(|f| e.eq_ignore_ascii_case(f)))
}

/// `*` (any run), `?` (one character) and `[abc]`/`[a-z]` (one of a set)
/// against a whole file name.
pub fn wildcard_match(pattern: &str, name: &str) -> bool {
    let p: Vec<char> = pattern.chars().collect();
    let n: Vec<char> = name.chars().collect();
    // (pattern index, name index) to retry at, for the last `*`.
    let (mut pi, mut ni, mut star): (usize, usize, Option<(usize, usize)>) = (0, 0, None);
    while ni < n.len() {
        let step = match p.get(pi) {
            Some('*') => {
                star = Some((pi, ni));
                pi += 1;
                continue;
            }
            Some('?') => Some(1),
            Some('[') => class_match(&p[pi..], n[ni]),
            Some(&c) => (c == n[ni]).then_some(1),
            None => None,
        };
        match (step, star) {
            (Some(len), _) => {
                pi += len;
                ni += 1;
            }
            (None, Some((sp, sn))) => {
                pi = sp + 1;
                ni = sn + 1;
                star = Some((sp, sn + 1));
            }
            (None, None) => return false,
        }
    }
    p[pi..].iter().all(|&c| c == '*')
}

/// Match `c` against the class at the start of `p` (`[...]`): the class's
/// length in pattern characters when it matches.
fn class_match(p: &[char], c: char) -> Option<usize> {
    let end = p.iter().skip(1).position(|&x| x == ']')? + 1;
    let set = &p[1..end];
    let (negate, set) = match set.first() {
        Some('!' | '^') => (true, &set[1..]),
        _ => (false, set),
    };
    let mut hit = false;
    let mut i = 0;
    while i < set.len() {
        if i + 2 < set.len() && set[i + 1] == '-' {
            hit |= (set[i]..=set[i + 2]).contains(&c);
            i += 3;
        } else {
            hit |= set[i] == c;
            i += 1;
        }
    }
    (hit != negate).then_some(end + 1)
}

/// The frames of a folder or glob, decoded one by one.
pub struct FolderSource {
    files: Vec<PathBuf>,
    next: usize,
    /// File and size of the last frame read, for the size check.
    last: Option<(PathBuf, (usize, usize))>,
    /// What each frame file's header may state.
    limits: Limits,
}

impl FolderSource {
    /// Every frame file directly inside `dir`, each decoded within `limits`.
    pub fn dir(dir: &Path, limits: Limits) -> Result<Self, HostError> {
        let files = list(dir, |name| is_frame_file(Path::new(name)))?;
        if files.is_empty() {
            return Err(input_error(
                dir,
                format!(
                    "no frames: the folder has no {} files",
                    FRAME_EXTENSIONS.join("/")
                ),
            ));
        }
        Self::from_files(files, limits)
    }

    /// The frame files matching a pattern whose last component has
    /// wildcards (`frames/*.png`, `seq/img_??.jpg`), each decoded within
    /// `limits`.
    pub fn glob(pattern: &Path, limits: Limits) -> Result<Self, HostError> {
        let name = pattern.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let dir = match pattern.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        if dir.to_str().is_some_and(|d| d.contains(['*', '?', '['])) {
            return Err(input_error(
                pattern,
                "wildcards are supported in the file name only, not in folder names",
            ));
        }
        if !dir.is_dir() {
            return Err(input_error(
                pattern,
                "no such file, folder, or folder of a glob",
            ));
        }
        let files = list(dir, |n| {
            wildcard_match(name, n) && is_frame_file(Path::new(n))
        })?;
        if files.is_empty() {
            return Err(input_error(pattern, "the pattern matches no frame files"));
        }
        Self::from_files(files, limits)
    }

    /// An explicit list of frame files, in the order given, each decoded
    /// within `limits`.
    pub fn from_files(files: Vec<PathBuf>, limits: Limits) -> Result<Self, HostError> {
        // Two files with one stem would write the same outputs.
        let mut stems: Vec<(&str, &PathBuf)> = files.iter().map(|f| (stem_of(f), f)).collect();
        stems.sort();
        if let Some(w) = stems.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(input_error(
                w[1].1,
                format!(
                    "has the same stem '{}' as {}; their outputs would collide",
                    w[0].0,
                    w[0].1.display()
                ),
            ));
        }
        Ok(Self {
            files,
            next: 0,
            last: None,
            limits,
        })
    }

    /// The files, in frame order.
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }
}

fn stem_of(path: &Path) -> &str {
    path.file_stem().and_then(|s| s.to_str()).unwrap_or("")
}

/// Files directly in `dir` whose UTF-8 names pass `keep`, in natural order.
pub fn list(dir: &Path, keep: impl Fn(&str) -> bool) -> Result<Vec<PathBuf>, HostError> {
    let mut names = Vec::new();
    for entry in fs::read_dir(dir).map_err(|e| HostError::io(dir, e))? {
        let entry = entry.map_err(|e| HostError::io(dir, e))?;
        let name = match entry.file_name().into_string() {
            Ok(name) => name,
            // Frames are named by their stems: one whose name is not
            // UTF-8 is refused, never left out silently.
            Err(odd) => {
                let lossy = odd.to_string_lossy();
                if !lossy.starts_with('.') && keep(&lossy) && entry.path().is_file() {
                    return Err(input_error(
                        entry.path(),
                        "the file name is not UTF-8 (outputs are named by the frames' stems); rename it",
                    ));
                }
                continue;
            }
        };
        if name.starts_with('.') || !keep(&name) {
            continue;
        }
        let path = entry.path();
        if path.is_file() {
            names.push(name);
        }
    }
    names.sort_by(|a, b| natural::compare(a, b));
    Ok(names.into_iter().map(|n| dir.join(n)).collect())
}

impl FrameSource for FolderSource {
    fn next_frame(&mut self) -> Result<Option<Frame>, HostError> {
        let Some(path) = self.files.get(self.next) else {
            return Ok(None);
        };
        let gray = image_file::read_gray(path, self.limits)?;
        if let Some((last_path, size)) = &self.last
            && gray.size() != *size
        {
            return Err(HostError::FrameSizes {
                prev_path: last_path.clone(),
                prev: *size,
                next_path: path.clone(),
                next: gray.size(),
            });
        }
        self.last = Some((path.clone(), gray.size()));
        self.next += 1;
        Ok(Some(Frame {
            stem: stem_of(path).to_owned(),
            gray,
            index: self.next - 1,
        }))
    }

    fn frame_count_hint(&self) -> Option<usize> {
        Some(self.files.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wildcards() {
        for (p, n, ok) in [
            ("*.png", "a.png", true),
            ("*.png", "a.jpg", false),
            ("f??.png", "f01.png", true),
            ("f??.png", "f1.png", false),
            ("f*_*.pgm", "f1_x_y.pgm", true),
            ("[ab]*", "b1", true),
            ("[!ab]*", "b1", false),
            ("img[0-9].png", "img7.png", true),
            ("img[0-9].png", "imgx.png", false),
            ("*", "", true),
            ("a*", "a", true),
            ("*a*b", "xxaxxbxb", true),
        ] {
            assert_eq!(wildcard_match(p, n), ok, "{p} {n}");
        }
    }
}
