//! `dataset`'s shard when `--shard` is not given: the one a scheduler
//! assigned to this process, from its environment.

use reynoldsflow_host::HostError;
use reynoldsflow_host::dataset::Shard;
use reynoldsflow_host::settings::Setting;

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

#[cfg(test)]
mod tests {
    use super::*;

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
        let (shard, from) = from_scheduler(env(&slurm), None).unwrap().unwrap();
        assert_eq!(shard, Shard { index: 4, count: 8 });
        assert!(from.contains("Slurm"), "{from}");
        let k8s = [("JOB_COMPLETION_INDEX", "2")];
        let (shard, _) = from_scheduler(env(&k8s), Some(3)).unwrap().unwrap();
        assert_eq!(shard, Shard { index: 2, count: 3 });
        let err = from_scheduler(env(&k8s), None).unwrap_err().to_string();
        assert!(err.contains("--shards N"), "{err}");
        assert!(from_scheduler(env(&k8s), Some(2)).is_err());
        assert!(from_scheduler(env(&[]), None).unwrap().is_none());
        assert!(from_scheduler(env(&[]), Some(2)).is_err());
        assert!(from_scheduler(env(&[("SLURM_ARRAY_TASK_ID", "x")]), None).is_err());
    }
}
