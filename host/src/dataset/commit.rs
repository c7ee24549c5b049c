//! An item's commit protocol: what makes a folder of outputs count as
//! finished, and how a redo replaces it.
//!
//! - **Staging.** A redo writes every output into the hidden folder
//!   [`STAGING`] inside the item's folder; nothing under a final name
//!   changes while it runs, so a kill, an error or new settings that fail
//!   leave the previous outputs and their manifest as they were.
//! - **Commit.** With every output written, the new manifest goes to the
//!   journal [`JOURNAL`] (atomically), listing the new files and the old
//!   ones they replace; then the old manifest and the old files go, the
//!   staged files are renamed into place, the staging folder is removed,
//!   and the journal is renamed to the manifest [`MANIFEST`]: written last,
//!   atomically. A kill at any point leaves either the old manifest (its
//!   files intact, or a journal naming them) or the new one.
//! - **Manifest.** JSON lines: a header (the source's path and content
//!   hash, the settings, frames, results and outputs), one line per output
//!   file (path, size, XXH3-128 of its bytes), and a last line holding the
//!   number of files and the hash of every byte before it. A manifest that
//!   is cut, edited or unreadable is not trusted; its readable file lines
//!   still say what the redo may remove.
//! - **Clean-up** removes the files a manifest or journal lists, the
//!   staging folder, and the other files of the item's own kinds
//!   ([`own_files`]: images at its top level, files in its side-output
//!   folders, which no other item may use); a nested item's folder, or a
//!   file of another kind (notes, labels), is never touched.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Component, Path};

use serde_json::{Value, json};
use xxhash_rust::xxh3::Xxh3;

use crate::HostError;
use crate::io::content_hash::{hash_bytes, hash_file};
use crate::sequence::folder::is_frame_file;

use super::Item;

/// The manifest of a finished item, in its output folder.
pub const MANIFEST: &str = ".reynoldsflow-done";
/// The manifest of a commit under way.
pub const JOURNAL: &str = ".reynoldsflow-commit";
/// Where a redo writes its outputs until the commit.
pub const STAGING: &str = ".reynoldsflow-new";
/// The sub-folders of an item's folder its side outputs go to.
pub const SIDE_FOLDERS: [&str; 4] = ["hsv", "v_c", "v_d", "v_R"];

/// The source's identity by content: a video's hash, or a frame folder's
/// number of frames and the hash of every frame file's name, size and hash.
pub fn source_hash(item: &Item) -> Result<String, HostError> {
    if !item.frames {
        return Ok(format!("xxh3-128:{}", hash_file(&item.src)?));
    }
    let files = crate::sequence::folder::list(&item.src, |name| is_frame_file(Path::new(name)))?;
    let mut hasher = Xxh3::new();
    for file in &files {
        let name = file.file_name().unwrap_or_default().as_encoded_bytes();
        let hash = hash_file(file)?;
        hasher.update(&(name.len() as u64).to_le_bytes());
        hasher.update(name);
        hasher.update(hash.as_bytes());
    }
    Ok(format!(
        "frames={} xxh3-128:{:032x}",
        files.len(),
        hasher.digest128()
    ))
}

/// One output file of a manifest.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Output {
    /// Relative to the item's folder, `/`-separated.
    pub path: String,
    /// Bytes.
    pub size: u64,
    /// XXH3-128, hex.
    pub hash: String,
}

/// A complete manifest: its header and files.
#[derive(Clone, Debug)]
pub struct Manifest {
    /// Source, source hash, settings, frames, results, outputs (and the
    /// source frames used, with `--step` or `--fps`).
    pub header: Value,
    /// Every output.
    pub files: Vec<Output>,
}

