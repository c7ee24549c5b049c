//! `dataset --shard I/N`: which items one of `N` cooperating processes
//! takes. An item belongs to shard `fnv1a64(relative path) mod N`, so the
//! share depends on the item alone: adding files never moves finished work
//! between shards, and any process can tell its items without talking to
//! the others. Without `--shard`, a Slurm job array's or a Kubernetes
//! Indexed Job's variables give the shard.

use crate::HostError;
use crate::settings::Setting;

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

    /// The shard a scheduler assigned to this process, read with `var`
    /// (the environment): a Slurm job array (`SLURM_ARRAY_TASK_ID` minus
    /// `SLURM_ARRAY_TASK_MIN`, of `SLURM_ARRAY_TASK_COUNT`; the array must
    /// be contiguous, e.g. `--array=0-7`), or a Kubernetes Indexed Job
    /// (`JOB_COMPLETION_INDEX`, of `count`: Kubernetes does not tell a pod
    /// how many completions its Job has). `None` outside both; the text
    /// says where the shard came from.
    pub fn from_scheduler(
        var: impl Fn(&str) -> Option<String>,
        count: Option<u64>,
    ) -> Result<Option<(Shard, String)>, HostError> {
        let number = |name: &str| -> Result<Option<u64>, HostError> {
            var(name)
                .map(|v| {
                    v.trim().parse::<u64>().map_err(|_| {
                        HostError::invalid(name, format!("'{v}' is not a non-negative integer"))
                    })
                })
                .transpose()
        };
        let checked = |index: u64, count: u64, from: String| {
            Shard::new(index, count)
                .map(|s| Some((s, from)))
                .map_err(|e| HostError::setting(Setting::Shard, e))
        };
        if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
            let min = number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
            let Some(n) = count.or(number("SLURM_ARRAY_TASK_COUNT")?) else {
                return Err(HostError::invalid(
                    "--shard",
                    "SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not; pass --shards N",
                ));
            };
            let index = id.checked_sub(min).ok_or_else(|| {
                HostError::invalid(
                    "SLURM_ARRAY_TASK_ID",
                    format!("{id} is below SLURM_ARRAY_TASK_MIN {min}"),
                )
            })?;
            return checked(
                index,
                n,
                format!("Slurm array task {id} (first {min}) of {n}"),
            );
        }
        if let Some(index) = number("JOB_COMPLETION_INDEX")? {
            let Some(n) = count else {
                return Err(HostError::invalid(
                    "--shards",
                    "JOB_COMPLETION_INDEX is set (a Kubernetes Indexed Job) but the shard count is unknown; \
                     pass --shards N with the Job's completions, or --shard I/N",
                ));
            };
            return checked(
                index,
                n,
                format!("Kubernetes completion index {index} of {n}"),
            );
        }
        match count {
            Some(_) => Err(HostError::invalid(
                "--shards",
                "gives the count only; the index comes from SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX, \
                 and neither is set (use --shard I/N)",
            )),
            None => Ok(None),
        }
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

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| {
            vars.iter()
                .find(|(k, _)| *k == name)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn reads_slurm_and_kubernetes_variables() {
        let slurm = [
            ("SLURM_ARRAY_TASK_ID", "5"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "8"),
        ];
        let (shard, from) = Shard::from_scheduler(env(&slurm), None).unwrap().unwrap();
        assert_eq!(shard, Shard { index: 4, count: 8 });
        assert!(from.contains("Slurm"), "{from}");
        let k8s = [("JOB_COMPLETION_INDEX", "2")];
        let (shard, _) = Shard::from_scheduler(env(&k8s), Some(3)).unwrap().unwrap();
        assert_eq!(shard, Shard { index: 2, count: 3 });
        let err = Shard::from_scheduler(env(&k8s), None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("--shards N"), "{err}");
        assert!(Shard::from_scheduler(env(&k8s), Some(2)).is_err());
        assert!(Shard::from_scheduler(env(&[]), None).unwrap().is_none());
        assert!(Shard::from_scheduler(env(&[]), Some(2)).is_err());
        assert!(Shard::from_scheduler(env(&[("SLURM_ARRAY_TASK_ID", "x")]), None).is_err());
    }
}
