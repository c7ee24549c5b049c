//! How the library knows a file by its content: XXH3-128, as 32 hex
//! digits. The dataset's manifests record it for every output and source
//! (`dataset::commit`); the output writer computes it on the bytes it
//! writes, so no output is read back to be known.

use std::fs;
use std::io::Read;
use std::path::Path;

use xxhash_rust::xxh3::Xxh3;

use crate::HostError;

/// XXH3-128 of `bytes`, as 32 hex digits.
pub fn hash_bytes(bytes: &[u8]) -> String {
    format!("{:032x}", xxhash_rust::xxh3::xxh3_128(bytes))
}

/// XXH3-128 of the file at `path`, read in blocks of 1 MiB.
pub fn hash_file(path: &Path) -> Result<String, HostError> {
    let mut file = fs::File::open(path).map_err(|e| HostError::io(path, e))?;
    let mut hasher = Xxh3::new();
    let mut block = vec![0; 1 << 20];
    loop {
        let n = file.read(&mut block).map_err(|e| HostError::io(path, e))?;
        if n == 0 {
            break;
        }
        hasher.update(&block[..n]);
    }
    Ok(format!("{:032x}", hasher.digest128()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_hashes_as_its_bytes_do() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        let bytes: Vec<u8> = (0..(3 << 19)).map(|i: u32| (i * 31 % 251) as u8).collect();
        fs::write(&path, &bytes).unwrap();
        assert_eq!(hash_file(&path).unwrap(), hash_bytes(&bytes));
        assert_ne!(hash_bytes(&bytes[1..]), hash_bytes(&bytes));
        assert_eq!(hash_bytes(b"").len(), 32);
    }
}
