//! [`CubeTester::overlapped_cells`] on AVX2 (no AVX-512): four cubes of a
//! row at once in f64 lanes, the same products and sums in the same order as
//! [`CubeTester::overlaps_zx`] and [`CubeTester::overlaps_ij_jk`] (no fused
//! multiply-adds), so the same decisions; the hits compressed with a byte
//! shuffle from a table of the 16 lane masks and stored four at a time, no
//! branch per cube.

use super::CubeTester;
use std::arch::x86_64::*;

/// Per mask of four lanes: the `vpshufb` control that moves the set lanes'
/// 32-bit values to the front, in lane order (the rest zeroed).
const COMPRESS: [[u8; 16]; 16] = {
    let mut table = [[0x80u8; 16]; 16];
    let mut mask = 0;
    while mask < 16 {
        let (mut lane, mut at) = (0, 0);
        while lane < 4 {
            if mask & (1 << lane) != 0 {
                let mut byte = 0;
                while byte < 4 {
                    table[mask][4 * at + byte] = (4 * lane + byte) as u8;
                    byte += 1;
                }
                at += 1;
            }
            lane += 1;
        }
        mask += 1;
    }
    table
};

impl CubeTester {
    /// [`CubeTester::overlapped_cells`] with AVX2, in the same order: i,
    /// then k, then j.
    ///
    /// # Safety
    /// The CPU has AVX2; `range` is inside the grid of side `side` and
    /// `side³ ≤ i32::MAX`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn overlapped_cells_avx2(
        &self,
        range: [(usize, usize); 3],
        side: usize,
        cells: &mut Vec<u32>,
    ) {
        let splat = _mm256_set1_pd;
        let lanes = _mm256_set_pd(3.0, 2.0, 1.0, 0.0);
        let four = |first: usize, end: usize| {
            let mask = if end - first >= 4 {
                0xf
            } else {
                (1u32 << (end - first)) - 1
            };
            (_mm256_add_pd(splat(first as f64), lanes), mask)
        };
        let (k_end, j_end) = (range[2].1 + 1, range[1].1 + 1);
        // room for every cube of the range, and a whole vector past it
        let most: usize = range.iter().map(|&(a, b)| b + 1 - a).product();
        cells.reserve(most + 4);
        let mut len = cells.len();
        let mut ks = [0u32; 4];
        // a triangle spanning at most 2 rows j: 4 / L columns per vector, L
        // (1 or 2) the span rounded up to a power of two
        let span = j_end - range[1].0;
        let few_rows = (span <= 2).then(|| {
            let l = span.next_power_of_two();
            let rows = [0, 1, 2, 3].map(|lane| lane % l);
            FewRows {
                l,
                rows: (0..4)
                    .filter(|&lane| rows[lane] < span)
                    .fold(0, |m, lane| m | 1 << lane),
                y: _mm256_setr_pd(
                    (range[1].0 + rows[0]) as f64,
                    (range[1].0 + rows[1]) as f64,
                    (range[1].0 + rows[2]) as f64,
                    (range[1].0 + rows[3]) as f64,
                ),
                offset: rows.map(|r| ((range[1].0 + r) * side) as i32),
            }
        });
        for i in range[0].0..=range[0].1 {
            let x = i as f64;
            for k0 in (range[2].0..k_end).step_by(4) {
                // the zx tests of four columns: ((a·z + b·x) + d) ≥ 0
                let (z, mut columns) = four(k0, k_end);
                for [a, b, d] in self.zx {
                    let v = _mm256_add_pd(
                        _mm256_add_pd(_mm256_mul_pd(splat(a), z), splat(b * x)),
                        splat(d),
                    );
                    columns &= non_negative(v);
                }
                let mut count = 0;
                while columns != 0 {
                    ks[count] = k0 as u32 + columns.trailing_zeros();
                    count += 1;
                    columns &= columns - 1;
                }
                if let Some(few) = &few_rows {
                    let per_vector = 4 / few.l;
                    for g in (0..count).step_by(per_vector) {
                        // lane l: column g + l / L of the kept ones, row
                        // j0 + l % L
                        let column = [0, 1, 2, 3].map(|lane| g + lane / few.l);
                        let k = column.map(|c| ks[c.min(count - 1)]);
                        let valid = (0..4).fold(few.rows, |m, lane| {
                            m & !(u32::from(column[lane] >= count) << lane)
                        });
                        let z = _mm256_setr_pd(
                            f64::from(k[0]),
                            f64::from(k[1]),
                            f64::from(k[2]),
                            f64::from(k[3]),
                        );
                        let cubes = valid & self.row_tests_avx2(x, few.y, z);
                        let base = (i * side * side) as i32;
                        let cell = _mm_setr_epi32(
                            base + few.offset[0] + k[0] as i32,
                            base + few.offset[1] + k[1] as i32,
                            base + few.offset[2] + k[2] as i32,
                            base + few.offset[3] + k[3] as i32,
                        );
                        // SAFETY: at most `most` hits in all, capacity
                        // `most + 4`: room for a whole vector after them.
                        unsafe { append_hits(cells, &mut len, cubes, cell) };
                    }
                    continue;
                }
                for &k in &ks[..count] {
                    let (k, z) = (k as usize, f64::from(k));
                    for j0 in (range[1].0..j_end).step_by(4) {
                        let (y, cubes) = four(j0, j_end);
                        let cubes = cubes & self.row_tests_avx2(x, y, splat(z));
                        // cells (i·side + j)·side + k of the hits
                        let first = ((i * side + j0) * side + k) as i32;
                        let s = side as i32;
                        let cell = _mm_setr_epi32(first, first + s, first + 2 * s, first + 3 * s);
                        // SAFETY: as above.
                        unsafe { append_hits(cells, &mut len, cubes, cell) };
                    }
                }
            }
        }
        // SAFETY: the first `len` entries were written above.
        unsafe { cells.set_len(len) };
    }

    /// Of four cubes (`x`, `y`, `z`) of a column that passed the zx tests,
    /// those that pass the plane and the xy and yz tests (bit per lane): the
    /// products and sums of [`CubeTester::overlaps_ij_jk`] in the same order
    /// (NaN compares false in both forms: not separated).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn row_tests_avx2(&self, x: f64, y: __m256d, z: __m256d) -> u32 {
        let splat = _mm256_set1_pd;
        let zero = _mm256_setzero_pd();
        // the plane: ((n0·x + n1·y) + n2·z)
        let np = _mm256_add_pd(
            _mm256_add_pd(splat(self.n[0] * x), _mm256_mul_pd(splat(self.n[1]), y)),
            _mm256_mul_pd(splat(self.n[2]), z),
        );
        let product = _mm256_mul_pd(
            _mm256_add_pd(np, splat(self.d1)),
            _mm256_add_pd(np, splat(self.d2)),
        );
        let mut cubes =
            !(_mm256_movemask_pd(_mm256_cmp_pd::<_CMP_GT_OQ>(product, zero)) as u32) & 0xf;
        for [a, b, d] in self.xy {
            let v = _mm256_add_pd(
                _mm256_add_pd(splat(a * x), _mm256_mul_pd(splat(b), y)),
                splat(d),
            );
            cubes &= non_negative(v);
        }
        for [a, b, d] in self.yz {
            let v = _mm256_add_pd(
                _mm256_add_pd(_mm256_mul_pd(splat(a), y), _mm256_mul_pd(splat(b), z)),
                splat(d),
            );
            cubes &= non_negative(v);
        }
        cubes
    }
}

