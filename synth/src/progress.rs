//! Progress reporting without printing: the library calls a [`Progress`]
//! implementation; the binary draws a progress bar with it.

/// Receives progress of a long job (called from worker threads).
pub trait Progress: Sync {
    /// A stage begins, with `total` units of work.
    fn begin(&self, stage: &str, total: u64);
    /// `n` more units are done.
    fn advance(&self, n: u64);
    /// The stage is over.
    fn finish(&self);
}

/// Ignores all progress.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn begin(&self, _stage: &str, _total: u64) {}
    fn advance(&self, _n: u64) {}
    fn finish(&self) {}
}