impl Manifest {
    /// The manifest's text: header, files, and the closing line.
    pub fn text(&self, replaces: &[String]) -> String {
        let mut text = format!("{}\n", self.header);
        for f in &self.files {
            text += &format!(
                "{}\n",
                json!({"file": f.path, "size": f.size, "xxh3": f.hash})
            );
        }
        for path in replaces {
            text += &format!("{}\n", json!({ "replaces": path }));
        }
        let end = json!({"end": self.files.len(), "xxh3": hash_bytes(text.as_bytes())});
        text + &format!("{end}\n")
    }

    /// A header field.
    pub fn field(&self, name: &str) -> &Value {
        &self.header[name]
    }

    /// Whether every file is in `dir` with its size and hash, and no other
    /// file of the item's own kinds ([`own_files`]) is there.
    pub fn intact(&self, dir: &Path) -> bool {
        let listed: BTreeSet<&str> = self.files.iter().map(|f| f.path.as_str()).collect();
        own_files(dir).iter().all(|f| listed.contains(f.as_str()))
            && self.files.iter().all(|f| {
                let path = dir.join(&f.path);
                fs::metadata(&path).is_ok_and(|m| m.is_file() && m.len() == f.size)
                    && hash_file(&path).is_ok_and(|h| h == f.hash)
            })
    }
}

/// What a manifest or journal file says: the manifest when it is whole,
/// and every path it names (for the clean-up), whole or not.
#[derive(Default)]
pub struct Listing {
    /// The manifest, when whole and unaltered.
    pub whole: Option<Manifest>,
    /// Every output path it lists or replaces.
    pub listed: BTreeSet<String>,
}

/// Read the manifest or journal at `path` (missing: empty).
pub fn read(path: &Path) -> Listing {
    let Ok(bytes) = fs::read(path) else {
        return Listing::default();
    };
    let text = String::from_utf8_lossy(&bytes);
    let mut out = Listing::default();
    let (mut header, mut files, mut end_ok) = (None, Vec::new(), false);
    let mut offset = 0;
    for (i, line) in text.split_inclusive('\n').enumerate() {
        let start = offset;
        offset += line.len();
        // An earlier format: `file: SIZE PATH`.
        if let Some(rest) = line.trim_end().strip_prefix("file: ") {
            if let Some((_, p)) = rest.split_once(' ') {
                out.listed.insert(p.to_owned());
            }
            continue;
        }
        let Ok(value) = serde_json::from_str::<Value>(line) else {
            continue;
        };
        if i == 0 && value["reynoldsflow_dataset_item"].is_number() {
            header = Some(value);
        } else if let Some(p) = value["file"].as_str() {
            out.listed.insert(p.to_owned());
            if let (Some(size), Some(hash)) = (value["size"].as_u64(), value["xxh3"].as_str()) {
                files.push(Output {
                    path: p.to_owned(),
                    size,
                    hash: hash.to_owned(),
                });
            }
        } else if let Some(p) = value["replaces"].as_str() {
            out.listed.insert(p.to_owned());
        } else if value["end"].as_u64() == Some(files.len() as u64)
            && value["xxh3"].as_str() == Some(&hash_bytes(&bytes[..start]))
            && offset == bytes.len()
        {
            end_ok = true;
        }
    }
    if let (Some(header), true) = (header, end_ok && bytes.ends_with(b"\n")) {
        out.whole = Some(Manifest { header, files });
    }
    out
}

/// Whether `rel` is a path inside an item's folder as this tool writes
/// them (no `..`, not absolute, not in the staging folder).
fn own_path(rel: &str) -> bool {
    let path = Path::new(rel);
    path.components().next().is_some()
        && path.components().all(|c| matches!(c, Component::Normal(_)))
        && !rel.starts_with(STAGING)
        && rel != MANIFEST
        && rel != JOURNAL
}

/// The extensions of output files.
const OUTPUT_EXTENSIONS: [&str; 4] = ["png", "jpg", "npy", "flo"];

