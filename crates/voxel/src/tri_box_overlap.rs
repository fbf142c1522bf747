//! Triangle–box overlap (SPEC §5 step 4).
//!
//! T. Akenine-Möller, "Fast 3D triangle-box overlap testing", Journal of
//! Graphics Tools 6(1), 2001, DOI 10.1080/10867651.2001.10487535: the
//! separating-axis test over 13 axes (the 3 box axes, the triangle normal, and
//! the 9 cross products of box axes with triangle edges). Touching counts as
//! overlap.
//!
//! [`tri_box_overlap`] is the reference form of that test for any box.
//! [`CubeTester`] is the same 13-axis test rearranged for the voxelizer's
//! inner loop, after M. Schwarz and H.-P. Seidel, "Fast parallel surface and
//! solid voxelization on GPUs", ACM TOG 29(6), 2010, DOI
//! 10.1145/1882261.1866201: in grid units (cube `(i, j, k)` spans
//! `[i, i+1] × [j, j+1] × [k, k+1]`) the normal axis becomes one plane test
//! and the 9 edge axes become three 2D edge-function tests per coordinate
//! projection, each with per-triangle constants, so a cube costs a few
//! multiply-adds. For a triangle and a cube whose bounding boxes overlap, the
//! two forms decide the same (the 2D tests on the outer side of each
//! projected edge plus the box axes are the 2D SAT, which equals the 3D SAT
//! restricted to those axes); the tests check this on random cases.

use normalnet_mesh::vec3::{self, Vec3};

#[cfg(target_arch = "x86_64")]
mod avx2;

/// Does the triangle `tri` overlap the axis-aligned box with centre `centre`
/// and half-sizes `half`? Akenine-Möller's 13-axis separating-axis test.
/// A degenerate triangle (zero normal) is tested as a segment or point.
pub fn tri_box_overlap(centre: Vec3, half: Vec3, tri: [Vec3; 3]) -> bool {
    let v = tri.map(|p| vec3::sub(p, centre));
    // Box axes (bounding boxes).
    for a in 0..3 {
        let lo = v[0][a].min(v[1][a]).min(v[2][a]);
        let hi = v[0][a].max(v[1][a]).max(v[2][a]);
        if lo > half[a] || hi < -half[a] {
            return false;
        }
    }
    let e = [
        vec3::sub(v[1], v[0]),
        vec3::sub(v[2], v[1]),
        vec3::sub(v[0], v[2]),
    ];
    // Nine edge axes: e_i × unit axis a.
    for ei in &e {
        for a in 0..3 {
            let mut axis = [0.0; 3];
            axis[a] = 1.0;
            let ax = vec3::cross(*ei, axis);
            if separated_on(ax, &v, half) {
                return false;
            }
        }
    }
    // Triangle normal (the plane–box test).
    let n = vec3::cross(e[0], e[1]);
    !separated_on(n, &v, half)
}

fn separated_on(axis: Vec3, v: &[Vec3; 3], half: Vec3) -> bool {
    let p = [
        vec3::dot(axis, v[0]),
        vec3::dot(axis, v[1]),
        vec3::dot(axis, v[2]),
    ];
    let lo = p[0].min(p[1]).min(p[2]);
    let hi = p[0].max(p[1]).max(p[2]);
    let r = half[0] * axis[0].abs() + half[1] * axis[1].abs() + half[2] * axis[2].abs();
    lo > r || hi < -r
}

/// One triangle prepared for testing against the unit cubes of a grid.
///
/// Coordinates are grid units: cube `(i, j, k)` spans `[i, i+1] × [j, j+1] ×
/// [k, k+1]`. The caller iterates over the cubes of the triangle's bounding
/// box ([`CubeTester::cube_range`]); for each `(i, k)` column it calls
/// [`CubeTester::overlaps_zx`] once, then for each `j` [`CubeTester::overlaps_ij_jk`].
#[derive(Clone, Copy, Debug)]
pub struct CubeTester {
    /// triangle bounding box, min corner
    pub lo: Vec3,
    /// triangle bounding box, max corner
    pub hi: Vec3,
    // plane: n · p + d1 and n · p + d2 must not have the same sign.
    n: Vec3,
    d1: f64,
    d2: f64,
    // 2D edge functions per projection: a·u + b·w + d ≥ 0 for all 3 edges.
    xy: [[f64; 3]; 3],
    yz: [[f64; 3]; 3],
    zx: [[f64; 3]; 3],
}

