//! What the machine can spare, read once per run and handed to the shadow methods as plain
//! data ([`renderer::RenderSettings::memory_budget_bytes`]): the plugins never probe their
//! environment.

use renderer::SceneError;

/// The environment variable that overrides the budget, in MiB.
pub const BUDGET_VARIABLE: &str = "PENUMBRA_MASK_BUDGET_MIB";

/// `PENUMBRA_MASK_BUDGET_MIB` in bytes when it is set; an error naming it when it is set to
/// anything but a whole number of MiB. A value that does not parse used to be ignored, so
/// a typo ("4G", "4096 MiB") silently gave the machine's budget instead of the one asked for.
pub fn budget_override() -> Result<Option<u64>, SceneError> {
    let Some(value) = std::env::var_os(BUDGET_VARIABLE) else { return Ok(None) };
    let text = value.to_string_lossy();
    match text.trim().parse::<u64>() {
        Ok(mib) => Ok(Some(mib.saturating_mul(1 << 20))),
        Err(_) => Err(SceneError::new(
            BUDGET_VARIABLE,
            "",
            format!("the environment variable must be a whole number of MiB (such as 4096), got {text:?}"),
        )),
    }
}

/// Most bytes one light's shadow method may hold (`edge_table`'s masks and depth map): half
/// the memory available when it is read (Linux's `MemAvailable`, or the cgroup's headroom
/// under `memory.max` when that is smaller: a container is killed at its limit, not the
/// machine's), at most 16 GiB; 4 GiB where neither is known. `PENUMBRA_MASK_BUDGET_MIB`
/// overrides it.
///
/// # Errors
/// `PENUMBRA_MASK_BUDGET_MIB` is set but is not a whole number ([`budget_override`]).
pub fn memory_budget_bytes() -> Result<u64, SceneError> {
    if let Some(bytes) = budget_override()? {
        return Ok(bytes);
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
    Ok(free.map_or(4 << 30, |b| b / 2).min(16 << 30))
}
