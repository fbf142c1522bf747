//! Turning voxel grids and targets into tensors (SPEC §5, §8): one place that
//! knows the layout. A grid is `[3, D, H, W]` f32 (channel = normal x/y/z,
//! D = H = W = 2·T_s+1), a target is 18 f32 (six local-frame 3-vectors, μ_g
//! order of [`crate::MU_GS`]).

#[cfg(feature = "burn")]
use burn::tensor::{Device, Tensor, TensorData};

/// A batch of samples as flat buffers: `grids` holds `len` grids back to
/// back (`len · 3·side³` values), `targets` `len · 18` values.
#[derive(Clone, Debug, Default)]
pub struct SampleBatch {
    /// grid side D (= H = W)
    pub side: usize,
    /// number of samples
    pub len: usize,
    /// `len` grids `[3, D, H, W]`, row-major, back to back
    pub grids: Vec<f32>,
    /// `len` targets of 18 values
    pub targets: Vec<f32>,
}

impl SampleBatch {
    /// An empty batch for grids of side `side` with room for `capacity` samples.
    pub fn with_capacity(side: usize, capacity: usize) -> SampleBatch {
        SampleBatch {
            side,
            len: 0,
            grids: Vec::with_capacity(capacity * grid_len(side)),
            targets: Vec::with_capacity(capacity * crate::arch::NUM_OUTPUTS),
        }
    }

    /// Synthetic samples for tests and benchmarks: grids holding a tilted,
    /// noisy sheet of normals through the middle (a face neighbourhood's
    /// shape: a few % of the cubes occupied), targets uniform in ±0.8.
    pub fn sheets(side: usize, len: usize, seed: u64) -> SampleBatch {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let cubes = side * side * side;
        let mut b = SampleBatch::with_capacity(side, len);
        for _ in 0..len {
            let mut g = vec![0.0f32; 3 * cubes];
            let tilt: f32 = rng.random_range(-0.4..0.4);
            for d in 0..side {
                for w in 0..side {
                    let h0 = (side as f32 / 2.0 + tilt * (d as f32 - side as f32 / 2.0)) as usize;
                    for h in [h0, h0 + 1] {
                        if h < side && rng.random_bool(0.8) {
                            let i = (d * side + h) * side + w;
                            g[i] = rng.random_range(-0.3..0.3);
                            g[cubes + i] = rng.random_range(0.7..1.0);
                            g[2 * cubes + i] = rng.random_range(-0.3..0.3);
                        }
                    }
                }
            }
            b.grids.extend(g);
            b.targets
                .extend((0..crate::arch::NUM_OUTPUTS).map(|_| rng.random_range(-0.8f32..0.8)));
        }
        b.len = len;
        b
    }

    /// Values in one grid.
    pub fn grid_len(&self) -> usize {
        grid_len(self.side)
    }

    /// The grids as a tensor `[len, 3, D, H, W]` on `device`.
    #[cfg(feature = "burn")]
    pub fn grids_tensor(&self, device: &Device) -> Tensor<5> {
        grids_tensor(&self.grids, self.len, self.side, device)
    }

    /// The targets as a tensor `[len, 18]` on `device`.
    #[cfg(feature = "burn")]
    pub fn targets_tensor(&self, device: &Device) -> Tensor<2> {
        let data = TensorData::new(self.targets.clone(), [self.len, crate::arch::NUM_OUTPUTS]);
        Tensor::from_data(data, device)
    }
}

/// Values in one grid of side `side`: `3·side³`.
pub fn grid_len(side: usize) -> usize {
    3 * side * side * side
}

#[cfg(feature = "burn")]
/// `len` grids stored back to back → tensor `[len, 3, side, side, side]`.
///
/// # Panics
/// If `grids.len() != len · 3·side³` (a broken invariant of the caller).
pub fn grids_tensor(grids: &[f32], len: usize, side: usize, device: &Device) -> Tensor<5> {
    assert_eq!(grids.len(), len * grid_len(side), "grid buffer size");
    let data = TensorData::new(grids.to_vec(), [len, 3, side, side, side]);
    Tensor::from_data(data, device)
}

/// A `[len, k]` tensor back to a flat `Vec<f32>`.
#[cfg(feature = "burn")]
pub fn tensor_to_vec(t: Tensor<2>) -> Vec<f32> {
    t.into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .unwrap_or_default()
}
