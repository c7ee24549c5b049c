//! Watching and disturbing a running `reynoldsflow`: its peak memory and
//! CPU time (wait4), its resident memory while it runs (/proc), signals,
//! and a small tmpfs to fill up or turn read-only (needs root, as CI runs).
#![allow(dead_code)]

use std::ffi::OsString;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};

/// What a finished child left: exit status, output, peak memory, CPU time.
pub struct Measured {
    pub status: ExitStatus,
    pub stdout: Vec<u8>,
    pub stderr: String,
    /// Peak resident set, KiB (`ru_maxrss`).
    pub max_rss_kib: u64,
    /// User + system CPU seconds.
    pub cpu_seconds: f64,
}

/// Run `bin args` to the end and measure it (stdin empty).
pub fn run_measured(bin: &str, args: &[OsString]) -> Measured {
    let child = Command::new(bin)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start the child");
    wait_measured(child)
}

/// Wait for `child` with wait4, collecting its output meanwhile.
pub fn wait_measured(mut child: Child) -> Measured {
    let drain = |r: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            if let Some(mut r) = r {
                let _ = r.read_to_end(&mut bytes);
            }
            bytes
        })
    };
    let out = drain(child.stdout.take().map(|r| Box::new(r) as _));
    let err = drain(child.stderr.take().map(|r| Box::new(r) as _));
    let pid = child.id() as libc::pid_t;
    let mut raw_status = 0;
    // SAFETY: plain syscall on our own child; `usage` is a valid out-pointer.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let waited = unsafe { libc::wait4(pid, &mut raw_status, 0, &mut usage) };
    assert_eq!(waited, pid, "wait4: {}", std::io::Error::last_os_error());
    use std::os::unix::process::ExitStatusExt;
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    Measured {
        status: ExitStatus::from_raw(raw_status),
        stdout: out.join().unwrap(),
        stderr: String::from_utf8_lossy(&err.join().unwrap()).into_owned(),
        max_rss_kib: usage.ru_maxrss as u64,
        cpu_seconds: secs(usage.ru_utime) + secs(usage.ru_stime),
    }
}

/// A field of /proc/PID/status in KiB (`VmRSS`, `VmHWM`), while it runs.
pub fn status_kib(pid: u32, field: &str) -> u64 {
    let text = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("the child runs");
    text.lines()
        .find_map(|l| l.strip_prefix(field)?.strip_prefix(':'))
        .and_then(|v| v.trim().strip_suffix("kB")?.trim().parse().ok())
        .unwrap_or_else(|| panic!("no {field} in /proc/{pid}/status"))
}

/// Send `signal` to `pid`.
pub fn signal(pid: u32, signal: libc::c_int) {
    // SAFETY: kill(2) on our own child's pid.
    let r = unsafe { libc::kill(pid as libc::pid_t, signal) };
    assert_eq!(r, 0, "kill: {}", std::io::Error::last_os_error());
}

/// Stop `pid` (SIGSTOP) and return once every thread of it is stopped:
/// kill(2) only queues the signal, so a thread on another core may still
/// finish a syscall (create a file) after it returns.
pub fn stop(pid: u32) {
    signal(pid, libc::SIGSTOP);
    let tasks = format!("/proc/{pid}/task");
    let stopped = || {
        std::fs::read_dir(&tasks).unwrap().all(|task| {
            let stat =
                std::fs::read_to_string(task.unwrap().path().join("stat")).unwrap_or_default();
            // The state follows the parenthesised command name.
            let state = stat
                .rsplit_once(") ")
                .and_then(|(_, rest)| rest.bytes().next());
            matches!(state, Some(b'T' | b't'))
        })
    };
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(30);
    while !stopped() {
        assert!(
            std::time::Instant::now() < deadline,
            "pid {pid} did not stop"
        );
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
}

/// A tmpfs mounted on a fresh folder for one test, unmounted on drop.
pub struct Tmpfs {
    pub dir: PathBuf,
}

fn mount(args: &[&str]) -> Result<(), String> {
    let out = Command::new("mount")
        .args(args)
        .output()
        .map_err(|e| format!("cannot run mount: {e}"))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(String::from_utf8_lossy(&out.stderr).trim().to_owned())
    }
}

impl Tmpfs {
    /// Mount `size` bytes of tmpfs on `dir` (created).
    pub fn mount(dir: &Path, size: u64) -> Self {
        std::fs::create_dir_all(dir).unwrap();
        let dir_s = dir.to_str().unwrap();
        if let Err(e) = mount(&["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs", dir_s]) {
            panic!(
                "the fault-injection tests mount a small tmpfs and need root (CI runs as root): {e}"
            );
        }
        Self {
            dir: dir.to_owned(),
        }
    }

    /// Remount with `options` (`ro`, `rw,size=…`); `Err` with mount's message.
    pub fn remount(&self, options: &str) -> Result<(), String> {
        mount(&[
            "-o",
            &format!("remount,{options}"),
            self.dir.to_str().unwrap(),
        ])
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg("-l").arg(&self.dir).status();
    }
}
