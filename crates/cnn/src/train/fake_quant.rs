//! Fake quantization for quantization-aware training: the values the int8
//! inference rounds ([`crate::conv_int8`], [`crate::stem_rows`]) rounded
//! the same way during training and kept in f32, so that the networks learn
//! with the steps they will run with. Gradients pass straight through (the
//! rounding's derivative taken as 1): the weight gradients are those of the
//! rounded weights, applied to the f32 weights Adam keeps.

use crate::conv_int8::{Int8Range, weight_scales};

/// Each sample's block input (`[samples][per]`, ≥ 0 after a ReLU) on its
/// byte steps, as [`crate::conv_int8::quantize`] makes them: byte =
/// ⌊x / s + ½⌋ with s = the sample's largest value / `range`'s largest byte,
/// x̂ = byte · s (0 for an all-zero sample).
pub(crate) fn block_inputs(x: &[f32], per: usize, range: Int8Range, out: &mut [f32]) {
    use rayon::prelude::*;
    let top = range.activation_max();
    out.par_chunks_mut(per)
        .zip(x.par_chunks(per))
        .for_each(|(out, x)| {
            let max = x.iter().fold(0.0f32, |m, &v| m.max(v));
            let scale = if max > 0.0 { max / top } else { 1.0 };
            let inv = 1.0 / scale;
            for (o, &v) in out.iter_mut().zip(x) {
                *o = (v * inv + 0.5).clamp(0.0, top).trunc() * scale;
            }
        });
}

/// Weights `[k³][cin][cout]` on their output channel's steps, as
/// [`crate::conv_int8::Int8Conv`] makes them: w / s rounded (halves away
/// from zero) with s = the channel's largest |w| / `range`'s largest weight.
/// Per channel, so the same steps as the inference's weights with batch
/// norm folded in (folding scales a channel by one factor: its rounded
/// values scale with it).
pub(crate) fn weights(w: &[f32], cout: usize, range: Int8Range) -> Vec<f32> {
    let scale = weight_scales(w, cout, range);
    let top = range.weight_max();
    w.iter()
        .enumerate()
        .map(|(i, &v)| (v / scale[i % cout]).round().clamp(-top, top) * scale[i % cout])
        .collect()
}

/// A sample's stem inputs (the occupied cubes' signed values) on their
/// steps, as [`crate::stem_rows::Rows::quantize`] makes them: v / s rounded
/// to even with s = their largest |v| / `range`'s largest stem step.
pub(crate) fn stem_inputs(values: &mut [f32], range: Int8Range) {
    let top = range.stem_levels().0 as f32;
    let max = values.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let scale = if max > 0.0 { max / top } else { 1.0 };
    let inv = 1.0 / scale;
    for v in values {
        *v = (*v * inv).round_ties_even().clamp(-top, top) * scale;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_inputs_take_the_inference_bytes_per_sample() {
        let x = [0.0, 1.0, 0.5, 2.0, 0.013, 0.0, 0.0, 0.0];
        let mut out = [f32::NAN; 8];
        block_inputs(&x, 4, Int8Range::Narrow, &mut out);
        let s = 2.0 / 127.0;
        for (&v, &q) in x[..4].iter().zip(&out[..4]) {
            let byte = q / s;
            assert!(
                (byte - byte.round()).abs() < 1e-4 && byte <= 127.0,
                "{v} -> {q}"
            );
            assert!((q - v).abs() <= 0.5 * s + 1e-6, "{v} -> {q}");
        }
        assert_eq!(out[3], 2.0);
        // a sample of zeros stays zero; each sample has its own scale
        assert_eq!(out[5..], [0.0; 3]);
        assert_eq!(
            out[4],
            (0.013f32 / 0.013 * 127.0 + 0.5).trunc() * (0.013 / 127.0)
        );
        // the bytes are those `conv_int8::quantize` writes
        let mut buffer = Vec::new();
        let isa = normalnet_isa::Isa::detected();
        for range in [Int8Range::Full, Int8Range::Narrow] {
            let x: Vec<f32> = (0..64).map(|i| ((i * 37) % 23) as f32 * 0.11).collect();
            let mut out = vec![0.0; 64];
            block_inputs(&x, 64, range, &mut out);
            let (bytes, s) =
                crate::conv_int8::quantize(isa, &x, 4, 0, range, (None, None), &mut buffer);
            for (&b, &q) in bytes.iter().zip(&out) {
                assert_eq!(f32::from(b) * s, q, "{range:?}");
            }
        }
    }

    #[test]
    fn weights_take_per_channel_steps() {
        // [k³ = 1][cin = 3][cout = 2]
        let w = [0.5, -0.01, -1.0, 0.02, 0.25, 0.04];
        let q = weights(&w, 2, Int8Range::Narrow);
        // channel 0: max 1.0, steps of 1/63; channel 1: max 0.04, steps 0.04/63
        assert_eq!(q[2], -1.0);
        assert_eq!(q[5], 0.04);
        for (i, (&v, &r)) in w.iter().zip(&q).enumerate() {
            let s = if i % 2 == 0 { 1.0 / 63.0 } else { 0.04 / 63.0 };
            assert!((v - r).abs() <= 0.5 * s + 1e-7, "{v} -> {r}");
            assert!(((r / s) - (r / s).round()).abs() < 1e-3);
        }
        assert_eq!(weights(&[0.0, 0.0], 2, Int8Range::Narrow), [0.0, 0.0]);
    }

    #[test]
    fn stem_inputs_take_signed_steps() {
        let x = [0.3, -0.6, 0.0, 0.31, 0.0049];
        for (range, top) in [(Int8Range::Full, 127.0), (Int8Range::Narrow, 63.0)] {
            let mut v = x;
            stem_inputs(&mut v, range);
            let s = 0.6 / top;
            assert_eq!((v[1], v[2]), (-0.6, 0.0), "{range:?}");
            for (&a, &q) in x.iter().zip(&v) {
                assert!((a - q).abs() <= 0.5 * s + 1e-6, "{range:?}: {a} -> {q}");
                assert!(((q / s) - (q / s).round()).abs() < 1e-3, "{range:?}: {q}");
            }
        }
    }
}
