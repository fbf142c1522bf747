//! Gradients of a 3D convolution, channels-last, for one sample:
//! - [`input_grad`]: `dx[i][ci] = Σ_{o·s + kk − p = i} Σ_co dz[o][co] · w[kk][ci][co]`,
//!   gathered per input cube with the input channels held in registers;
//! - [`weight_grad`]: `dw[kk][ci][co] += Σ_o x[o·s + kk − p][ci] · dz[o][co]`,
//!   a block of `ci × co` accumulators in registers while the outputs stream by;
//! - [`stem_weight_grad`]: the same for the first convolution, scattered from
//!   the occupied cubes only (the input grid is a surface sheet).
//!
//! Same instruction-set dispatch as the forward kernels (`crate::conv`).

#[cfg(target_arch = "x86_64")]
use crate::conv::Fused;
use crate::conv::{Level, MulAdd, Plain};
use crate::sparse_conv::{Occupied, reach};

/// Shape of one convolution: kernel side, stride, padding, channels.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ConvShape {
    pub k: usize,
    pub stride: usize,
    pub pad: usize,
    pub cin: usize,
    pub cout: usize,
}

impl ConvShape {
    pub(crate) fn output_side(&self, n: usize) -> usize {
        (n + 2 * self.pad).saturating_sub(self.k) / self.stride + 1
    }
}

/// For every input coordinate along one axis, the `(kk, o)` pairs with
/// `o·s + kk − p = i`, `0 ≤ o < m`.
fn axis_pairs(n: usize, m: usize, sh: &ConvShape) -> Vec<Vec<(usize, usize)>> {
    (0..n)
        .map(|i| {
            (0..sh.k)
                .filter_map(|kk| {
                    let t = (i + sh.pad).checked_sub(kk)?;
                    (t % sh.stride == 0 && t / sh.stride < m).then_some((kk, t / sh.stride))
                })
                .collect()
        })
        .collect()
}

/// Outputs `o` along one axis whose input `o·s + kk − p` lies in `[0, n)`.
#[inline(always)]
fn outputs_for_tap(kk: usize, n: usize, m: usize, sh: &ConvShape) -> std::ops::Range<usize> {
    let lo = sh.pad.saturating_sub(kk).div_ceil(sh.stride);
    // o·s + kk − p ≤ n − 1  ⇔  o ≤ (n − 1 + p − kk) / s
    let hi = match (n - 1 + sh.pad).checked_sub(kk) {
        Some(t) => (t / sh.stride + 1).min(m),
        None => 0,
    };
    lo..hi.max(lo)
}

