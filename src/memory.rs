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
/// the memory available when it is read ([`available_bytes`]), at most 16 GiB; 4 GiB where
/// that is not known. `PENUMBRA_MASK_BUDGET_MIB`
/// overrides it.
///
/// # Errors
/// `PENUMBRA_MASK_BUDGET_MIB` is set but is not a whole number ([`budget_override`]).
pub fn memory_budget_bytes() -> Result<u64, SceneError> {
    if let Some(bytes) = budget_override()? {
        return Ok(bytes);
    }
    Ok(available_bytes().map_or(4 << 30, |b| b / 2).min(16 << 30))
}

/// The memory this process can still take (Linux): the smallest of `MemAvailable`, the
/// cgroup's headroom under `memory.max` (a container is killed at its limit, not the
/// machine's) and the address-space limit's headroom (`ulimit -v`: an allocation past it
/// aborts). `None` where none of them is known.
pub fn available_bytes() -> Option<u64> {
    let read = |path: &str| std::fs::read_to_string(path).ok();
    let read_u64 = |path: &str| read(path).and_then(|t| t.trim().parse::<u64>().ok());
    let kib_field = |text: &str, field: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(field))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
            .map(|kib| kib << 10)
    };
    let available = read("/proc/meminfo").and_then(|m| kib_field(&m, "MemAvailable:"));
    // cgroup v2; "max" (no limit) does not parse and is ignored.
    let cgroup = read_u64("/sys/fs/cgroup/memory.max")
        .zip(read_u64("/sys/fs/cgroup/memory.current"))
        .map(|(max, current)| max.saturating_sub(current));
    let address_space = read("/proc/self/limits")
        .and_then(|l| address_space_limit(&l))
        .zip(read("/proc/self/status").and_then(|s| kib_field(&s, "VmSize:")))
        .map(|(limit, used)| limit.saturating_sub(used));
    [available, cgroup, address_space].into_iter().flatten().min()
}

/// The soft address-space limit in `/proc/self/limits`' text (`Max address space`), or
/// `None` when it is "unlimited" or absent.
fn address_space_limit(limits: &str) -> Option<u64> {
    let line = limits.lines().find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..].split_whitespace().next()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_address_space_limit_is_read_from_the_soft_column() {
        let limited = "Limit                     Soft Limit           Hard Limit           Units     \n\
                       Max stack size            8388608              unlimited            bytes     \n\
                       Max address space         17179869184          unlimited            bytes     \n";
        assert_eq!(address_space_limit(limited), Some(17179869184));
        let unlimited = "Max address space         unlimited            unlimited            bytes     \n";
        assert_eq!(address_space_limit(unlimited), None);
        assert_eq!(address_space_limit(""), None);
    }
}
