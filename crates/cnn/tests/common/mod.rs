//! Random networks and grids, and a naive reference forward pass.
#![allow(dead_code, missing_docs)]

use normalnet_cnn::{BatchNormWeights, BlockWeights, ConvWeights, LinearWeights, NetWeights};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn vals(rng: &mut ChaCha8Rng, n: usize, scale: f32) -> Vec<f32> {
    (0..n).map(|_| rng.random_range(-scale..scale)).collect()
}

fn conv(
    rng: &mut ChaCha8Rng,
    cin: usize,
    cout: usize,
    k: usize,
    s: usize,
    p: usize,
) -> ConvWeights {
    let fan = (cin * k * k * k) as f32;
    ConvWeights {
        weight: vals(rng, cout * cin * k * k * k, (3.0 / fan).sqrt()),
        bias: Some(vals(rng, cout, 0.1)),
        in_channels: cin,
        out_channels: cout,
        kernel: k,
        stride: s,
        padding: p,
    }
}

fn bn(rng: &mut ChaCha8Rng, c: usize) -> BatchNormWeights {
    BatchNormWeights {
        gamma: (0..c).map(|_| rng.random_range(0.5..1.5)).collect(),
        beta: vals(rng, c, 0.2),
        mean: vals(rng, c, 0.2),
        var: (0..c).map(|_| rng.random_range(0.5..2.0)).collect(),
        epsilon: 1e-5,
    }
}

fn linear(rng: &mut ChaCha8Rng, i: usize, o: usize) -> LinearWeights {
    LinearWeights {
        weight: vals(rng, i * o, (3.0 / i as f32).sqrt()),
        bias: Some(vals(rng, o, 0.1)),
        in_features: i,
        out_features: o,
    }
}

/// A random network of the SPEC §6 shape.
pub fn random_net(seed: u64, grid: usize, channels: [usize; 3]) -> NetWeights {
    random_net_with(seed, grid, channels, [512, 256, 128], true)
}

/// A random network with the given hidden widths; `conv_bias: false` gives
/// convolutions without bias (as training builds them).
pub fn random_net_with(
    seed: u64,
    grid: usize,
    channels: [usize; 3],
    widths: [usize; 3],
    conv_bias: bool,
) -> NetWeights {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let conv = |rng: &mut ChaCha8Rng, cin, cout, k, s, p| {
        let mut c = conv(rng, cin, cout, k, s, p);
        if !conv_bias {
            c.bias = None;
        }
        c
    };
    let stem = conv(&mut rng, 3, channels[0], 5, 1, 2);
    let stem_bn = bn(&mut rng, channels[0]);
    let mut blocks = Vec::new();
    let mut c = channels[0];
    for &co in &channels {
        blocks.push(BlockWeights {
            conv_a: conv(&mut rng, c, co, 3, 2, 1),
            bn_a: bn(&mut rng, co),
            conv_b: conv(&mut rng, co, co, 3, 1, 1),
            bn_b: bn(&mut rng, co),
            shortcut: conv(&mut rng, c, co, 1, 2, 0),
            bn_shortcut: bn(&mut rng, co),
        });
        c = co;
    }
    let mut hidden = Vec::new();
    for h in widths {
        hidden.push((linear(&mut rng, c, h), bn(&mut rng, h)));
        c = h;
    }
    NetWeights {
        grid,
        stem,
        stem_bn,
        blocks,
        hidden,
        output: linear(&mut rng, c, 18),
    }
}

/// A sparse grid like a surface sheet: a tilted plane of unit normals.
pub fn sheet_grid(seed: u64, n: usize) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let cubes = n * n * n;
    let mut g = vec![0.0f32; 3 * cubes];
    let tilt: f32 = rng.random_range(-0.3..0.3);
    for d in 0..n {
        for w in 0..n {
            let h = (n as f32 / 2.0 + tilt * (d as f32 - n as f32 / 2.0)).round() as usize;
            for h in [h, h + 1] {
                if h < n && rng.random_bool(0.8) {
                    let i = (d * n + h) * n + w;
                    g[i] = rng.random_range(-0.2..0.2);
                    g[cubes + i] = rng.random_range(0.8..1.0);
                    g[2 * cubes + i] = rng.random_range(-0.2..0.2);
                }
            }
        }
    }
    g
}

