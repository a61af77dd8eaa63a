//! What the machine can spare, read once per run and handed to the shadow methods as plain
//! data ([`renderer::RenderSettings::memory_budget_bytes`]): the plugins never probe their
//! environment.

/// Most bytes one light's shadow method may hold (`edge_table`'s masks): half the memory
/// available when it is read (Linux's `MemAvailable`, or the cgroup's headroom under
/// `memory.max` when that is smaller: a container is killed at its limit, not the
/// machine's), at most 16 GiB; 4 GiB where neither is known. `PENUMBRA_MASK_BUDGET_MIB`
/// overrides it.
pub fn memory_budget_bytes() -> u64 {
    if let Some(mib) = std::env::var("PENUMBRA_MASK_BUDGET_MIB").ok().and_then(|v| v.parse::<u64>().ok()) {
        return mib.saturating_mul(1 << 20);
    }
    let read_u64 = |path: &str| std::fs::read_to_string(path).ok().and_then(|t| t.trim().parse::<u64>().ok());
    let available = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|m| {
            m.lines()
                .find_map(|l| l.strip_prefix("MemAvailable:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        })
        .map(|kib| kib << 10);
    // cgroup v2; "max" (no limit) does not parse and is ignored.
    let cgroup = read_u64("/sys/fs/cgroup/memory.max")
        .zip(read_u64("/sys/fs/cgroup/memory.current"))
        .map(|(max, current)| max.saturating_sub(current));
    let free = match (available, cgroup) {
        (Some(a), Some(c)) => Some(a.min(c)),
        (a, c) => a.or(c),
    };
    free.map_or(4 << 30, |b| b / 2).min(16 << 30)
}
