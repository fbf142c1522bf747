//! The first convolution as a scatter over occupied voxels. A face
//! neighbourhood grid is a surface sheet: only a few % of its cubes are
//! non-zero, so instead of gathering `k³` taps for every output cube, each
//! occupied input cube adds its contribution to the `k³` outputs it reaches.
//! Stride 1 only (the stem of SPEC §6).

#[cfg(target_arch = "x86_64")]
use crate::conv::Fused;
use crate::conv::{CubeMask, FoldedConv, Level, MulAdd, Plain};

/// Occupied cubes of a `[cin, n, n, n]` channel-major grid: flat cube indices
/// and their `cin` values, channels-last.
#[derive(Default)]
pub(crate) struct Occupied {
    pub index: Vec<u32>,
    pub values: Vec<f32>,
}

impl Occupied {
    /// The occupied cubes given by their indices (ascending) and values
    /// (`cin` per cube).
    pub(crate) fn set(&mut self, index: &[u32], values: &[f32]) {
        self.index.clear();
        self.index.extend_from_slice(index);
        self.values.clear();
        self.values.extend_from_slice(values);
    }

    /// Collects the cubes of `grid` with any non-zero channel.
    pub(crate) fn gather(&mut self, grid: &[f32], cin: usize) {
        self.index.clear();
        self.values.clear();
        let cubes = grid.len() / cin;
        // blocks of 32 cubes: a bit per non-zero cube (the compare vectorizes),
        // then only the set bits are visited
        for start in (0..cubes).step_by(32) {
            let len = 32.min(cubes - start);
            let mut bits = 0u32;
            for c in 0..cin {
                let channel = &grid[c * cubes + start..c * cubes + start + len];
                for (j, &v) in channel.iter().enumerate() {
                    bits |= u32::from(v != 0.0) << j;
                }
            }
            while bits != 0 {
                let i = start + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                self.index.push(i as u32);
                self.values.extend((0..cin).map(|c| grid[c * cubes + i]));
            }
        }
    }
}