/// The files of the item's own kinds in `dir`: outputs' extensions at the
/// top level and in the side-output folders, which no other item writes
/// (the front end refuses items inside them), `/`-separated.
pub fn own_files(dir: &Path) -> Vec<String> {
    let mut files = Vec::new();
    for sub in std::iter::once("").chain(SIDE_FOLDERS) {
        let Ok(entries) = fs::read_dir(dir.join(sub)) else {
            continue;
        };
        for entry in entries.flatten() {
            let Ok(name) = entry.file_name().into_string() else {
                continue;
            };
            let ext = name.rsplit_once('.').map(|(_, e)| e);
            if !name.starts_with('.')
                && ext.is_some_and(|e| OUTPUT_EXTENSIONS.contains(&e))
                && entry.file_type().is_ok_and(|t| t.is_file())
            {
                files.push(if sub.is_empty() {
                    name
                } else {
                    format!("{sub}/{name}")
                });
            }
        }
    }
    files
}

/// Remove the file `path`; one already gone is fine.
pub fn remove_if_present(path: &Path) -> Result<(), HostError> {
    match fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(HostError::io(path, e)),
        _ => Ok(()),
    }
}

/// Remove the staging folder a killed or failed run left in `dir`.
pub fn remove_staging(dir: &Path) -> Result<(), HostError> {
    let staging = dir.join(STAGING);
    match fs::remove_dir_all(&staging) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(HostError::io(&staging, e)),
        _ => Ok(()),
    }
}

