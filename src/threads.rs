//! The worker pool of a command (`--threads`), its threads recording their spans into the
//! run's trace where `--profile` asks.

use crate::profile;
use renderer::SceneError;

/// The worker pool for `--threads` (default: all cores), and its size; errors name `file`.
pub fn thread_pool(
    threads: Option<u32>,
    file: &std::path::Path,
) -> Result<(usize, rayon::ThreadPool), SceneError> {
    thread_pool_traced(threads, file, None)
}

/// [`thread_pool`] whose threads record their spans into `trace`.
pub fn thread_pool_traced(
    threads: Option<u32>,
    file: &std::path::Path,
    trace: Option<&profile::Trace>,
) -> Result<(usize, rayon::ThreadPool), SceneError> {
    let threads = match threads {
        Some(n) => n as usize,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    let dispatch = trace.map(|t| t.dispatch.clone());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("worker {i}"))
        .start_handler(move |_| {
            if let Some(d) = &dispatch {
                // For the thread's whole life: the pool is the run's.
                std::mem::forget(tracing::dispatcher::set_default(d));
            }
        })
        .build()
        .map_err(|e| SceneError::new(file, "--threads", e.to_string()))?;
    Ok((threads, pool))
}
