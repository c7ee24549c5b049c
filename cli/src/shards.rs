//! WebDataset shards (`dataset --webdataset`): POSIX tar files
//! `DST/shard-NNNNNN.tar` (`shard-IIII-NNNNNN.tar` for `--shard I/N`, so
//! the processes of one dataset never write the same name), each sample a
//! group of members sharing a key (`KEY.rep.png`, `KEY.v_R.npy`, …,
//! `KEY.json`), as the `webdataset` package reads them.
//!
//! - **Whole items.** A shard is closed only between items, once it holds
//!   `--shard-size` bytes or more: an item's samples are never split across
//!   shards, so a complete shard holds complete items only.
//! - **Atomic.** A shard is written under a hidden temp name in DST
//!   (`.shard-NNNNNN.tar.XXXXXX.tmp`) and renamed when complete; an item
//!   that fails is cut back out of it ([`ShardWriter::rollback`]). A killed
//!   run leaves only a temp file, which the next run of the same shard
//!   removes.
//! - **Deterministic.** Members carry no time, owner or mode of the
//!   machine (mtime 0, uid/gid 0, mode 0644), so the same items give the
//!   same bytes.

use std::fs::{self, File};
use std::io::{Seek, SeekFrom};
use std::path::{Path, PathBuf};

use tempfile::TempPath;

use reynoldsflow_host::HostError;

/// The names of one process's shards: `shard-NNNNNN.tar`, or with a shard
/// of several, `shard-IIII-NNNNNN.tar` (`I` at least 4 digits).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ShardNames {
    prefix: String,
}

impl ShardNames {
    /// The names of shard `index` of `count` (`count == 1`: unsharded).
    pub fn new(index: u64, count: u64) -> Self {
        let prefix = if count <= 1 {
            "shard-".to_owned()
        } else {
            let width = (count - 1).to_string().len().max(4);
            format!("shard-{index:0width$}-")
        };
        Self { prefix }
    }

    /// The file name of sequence number `seq`.
    pub fn name(&self, seq: u64) -> String {
        format!("{}{seq:06}.tar", self.prefix)
    }

    /// The sequence number of one of these names.
    pub fn seq_of(&self, name: &str) -> Option<u64> {
        let digits = name.strip_prefix(&self.prefix)?.strip_suffix(".tar")?;
        (digits.len() >= 6 && digits.bytes().all(|b| b.is_ascii_digit()))
            .then(|| digits.parse().ok())
            .flatten()
    }

    /// Whether `name` is the temp file of one of these names
    /// (`.NAME.XXXXXX.tmp`).
    fn is_temp_of_mine(&self, name: &str) -> bool {
        name.strip_prefix('.')
            .and_then(|n| n.strip_suffix(".tmp"))
            .and_then(|n| n.rsplit_once('.'))
            .is_some_and(|(tar, _)| self.seq_of(tar).is_some())
    }
}

/// Whether `name` is a complete shard file of any process (`shard-….tar`).
pub fn is_shard_name(name: &str) -> bool {
    name.starts_with("shard-") && name.ends_with(".tar")
}

/// The shard being written.
struct Open {
    builder: tar::Builder<File>,
    temp: TempPath,
    name: String,
    /// Bytes of members so far (the end of the last one).
    len: u64,
}

/// Writes one process's shards into a folder, whole items at a time.
pub struct ShardWriter {
    dir: PathBuf,
    names: ShardNames,
    shard_size: u64,
    next_seq: u64,
    open: Option<Open>,
    /// Where the item being written began in the open shard.
    item_start: u64,
}