impl CubeTester {
    /// Prepares the triangle `tri` (grid units).
    pub fn new(tri: [Vec3; 3]) -> CubeTester {
        let [v0, v1, v2] = tri;
        let mut lo = v0;
        let mut hi = v0;
        for p in [v1, v2] {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        let e = [vec3::sub(v1, v0), vec3::sub(v2, v1), vec3::sub(v0, v2)];
        let n = vec3::cross(e[0], e[1]);
        // Critical corner of the unit cube for the plane test.
        let c = [0, 1, 2].map(|a| if n[a] > 0.0 { 1.0 } else { 0.0 });
        let d1 = vec3::dot(n, vec3::sub(c, v0));
        let d2 = vec3::dot(n, vec3::sub([1.0 - c[0], 1.0 - c[1], 1.0 - c[2]], v0));
        // Projection onto the plane of axes (u, w), dropping axis `drop`,
        // edge normals oriented inwards by the sign of n[drop].
        let proj = |u: usize, w: usize, drop: usize| {
            let s = if n[drop] >= 0.0 { 1.0 } else { -1.0 };
            let mut out = [[0.0; 3]; 3];
            for i in 0..3 {
                let a = -e[i][w] * s;
                let b = e[i][u] * s;
                let d = -(a * tri[i][u] + b * tri[i][w]) + a.max(0.0) + b.max(0.0);
                out[i] = [a, b, d];
            }
            out
        };
        CubeTester {
            lo,
            hi,
            n,
            d1,
            d2,
            xy: proj(0, 1, 2),
            yz: proj(1, 2, 0),
            zx: proj(2, 0, 1),
        }
    }

    /// The cubes whose closed box meets the triangle's bounding box, clamped
    /// to `0..side` on each axis: `[(first, last); 3]` inclusive, or `None`
    /// when the bounding box misses the grid.
    #[inline]
    #[allow(clippy::needless_range_loop)]
    pub fn cube_range(&self, side: usize) -> Option<[(usize, usize); 3]> {
        let mut r = [(0usize, 0usize); 3];
        for a in 0..3 {
            // Cube i touches [lo, hi] iff i ≤ hi and i + 1 ≥ lo.
            let first = (self.lo[a].ceil() - 1.0).max(0.0);
            let last = self.hi[a].floor().min(side as f64 - 1.0);
            if first.is_nan() || last.is_nan() || first > last {
                return None;
            }
            r[a] = (first as usize, last as usize);
        }
        Some(r)
    }

    /// The zx-projection test of column `(i, k)`.
    #[inline]
    pub fn overlaps_zx(&self, i: usize, k: usize) -> bool {
        let (x, z) = (i as f64, k as f64);
        self.zx.iter().all(|&[a, b, d]| a * z + b * x + d >= 0.0)
    }

    /// The plane, xy- and yz-projection tests of cube `(i, j, k)` (call only
    /// when [`Self::overlaps_zx`] holds for `(i, k)` and the cube is in
    /// [`Self::cube_range`]).
    #[inline]
    pub fn overlaps_ij_jk(&self, i: usize, j: usize, k: usize) -> bool {
        let (x, y, z) = (i as f64, j as f64, k as f64);
        let np = self.n[0] * x + self.n[1] * y + self.n[2] * z;
        if (np + self.d1) * (np + self.d2) > 0.0 {
            return false;
        }
        self.xy.iter().all(|&[a, b, d]| a * x + b * y + d >= 0.0)
            && self.yz.iter().all(|&[a, b, d]| a * y + b * z + d >= 0.0)
    }

    /// Appends to `cells` the cubes of `range` ([`Self::cube_range`]) that
    /// the triangle overlaps, as `(i·side + j)·side + k` in the order i,
    /// then k, then j: the decisions of [`Self::overlaps_zx`] and
    /// [`Self::overlaps_ij_jk`], eight cubes of a row at once where the CPU
    /// has AVX-512 (the same products and sums in the same order, so the
    /// same decisions; the hits compress-stored, no branch per cube), one
    /// by one elsewhere.
    ///
    /// # Panics
    /// If `range` is not inside the grid (`a ≤ b < side` on every axis;
    /// [`Self::cube_range`] always is): the vector path reserves room by it.
    #[inline]
    pub fn overlapped_cells(&self, range: [(usize, usize); 3], side: usize, cells: &mut Vec<u32>) {
        assert!(
            range.iter().all(|&(a, b)| a <= b && b < side),
            "cube range {range:?} outside a grid of side {side}"
        );
        #[cfg(target_arch = "x86_64")]
        if side.pow(3) <= i32::MAX as usize {
            let isa = normalnet_isa::active();
            if isa.has_avx512() {
                // SAFETY: the AVX-512 path runs only where the CPU has F and VL.
                return unsafe { self.overlapped_cells_avx512(range, side, cells) };
            }
            if isa.has_avx2() {
                // SAFETY: the AVX2 path runs only where the CPU has it.
                return unsafe { self.overlapped_cells_avx2(range, side, cells) };
            }
        }
        self.overlapped_cells_plain(range, side, cells);
    }

    fn overlapped_cells_plain(
        &self,
        range: [(usize, usize); 3],
        side: usize,
        cells: &mut Vec<u32>,
    ) {
        for i in range[0].0..=range[0].1 {
            for k in range[2].0..=range[2].1 {
                if !self.overlaps_zx(i, k) {
                    continue;
                }
                for j in range[1].0..=range[1].1 {
                    if self.overlaps_ij_jk(i, j, k) {
                        cells.push(((i * side + j) * side + k) as u32);
                    }
                }
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl")]
    fn overlapped_cells_avx512(
        &self,
        range: [(usize, usize); 3],
        side: usize,
        cells: &mut Vec<u32>,
    ) {
        use std::arch::x86_64::*;
        let splat = _mm512_set1_pd;
        let zero = _mm512_setzero_pd();
        let lanes = _mm512_set_pd(7.0, 6.0, 5.0, 4.0, 3.0, 2.0, 1.0, 0.0);
        let int_lanes = _mm256_set_epi32(7, 6, 5, 4, 3, 2, 1, 0);
        let eight = |first: usize, end: usize| {
            let mask = if end - first >= 8 {
                0xff
            } else {
                (1u8 << (end - first)) - 1
            };
            (_mm512_add_pd(splat(first as f64), lanes), mask)
        };
        let (k_end, j_end) = (range[2].1 + 1, range[1].1 + 1);
        // room for every cube of the range, and a whole vector past it
        let most: usize = range.iter().map(|&(a, b)| b + 1 - a).product();
        cells.reserve(most + 8);
        let mut len = cells.len();
        let mut ks = [0u32; 8];
        // a triangle spanning at most 4 rows j: 8 / L columns per vector,
        // L = the span rounded up to a power of two
        let span = j_end - range[1].0;
        let few_rows = (span <= 4).then(|| {
            let l = span.next_power_of_two() as i32;
            let row = _mm256_and_si256(int_lanes, _mm256_set1_epi32(l - 1));
            let j = _mm256_add_epi32(row, _mm256_set1_epi32(range[1].0 as i32));
            FewRows {
                columns: 8 / l as usize,
                column: _mm256_srlv_epi32(int_lanes, _mm256_set1_epi32(l.trailing_zeros() as i32)),
                rows: _mm256_cmplt_epi32_mask(row, _mm256_set1_epi32(span as i32)),
                y: _mm512_cvtepi32_pd(j),
                offset: _mm256_mullo_epi32(j, _mm256_set1_epi32(side as i32)),
            }
        });
        for i in range[0].0..=range[0].1 {
            let x = i as f64;
            for k0 in (range[2].0..k_end).step_by(8) {
                // the zx tests of eight columns: ((a·z + b·x) + d) ≥ 0
                let (z, mut columns) = eight(k0, k_end);
                for [a, b, d] in self.zx {
                    let v = _mm512_add_pd(
                        _mm512_add_pd(_mm512_mul_pd(splat(a), z), splat(b * x)),
                        splat(d),
                    );
                    columns &= _mm512_cmp_pd_mask::<_CMP_GE_OQ>(v, zero);
                }
                let ks_vec = _mm256_add_epi32(_mm256_set1_epi32(k0 as i32), int_lanes);
                // SAFETY: `ks` holds 8 lanes.
                unsafe {
                    _mm256_mask_compressstoreu_epi32(ks.as_mut_ptr().cast(), columns, ks_vec)
                };
                let count = columns.count_ones() as usize;
                if let Some(few) = &few_rows {
                    // SAFETY: `ks` holds 8 lanes.
                    let ks_vec = unsafe { _mm256_loadu_si256(ks.as_ptr().cast()) };
                    for g in (0..count).step_by(few.columns) {
                        // lane l: column g + l / L of the kept ones, row
                        // j0 + l % L
                        let column = _mm256_add_epi32(_mm256_set1_epi32(g as i32), few.column);
                        let k = _mm256_permutexvar_epi32(
                            _mm256_min_epi32(column, _mm256_set1_epi32(7)),
                            ks_vec,
                        );
                        let z = _mm512_cvtepi32_pd(k);
                        let cubes = few.rows
                            & _mm256_cmplt_epi32_mask(column, _mm256_set1_epi32(count as i32));
                        let cubes = cubes & self.row_tests(x, few.y, z);
                        let cell = _mm256_add_epi32(
                            _mm256_add_epi32(
                                _mm256_set1_epi32((i * side * side) as i32),
                                few.offset,
                            ),
                            k,
                        );
                        // SAFETY: at most `most` hits in all, capacity
                        // `most + 8`: room for a whole vector after them.
                        unsafe { append_hits(cells, &mut len, cubes, cell) };
                    }
                    continue;
                }
                for &k in &ks[..count] {
                    let (k, z) = (k as usize, f64::from(k));
                    for j0 in (range[1].0..j_end).step_by(8) {
                        let (y, cubes) = eight(j0, j_end);
                        let cubes = cubes & self.row_tests(x, y, splat(z));
                        // cells (i·side + j)·side + k of the hits, stored
                        // side by side
                        let first = ((i * side + j0) * side + k) as i32;
                        let cell = _mm256_add_epi32(
                            _mm256_set1_epi32(first),
                            _mm256_mullo_epi32(int_lanes, _mm256_set1_epi32(side as i32)),
                        );
                        // SAFETY: at most `most` hits in all, capacity
                        // `most + 8`: room for a whole vector after them.
                        unsafe { append_hits(cells, &mut len, cubes, cell) };
                    }
                }
            }
        }
        // SAFETY: the first `len` entries were written above.
        unsafe { cells.set_len(len) };
    }

    /// Of eight cubes (`x`, `y`, `z`) of a column that passed the zx tests,
    /// those that pass the plane and the xy and yz tests: the products and
    /// sums of [`Self::overlaps_ij_jk`] in the same order (NaN compares
    /// false in both forms: not separated).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl")]
    #[inline]
    fn row_tests(
        &self,
        x: f64,
        y: std::arch::x86_64::__m512d,
        z: std::arch::x86_64::__m512d,
    ) -> u8 {
        use std::arch::x86_64::*;
        let splat = _mm512_set1_pd;
        let zero = _mm512_setzero_pd();
        // the plane: ((n0·x + n1·y) + n2·z)
        let np = _mm512_add_pd(
            _mm512_add_pd(splat(self.n[0] * x), _mm512_mul_pd(splat(self.n[1]), y)),
            _mm512_mul_pd(splat(self.n[2]), z),
        );
        let product = _mm512_mul_pd(
            _mm512_add_pd(np, splat(self.d1)),
            _mm512_add_pd(np, splat(self.d2)),
        );
        let mut cubes = !_mm512_cmp_pd_mask::<_CMP_GT_OQ>(product, zero);
        for [a, b, d] in self.xy {
            let v = _mm512_add_pd(
                _mm512_add_pd(splat(a * x), _mm512_mul_pd(splat(b), y)),
                splat(d),
            );
            cubes &= _mm512_cmp_pd_mask::<_CMP_GE_OQ>(v, zero);
        }
        for [a, b, d] in self.yz {
            let v = _mm512_add_pd(
                _mm512_add_pd(_mm512_mul_pd(splat(a), y), _mm512_mul_pd(splat(b), z)),
                splat(d),
            );
            cubes &= _mm512_cmp_pd_mask::<_CMP_GE_OQ>(v, zero);
        }
        cubes
    }

    /// Full test of cube `(i, j, k)` (bounding box included).
    pub fn overlaps(&self, i: usize, j: usize, k: usize) -> bool {
        let p = [i as f64, j as f64, k as f64];
        (0..3).all(|a| p[a] <= self.hi[a] && p[a] + 1.0 >= self.lo[a])
            && self.overlaps_zx(i, k)
            && self.overlaps_ij_jk(i, j, k)
    }
}

/// Writes the cells of `cell` whose bit is set in `cubes` side by side at
/// `cells[*len..]` (a whole vector written) and counts them into `len`.
///
/// # Safety
/// The CPU has AVX-512 F and VL, and `*len + 8 <= cells.capacity()`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl")]
#[inline]
unsafe fn append_hits(
    cells: &mut Vec<u32>,
    len: &mut usize,
    cubes: u8,
    cell: std::arch::x86_64::__m256i,
) {
    use std::arch::x86_64::*;
    debug_assert!(*len + 8 <= cells.capacity());
    // SAFETY: room for 8 lanes at `len` (the caller's promise).
    unsafe {
        _mm256_storeu_si256(
            cells.as_mut_ptr().add(*len).cast(),
            _mm256_maskz_compress_epi32(cubes, cell),
        )
    };
    *len += cubes.count_ones() as usize;
}

/// For [`CubeTester::overlapped_cells`]: a triangle whose cubes span at most
/// 4 rows j tests several columns k per vector, `L` lanes each (its span
/// rounded up to a power of two).
#[cfg(target_arch = "x86_64")]
struct FewRows {
    /// columns per vector: 8 / L
    columns: usize,
    /// per lane: its column in the group, lane / L
    column: std::arch::x86_64::__m256i,
    /// the lanes whose row is in the span (lane % L < span)
    rows: u8,
    /// per lane: its row j as f64
    y: std::arch::x86_64::__m512d,
    /// per lane: j · side
    offset: std::arch::x86_64::__m256i,
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Exact oracle: clip the triangle against the six box planes
    /// (Sutherland–Hodgman); overlap iff something is left.
    fn clip_overlap(centre: Vec3, half: Vec3, tri: [Vec3; 3]) -> bool {
        let mut poly: Vec<Vec3> = tri.to_vec();
        for a in 0..3 {
            for sign in [1.0, -1.0] {
                // keep sign·(p[a] − centre[a]) ≤ half[a]
                let inside = |p: &Vec3| sign * (p[a] - centre[a]) <= half[a];
                let mut out = Vec::new();
                for i in 0..poly.len() {
                    let p = poly[i];
                    let q = poly[(i + 1) % poly.len()];
                    let (ip, iq) = (inside(&p), inside(&q));
                    if ip {
                        out.push(p);
                    }
                    if ip != iq {
                        let fp = sign * (p[a] - centre[a]) - half[a];
                        let fq = sign * (q[a] - centre[a]) - half[a];
                        let t = fp / (fp - fq);
                        out.push(vec3::add(p, vec3::scale(vec3::sub(q, p), t)));
                    }
                }
                poly = out;
                if poly.is_empty() {
                    return false;
                }
            }
        }
        true
    }

    fn random_case(rng: &mut ChaCha8Rng) -> (Vec3, Vec3, [Vec3; 3]) {
        let centre = [0.0; 3].map(|_: f64| rng.random_range(-1.0..1.0));
        let half = [0.0; 3].map(|_: f64| rng.random_range(0.1..1.0));
        let size = rng.random_range(0.05..3.0);
        let base = [0.0; 3].map(|_: f64| rng.random_range(-1.2..1.2));
        let tri = [0; 3]
            .map(|_| [0; 3].map(|a| centre[a] + base[a] + size * rng.random_range(-1.0..1.0)));
        (centre, half, tri)
    }

    fn point_in_triangle(rng: &mut ChaCha8Rng, tri: &[Vec3; 3]) -> Vec3 {
        let (mut u, mut v): (f64, f64) = (rng.random(), rng.random());
        if u + v > 1.0 {
            u = 1.0 - u;
            v = 1.0 - v;
        }
        let e1 = vec3::sub(tri[1], tri[0]);
        let e2 = vec3::sub(tri[2], tri[0]);
        vec3::add(tri[0], vec3::add(vec3::scale(e1, u), vec3::scale(e2, v)))
    }

    fn in_box(p: Vec3, centre: Vec3, half: Vec3) -> bool {
        (0..3).all(|a| (p[a] - centre[a]).abs() <= half[a])
    }

    /// SAT against brute-force sampling: a sampled triangle point inside the
    /// box proves overlap; when SAT separates, no sampled point is inside.
    /// Also against the exact clipping oracle.
    #[test]
    fn sat_agrees_with_sampling_and_clipping() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (mut overlaps, mut proven, mut cases) = (0, 0, 0);
        for _ in 0..20000 {
            let (c, h, t) = random_case(&mut rng);
            let sat = tri_box_overlap(c, h, t);
            let exact = clip_overlap(c, h, t);
            assert_eq!(sat, exact, "case {c:?} {h:?} {t:?}");
            let mut found = false;
            for _ in 0..400 {
                if in_box(point_in_triangle(&mut rng, &t), c, h) {
                    found = true;
                    break;
                }
            }
            if found {
                assert!(
                    sat,
                    "sampled common point but SAT separates: {c:?} {h:?} {t:?}"
                );
                proven += 1;
            }
            overlaps += sat as usize;
            cases += 1;
        }
        // The generator must exercise both outcomes substantially.
        assert!(
            overlaps > cases / 5 && overlaps < cases * 4 / 5,
            "{overlaps}/{cases}"
        );
        assert!(proven > overlaps / 2, "{proven} of {overlaps}");
        println!("{cases} cases, {overlaps} overlapping, {proven} proven by a sampled point");
    }

    /// The grid-unit tester decides exactly like the reference SAT.
    #[test]
    fn cube_tester_equals_reference() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut hits = 0;
        let mut tested = 0;
        for _ in 0..3000 {
            let size = rng.random_range(0.2..6.0);
            let base = [0; 3].map(|_| rng.random_range(1.0..7.0));
            let mut tri =
                [0; 3].map(|_| [0; 3].map(|a| base[a] + size * rng.random_range(-1.0..1.0f64)));
            // Flat and axis-aligned triangles, as the voxelizer sees them.
            if rng.random_bool(0.2) {
                let y = tri[0][1];
                for p in &mut tri {
                    p[1] = y;
                }
            }
            let t = CubeTester::new(tri);
            for i in 0..8 {
                for j in 0..8 {
                    for k in 0..8 {
                        let c = [i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5];
                        let r = tri_box_overlap(c, [0.5; 3], tri);
                        assert_eq!(t.overlaps(i, j, k), r, "cube {i} {j} {k} tri {tri:?}");
                        hits += r as usize;
                        tested += 1;
                        if let Some(range) = t.cube_range(8) {
                            let inside = (0..3).all(|a| {
                                let v = [i, j, k][a];
                                v >= range[a].0 && v <= range[a].1
                            });
                            if r {
                                assert!(inside, "overlapping cube outside range");
                            }
                        } else {
                            assert!(!r);
                        }
                    }
                }
            }
        }
        assert!(hits > tested / 50, "{hits}/{tested}");
    }

    /// The cubes found eight at a time (several columns at a time for
    /// triangles spanning few rows) are those the single tests find,
    /// in the same order, on the voxelizer's kind of triangles and on
    /// flat, degenerate and NaN ones.
    #[test]
    fn overlapped_cells_equal_single_tests() {
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        let (mut hits, mut few, mut two) = (0, 0, 0);
        for case in 0..4000 {
            let size = rng.random_range(0.2..12.0);
            let base = [0; 3].map(|_| rng.random_range(1.0..20.0));
            let mut tri =
                [0; 3].map(|_| [0; 3].map(|a| base[a] + size * rng.random_range(-1.0..1.0f64)));
            match case % 10 {
                0 => tri[1] = tri[0],
                1 => tri[2][1] = f64::NAN,
                2 => {
                    let y = tri[0][1].floor();
                    tri.iter_mut().for_each(|p| p[1] = y);
                }
                _ => {}
            }
            let t = CubeTester::new(tri);
            let range = t.cube_range(21).unwrap_or([(0, 20); 3]);
            let (mut fast, mut plain) = (vec![7], vec![7]);
            t.overlapped_cells(range, 21, &mut fast);
            t.overlapped_cells_plain(range, 21, &mut plain);
            assert_eq!(fast, plain, "{tri:?}");
            // every vector path this CPU runs, whichever is active
            #[cfg(target_arch = "x86_64")]
            for isa in normalnet_isa::Isa::all_here() {
                let mut vector = vec![7];
                match isa {
                    // SAFETY: the CPU runs `isa`.
                    normalnet_isa::Isa::Avx2 => unsafe {
                        t.overlapped_cells_avx2(range, 21, &mut vector)
                    },
                    // SAFETY: as above.
                    normalnet_isa::Isa::Avx512 => unsafe {
                        t.overlapped_cells_avx512(range, 21, &mut vector)
                    },
                    _ => continue,
                }
                assert_eq!(vector, plain, "{isa}: {tri:?}");
            }
            hits += plain.len() - 1;
            // spans of at most 4 rows j: several columns per vector
            few += usize::from(range[1].1 - range[1].0 < 4);
            two += usize::from(range[1].1 - range[1].0 < 2);
        }
        assert!(hits > 100_000, "{hits}");
        assert!(few > 400, "{few} triangles of at most 4 rows");
        assert!(two > 200, "{two} triangles of at most 2 rows");
    }

    /// Review: a range beyond the grid made the vector path's room (the
    /// product of the spans) wrap and write past it.
    #[test]
    #[should_panic(expected = "outside a grid of side 1")]
    fn a_range_outside_the_grid_is_refused() {
        let t = CubeTester::new([[0.0, 0.0, 0.5], [1e9, 0.0, 0.5], [0.0, 1e9, 0.5]]);
        let huge = u32::MAX as usize;
        t.overlapped_cells([(0, huge), (0, huge), (0, 0)], 1, &mut Vec::new());
    }

    #[test]
    fn degenerate_triangle_is_a_segment() {
        let seg = [[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]];
        assert!(tri_box_overlap([0.0; 3], [0.1; 3], seg));
        assert!(!tri_box_overlap([0.0, 0.5, 0.0], [0.1; 3], seg));
        let point = [[0.0; 3]; 3];
        assert!(tri_box_overlap([0.05, 0.0, 0.0], [0.1; 3], point));
    }
}
