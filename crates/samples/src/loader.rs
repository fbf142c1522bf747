//! Threaded training-data loader (SPEC §8: "voxel grids are made on the fly
//! in data-loader threads, not stored").
//!
//! N worker threads build batches of (grid, targets) from a list of
//! [`SampleRef`]s; batch `b` is built by worker `b mod N` and delivered in
//! order over a bounded channel per worker. Batch contents (items and yaw
//! angles) depend only on the item list, the batch size and the seed, never
//! on the number of workers or on timing.

use crate::error::SampleError;
use crate::sampler::SampleRef;
use crate::source::{SampleSource, TARGET_LEN};
use normalnet_voxel::Scratch;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;

/// Settings of a [`Loader`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoaderConfig {
    /// Items per batch (the paper: 80).
    pub batch_size: usize,
    /// Worker threads (default 2).
    pub workers: usize,
    /// Batches each worker may build ahead (default 2).
    pub prefetch: usize,
    /// Seed of the yaw angles.
    pub seed: u64,
    /// Batch `b` draws its yaws from stream `first_stream + b` of the seed:
    /// a loader over the items after the first `s` batches with
    /// `first_stream = s` gives exactly those batches of the whole run (a
    /// resumed training run equals an uninterrupted one).
    pub first_stream: u64,
    /// Random yaw in `[0, 2π)` per item (training augmentation); 0 if false.
    pub yaw_augmentation: bool,
    /// Keep a final batch smaller than `batch_size` (default true).
    pub keep_last: bool,
}

impl Default for LoaderConfig {
    fn default() -> Self {
        LoaderConfig {
            batch_size: 80,
            workers: 2,
            prefetch: 2,
            seed: 0,
            first_stream: 0,
            yaw_augmentation: true,
            keep_last: true,
        }
    }
}

/// One batch, ready for the network.
#[derive(Clone, Debug)]
pub struct Batch {
    /// Batch number (0-based, in delivery order).
    pub index: usize,
    /// The items of the batch.
    pub items: Vec<SampleRef>,
    /// `[B, 3, D, H, W]` f32 grids back to back (len `B · grid_len`).
    pub grids: Vec<f32>,
    /// `[B, 18]` targets in each item's local frame (len `B · 18`).
    pub targets: Vec<f32>,
    /// The yaw of each item in radians (len B).
    pub yaws: Vec<f64>,
}

impl Batch {
    /// Number of items.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// True when the batch has no items.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }
}

/// An iterator over batches built by worker threads. Dropping it stops the
/// workers.
pub struct Loader {
    receivers: Vec<Receiver<Batch>>,
    handles: Vec<JoinHandle<()>>,
    next: usize,
    num_batches: usize,
}

impl Loader {
    /// Starts the workers over `items` (in the given order; shuffle before).
    ///
    /// # Errors
    /// [`SampleError::InvalidParameter`] for a zero batch size or worker
    /// count, sources with different grid parameters, or an item whose
    /// source or face is out of range.
    pub fn new(
        sources: Arc<Vec<SampleSource>>,
        items: Vec<SampleRef>,
        config: LoaderConfig,
    ) -> Result<Loader, SampleError> {
        let invalid = |name, message: String| SampleError::InvalidParameter { name, message };
        if config.batch_size == 0 {
            return Err(invalid("batch_size", "must be at least 1".into()));
        }
        if config.workers == 0 {
            return Err(invalid("workers", "must be at least 1".into()));
        }
        if let Some(first) = sources.first()
            && let Some((i, s)) = sources
                .iter()
                .enumerate()
                .find(|(_, s)| s.params() != first.params())
        {
            return Err(invalid(
                "sources",
                format!(
                    "source {i} has grid {:?}, source 0 {:?}",
                    s.params(),
                    first.params()
                ),
            ));
        }
        if let Some(bad) = items.iter().find(|it| {
            sources
                .get(it.source as usize)
                .is_none_or(|s| it.face as usize >= s.num_faces())
        }) {
            return Err(invalid(
                "items",
                format!("item {bad:?} refers to a missing source or face"),
            ));
        }
        let num_batches = if config.keep_last {
            items.len().div_ceil(config.batch_size)
        } else {
            items.len() / config.batch_size
        };
        let items = Arc::new(items);
        let mut receivers = Vec::new();
        let mut handles = Vec::new();
        for w in 0..config.workers.min(num_batches.max(1)) {
            let (tx, rx) = sync_channel(config.prefetch.max(1));
            receivers.push(rx);
            let (sources, items) = (Arc::clone(&sources), Arc::clone(&items));
            let workers = config.workers.min(num_batches.max(1));
            handles.push(std::thread::spawn(move || {
                worker(&sources, &items, config, w, workers, num_batches, tx)
            }));
        }
        Ok(Loader {
            receivers,
            handles,
            next: 0,
            num_batches,
        })
    }

    /// Number of batches this loader delivers.
    pub fn num_batches(&self) -> usize {
        self.num_batches
    }
}

fn worker(
    sources: &[SampleSource],
    items: &[SampleRef],
    config: LoaderConfig,
    w: usize,
    workers: usize,
    num_batches: usize,
    tx: SyncSender<Batch>,
) {
    let mut scratch = Scratch::new();
    let grid_len = sources.first().map_or(0, |s| s.params().grid_len());
    for b in (w..num_batches).step_by(workers) {
        let start = b * config.batch_size;
        let end = (start + config.batch_size).min(items.len());
        let batch_items = items[start..end].to_vec();
        let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
        rng.set_stream(config.first_stream + b as u64);
        let mut grids = vec![0.0f32; batch_items.len() * grid_len];
        let mut targets = vec![0.0f32; batch_items.len() * TARGET_LEN];
        let mut yaws = Vec::with_capacity(batch_items.len());
        for (i, it) in batch_items.iter().enumerate() {
            let yaw = if config.yaw_augmentation {
                rng.random_range(0.0..std::f64::consts::TAU)
            } else {
                0.0
            };
            let src = &sources[it.source as usize];
            let grid = &mut grids[i * grid_len..(i + 1) * grid_len];
            let (t, _) = src.sample_with(&mut scratch, it.face as usize, yaw, grid);
            targets[i * TARGET_LEN..(i + 1) * TARGET_LEN].copy_from_slice(&t);
            yaws.push(yaw);
        }
        let batch = Batch {
            index: b,
            items: batch_items,
            grids,
            targets,
            yaws,
        };
        if tx.send(batch).is_err() {
            return;
        }
    }
}

impl std::fmt::Debug for Loader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Loader")
            .field("workers", &self.receivers.len())
            .field("next", &self.next)
            .field("num_batches", &self.num_batches)
            .finish()
    }
}

impl Iterator for Loader {
    type Item = Batch;

    fn next(&mut self) -> Option<Batch> {
        if self.next >= self.num_batches {
            return None;
        }
        let rx = &self.receivers[self.next % self.receivers.len()];
        match rx.recv() {
            Ok(batch) => {
                self.next += 1;
                Some(batch)
            }
            Err(_) => {
                // A worker ended early: only a panic does that. Pass it on.
                self.receivers.clear();
                for h in self.handles.drain(..) {
                    if let Err(payload) = h.join() {
                        std::panic::resume_unwind(payload);
                    }
                }
                None
            }
        }
    }
}

impl Drop for Loader {
    fn drop(&mut self) {
        self.receivers.clear();
        for h in self.handles.drain(..) {
            let _ = h.join();
        }
    }
}
