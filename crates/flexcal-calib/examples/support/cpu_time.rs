//! CPU time and load average from `/proc` (Linux), shared by the speed
//! examples (each uses part of them).
#![allow(dead_code)]

/// CPU time of this process so far (s), when the system says.
pub fn cpu_seconds() -> Option<f64> {
    stat_cpu_seconds("/proc/self/stat")
}

/// Time the calling thread has run on a CPU so far (s, to the
/// nanosecond: the scheduler's own account, `/proc/thread-self/schedstat`),
/// when the system says.
pub fn thread_run_seconds() -> Option<f64> {
    schedstat_seconds("/proc/thread-self/schedstat")
}

/// Time every live thread of this process has run on a CPU so far (s, to
/// the nanosecond; the threads of a pool live as long as the process),
/// when the system says.
pub fn process_run_seconds() -> Option<f64> {
    std::fs::read_dir("/proc/self/task")
        .ok()?
        .map(|task| schedstat_seconds(&task.ok()?.path().join("schedstat").to_string_lossy()))
        .sum()
}

/// The first field of a `schedstat` file: run time (ns), in s.
fn schedstat_seconds(path: &str) -> Option<f64> {
    let stat = std::fs::read_to_string(path).ok()?;
    Some(stat.split_whitespace().next()?.parse::<f64>().ok()? * 1e-9)
}

/// User + system time (s) of a `/proc/.../stat` file.
fn stat_cpu_seconds(path: &str) -> Option<f64> {
    let stat = std::fs::read_to_string(path).ok()?;
    // Fields after the command name (which may hold spaces) in parentheses.
    let fields: Vec<&str> = stat
        .get(stat.rfind(')')? + 2..)?
        .split_whitespace()
        .collect();
    let ticks = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    // The kernel's USER_HZ, 100 on every Linux architecture in use.
    Some(ticks / 100.0)
}

/// The load averages (1, 5, 15 min) as the system prints them.
pub fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}
