//! Balanced drawing of training faces (paper §4, SPEC §8 "Balance"): equal
//! counts per `A_p` category, pooled over several [`SampleSource`]s. Empty
//! categories are skipped. Randomness comes from the caller's RNG.

use crate::source::{NUM_CATEGORIES, SampleSource};
use rand::Rng;
use rand::seq::SliceRandom;

/// One training item: face `face` of source `source` (index into the slice
/// the sampler was built from), of `A_p` category `category`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SampleRef {
    /// index of the source
    pub source: u32,
    /// face index in that source
    pub face: u32,
    /// `A_p` category (0: > 80°, …, 3: ≤ 20°)
    pub category: u8,
}

/// All sampleable (source, face) pairs, pooled per category.
#[derive(Clone, Debug, Default)]
pub struct BalancedSampler {
    pools: [Vec<SampleRef>; NUM_CATEGORIES],
}

impl BalancedSampler {
    /// Pools the category face lists of `sources` (source `i` is
    /// `sources[i]`).
    pub fn new<'a>(sources: impl IntoIterator<Item = &'a SampleSource>) -> BalancedSampler {
        let mut pools: [Vec<SampleRef>; NUM_CATEGORIES] = Default::default();
        for (s, src) in sources.into_iter().enumerate() {
            for (c, pool) in pools.iter_mut().enumerate() {
                pool.extend(src.category_faces(c).iter().map(|&face| SampleRef {
                    source: s as u32,
                    face,
                    category: c as u8,
                }));
            }
        }
        BalancedSampler { pools }
    }

    /// Number of pooled faces per category.
    pub fn category_sizes(&self) -> [usize; NUM_CATEGORIES] {
        [0, 1, 2, 3].map(|c| self.pools[c].len())
    }

    /// The categories with at least one face.
    pub fn non_empty_categories(&self) -> Vec<usize> {
        (0..NUM_CATEGORIES)
            .filter(|&c| !self.pools[c].is_empty())
            .collect()
    }

    /// One item: a uniformly chosen non-empty category, then a uniform face
    /// of it. `None` when every category is empty.
    pub fn draw<R: Rng + ?Sized>(&self, rng: &mut R) -> Option<SampleRef> {
        let cats = self.non_empty_categories();
        if cats.is_empty() {
            return None;
        }
        let pool = &self.pools[cats[rng.random_range(0..cats.len())]];
        Some(pool[rng.random_range(0..pool.len())])
    }

    /// `per_category` items from each non-empty category, shuffled. Within a
    /// category faces are drawn without replacement while they last (the
    /// whole pool is used once before any face repeats).
    pub fn draw_balanced<R: Rng + ?Sized>(
        &self,
        per_category: usize,
        rng: &mut R,
    ) -> Vec<SampleRef> {
        let mut out = Vec::with_capacity(per_category * NUM_CATEGORIES);
        for pool in self.pools.iter().filter(|p| !p.is_empty()) {
            let mut left = per_category;
            while left > 0 {
                let take = left.min(pool.len());
                if take == pool.len() {
                    out.extend_from_slice(pool);
                } else {
                    let idx = rand::seq::index::sample(rng, pool.len(), take);
                    out.extend(idx.iter().map(|i| pool[i]));
                }
                left -= take;
            }
        }
        out.shuffle(rng);
        out
    }

    /// [`Self::draw_count`] with a ChaCha8 generator seeded by `seed`.
    pub fn draw_count_seeded(&self, count: usize, seed: u64) -> Vec<SampleRef> {
        use rand::SeedableRng;
        self.draw_count(count, &mut rand_chacha::ChaCha8Rng::seed_from_u64(seed))
    }

    /// `count` items split as evenly as possible over the non-empty
    /// categories (the remainder goes to randomly chosen categories),
    /// shuffled.
    pub fn draw_count<R: Rng + ?Sized>(&self, count: usize, rng: &mut R) -> Vec<SampleRef> {
        let cats = self.non_empty_categories();
        if cats.is_empty() {
            return Vec::new();
        }
        let base = count / cats.len();
        let mut out = self.draw_balanced(base, rng);
        let mut extra = cats.clone();
        extra.shuffle(rng);
        for &c in extra.iter().take(count - base * cats.len()) {
            let pool = &self.pools[c];
            out.push(pool[rng.random_range(0..pool.len())]);
        }
        out.shuffle(rng);
        out
    }
}