pub fn conv_ref(x: &[f64], c_in: usize, n: usize, w: &ConvWeights) -> (Vec<f64>, usize) {
    let (k, s, p, co) = (w.kernel, w.stride, w.padding, w.out_channels);
    let m = (n + 2 * p - k) / s + 1;
    let mut y = vec![0.0; co * m * m * m];
    for o in 0..co {
        for od in 0..m {
            for oh in 0..m {
                for ow in 0..m {
                    let mut acc = w.bias.as_ref().map_or(0.0, |b| b[o] as f64);
                    for ci in 0..c_in {
                        for kd in 0..k {
                            for kh in 0..k {
                                for kw in 0..k {
                                    let (id, ih, iw) = (
                                        (od * s + kd) as isize - p as isize,
                                        (oh * s + kh) as isize - p as isize,
                                        (ow * s + kw) as isize - p as isize,
                                    );
                                    let nn = n as isize;
                                    if id < 0
                                        || ih < 0
                                        || iw < 0
                                        || id >= nn
                                        || ih >= nn
                                        || iw >= nn
                                    {
                                        continue;
                                    }
                                    let xi = ((ci * n + id as usize) * n + ih as usize) * n
                                        + iw as usize;
                                    let wi = (((o * c_in + ci) * k + kd) * k + kh) * k + kw;
                                    acc += x[xi] * w.weight[wi] as f64;
                                }
                            }
                        }
                    }
                    y[((o * m + od) * m + oh) * m + ow] = acc;
                }
            }
        }
    }
    (y, m)
}

fn bn_ref(x: &mut [f64], bn: &BatchNormWeights) {
    let c = bn.gamma.len();
    let per = x.len() / c;
    for ch in 0..c {
        for v in &mut x[ch * per..(ch + 1) * per] {
            *v = bn.gamma[ch] as f64 * (*v - bn.mean[ch] as f64)
                / (bn.var[ch] as f64 + bn.epsilon).sqrt()
                + bn.beta[ch] as f64;
        }
    }
}

pub fn linear_ref(x: &[f64], l: &LinearWeights) -> Vec<f64> {
    (0..l.out_features)
        .map(|o| {
            l.bias.as_ref().map_or(0.0, |b| b[o] as f64)
                + (0..l.in_features)
                    .map(|i| x[i] * l.weight[i * l.out_features + o] as f64)
                    .sum::<f64>()
        })
        .collect()
}

fn relu(x: &mut [f64]) {
    x.iter_mut().for_each(|v| *v = v.max(0.0));
}

/// The network evaluated literally, in f64, channel-major (NCDHW).
pub fn reference_forward(w: &NetWeights, grid: &[f32]) -> Vec<f64> {
    let x: Vec<f64> = grid.iter().map(|&v| v as f64).collect();
    let (mut x, mut n) = conv_ref(&x, 3, w.grid, &w.stem);
    bn_ref(&mut x, &w.stem_bn);
    relu(&mut x);
    let mut c = w.stem.out_channels;
    for b in &w.blocks {
        let (mut t, m) = conv_ref(&x, c, n, &b.conv_a);
        bn_ref(&mut t, &b.bn_a);
        relu(&mut t);
        let (mut y, _) = conv_ref(&t, b.conv_a.out_channels, m, &b.conv_b);
        bn_ref(&mut y, &b.bn_b);
        let (mut s, _) = conv_ref(&x, c, n, &b.shortcut);
        bn_ref(&mut s, &b.bn_shortcut);
        for (a, b) in y.iter_mut().zip(&s) {
            *a += b;
        }
        relu(&mut y);
        x = y;
        n = m;
        c = b.conv_a.out_channels;
    }
    let per = n * n * n;
    let mut v: Vec<f64> = (0..c)
        .map(|ch| {
            x[ch * per..(ch + 1) * per]
                .iter()
                .cloned()
                .fold(f64::NEG_INFINITY, f64::max)
        })
        .collect();
    for (l, bn) in &w.hidden {
        let mut h = linear_ref(&v, l);
        bn_ref(&mut h, bn);
        relu(&mut h);
        v = h;
    }
    linear_ref(&v, &w.output)
        .into_iter()
        .map(f64::tanh)
        .collect()
}

/// The occupied cubes of each dense `[3, D, H, W]` grid of `grids` (each
/// `grid_len` values) as (indices, values channels-last).
pub fn sparse_grids(grids: &[f32], grid_len: usize) -> Vec<(Vec<u32>, Vec<f32>)> {
    grids
        .chunks_exact(grid_len)
        .map(|grid| {
            let cubes = grid.len() / 3;
            let index: Vec<u32> = (0..cubes)
                .filter(|&i| (0..3).any(|c| grid[c * cubes + i] != 0.0))
                .map(|i| i as u32)
                .collect();
            let values = index
                .iter()
                .flat_map(|&i| (0..3).map(move |c| grid[c * cubes + i as usize]))
                .collect();
            (index, values)
        })
        .collect()
}