impl FoldedConv {
    /// `out = [relu](conv(grid))` for stride 1, scattering the occupied cubes.
    /// `out`: `[m, m, m, cout]` channels-last, `m = output_side(n)`.
    pub(crate) fn run_sparse(
        &self,
        level: Level,
        occupied: &Occupied,
        n: usize,
        out: &mut [f32],
        relu: bool,
    ) {
        debug_assert_eq!(self.stride, 1);
        let m = self.output_side(n);
        debug_assert_eq!(out.len(), m * m * m * self.cout);
        macro_rules! go {
            ($co:literal) => {
                match level {
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: `Level::detect` found the features at run time.
                    Level::Avx512 => unsafe {
                        scatter_avx512::<$co>(self, occupied, n, out, m, relu)
                    },
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: as above.
                    Level::Avx2 => unsafe { scatter_avx2::<$co>(self, occupied, n, out, m, relu) },
                    _ => scatter::<$co, Plain>(self, occupied, n, out, m, relu),
                }
            };
        }
        match self.cout {
            8 => go!(8),
            16 => go!(16),
            32 => go!(32),
            64 => go!(64),
            128 => go!(128),
            256 => go!(256),
            c => unreachable!("channel count {c} rejected by Cnn::new"),
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
fn scatter_avx512<const CO: usize>(
    c: &FoldedConv,
    occ: &Occupied,
    n: usize,
    out: &mut [f32],
    m: usize,
    relu: bool,
) {
    scatter::<CO, Fused>(c, occ, n, out, m, relu)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn scatter_avx2<const CO: usize>(
    c: &FoldedConv,
    occ: &Occupied,
    n: usize,
    out: &mut [f32],
    m: usize,
    relu: bool,
) {
    scatter::<CO, Fused>(c, occ, n, out, m, relu)
}

impl FoldedConv {
    /// Output cubes reached by an occupied input cube (of an `n³` grid).
    pub(crate) fn reach_mask(&self, occupied: &Occupied, n: usize, out: &mut CubeMask) {
        let (k, p) = (self.k, self.pad);
        let m = self.output_side(n);
        out.reset(m);
        let rows = out.rows_mut();
        for &i in &occupied.index {
            let i = i as usize;
            let (id, ih, iw) = (i / (n * n), (i / n) % n, i % n);
            for kd in reach(id, p, k, m) {
                for kh in reach(ih, p, k, m) {
                    for kw in reach(iw, p, k, m) {
                        rows[(id + p - kd) * m + ih + p - kh] |= 1 << (iw + p - kw);
                    }
                }
            }
        }
    }
}

/// Output coordinates `o = i + p − kk` inside `[0, m)`, as the kernel offsets `kk`.
#[inline(always)]
pub(crate) fn reach(i: usize, p: usize, k: usize, m: usize) -> std::ops::Range<usize> {
    // o = i + p - kk >= 0  <=>  kk <= i + p ;  o < m  <=>  kk > i + p - m
    let lo = (i + p + 1).saturating_sub(m);
    let hi = (i + p + 1).min(k);
    lo..hi.max(lo)
}

/// One output plane (fixed depth `od`) at a time, so the plane being summed
/// (`m² · CO` floats: 28 KB for the lite stem) stays in L1; the occupied
/// cubes that reach it are a contiguous run (they are sorted by index, so
/// by depth). Each output receives the same contributions in the same order
/// as a scatter over all cubes: the results are bit-identical to it.
#[inline(always)]
fn scatter<const CO: usize, F: MulAdd>(
    c: &FoldedConv,
    occ: &Occupied,
    n: usize,
    out: &mut [f32],
    m: usize,
    relu: bool,
) {
    let (cin, k, p) = (c.cin, c.k, c.pad);
    let bias: [f32; CO] = c.b[..CO].try_into().expect("bias length");
    let plane_len = m * m * CO;
    for (od, plane) in out.chunks_exact_mut(plane_len).enumerate() {
        for row in plane.chunks_exact_mut(CO) {
            row.copy_from_slice(&bias);
        }
        // input depths id = od − p + kd, kd in 0..k
        let first = od.saturating_sub(p);
        let last = (od + k).saturating_sub(p + 1).min(n.saturating_sub(1));
        let lo = occ.index.partition_point(|&i| (i as usize) < first * n * n);
        let hi = occ
            .index
            .partition_point(|&i| (i as usize) < (last + 1) * n * n);
        for slot in lo..hi {
            // the stem has 3 input channels (`Cnn::new` checks): a fixed
            // count lets the three products of a tap stay in registers
            let v: [f32; 3] = occ.values[slot * cin..slot * cin + cin]
                .try_into()
                .expect("3 input channels");
            let i = occ.index[slot] as usize;
            let (id, ih, iw) = (i / (n * n), (i / n) % n, i % n);
            let kd = id + p - od;
            for kh in reach(ih, p, k, m) {
                let oh = ih + p - kh;
                for kw in reach(iw, p, k, m) {
                    let ow = iw + p - kw;
                    let tap = (kd * k + kh) * k + kw;
                    let wt = &c.w[tap * 3 * CO..(tap + 1) * 3 * CO];
                    let mut acc = [0.0f32; CO];
                    for (ci, &x) in v.iter().enumerate() {
                        let wr: &[f32; CO] =
                            wt[ci * CO..ci * CO + CO].try_into().expect("weight row");
                        for j in 0..CO {
                            acc[j] = F::mul_add(x, wr[j], acc[j]);
                        }
                    }
                    let o = oh * m + ow;
                    let dst: &mut [f32; CO] = (&mut plane[o * CO..o * CO + CO])
                        .try_into()
                        .expect("out row");
                    for j in 0..CO {
                        dst[j] += acc[j];
                    }
                }
            }
        }
        if relu {
            for v in plane.iter_mut() {
                *v = v.max(0.0);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::weights::{BatchNormWeights, ConvWeights};

    /// The scatter over all occupied cubes at once, output in L2 (the form
    /// before the per-plane loop).
    fn scatter_all(c: &FoldedConv, occ: &Occupied, n: usize, out: &mut [f32], relu: bool) {
        const CO: usize = 16;
        let (cin, k, p) = (c.cin, c.k, c.pad);
        let m = c.output_side(n);
        for row in out.chunks_exact_mut(CO) {
            row.copy_from_slice(&c.b);
        }
        for (slot, &i) in occ.index.iter().enumerate() {
            let v = &occ.values[slot * cin..slot * cin + cin];
            let i = i as usize;
            let (id, ih, iw) = (i / (n * n), (i / n) % n, i % n);
            for kd in reach(id, p, k, m) {
                for kh in reach(ih, p, k, m) {
                    for kw in reach(iw, p, k, m) {
                        let tap = (kd * k + kh) * k + kw;
                        let mut acc = [0.0f32; CO];
                        for (ci, &x) in v.iter().enumerate() {
                            let w = &c.w[(tap * cin + ci) * CO..][..CO];
                            for (a, &wj) in acc.iter_mut().zip(w) {
                                *a += x * wj;
                            }
                        }
                        let o = ((id + p - kd) * m + ih + p - kh) * m + iw + p - kw;
                        for j in 0..CO {
                            out[o * CO + j] += acc[j];
                        }
                    }
                }
            }
        }
        if relu {
            for v in out.iter_mut() {
                *v = v.max(0.0);
            }
        }
    }

    #[test]
    fn masks_equal_marking_every_window_cube_by_cube() {
        let n = 11;
        let mut state = 3u32;
        let mut coin = |p: u32| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) % 100 < p
        };
        for (k, stride, pad) in [
            (5, 1, 2),
            (3, 1, 1),
            (3, 2, 1),
            (1, 2, 0),
            (1, 1, 0),
            (3, 1, 0),
        ] {
            let conv = ConvWeights {
                in_channels: 1,
                out_channels: 8,
                kernel: k,
                stride,
                padding: pad,
                weight: vec![0.0; 8 * k * k * k],
                bias: None,
            };
            let c = FoldedConv::new(&conv, &BatchNormWeights::identity(8));
            let m = c.output_side(n);
            let mask: Vec<bool> = (0..n * n * n).map(|_| coin(6)).collect();
            // every flagged input cube marks the outputs whose window holds it
            let mut want = vec![false; m * m * m];
            for id in 0..n {
                for ih in 0..n {
                    for iw in 0..n {
                        if !mask[(id * n + ih) * n + iw] {
                            continue;
                        }
                        let outs = |i: usize| {
                            (0..m)
                                .filter(move |&o| o * stride + k > i + pad && o * stride <= i + pad)
                        };
                        for od in outs(id) {
                            for oh in outs(ih) {
                                for ow in outs(iw) {
                                    want[(od * m + oh) * m + ow] = true;
                                }
                            }
                        }
                    }
                }
            }
            let mut got = CubeMask::default();
            c.window_mask(&CubeMask::from_flags(&mask, n), &mut got);
            assert_eq!(got.to_flags(), want, "k {k} stride {stride}");
            if stride == 1 && k == 5 {
                let mut occ = Occupied::default();
                let grid: Vec<f32> = mask.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
                occ.gather(&grid, 1);
                c.reach_mask(&occ, n, &mut got);
                assert_eq!(got.to_flags(), want, "reach mask");
            }
        }
    }

    #[test]
    fn the_per_plane_scatter_is_bit_identical_to_scattering_all_cubes() {
        let (n, cin, cout) = (9, 3, 16);
        let mut state = 11u32;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let conv = ConvWeights {
            in_channels: cin,
            out_channels: cout,
            kernel: 5,
            stride: 1,
            padding: 2,
            weight: (0..cout * cin * 125).map(|_| next()).collect(),
            bias: Some((0..cout).map(|_| next()).collect()),
        };
        let c = FoldedConv::new(&conv, &BatchNormWeights::identity(cout));
        // a sparse grid, channel-major, cubes on every border included
        let cubes = n * n * n;
        let mut grid = vec![0.0f32; cin * cubes];
        for i in (0..cubes).filter(|i| i % 7 == 0 || *i == cubes - 1) {
            for ch in 0..cin {
                grid[ch * cubes + i] = next();
            }
        }
        let mut occ = Occupied::default();
        occ.gather(&grid, cin);
        for relu in [false, true] {
            let mut want = vec![0.0f32; cubes * cout];
            scatter_all(&c, &occ, n, &mut want, relu);
            let mut got = vec![f32::NAN; cubes * cout];
            scatter::<16, Plain>(&c, &occ, n, &mut got, n, relu);
            assert!(
                want.iter()
                    .zip(&got)
                    .all(|(a, b)| a.to_bits() == b.to_bits())
            );
        }
    }

    #[test]
    fn reach_clips_at_borders() {
        // n = m = 21, k = 5, p = 2: input 0 reaches outputs 0..=2 via kk 2..=0
        assert_eq!(reach(0, 2, 5, 21), 0..3);
        assert_eq!(reach(10, 2, 5, 21), 0..5);
        assert_eq!(reach(20, 2, 5, 21), 2..5);
    }
}