macro_rules! dispatch {
    ($level:expr, $f:ident :: <$($g:tt),*> ($($a:expr),*)) => {
        match $level {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Level::detect` found the features at run time.
            Level::Avx512 => unsafe { avx512::$f::<$($g),*>($($a),*) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            Level::Avx2 => unsafe { avx2::$f::<$($g),*>($($a),*) },
            _ => $f::<$($g,)* Plain>($($a),*),
        }
    };
}

/// `dx = ∂L/∂x` of one sample (overwritten, or added with `accumulate`).
///
/// `wt`: weights transposed to `[k³][cout][cin]`; `dz`: `[m³][cout]`;
/// `dx`: `[n³][cin]`.
pub(crate) fn input_grad(
    level: Level,
    sh: &ConvShape,
    wt: &[f32],
    dz: &[f32],
    n: usize,
    dx: &mut [f32],
    accumulate: bool,
) {
    let m = sh.output_side(n);
    debug_assert_eq!(dz.len(), m * m * m * sh.cout);
    debug_assert_eq!(dx.len(), n * n * n * sh.cin);
    let ax = axis_pairs(n, m, sh);
    macro_rules! go {
        ($ci:literal, $s:literal) => {
            dispatch!(
                level,
                input_grad_kernel::<$ci, $s>(sh, wt, dz, n, m, dx, accumulate, &ax)
            )
        };
    }
    match sh.cin {
        8 => go!(8, 8),
        16 => go!(16, 4),
        32 => go!(32, 4),
        64 => go!(64, 2),
        128 => go!(128, 1),
        256 => go!(256, 1),
        c => unreachable!("channel count {c} rejected by Trainer::new"),
    }
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn input_grad_kernel<const CI: usize, const S: usize, F: MulAdd>(
    sh: &ConvShape,
    wt: &[f32],
    dz: &[f32],
    n: usize,
    m: usize,
    dx: &mut [f32],
    accumulate: bool,
    ax: &[Vec<(usize, usize)>],
) {
    let (k, cout) = (sh.k, sh.cout);
    for id in 0..n {
        for ih in 0..n {
            for iw in 0..n {
                let mut accs = [[0.0f32; CI]; S];
                for &(kd, od) in &ax[id] {
                    for &(kh, oh) in &ax[ih] {
                        for &(kw, ow) in &ax[iw] {
                            let o = (od * m + oh) * m + ow;
                            let g = &dz[o * cout..o * cout + cout];
                            let tap = (kd * k + kh) * k + kw;
                            let w = &wt[tap * cout * CI..(tap + 1) * cout * CI];
                            let mut gs = g.chunks_exact(S);
                            let mut ws = w.chunks_exact(S * CI);
                            for (gc, wc) in (&mut gs).zip(&mut ws) {
                                for u in 0..S {
                                    let gv = gc[u];
                                    let wr: &[f32; CI] =
                                        wc[u * CI..u * CI + CI].try_into().expect("weight row");
                                    for j in 0..CI {
                                        accs[u][j] = F::mul_add(gv, wr[j], accs[u][j]);
                                    }
                                }
                            }
                            for (u, (&gv, wr)) in gs
                                .remainder()
                                .iter()
                                .zip(ws.remainder().chunks_exact(CI))
                                .enumerate()
                            {
                                for j in 0..CI {
                                    accs[u][j] = F::mul_add(gv, wr[j], accs[u][j]);
                                }
                            }
                        }
                    }
                }
                let i = (id * n + ih) * n + iw;
                let dst: &mut [f32; CI] =
                    (&mut dx[i * CI..i * CI + CI]).try_into().expect("dx row");
                let mut acc = if accumulate { *dst } else { [0.0; CI] };
                for a in &accs {
                    for j in 0..CI {
                        acc[j] += a[j];
                    }
                }
                *dst = acc;
            }
        }
    }
}

/// Input channels per register block of [`weight_grad`]: about sixteen
/// vectors of accumulators, dividing `cin`.
fn channel_block(cin: usize, cout: usize) -> usize {
    let mut cb = (64 / cout).clamp(1, 16);
    while !cin.is_multiple_of(cb) {
        cb /= 2;
    }
    cb
}

/// `dw += ∂L/∂w` of one sample. `x`: `[n³][cin]`; `dz`: `[m³][cout]`;
/// `dw`: `[k³][cin][cout]`.
pub(crate) fn weight_grad(
    level: Level,
    sh: &ConvShape,
    x: &[f32],
    dz: &[f32],
    n: usize,
    dw: &mut [f32],
) {
    let m = sh.output_side(n);
    debug_assert_eq!(x.len(), n * n * n * sh.cin);
    debug_assert_eq!(dz.len(), m * m * m * sh.cout);
    debug_assert_eq!(dw.len(), sh.k.pow(3) * sh.cin * sh.cout);
    macro_rules! go {
        ($co:literal, $cb:literal) => {
            dispatch!(level, weight_grad_kernel::<$co, $cb>(sh, x, dz, n, m, dw))
        };
    }
    match (sh.cout, channel_block(sh.cin, sh.cout)) {
        (8, 8) => go!(8, 8),
        (16, 4) => go!(16, 4),
        (32, 2) => go!(32, 2),
        (64, 1) => go!(64, 1),
        (8, _) => go!(8, 1),
        (16, _) => go!(16, 1),
        (32, _) => go!(32, 1),
        (64, _) => go!(64, 1),
        (128, _) => go!(128, 1),
        (c, _) => unreachable!("channel count {c} rejected by Trainer::new"),
    }
}

#[inline(always)]
fn weight_grad_kernel<const CO: usize, const CB: usize, F: MulAdd>(
    sh: &ConvShape,
    x: &[f32],
    dz: &[f32],
    n: usize,
    m: usize,
    dw: &mut [f32],
) {
    let (k, s, p, cin) = (sh.k, sh.stride, sh.pad, sh.cin);
    for kd in 0..k {
        let rd = outputs_for_tap(kd, n, m, sh);
        for kh in 0..k {
            let rh = outputs_for_tap(kh, n, m, sh);
            for kw in 0..k {
                let rw = outputs_for_tap(kw, n, m, sh);
                let tap = (kd * k + kh) * k + kw;
                for c0 in (0..cin).step_by(CB) {
                    let mut acc = [[0.0f32; CO]; CB];
                    for od in rd.clone() {
                        let id = od * s + kd - p;
                        for oh in rh.clone() {
                            let ih = oh * s + kh - p;
                            let orow = (od * m + oh) * m;
                            let irow = (id * n + ih) * n;
                            for ow in rw.clone() {
                                let iw = ow * s + kw - p;
                                let o = orow + ow;
                                let i = irow + iw;
                                let g: &[f32; CO] =
                                    dz[o * CO..o * CO + CO].try_into().expect("dz row");
                                let xr: &[f32; CB] = x[i * cin + c0..i * cin + c0 + CB]
                                    .try_into()
                                    .expect("x row");
                                for u in 0..CB {
                                    for j in 0..CO {
                                        acc[u][j] = F::mul_add(xr[u], g[j], acc[u][j]);
                                    }
                                }
                            }
                        }
                    }
                    for (u, a) in acc.iter().enumerate() {
                        let row = (tap * cin + c0 + u) * CO;
                        for (d, &v) in dw[row..row + CO].iter_mut().zip(a) {
                            *d += v;
                        }
                    }
                }
            }
        }
    }
}

/// `dw += ∂L/∂w` of the first convolution (stride 1) of one sample,
/// scattered from its occupied input cubes. `dz`: `[m³][cout]`.
pub(crate) fn stem_weight_grad(
    level: Level,
    sh: &ConvShape,
    occupied: &Occupied,
    n: usize,
    dz: &[f32],
    dw: &mut [f32],
) {
    debug_assert_eq!(sh.stride, 1);
    macro_rules! go {
        ($co:literal) => {
            dispatch!(
                level,
                stem_weight_grad_kernel::<$co>(sh, occupied, n, dz, dw)
            )
        };
    }
    match sh.cout {
        8 => go!(8),
        16 => go!(16),
        32 => go!(32),
        64 => go!(64),
        128 => go!(128),
        256 => go!(256),
        c => unreachable!("channel count {c} rejected by Trainer::new"),
    }
}

#[inline(always)]
fn stem_weight_grad_kernel<const CO: usize, F: MulAdd>(
    sh: &ConvShape,
    occ: &Occupied,
    n: usize,
    dz: &[f32],
    dw: &mut [f32],
) {
    let (k, p, cin) = (sh.k, sh.pad, sh.cin);
    let m = sh.output_side(n);
    for (slot, &i) in occ.index.iter().enumerate() {
        let v = &occ.values[slot * cin..slot * cin + cin];
        let i = i as usize;
        let (id, ih, iw) = (i / (n * n), (i / n) % n, i % n);
        for kd in reach(id, p, k, m) {
            let od = id + p - kd;
            for kh in reach(ih, p, k, m) {
                let oh = ih + p - kh;
                for kw in reach(iw, p, k, m) {
                    let ow = iw + p - kw;
                    let o = (od * m + oh) * m + ow;
                    let g: &[f32; CO] = dz[o * CO..o * CO + CO].try_into().expect("dz row");
                    let tap = (kd * k + kh) * k + kw;
                    for (ci, &xv) in v.iter().enumerate() {
                        let row = (tap * cin + ci) * CO;
                        let d: &mut [f32; CO] =
                            (&mut dw[row..row + CO]).try_into().expect("dw row");
                        for j in 0..CO {
                            d[j] = F::mul_add(xv, g[j], d[j]);
                        }
                    }
                }
            }
        }
    }
}

/// The kernels compiled for one instruction set (`$features`), with fused
/// multiply-add.
macro_rules! compiled_for {
    ($name:ident, $features:literal) => {
        #[cfg(target_arch = "x86_64")]
        mod $name {
            use super::*;

            #[target_feature(enable = $features)]
            #[allow(clippy::too_many_arguments)]
            pub(super) fn input_grad_kernel<const CI: usize, const S: usize>(
                sh: &ConvShape,
                wt: &[f32],
                dz: &[f32],
                n: usize,
                m: usize,
                dx: &mut [f32],
                accumulate: bool,
                ax: &[Vec<(usize, usize)>],
            ) {
                super::input_grad_kernel::<CI, S, Fused>(sh, wt, dz, n, m, dx, accumulate, ax)
            }

            #[target_feature(enable = $features)]
            pub(super) fn weight_grad_kernel<const CO: usize, const CB: usize>(
                sh: &ConvShape,
                x: &[f32],
                dz: &[f32],
                n: usize,
                m: usize,
                dw: &mut [f32],
            ) {
                super::weight_grad_kernel::<CO, CB, Fused>(sh, x, dz, n, m, dw)
            }

            #[target_feature(enable = $features)]
            pub(super) fn stem_weight_grad_kernel<const CO: usize>(
                sh: &ConvShape,
                occ: &Occupied,
                n: usize,
                dz: &[f32],
                dw: &mut [f32],
            ) {
                super::stem_weight_grad_kernel::<CO, Fused>(sh, occ, n, dz, dw)
            }
        }
    };
}

compiled_for!(avx512, "avx512f,avx2,fma");
compiled_for!(avx2, "avx2,fma");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tap_ranges_match_brute_force() {
        for (k, s, p, n) in [
            (3, 2, 1, 21),
            (3, 1, 1, 11),
            (1, 2, 0, 21),
            (5, 1, 2, 9),
            (3, 2, 1, 6),
        ] {
            let sh = ConvShape {
                k,
                stride: s,
                pad: p,
                cin: 1,
                cout: 1,
            };
            let m = sh.output_side(n);
            for kk in 0..k {
                let brute: Vec<usize> = (0..m)
                    .filter(|&o| (o * s + kk) >= p && o * s + kk - p < n)
                    .collect();
                let range: Vec<usize> = outputs_for_tap(kk, n, m, &sh).collect();
                assert_eq!(brute, range, "k {k} s {s} p {p} n {n} kk {kk}");
            }
            let ax = axis_pairs(n, m, &sh);
            for (i, pairs) in ax.iter().enumerate() {
                for &(kk, o) in pairs {
                    assert_eq!(o * s + kk, i + p);
                }
            }
        }
    }
}

#[cfg(test)]
mod speed {
    use super::*;
    use crate::conv::FoldedConv;

    #[test]
    #[ignore]
    fn kernel_speed() {
        let lv = Level::detect();
        for (n, k, s, p, ci, co) in [
            (11, 3, 1, 1, 16, 16),
            (21, 3, 2, 1, 16, 16),
            (11, 3, 2, 1, 16, 32),
            (6, 3, 1, 1, 32, 32),
        ] {
            let sh = ConvShape {
                k,
                stride: s,
                pad: p,
                cin: ci,
                cout: co,
            };
            let m = sh.output_side(n);
            let x: Vec<f32> = (0..n * n * n * ci)
                .map(|i| ((i * 7919) % 13) as f32 * 0.1 - 0.5)
                .collect();
            let dz: Vec<f32> = (0..m * m * m * co)
                .map(|i| ((i * 104729) % 17) as f32 * 0.1 - 0.8)
                .collect();
            let w: Vec<f32> = (0..k * k * k * ci * co)
                .map(|i| ((i * 31) % 11) as f32 * 0.01)
                .collect();
            let f = FoldedConv {
                w: w.clone(),
                b: vec![0.0; co],
                cin: ci,
                cout: co,
                k,
                stride: s,
                pad: p,
            };
            let mut out = vec![0.0; m * m * m * co];
            let mut dx = vec![0.0; n * n * n * ci];
            let mut dw = vec![0.0; w.len()];
            let macs = (m * m * m * k * k * k * ci * co) as f64;
            let reps = 50;
            let t = std::time::Instant::now();
            for _ in 0..reps {
                f.run(lv, &x, n, &mut out, false, false, None);
            }
            let fwd = t.elapsed().as_secs_f64() / reps as f64;
            let t = std::time::Instant::now();
            for _ in 0..reps {
                input_grad(lv, &sh, &w, &dz, n, &mut dx, false);
            }
            let dxt = t.elapsed().as_secs_f64() / reps as f64;
            let t = std::time::Instant::now();
            for _ in 0..reps {
                weight_grad(lv, &sh, &x, &dz, n, &mut dw);
            }
            let dwt = t.elapsed().as_secs_f64() / reps as f64;
            println!(
                "n {n} s {s} {ci}->{co}: fwd {:.1} dx {:.1} dw {:.1} GFLOP/s",
                2.0 * macs / fwd / 1e9,
                2.0 * macs / dxt / 1e9,
                2.0 * macs / dwt / 1e9
            );
        }
    }
}