impl ShardWriter {
    /// The writer of `names` in `dir` (created if missing): temp files a
    /// killed run of the same names left are removed, and numbering goes
    /// on after the last complete shard.
    pub fn new(dir: &Path, names: ShardNames, shard_size: u64) -> Result<Self, HostError> {
        fs::create_dir_all(dir).map_err(|e| HostError::io(dir, e))?;
        let mut next_seq = 0;
        for entry in fs::read_dir(dir).map_err(|e| HostError::io(dir, e))? {
            let entry = entry.map_err(|e| HostError::io(dir, e))?;
            let Ok(name) = entry.file_name().into_string() else {
                continue;
            };
            if names.is_temp_of_mine(&name) {
                fs::remove_file(entry.path()).map_err(|e| HostError::io(entry.path(), e))?;
            } else if let Some(seq) = names.seq_of(&name) {
                next_seq = next_seq.max(seq + 1);
            }
        }
        Ok(Self {
            dir: dir.to_owned(),
            names,
            shard_size: shard_size.max(1),
            next_seq,
            open: None,
            item_start: 0,
        })
    }

    /// The shard the next item goes into (its final name).
    pub fn current_name(&self) -> String {
        self.open
            .as_ref()
            .map_or_else(|| self.names.name(self.next_seq), |o| o.name.clone())
    }

    /// Start an item: [`Self::rollback`] cuts back to here.
    pub fn begin_item(&mut self) {
        self.item_start = self.open.as_ref().map_or(0, |o| o.len);
    }

    /// Append a member `name` holding `bytes` to the current item.
    pub fn append(&mut self, name: &str, bytes: &[u8]) -> Result<(), HostError> {
        if self.open.is_none() {
            self.open = Some(self.start()?);
            self.item_start = 0;
        }
        let open = self.open.as_mut().expect("opened above");
        let mut header = tar::Header::new_gnu();
        header.set_size(bytes.len() as u64);
        header.set_mode(0o644);
        header.set_uid(0);
        header.set_gid(0);
        header.set_mtime(0);
        header.set_entry_type(tar::EntryType::Regular);
        let at = open.temp.to_path_buf();
        open.builder
            .append_data(&mut header, name, bytes)
            .map_err(|e| HostError::io(&at, e))?;
        open.len = open
            .builder
            .get_mut()
            .stream_position()
            .map_err(|e| HostError::io(&at, e))?;
        Ok(())
    }

    /// A new temp shard.
    fn start(&mut self) -> Result<Open, HostError> {
        let name = self.names.name(self.next_seq);
        self.next_seq += 1;
        let prefix = format!(".{name}.");
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(".tmp");
        // As crate::io::atomic does: 0666 through the umask, an ordinary file's
        // permissions once renamed (tempfile's own are 0600).
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            builder.permissions(fs::Permissions::from_mode(0o666));
        }
        let temp = builder
            .tempfile_in(&self.dir)
            .map_err(|e| HostError::io(&self.dir, e))?;
        let (file, temp) = temp.into_parts();
        Ok(Open {
            builder: tar::Builder::new(file),
            temp,
            name,
            len: 0,
        })
    }

    /// Cut the item being written back out of the open shard.
    pub fn rollback(&mut self) -> Result<(), HostError> {
        let start = self.item_start;
        if let Some(open) = &mut self.open {
            let at = open.temp.to_path_buf();
            let file = open.builder.get_mut();
            file.set_len(start)
                .and_then(|()| file.seek(SeekFrom::Start(start)).map(drop))
                .map_err(|e| HostError::io(&at, e))?;
            open.len = start;
        }
        Ok(())
    }

    /// End an item: the shard is complete once it holds `shard_size` bytes.
    /// The name of a shard completed here.
    pub fn end_item(&mut self) -> Result<Option<String>, HostError> {
        if self.open.as_ref().is_some_and(|o| o.len >= self.shard_size) {
            return self.finish();
        }
        self.item_start = self.open.as_ref().map_or(0, |o| o.len);
        Ok(None)
    }

    /// Complete the open shard (if it holds anything): the archive's end,
    /// flushed to disk, renamed to its final name, which is returned.
    pub fn finish(&mut self) -> Result<Option<String>, HostError> {
        let Some(open) = self.open.take() else {
            return Ok(None);
        };
        self.item_start = 0;
        let at = open.temp.to_path_buf();
        if open.len == 0 {
            // Every item was cut back out: no shard.
            self.next_seq -= 1;
            return Ok(None);
        }
        let file = open
            .builder
            .into_inner()
            .map_err(|e| HostError::io(&at, e))?;
        file.sync_all().map_err(|e| HostError::io(&at, e))?;
        drop(file);
        let target = self.dir.join(&open.name);
        open.temp
            .persist_noclobber(&target)
            .map_err(|e| HostError::io(&target, e.error))?;
        Ok(Some(open.name))
    }
}

