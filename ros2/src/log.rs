//! The node's log: each line on stderr (where `ros2 launch` and systemd
//! collect it) and on `/rosout` (where `ros2 topic echo /rosout` and rqt
//! read it). A problem that repeats at the camera's rate is told at its
//! 1st, 10th, 100th, … occurrence, with its count, not at every frame.

use std::collections::HashMap;

use ros2_client::dds::{NodeLoggingHandle, RosoutRaw};
use ros2_client::log::LogLevel;

/// Where the lines go.
pub struct Log {
    rosout: Option<NodeLoggingHandle>,
    /// Occurrences of each repeating problem.
    counts: HashMap<String, u64>,
}

impl Log {
    /// A log on stderr only (until the node exists).
    pub fn stderr() -> Self {
        Self {
            rosout: None,
            counts: HashMap::new(),
        }
    }

    /// Also on `/rosout`, through `handle`.
    pub fn with_rosout(self, handle: NodeLoggingHandle) -> Self {
        Self {
            rosout: Some(handle),
            ..self
        }
    }

    /// An informational line.
    pub fn info(&self, line: &str) {
        self.write(LogLevel::Info, line);
    }

    /// A warning.
    pub fn warn(&self, line: &str) {
        self.write(LogLevel::Warn, line);
    }

    /// A problem of kind `kind` that may repeat: a warning at its 1st,
    /// 10th, 100th, … occurrence, `line` followed by the count.
    pub fn repeated(&mut self, kind: &str, line: &str) {
        let n = self.counts.entry(kind.to_owned()).or_default();
        *n += 1;
        if is_power_of_ten(*n) {
            let times = if *n == 1 {
                String::new()
            } else {
                format!(" ({n} times so far)")
            };
            self.warn(&format!("{line}{times}"));
        }
    }

    /// How many times each repeating problem occurred.
    pub fn counts(&self) -> impl Iterator<Item = (&str, u64)> {
        self.counts.iter().map(|(k, &n)| (k.as_str(), n))
    }

    fn write(&self, level: LogLevel, line: &str) {
        eprintln!("reynoldsflow-ros2: {line}");
        if let Some(rosout) = &self.rosout {
            rosout.rosout_raw(now(), level, rosout.base_name(), line, file!(), "", line!());
        }
    }
}

/// The wall clock as ros2-client's stamp.
fn now() -> ros2_client::builtin_interfaces::Time {
    ros2_client::builtin_interfaces::Time::now()
}

fn is_power_of_ten(mut n: u64) -> bool {
    while n >= 10 && n.is_multiple_of(10) {
        n /= 10;
    }
    n == 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeats_are_told_at_powers_of_ten() {
        let told: Vec<u64> = (1..=1000).filter(|&n| is_power_of_ten(n)).collect();
        assert_eq!(told, [1, 10, 100, 1000]);
        let mut log = Log::stderr();
        for _ in 0..12 {
            log.repeated("encoding yuv422", "dropped");
        }
        assert_eq!(log.counts().collect::<Vec<_>>(), [("encoding yuv422", 12)]);
    }
}
