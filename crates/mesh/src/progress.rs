//! `Progress`: how long-running library work reports progress without
//! depending on a terminal library. The CLI implements it with indicatif.

/// Receives progress from long-running work. All methods default to no-ops.
pub trait Progress: Sync {
    /// A new stage begins with `total` units of work.
    fn start(&self, _label: &str, _total: u64) {}
    /// `n` more units are done.
    fn advance(&self, _n: u64) {}
    /// A short status line (loss, error, iteration).
    fn message(&self, _text: &str) {}
    /// The current stage is over.
    fn finish(&self) {}
}

/// Reports nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoProgress;

impl Progress for NoProgress {}