/// The key of a member name: up to the first dot of its last component,
/// as the `webdataset` package splits it.
pub fn key_of(member: &str) -> &str {
    let base = member.rfind('/').map_or(0, |i| i + 1);
    match member[base..].find('.') {
        Some(dot) => &member[..base + dot],
        None => member,
    }
}

/// Whether the file at `path` ends as [`ShardWriter::finish`] ends a shard:
/// whole 512-byte blocks, the last two of them zero (the archive's end).
pub fn is_whole(path: &Path) -> bool {
    let Ok(bytes) = fs::read(path) else {
        return false;
    };
    bytes.len() >= 1024
        && bytes.len() % 512 == 0
        && bytes[bytes.len() - 1024..].iter().all(|&b| b == 0)
}

/// Rewrite the complete shard `path` without the members whose key `drop`
/// says (through a temp file renamed over it; removed when nothing is
/// left). The number of members kept.
pub fn rewrite_without(path: &Path, drop: impl Fn(&str) -> bool) -> Result<usize, HostError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or("shard.tar");
    let mut archive = tar::Archive::new(File::open(path).map_err(|e| HostError::io(path, e))?);
    let temp = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(".tmp")
        .tempfile_in(dir)
        .map_err(|e| HostError::io(dir, e))?;
    let (file, temp) = temp.into_parts();
    let mut builder = tar::Builder::new(file);
    let mut kept = 0;
    for entry in archive.entries().map_err(|e| HostError::io(path, e))? {
        let mut entry = entry.map_err(|e| HostError::io(path, e))?;
        let member = entry
            .path()
            .map_err(|e| HostError::io(path, e))?
            .to_string_lossy()
            .into_owned();
        if drop(key_of(&member)) {
            continue;
        }
        let mut header = entry.header().clone();
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut entry, &mut bytes).map_err(|e| HostError::io(path, e))?;
        builder
            .append_data(&mut header, &member, bytes.as_slice())
            .map_err(|e| HostError::io(&*temp, e))?;
        kept += 1;
    }
    let file = builder.into_inner().map_err(|e| HostError::io(&*temp, e))?;
    if kept == 0 {
        drop_file(path)?;
        return Ok(0);
    }
    file.sync_all().map_err(|e| HostError::io(&*temp, e))?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = fs::metadata(path)
            .map(|m| m.permissions().mode())
            .unwrap_or(0o644);
        let _ = fs::set_permissions(&*temp, fs::Permissions::from_mode(mode));
    }
    temp.persist(path)
        .map_err(|e| HostError::io(path, e.error))?;
    Ok(kept)
}

fn drop_file(path: &Path) -> Result<(), HostError> {
    fs::remove_file(path).map_err(|e| HostError::io(path, e))
}