/// The lanes of `v` that are ≥ 0 (NaN is not), a bit each: the scalar tests'
/// `… >= 0.0`.
#[target_feature(enable = "avx2")]
#[inline]
fn non_negative(v: __m256d) -> u32 {
    _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_GE_OQ>(v, _mm256_setzero_pd())) as u32
}

/// Writes the cells of `cell` whose bit is set in `cubes` side by side at
/// `cells[*len..]` (a whole vector written) and counts them into `len`.
///
/// # Safety
/// The CPU has AVX2, and `*len + 4 <= cells.capacity()`.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn append_hits(cells: &mut Vec<u32>, len: &mut usize, cubes: u32, cell: __m128i) {
    debug_assert!(cubes < 16 && *len + 4 <= cells.capacity());
    // SAFETY: 16 readable bytes of the table.
    let order = unsafe { _mm_loadu_si128(COMPRESS[cubes as usize].as_ptr().cast()) };
    // SAFETY: room for 4 lanes at `len` (the caller's promise).
    unsafe {
        _mm_storeu_si128(
            cells.as_mut_ptr().add(*len).cast(),
            _mm_shuffle_epi8(cell, order),
        )
    };
    *len += cubes.count_ones() as usize;
}

/// For [`CubeTester::overlapped_cells_avx2`]: a triangle whose cubes span at
/// most 2 rows j tests several columns k per vector, `L` lanes each.
struct FewRows {
    /// lanes per column: the span rounded up to a power of two (1 or 2)
    l: usize,
    /// the lanes whose row is in the span (lane % L < span)
    rows: u32,
    /// per lane: its row j as f64
    y: __m256d,
    /// per lane: j · side
    offset: [i32; 4],
}
