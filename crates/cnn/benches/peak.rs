//! The sustained throughput of the int8 kernels' inner steps on this CPU,
//! the ceiling the convolutions are measured against (docs/benchmarks.md,
//! "How far from peak"): 12 independent i32 chains (8 for the AVX2 step),
//! operands in registers, byte products per second as the throughput.
//!
//! - `vpdpbusd_zmm` (AVX-512 VNNI): 64 products per instruction;
//! - `vpdpbusd_ymm` (AVX-VNNI): 32;
//! - `narrow_avx2` (plain AVX2, narrow ranges): two `vpmaddubsw`, `vpaddw`,
//!   `vpmaddwd` by ones and `vpaddd` for 64 products, the step of
//!   `conv_int8_avx2::narrow_mac`.
//!
//! Each runs where the CPU has its instructions (`NORMALNET_ISA` does not
//! apply: this measures the CPU, not a path).
#![allow(missing_docs)]

use criterion::{Criterion, Throughput, criterion_group, criterion_main};

/// Steps per measured call (per chain: STEPS / chains).
const STEPS: usize = 1 << 20;

#[cfg(target_arch = "x86_64")]
mod steps {
    use super::STEPS;
    use std::arch::x86_64::*;
    use std::hint::black_box;

    /// STEPS `vpdpbusd` zmm over 12 chains; returns a lane of their sum.
    ///
    /// # Safety
    /// The CPU has AVX-512 F/BW and VNNI.
    #[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
    pub unsafe fn dpbusd_zmm(x: i32, w: i32) -> i32 {
        let (x, w) = (_mm512_set1_epi32(x), _mm512_set1_epi32(w));
        let mut acc = [_mm512_setzero_si512(); 12];
        for _ in 0..STEPS / 12 {
            let x = black_box(x);
            for a in &mut acc {
                *a = _mm512_dpbusd_epi32(*a, x, w);
            }
        }
        let sum = acc
            .iter()
            .fold(_mm512_setzero_si512(), |s, &a| _mm512_add_epi32(s, a));
        _mm512_reduce_add_epi32(sum)
    }

    /// STEPS `vpdpbusd` ymm (AVX-VNNI) over 12 chains.
    ///
    /// # Safety
    /// The CPU has AVX2 and AVX-VNNI.
    #[target_feature(enable = "avx2,avxvnni")]
    pub unsafe fn dpbusd_ymm(x: i32, w: i32) -> i32 {
        let (x, w) = (_mm256_set1_epi32(x), _mm256_set1_epi32(w));
        let mut acc = [_mm256_setzero_si256(); 12];
        for _ in 0..STEPS / 12 {
            let x = black_box(x);
            for a in &mut acc {
                *a = _mm256_dpbusd_avx_epi32(*a, x, w);
            }
        }
        let sum = acc
            .iter()
            .fold(_mm256_setzero_si256(), |s, &a| _mm256_add_epi32(s, a));
        _mm256_extract_epi32::<0>(sum)
    }

    /// STEPS narrow AVX2 steps over 8 chains; the inputs pass through an
    /// empty `asm!` before each step, so no step is shared between chains.
    ///
    /// # Safety
    /// The CPU has AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn narrow_avx2(x: i32, w: i32) -> i32 {
        let ones = _mm256_set1_epi16(1);
        let (w0, w1) = (_mm256_set1_epi32(w), _mm256_set1_epi32(w ^ 0x0101_0101));
        let (mut x0, mut x1) = (_mm256_set1_epi32(x), _mm256_set1_epi32(x ^ 0x0202_0202));
        let mut acc = [_mm256_setzero_si256(); 8];
        for _ in 0..STEPS / 8 {
            for a in &mut acc {
                // SAFETY: an empty template: the values stay as they are.
                unsafe { std::arch::asm!("/* {0} {1} */", inout(ymm_reg) x0, inout(ymm_reg) x1) };
                let pairs =
                    _mm256_add_epi16(_mm256_maddubs_epi16(x0, w0), _mm256_maddubs_epi16(x1, w1));
                *a = _mm256_add_epi32(*a, _mm256_madd_epi16(pairs, ones));
            }
        }
        let sum = acc
            .iter()
            .fold(_mm256_setzero_si256(), |s, &a| _mm256_add_epi32(s, a));
        _mm256_extract_epi32::<0>(sum)
    }
}

#[cfg(target_arch = "x86_64")]
fn peak(c: &mut Criterion) {
    use std::hint::black_box;
    let mut g = c.benchmark_group("int8_peak");
    g.sample_size(20);
    let (x, w) = (0x0102_0304, 0x0101_0101);
    if is_x86_feature_detected!("avx512vnni") && is_x86_feature_detected!("avx512bw") {
        g.throughput(Throughput::Elements((STEPS * 64) as u64));
        // SAFETY: checked above.
        g.bench_function("vpdpbusd_zmm", |b| {
            b.iter(|| unsafe { steps::dpbusd_zmm(black_box(x), w) })
        });
    }
    if is_x86_feature_detected!("avxvnni") {
        g.throughput(Throughput::Elements((STEPS * 32) as u64));
        // SAFETY: checked above.
        g.bench_function("vpdpbusd_ymm", |b| {
            b.iter(|| unsafe { steps::dpbusd_ymm(black_box(x), w) })
        });
    }
    if is_x86_feature_detected!("avx2") {
        g.throughput(Throughput::Elements((STEPS * 64) as u64));
        // SAFETY: checked above.
        g.bench_function("narrow_avx2", |b| {
            b.iter(|| unsafe { steps::narrow_avx2(black_box(x), w) })
        });
    }
    g.finish();
}

#[cfg(not(target_arch = "x86_64"))]
fn peak(_: &mut Criterion) {}

criterion_group!(benches, peak);
criterion_main!(benches);