/// Make `manifest`'s files, staged in `dir`'s staging folder, the item's
/// outputs: journal, old files out, new files in, manifest last.
/// `previous`: every path the old manifest and any old journal list.
pub fn commit(
    dir: &Path,
    manifest: &Manifest,
    previous: &BTreeSet<String>,
) -> Result<(), HostError> {
    let new: BTreeSet<&str> = manifest.files.iter().map(|f| f.path.as_str()).collect();
    let mut replaces: BTreeSet<String> = previous.iter().filter(|p| own_path(p)).cloned().collect();
    replaces.extend(own_files(dir));
    let replaces: Vec<String> = replaces
        .into_iter()
        .filter(|p| !new.contains(p.as_str()))
        .collect();
    let journal = dir.join(JOURNAL);
    crate::io::atomic::write_file(&journal, manifest.text(&replaces).as_bytes())?;
    remove_if_present(&dir.join(MANIFEST))?;
    for rel in &replaces {
        remove_if_present(&dir.join(rel))?;
    }
    let staging = dir.join(STAGING);
    for f in &manifest.files {
        let to = dir.join(&f.path);
        if let Some(parent) = to.parent() {
            fs::create_dir_all(parent).map_err(|e| HostError::io(parent, e))?;
        }
        let from = staging.join(&f.path);
        fs::rename(&from, &to).map_err(|e| HostError::io(&to, e))?;
    }
    remove_staging(dir)?;
    for side in SIDE_FOLDERS {
        // Fails, as it should, unless the folder is empty.
        let _ = fs::remove_dir(dir.join(side));
    }
    let target = dir.join(MANIFEST);
    fs::rename(&journal, &target).map_err(|e| HostError::io(&target, e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn manifest() -> Manifest {
        Manifest {
            header: json!({"reynoldsflow_dataset_item": 2, "settings": "s", "source_hash": "h"}),
            files: vec![
                Output {
                    path: "000000.png".into(),
                    size: 3,
                    hash: hash_bytes(b"abc"),
                },
                Output {
                    path: "hsv/000000.png".into(),
                    size: 1,
                    hash: hash_bytes(b"d"),
                },
            ],
        }
    }

    #[test]
    fn a_manifest_is_trusted_only_whole_and_unaltered() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(MANIFEST);
        let text = manifest().text(&[]);
        fs::write(&path, &text).unwrap();
        let read_back = read(&path);
        assert_eq!(read_back.whole.unwrap().files, manifest().files);
        // Cut at every line end, or anywhere: not whole, its listed files kept.
        for cut in [text.len() - 1, text.rfind("{\"end\"").unwrap(), 10] {
            fs::write(&path, &text[..cut]).unwrap();
            let r = read(&path);
            assert!(r.whole.is_none(), "cut at {cut}");
            if cut > 100 {
                assert!(r.listed.contains("hsv/000000.png"), "cut at {cut}");
            }
        }
        // One byte changed (a size): not whole.
        fs::write(&path, text.replace("\"size\":3", "\"size\":4")).unwrap();
        assert!(read(&path).whole.is_none());
        // Extra lines after the end: not whole.
        fs::write(&path, format!("{text}{{\"file\":\"x.png\"}}\n")).unwrap();
        assert!(read(&path).whole.is_none());
        // The earlier format's file lines are listed for the clean-up.
        fs::write(&path, "reynoldsflow dataset item\nfile: 12 000003.png\n").unwrap();
        let r = read(&path);
        assert!(r.whole.is_none() && r.listed.contains("000003.png"));
        assert!(read(&dir.path().join("missing")).listed.is_empty());
    }

    #[test]
    fn outputs_are_checked_by_size_and_content_and_extras_are_seen() {
        let dir = tempfile::tempdir().unwrap();
        fs::create_dir(dir.path().join("hsv")).unwrap();
        fs::write(dir.path().join("000000.png"), b"abc").unwrap();
        fs::write(dir.path().join("hsv/000000.png"), b"d").unwrap();
        fs::write(dir.path().join("notes.txt"), b"mine").unwrap();
        assert!(manifest().intact(dir.path()));
        fs::write(dir.path().join("000000.png"), b"abd").unwrap();
        assert!(!manifest().intact(dir.path()), "same size, other bytes");
        fs::write(dir.path().join("000000.png"), b"abc").unwrap();
        fs::write(dir.path().join("hsv/000001.png"), b"e").unwrap();
        assert!(!manifest().intact(dir.path()), "an extra output");
        let mut own = own_files(dir.path());
        own.sort();
        assert_eq!(own, ["000000.png", "hsv/000000.png", "hsv/000001.png"]);
        assert!(!own_path("../x.png") && !own_path("/x.png") && !own_path(MANIFEST));
        assert!(own_path("v_R/000000.npy"));
    }

    #[test]
    fn a_commit_replaces_exactly_the_old_files() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        fs::create_dir_all(d.join("v_R")).unwrap();
        fs::create_dir_all(d.join("inner")).unwrap();
        fs::write(d.join("v_R/000000.npy"), b"old").unwrap();
        fs::write(d.join("000009.png"), b"old").unwrap();
        fs::write(d.join("inner/000000.png"), b"a nested item's").unwrap();
        fs::write(d.join("notes.txt"), b"mine").unwrap();
        fs::create_dir_all(d.join(STAGING).join("hsv")).unwrap();
        fs::write(d.join(STAGING).join("000000.png"), b"abc").unwrap();
        fs::write(d.join(STAGING).join("hsv/000000.png"), b"d").unwrap();
        let previous = ["v_R/000000.npy".to_owned()].into();
        commit(d, &manifest(), &previous).unwrap();
        let mut left: Vec<String> = walk(d);
        left.sort();
        assert_eq!(
            left,
            [
                MANIFEST,
                "000000.png",
                "hsv/000000.png",
                "inner/000000.png",
                "notes.txt"
            ]
        );
        assert!(read(&d.join(MANIFEST)).whole.is_some());
        assert!(manifest().intact(d));
    }

    fn walk(dir: &Path) -> Vec<String> {
        let mut out = Vec::new();
        for e in fs::read_dir(dir).unwrap().flatten() {
            let name = e.file_name().into_string().unwrap();
            if e.path().is_dir() {
                out.extend(walk(&e.path()).into_iter().map(|n| format!("{name}/{n}")));
            } else {
                out.push(name);
            }
        }
        out
    }
}
