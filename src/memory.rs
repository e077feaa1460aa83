//! The memory a command may use, read before any voxel is: what the system has available (the
//! cgroup's headroom under its limit, or `MemAvailable` in `/proc/meminfo`, whichever is
//! smaller), or a cap the user set; and what the command will hold at its peak, as a multiple of
//! the dense f32 volume ([`MemoryBudget::volumes`], measured by `bench/memory.sh`). A volume
//! whose peak would not fit is refused with both figures named, instead of failing halfway
//! through the work (or being killed for memory).

use crate::error::{Error, Result};
use std::path::Path;

/// Where the memory available comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MemoryLimit {
    /// Read from the system when a volume is about to be loaded.
    System,
    /// A fixed number of bytes; the name of the setting that gave it, for messages.
    Bytes(u64, &'static str),
}

/// Assumed where the system's free memory cannot be read (outside Linux).
const UNREAD_DEFAULT: u64 = 8 << 30;

impl MemoryLimit {
    /// Bytes available, and where that figure comes from.
    pub fn read(self) -> (u64, String) {
        match self {
            MemoryLimit::Bytes(bytes, source) => (bytes, source.to_owned()),
            MemoryLimit::System => system_available().unwrap_or_else(|| {
                (
                    UNREAD_DEFAULT,
                    "a default of 8 GiB (the system's free memory could not be read)".to_owned(),
                )
            }),
        }
    }
}

/// What a command may allocate for its volume.
#[derive(Clone, Debug, PartialEq)]
pub struct MemoryBudget {
    pub limit: MemoryLimit,
    /// The command's peak memory as a multiple of its dense f32 volume (1: the volume alone).
    pub volumes: f64,
    /// Bytes the command holds besides, whatever the volume's size (an image's layers).
    pub fixed_bytes: u64,
    /// What holds that peak, for messages ("loading the volume", "ao --method sweep").
    pub holder: String,
}

impl Default for MemoryBudget {
    /// The system's memory, for loading the volume alone.
    fn default() -> Self {
        Self {
            limit: MemoryLimit::System,
            volumes: 1.0,
            fixed_bytes: 0,
            holder: "loading the volume".to_owned(),
        }
    }
}

impl MemoryBudget {
    /// The same limit for a command that holds `volumes` dense f32 volumes and `fixed_bytes`
    /// besides at its peak.
    pub fn holding(mut self, volumes: f64, fixed_bytes: u64, holder: impl Into<String>) -> Self {
        self.volumes = volumes.max(1.0);
        self.fixed_bytes = fixed_bytes;
        self.holder = holder.into();
        self
    }

    /// Checks, before anything is allocated, that a grid of `dims` fits: its f32 values times
    /// the command's multiple against the bytes available. Returns the voxel count.
    pub fn check(&self, dims: [usize; 3]) -> Result<usize> {
        let count = crate::volume::voxel_count(dims)?;
        let volume = count as f64 * 4.0;
        let need = volume * self.volumes + self.fixed_bytes as f64;
        let (available, source) = self.limit.read();
        if need > available as f64 {
            let besides = match self.fixed_bytes {
                0 => String::new(),
                bytes => format!(" and {} besides", size_text(bytes as f64)),
            };
            let holds = if need > volume {
                format!(
                    "; {} holds about {:.1} such volumes{besides} at its peak, {} in all",
                    self.holder,
                    self.volumes,
                    size_text(need)
                )
            } else {
                String::new()
            };
            return Err(Error::Volume(format!(
                "dims {}x{}x{} need {} as f32{holds}: more than the {} available ({source})",
                dims[0],
                dims[1],
                dims[2],
                size_text(volume),
                size_text(available as f64),
            )));
        }
        Ok(count)
    }
}

/// A byte count for people: GiB from 1 GiB up, else MiB, else KiB (a 5 MiB budget must not
/// read "0.0 GiB").
pub fn size_text(bytes: f64) -> String {
    const KIB: f64 = 1024.0;
    if bytes >= KIB * KIB * KIB {
        format!("{:.1} GiB", bytes / (KIB * KIB * KIB))
    } else if bytes >= KIB * KIB {
        format!("{:.1} MiB", bytes / (KIB * KIB))
    } else {
        format!("{:.1} KiB", bytes / KIB)
    }
}

/// The smaller of the cgroup's headroom and `MemAvailable`, with where it was read; None where
/// neither can be read.
fn system_available() -> Option<(u64, String)> {
    let meminfo = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| mem_available(&text))
        .map(|bytes| (bytes, "MemAvailable in /proc/meminfo".to_owned()));
    let cgroup = cgroup_headroom();
    match (meminfo, cgroup) {
        (Some(m), Some(c)) => Some(if c.0 < m.0 { c } else { m }),
        (m, c) => m.or(c),
    }
}