/// A member of a complete shard: `(member name, bytes)` of every `.json`.
pub fn json_members(path: &Path) -> Result<Vec<(String, Vec<u8>)>, HostError> {
    let file = File::open(path).map_err(|e| HostError::io(path, e))?;
    let mut archive = tar::Archive::new(file);
    let mut out = Vec::new();
    let entries = archive
        .entries_with_seek()
        .map_err(|e| HostError::io(path, e))?;
    for entry in entries {
        let mut entry = entry.map_err(|e| HostError::io(path, e))?;
        let name = entry
            .path()
            .map_err(|e| HostError::io(path, e))?
            .to_string_lossy()
            .into_owned();
        if name.ends_with(".json") {
            let mut bytes = Vec::new();
            std::io::Read::read_to_end(&mut entry, &mut bytes)
                .map_err(|e| HostError::io(path, e))?;
            out.push((name, bytes));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn members(path: &Path) -> Vec<(String, Vec<u8>)> {
        let mut archive = tar::Archive::new(File::open(path).unwrap());
        archive
            .entries()
            .unwrap()
            .map(|e| {
                let mut e = e.unwrap();
                let name = e.path().unwrap().to_string_lossy().into_owned();
                let mut bytes = Vec::new();
                std::io::Read::read_to_end(&mut e, &mut bytes).unwrap();
                (name, bytes)
            })
            .collect()
    }

    #[test]
    fn names_say_the_shard_and_never_collide() {
        let all = ShardNames::new(0, 1);
        assert_eq!(all.name(3), "shard-000003.tar");
        let third = ShardNames::new(3, 8);
        assert_eq!(third.name(12), "shard-0003-000012.tar");
        assert_eq!(ShardNames::new(7, 12345).name(0), "shard-00007-000000.tar");
        assert_eq!(third.seq_of("shard-0003-000012.tar"), Some(12));
        assert_eq!(third.seq_of("shard-0004-000012.tar"), None);
        assert_eq!(all.seq_of("shard-0003-000012.tar"), None);
        assert_eq!(all.seq_of("shard-000012.tar"), Some(12));
        assert!(third.is_temp_of_mine(".shard-0003-000001.tar.aB3xYz.tmp"));
        assert!(!third.is_temp_of_mine(".shard-0002-000001.tar.aB3xYz.tmp"));
        assert!(!all.is_temp_of_mine(".shard-0003-000001.tar.aB3xYz.tmp"));
        assert!(is_shard_name("shard-0003-000012.tar") && !is_shard_name(".shard-1.tar.x.tmp"));
    }

    #[test]
    fn shards_close_between_items_and_a_rollback_cuts_an_item_out() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = ShardWriter::new(dir.path(), ShardNames::new(0, 1), 3000).unwrap();
        w.begin_item();
        w.append("a/0.rep.png", &[1; 1000]).unwrap();
        w.append("a/0.json", b"{}").unwrap();
        assert_eq!(w.end_item().unwrap(), None);
        w.begin_item();
        w.append("b/0.rep.png", &[2; 700]).unwrap();
        w.rollback().unwrap();
        w.begin_item();
        w.append("c/0.rep.png", &[3; 2000]).unwrap();
        assert_eq!(w.end_item().unwrap().as_deref(), Some("shard-000000.tar"));
        w.begin_item();
        w.append("d/0.rep.png", &[4; 10]).unwrap();
        w.end_item().unwrap();
        // A failed last item leaves no empty shard.
        w.begin_item();
        w.append("e/0.rep.png", &[4; 10]).unwrap();
        w.rollback().unwrap();
        assert_eq!(w.finish().unwrap().as_deref(), Some("shard-000001.tar"));
        let first = members(&dir.path().join("shard-000000.tar"));
        let names: Vec<&str> = first.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["a/0.rep.png", "a/0.json", "c/0.rep.png"]);
        assert_eq!(first[2].1, vec![3; 2000]);
        assert_eq!(members(&dir.path().join("shard-000001.tar")).len(), 1);
        assert_eq!(
            json_members(&dir.path().join("shard-000000.tar")).unwrap(),
            [("a/0.json".to_owned(), b"{}".to_vec())]
        );
        // Numbering goes on after the complete shards; a killed run's temp is removed.
        fs::write(dir.path().join(".shard-000002.tar.XyZ123.tmp"), b"partial").unwrap();
        let mut again = ShardWriter::new(dir.path(), ShardNames::new(0, 1), 3000).unwrap();
        assert!(!dir.path().join(".shard-000002.tar.XyZ123.tmp").exists());
        assert_eq!(again.current_name(), "shard-000002.tar");
        assert_eq!(again.finish().unwrap(), None);
        let mut names: Vec<String> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        assert_eq!(names, ["shard-000000.tar", "shard-000001.tar"]);
    }
}
