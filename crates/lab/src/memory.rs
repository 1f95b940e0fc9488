//! Peak resident memory of this process, for the benchmarks.
//!
//! `cpg` and `cargo xtask` print it at exit when the environment variable
//! [`REPORT_PEAK_RSS`] is set, one line on standard error that
//! [`parse_report`] reads back (`cargo xtask bench` runs them as child
//! processes and tables their peaks).

/// The environment variable that asks for the report.
pub const REPORT_PEAK_RSS: &str = "CPG_REPORT_PEAK_RSS";

const PREFIX: &str = "peak resident memory: ";

/// This process's peak resident set (`VmHWM` of `/proc/self/status`), MiB;
/// `None` where the kernel does not say (not Linux).
pub fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    parse_vm_hwm(&status)
}

fn parse_vm_hwm(status: &str) -> Option<f64> {
    let line = status.lines().find_map(|l| l.strip_prefix("VmHWM:"))?;
    let mut parts = line.split_whitespace();
    let kib: f64 = parts.next()?.parse().ok()?;
    (parts.next()? == "kB").then_some(kib / 1024.0)
}

/// The line printed at exit when [`REPORT_PEAK_RSS`] is set, or `None`.
pub fn report_line() -> Option<String> {
    std::env::var_os(REPORT_PEAK_RSS)?;
    Some(match peak_rss_mib() {
        Some(mib) => format!("{PREFIX}{mib:.1} MiB"),
        None => format!("{PREFIX}unknown MiB"),
    })
}

/// The peak a child process reported on its standard error, MiB.
pub fn parse_report(stderr: &str) -> Option<f64> {
    stderr.lines().rev().find_map(|l| l.strip_prefix(PREFIX)?.strip_suffix(" MiB")?.parse().ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_high_water_mark_is_read_in_mib() {
        let status = "Name:\tcpg\nVmPeak:\t  20000 kB\nVmHWM:\t    2048 kB\nVmRSS:\t  1024 kB\n";
        assert_eq!(parse_vm_hwm(status), Some(2.0));
        assert_eq!(parse_vm_hwm("VmHWM:\t12 MB\n"), None);
        assert_eq!(parse_vm_hwm("VmRSS:\t12 kB\n"), None);
        assert_eq!(parse_report("progress\npeak resident memory: 17.5 MiB\n"), Some(17.5));
        assert_eq!(parse_report("peak resident memory: unknown MiB\n"), None);
    }

    #[test]
    fn this_process_has_a_peak() {
        if cfg!(target_os = "linux") {
            assert!(peak_rss_mib().is_some_and(|m| m > 0.1));
        }
    }
}