/// `MemAvailable` of a `/proc/meminfo` text, in bytes.
fn mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// Limits at or above this mean "no limit" (cgroup v1 writes 2^63 rounded to a page).
const UNLIMITED: u64 = 1 << 60;

/// The memory cgroup's limit minus its usage, counting the inactive page cache as free (the
/// kernel reclaims it before failing an allocation), for this process's cgroup, v2 or v1;
/// None without a limit.
fn cgroup_headroom() -> Option<(u64, String)> {
    let membership = std::fs::read_to_string("/proc/self/cgroup").unwrap_or_default();
    for (root, own, files) in [
        (
            "/sys/fs/cgroup",
            membership.lines().find_map(|l| l.strip_prefix("0::")),
            ["memory.max", "memory.current", "memory.stat"],
        ),
        (
            "/sys/fs/cgroup/memory",
            membership.lines().find_map(|l| {
                let (_, rest) = l.split_once(':')?;
                rest.strip_prefix("memory:")
            }),
            [
                "memory.limit_in_bytes",
                "memory.usage_in_bytes",
                "memory.stat",
            ],
        ),
    ] {
        // Inside a container the listed path may not exist: its own cgroup is the root.
        for dir in own
            .map(|path| format!("{root}{path}"))
            .into_iter()
            .chain([root.to_owned()])
        {
            let read = |name: &str| std::fs::read_to_string(Path::new(&dir).join(name)).ok();
            let (Some(limit), Some(usage)) = (read(files[0]), read(files[1])) else {
                continue;
            };
            if let Some(headroom) = headroom(&limit, &usage, &read(files[2]).unwrap_or_default()) {
                return Some((headroom, format!("the memory cgroup's limit in {dir}")));
            }
        }
    }
    None
}

/// limit - usage + inactive page cache, from a cgroup's files' texts; None when unlimited or
/// unreadable.
fn headroom(limit: &str, usage: &str, stat: &str) -> Option<u64> {
    let limit: u64 = limit.trim().parse().ok()?; // "max" (v2, no limit) does not parse
    if limit >= UNLIMITED {
        return None;
    }
    let usage: u64 = usage.trim().parse().ok()?;
    let inactive = stat
        .lines()
        .find_map(|l| l.strip_prefix("inactive_file "))
        .and_then(|v| v.trim().parse::<u64>().ok())
        .unwrap_or(0);
    Some(limit.saturating_sub(usage.saturating_sub(inactive)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mem_available_reads_kib_lines() {
        let text = "MemTotal:       24683772 kB\nMemFree:  100 kB\nMemAvailable:   2048 kB\n";
        assert_eq!(mem_available(text), Some(2048 * 1024));
        assert_eq!(mem_available("MemTotal: 5 kB\n"), None);
    }

    #[test]
    fn cgroup_headroom_counts_inactive_cache_and_no_limit() {
        let stat = "cache 100\ninactive_file 300\nactive_file 5\n";
        assert_eq!(headroom("1000\n", "900\n", stat), Some(400));
        assert_eq!(headroom("1000", "1200", ""), Some(0));
        assert_eq!(headroom("max\n", "900", stat), None);
        assert_eq!(headroom("9223372036854771712", "900", stat), None);
    }

    #[test]
    fn the_check_names_need_multiple_and_availability() {
        let budget = MemoryBudget {
            limit: MemoryLimit::Bytes(5 << 20, "a test's cap"),
            ..Default::default()
        };
        let err = budget.check([512, 512, 512]).unwrap_err().to_string();
        assert!(
            err.contains("need 512.0 MiB as f32")
                && err.contains("5.0 MiB available (a test's cap)"),
            "{err}"
        );
        let sweep = budget.clone().holding(2.5, 0, "ao --method sweep");
        assert!(sweep.check([64, 64, 64]).is_ok()); // 2.5 MiB of 5
        let err = sweep.check([96, 96, 96]).unwrap_err().to_string();
        assert!(
            err.contains("ao --method sweep holds about 2.5 such volumes at its peak, 8.4 MiB"),
            "{err}"
        );
        let render = budget.clone().holding(1.2, 4 << 20, "a render");
        let err = render.check([64, 64, 64]).unwrap_err().to_string();
        assert!(
            err.contains(
                "a render holds about 1.2 such volumes and 4.0 MiB besides at its peak, 5.2 MiB"
            ),
            "{err}"
        );
        assert!(budget.check([usize::MAX, 2, 2]).is_err());
        let err = MemoryBudget::default()
            .check([100_000, 100_000, 100_000])
            .unwrap_err()
            .to_string();
        assert!(err.contains("3725290.3 GiB as f32"), "{err}");
    }
}
