//! `dataset --shard I/N`: which items one of `N` cooperating processes
//! takes. An item belongs to shard `fnv1a64(relative path) mod N`, so the
//! share depends on the item alone: adding files never moves finished work
//! between shards, and any process can tell its items without talking to
//! the others. (The CLI's `dataset` also reads the shard from a Slurm job
//! array's or a Kubernetes Indexed Job's variables.)

/// Shard `index` of `count` (`index < count`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This process's share, from 0.
    pub index: u64,
    /// How many shares there are, at least 1.
    pub count: u64,
}

/// Parse `I/N` (`0 <= I < N`).
pub fn parse_shard(s: &str) -> Result<Shard, String> {
    let usage = "expected I/N with 0 <= I < N (e.g. 0/4 ... 3/4)";
    let number = |v: &str| v.trim().parse::<u64>().ok();
    match s.split_once('/').map(|(i, n)| (number(i), number(n))) {
        Some((Some(index), Some(count))) => {
            Shard::new(index, count).map_err(|e| format!("{e}; {usage}"))
        }
        _ => Err(usage.to_owned()),
    }
}

/// FNV-1a, 64 bits: fixed by its definition, unlike `std`'s hashers.
fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}

impl Shard {
    /// The whole dataset, unsharded.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Shard `index` of `count`, checked.
    pub fn new(index: u64, count: u64) -> Result<Self, String> {
        if count == 0 {
            return Err("the shard count N is 0".to_owned());
        }
        if index >= count {
            return Err(format!(
                "shard index {index} is not below the count {count}"
            ));
        }
        Ok(Self { index, count })
    }

    /// Whether the item at `key` (its path relative to SRC, `/`-separated)
    /// is this shard's.
    pub fn contains(&self, key: &str) -> bool {
        fnv1a64(key.as_bytes()) % self.count == self.index
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_checks_i_of_n() {
        assert_eq!(parse_shard("1/4"), Ok(Shard { index: 1, count: 4 }));
        assert_eq!(parse_shard("0/1"), Ok(Shard::ALL));
        for bad in ["4/4", "0/0", "1", "-1/2", "a/b", "1/2/3", ""] {
            assert!(parse_shard(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn every_key_is_in_exactly_one_shard_and_shares_are_even() {
        let keys: Vec<String> = (0..4000)
            .map(|i| format!("class{}/clip_{i}.mp4", i % 7))
            .collect();
        let n = 4;
        let mut sizes = [0usize; 4];
        for key in &keys {
            let owners: Vec<u64> = (0..n)
                .filter(|&i| Shard { index: i, count: n }.contains(key))
                .collect();
            assert_eq!(owners.len(), 1, "{key}");
            sizes[owners[0] as usize] += 1;
        }
        // 1000 expected per shard; a binomial spread of ~27.
        assert!(sizes.iter().all(|&s| (850..1150).contains(&s)), "{sizes:?}");
        // The hash is the published FNV-1a: stable across builds and platforms.
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
    }
}
