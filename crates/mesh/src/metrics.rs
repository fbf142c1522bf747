//! Error metrics of a result against ground truth (SPEC §3), defined exactly
//! as the independent Python checker (`shared/tools/eval/metrics.py`):
//!
//! - `E_a`: mean over faces of the angle between result and GT unit face
//!   normals, in degrees, computed as `atan2(|n_g × n_r|, n_g · n_r)`; a face
//!   degenerate in either mesh counts as 90° (zero normal, OpenMesh
//!   convention). Also the MSAE (mean squared angle, rad²) of Sun et al. 2007,
//!   the RMS angle, median, maximum and the fraction of faces over 30°.
//! - `E_v` (Zheng et al. 2011, "Bilateral normal filtering"):
//!   `sqrt( Σ_i Σ_{j∈F(i)} A_j · d(x_i, T)² / (3 Σ_k A_k) )`, `x_i` result
//!   vertices, `A_j` result face areas, `d` the exact distance to the GT
//!   surface ([`crate::bvh`]). Reported with `E_v / l_e(GT)` and
//!   `E_v / bbox diagonal(GT)`.
//! - `flipped_faces` (issue 14): result faces whose unit normal opposes the
//!   ground truth's (`n_g · n_r < 0`, an angle over 90°); degenerate faces
//!   are not counted (they have no direction).
//! - distances: area-weighted mean (same weights as `E_v`), one-sided maxima
//!   over the vertices used by faces (result → GT, GT → result) and their
//!   maximum, the vertex-sampled symmetric Hausdorff distance.
//!
//! Per-vertex distances are computed in parallel; every sum is sequential in
//! index order, so the numbers do not depend on the thread count.

use crate::bvh::{Closest, TriangleBvh, closest_point_on_triangle};
use crate::error::MeshError;
use crate::geometry::{face_areas, face_normals};
use crate::mesh::Mesh;
use crate::progress::{NoProgress, Progress};
use crate::scale::{cap_exponent, largest_coordinate, mul_pow2, pow2_scaled, working_exponent};
use crate::vec3::{self, Vec3};
use rayon::prelude::*;

/// All metrics of one result against its ground truth.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Metrics {
    /// `E_a`: mean face-normal angle in degrees
    pub e_a_deg: f64,
    /// mean squared face-normal angle in rad² (MSAE, Sun et al. 2007)
    pub msae_rad2: f64,
    /// sqrt of the mean squared angle in degrees
    pub rms_angle_deg: f64,
    /// median face-normal angle in degrees
    pub median_angle_deg: f64,
    /// largest face-normal angle in degrees
    pub max_angle_deg: f64,
    /// fraction of faces whose angle exceeds 30°
    pub frac_faces_over_30deg: f64,
    /// number of degenerate (zero-normal) result faces
    pub degenerate_faces_result: usize,
    /// result faces folded over: normal opposed to the ground truth's
    /// (`n_g · n_r < 0`); degenerate faces not counted
    pub flipped_faces: usize,
    /// `E_v`: area-weighted RMS distance of result vertices to the GT surface
    pub e_v: f64,
    /// `E_v / l_e(GT)`
    pub e_v_over_le: f64,
    /// `E_v` divided by the GT bounding-box diagonal
    pub e_v_over_bbox_diag: f64,
    /// area-weighted mean distance of result vertices to the GT surface
    pub mean_dist: f64,
    /// largest distance of a result vertex to the GT surface
    pub max_dist_result_to_gt: f64,
    /// largest distance of a GT vertex to the result surface
    pub max_dist_gt_to_result: f64,
    /// vertex-sampled symmetric Hausdorff distance (max of the two above)
    pub hausdorff: f64,
    /// `l_e(GT)`: mean GT edge length
    pub gt_mean_edge_length: f64,
    /// GT bounding-box diagonal (vertices used by faces)
    pub gt_bbox_diag: f64,
    /// GT vertex count
    pub n_vertices_gt: usize,
    /// GT face count
    pub n_faces_gt: usize,
    /// result vertex count
    pub n_vertices_result: usize,
    /// result face count
    pub n_faces_result: usize,
    /// whether both meshes have identical face index lists
    pub faces_identical: bool,
}

/// The angle in degrees between the normals of each face of `result` and
/// the same face of `gt` (90° where either is degenerate), measured in the
/// same frame as [`compare`] (a pair at an extreme scale scaled by a power
/// of two: angles do not change with the unit).
///
/// # Errors
/// [`MeshError::Mismatch`] when the face counts differ.
pub fn per_face_angle_errors(gt: &Mesh, result: &Mesh) -> Result<Vec<f64>, MeshError> {
    check_counts(gt, result)?;
    // angles do not change with the unit: measured where the normals are safe
    let (gt, result) = measuring_frame(gt, result);
    let ng = face_normals(&gt);
    let nr = face_normals(&result);
    Ok(ng
        .par_iter()
        .zip(nr.par_iter())
        .map(|(&a, &b)| face_angle(a, b).to_degrees())
        .collect())
}

/// The largest coordinate exponent the metrics scale a pair to (`2^240`):
/// `L⁴` of every face (the squared norm of an edge cross product) stays
/// finite, also for a stray vertex far from the body.
const MEASURING_MAX_EXPONENT: i32 = 240;

/// The `k` that `gt` and `result` are measured at (both times `2^k`, so
/// that distances between them scale with it), `None` to measure them as
/// they are: the ground truth's [`working_exponent`] (its robust radius
/// sets the unit: the relative metrics are in its units, and a result
/// that exploded must not push the ground truth out of range), capped so
/// that no coordinate of either mesh exceeds `2^240`.
fn measuring_exponent(gt: &Mesh, result: &Mesh) -> Option<i32> {
    let k = working_exponent(gt, MEASURING_MAX_EXPONENT)?;
    let k = cap_exponent(
        k,
        largest_coordinate(&result.positions),
        MEASURING_MAX_EXPONENT,
    );
    (k != 0).then_some(k)
}

/// `gt` and `result` scaled by [`measuring_exponent`] (borrowed as they are
/// when there is none).
fn measuring_frame<'a>(
    gt: &'a Mesh,
    result: &'a Mesh,
) -> (std::borrow::Cow<'a, Mesh>, std::borrow::Cow<'a, Mesh>) {
    use std::borrow::Cow;
    match measuring_exponent(gt, result) {
        Some(k) => {
            let scaled = |m: &Mesh| Cow::Owned(m.with_positions(pow2_scaled(&m.positions, k)));
            (scaled(gt), scaled(result))
        }
        None => (Cow::Borrowed(gt), Cow::Borrowed(result)),
    }
}

/// Angle in radians between two unit (or zero) normals; π/2 when either is zero.
#[inline]
fn face_angle(a: Vec3, b: Vec3) -> f64 {
    if vec3::norm2(a) == 0.0 || vec3::norm2(b) == 0.0 {
        return std::f64::consts::FRAC_PI_2;
    }
    vec3::norm(vec3::cross(a, b)).atan2(vec3::dot(a, b))
}

fn check_counts(gt: &Mesh, result: &Mesh) -> Result<(), MeshError> {
    if gt.num_faces() != result.num_faces() {
        return Err(MeshError::Mismatch(format!(
            "face counts differ (ground truth {} vs result {}); E_a compares faces one by one \
             and needs identical connectivity",
            gt.num_faces(),
            result.num_faces()
        )));
    }
    Ok(())
}

/// All metrics of `result` against `gt` (see the module docs).
///
/// A result of zero total area (every face degenerate) has no area weights:
/// `E_v` and the mean distance then weight its used vertices equally.
///
/// When the ground truth's robust radius (`crate::scale::robust_radius`:
/// a stray vertex does not set the unit, issue 39) lies outside
/// [`crate::scale::SAFE_DIAGONAL_MIN`] ..= [`crate::scale::SAFE_DIAGONAL_MAX`],
/// both meshes are measured scaled by the same exact power of two (that
/// radius ~1, no coordinate beyond `2^240`) and the distances and lengths
/// are scaled back: a pair at 1e-80 gets its true `E_a`, not 90° for every
/// face, also with a stray vertex near 1.
///
/// # Errors
/// [`MeshError::Mismatch`] when the face counts differ;
/// [`MeshError::InvalidParameter`] when the ground truth has zero mean edge
/// length or a zero bounding box (nothing to measure against).
pub fn compare(gt: &Mesh, result: &Mesh) -> Result<Metrics, MeshError> {
    compare_with_progress(gt, result, &NoProgress)
}

/// [`compare`] reporting progress (stages: normals, BVH, distances).
///
/// # Errors
/// As [`compare`].
pub fn compare_with_progress(
    gt: &Mesh,
    result: &Mesh,
    progress: &dyn Progress,
) -> Result<Metrics, MeshError> {
    check_counts(gt, result)?;
    if let Some(k) = measuring_exponent(gt, result) {
        let scaled = |m: &Mesh| m.with_positions(pow2_scaled(&m.positions, k));
        let m = compare_in_frame(&scaled(gt), &scaled(result), progress)?;
        let back = |x: f64| mul_pow2(x, -k);
        return Ok(Metrics {
            e_v: back(m.e_v),
            mean_dist: back(m.mean_dist),
            max_dist_result_to_gt: back(m.max_dist_result_to_gt),
            max_dist_gt_to_result: back(m.max_dist_gt_to_result),
            hausdorff: back(m.hausdorff),
            gt_mean_edge_length: back(m.gt_mean_edge_length),
            gt_bbox_diag: back(m.gt_bbox_diag),
            ..m
        });
    }
    compare_in_frame(gt, result, progress)
}

/// [`compare_with_progress`] in the frame the meshes are given in.
fn compare_in_frame(
    gt: &Mesh,
    result: &Mesh,
    progress: &dyn Progress,
) -> Result<Metrics, MeshError> {
    let nf = gt.num_faces();
    progress.start("metrics", 4);
    let (theta, flipped_faces) = {
        let ng = face_normals(gt);
        let nr = face_normals(result);
        let theta: Vec<f64> = ng
            .par_iter()
            .zip(nr.par_iter())
            .map(|(&a, &b)| face_angle(a, b))
            .collect();
        let flipped = ng
            .par_iter()
            .zip(nr.par_iter())
            .filter(|(a, b)| vec3::dot(**a, **b) < 0.0)
            .count();
        (theta, flipped)
    };
    let degenerate_faces_result = crate::geometry::count_degenerate_faces(result);
    let deg: Vec<f64> = theta.iter().map(|t| t.to_degrees()).collect();
    let n = nf as f64;
    let e_a_deg = deg.iter().sum::<f64>() / n;
    let msae_rad2 = theta.iter().map(|t| t * t).sum::<f64>() / n;
    let rms_angle_deg = (deg.iter().map(|t| t * t).sum::<f64>() / n).sqrt();
    let max_angle_deg = deg.iter().copied().fold(0.0, f64::max);
    let frac_faces_over_30deg = deg.iter().filter(|&&t| t > 30.0).count() as f64 / n;
    let median_angle_deg = median(deg);
    progress.advance(1);

    // Distances result -> GT at the result vertices used by faces, then
    // GT -> result. Same face count: face `f` of the other mesh is a good
    // first guess for the vertices of face `f` (same answer, less search).
    let used_g = used_vertices(gt);
    let (bvh_g, bvh_r) = rayon::join(|| TriangleBvh::new(gt), || TriangleBvh::new(result));
    progress.advance(1);
    let d = hinted_distances(result, gt, &bvh_g);
    progress.advance(1);
    let dg = hinted_distances(gt, result, &bvh_r);
    progress.advance(1);

    let areas = face_areas(result);
    let mut w = vec![0.0; result.num_vertices()];
    for k in 0..3 {
        for (t, a) in result.faces.iter().zip(&areas) {
            w[t[k] as usize] += a;
        }
    }
    let tot: f64 = areas.iter().sum();
    let (mut s2, mut s1) = (0.0, 0.0);
    for (wi, di) in w.iter().zip(&d) {
        s2 += wi * di * di;
        s1 += wi * di;
    }
    let (e_v, mean_dist) = if tot > 0.0 {
        ((s2 / (3.0 * tot)).sqrt(), s1 / (3.0 * tot))
    } else {
        // Zero total result area: the area weights are all zero, so fall back
        // to equal weights over the used result vertices rather than 0/0.
        let used = d.len() - count_unused(result);
        let (s2, s1) = d.iter().fold((0.0, 0.0), |(a, b), x| (a + x * x, b + x));
        ((s2 / used as f64).sqrt(), s1 / used as f64)
    };
    let max_r = d.iter().copied().fold(0.0, f64::max);
    let max_g = dg.iter().copied().fold(0.0, f64::max);
    let le = unique_edge_mean_length(gt);
    let diag = bbox_diag(gt, &used_g);
    if !(le > 0.0 && diag > 0.0) {
        return Err(MeshError::InvalidParameter {
            name: "ground truth",
            message: format!(
                "degenerate ground truth (mean edge length {le}, bounding-box diagonal {diag}): \
                 E_v / l_e is undefined"
            ),
        });
    }
    progress.finish();
    Ok(Metrics {
        e_a_deg,
        msae_rad2,
        rms_angle_deg,
        median_angle_deg,
        max_angle_deg,
        frac_faces_over_30deg,
        degenerate_faces_result,
        flipped_faces,
        e_v,
        e_v_over_le: e_v / le,
        e_v_over_bbox_diag: e_v / diag,
        mean_dist,
        max_dist_result_to_gt: max_r,
        max_dist_gt_to_result: max_g,
        hausdorff: max_r.max(max_g),
        gt_mean_edge_length: le,
        gt_bbox_diag: diag,
        n_vertices_gt: gt.num_vertices(),
        n_faces_gt: nf,
        n_vertices_result: result.num_vertices(),
        n_faces_result: result.num_faces(),
        faces_identical: gt.faces == result.faces,
    })
}

/// Distance of every vertex of `from` used by a face to the surface of `to`
/// (0 for unused vertices), starting each search at the face of `to` with the
/// index of the vertex's first face in `from` (same face counts).
fn hinted_distances(from: &Mesh, to: &Mesh, bvh: &TriangleBvh) -> Vec<f64> {
    let mut first = vec![u32::MAX; from.num_vertices()];
    for (f, t) in from.faces.iter().enumerate().rev() {
        for &v in t {
            first[v as usize] = f as u32;
        }
    }
    from.positions
        .par_iter()
        .zip(first.par_iter())
        .map(|(&p, &f)| {
            if f == u32::MAX {
                return 0.0;
            }
            let [a, b, c] = to.corners(f as usize);
            let q = closest_point_on_triangle(p, a, b, c);
            let start = Closest {
                dist2: vec3::dist2(q, p),
                face: f,
                point: q,
            };
            bvh.closest_from(p, start).map_or(0.0, |c| c.dist2.sqrt())
        })
        .collect()
}

/// Exact distances from `points` to the surface of `mesh`, in parallel.
pub fn point_surface_distances(points: &[Vec3], mesh: &Mesh) -> Vec<f64> {
    TriangleBvh::new(mesh).distances(points)
}

/// `l_e` (mean length over unique edges) without building a [`crate::Topology`]:
/// the same edges as `Topology::edges`, summed in the same sorted order.
pub(crate) fn unique_edge_mean_length(m: &Mesh) -> f64 {
    let mut keys: Vec<u64> = Vec::with_capacity(3 * m.num_faces());
    for t in &m.faces {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let (a, b) = if a < b { (a, b) } else { (b, a) };
            keys.push(((a as u64) << 32) | b as u64);
        }
    }
    keys.par_sort_unstable();
    keys.dedup();
    let total: f64 = keys
        .iter()
        .map(|&k| {
            vec3::dist2(
                m.positions[(k >> 32) as usize],
                m.positions[k as u32 as usize],
            )
            .sqrt()
        })
        .sum();
    total / keys.len() as f64
}

/// Number of vertices of `m` used by no face.
fn count_unused(m: &Mesh) -> usize {
    used_vertices(m).iter().filter(|u| !**u).count()
}

fn used_vertices(m: &Mesh) -> Vec<bool> {
    let mut used = vec![false; m.num_vertices()];
    for t in &m.faces {
        for &v in t {
            used[v as usize] = true;
        }
    }
    used
}

fn bbox_diag(m: &Mesh, used: &[bool]) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for (p, _) in m.positions.iter().zip(used).filter(|(_, u)| **u) {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    vec3::norm(vec3::sub(hi, lo))
}

/// numpy's median: mean of the two middle values for an even count.
fn median(mut v: Vec<f64>) -> f64 {
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    v.sort_unstable_by(f64::total_cmp);
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_meshes_have_zero_error() {
        let m = Mesh::tetrahedron();
        let r = compare(&m, &m).unwrap();
        assert_eq!(r.e_a_deg, 0.0);
        assert_eq!(r.e_v, 0.0);
        assert_eq!(r.hausdorff, 0.0);
        assert_eq!(r.degenerate_faces_result, 0);
        assert_eq!(r.flipped_faces, 0);
        assert!(r.faces_identical);
    }

    #[test]
    fn translated_mesh_and_flipped_face() {
        let m = Mesh::tetrahedron();
        // Shift every vertex by 0.1 along z: face normals unchanged, E_v > 0.
        let shifted = m.with_positions(
            m.positions
                .iter()
                .map(|p| [p[0], p[1], p[2] + 0.1])
                .collect(),
        );
        let r = compare(&m, &shifted).unwrap();
        assert!(r.e_a_deg < 1e-12, "{}", r.e_a_deg);
        assert!(r.e_v > 0.0 && r.e_v <= 0.1 + 1e-15, "{}", r.e_v);
        // Flip one face: its angle is 180°, the mean 45°.
        let mut flipped = m.clone();
        flipped.faces[0] = [0, 1, 2];
        let a = per_face_angle_errors(&m, &flipped).unwrap();
        assert!((a[0] - 180.0).abs() < 1e-12 && a[1] == 0.0);
        let r = compare(&m, &flipped).unwrap();
        assert!((r.e_a_deg - 45.0).abs() < 1e-12);
        assert_eq!(r.flipped_faces, 1);
        assert!(!r.faces_identical);
    }

    /// The audit's extreme scales: a pair times 1e±80 gets the unscaled
    /// angles and scaled distances, not 90° for every face.
    #[test]
    fn extreme_scales_give_the_unscaled_metrics_scaled() {
        let m = Mesh::tetrahedron();
        let moved = m.with_positions(
            m.positions
                .iter()
                .enumerate()
                .map(|(i, p)| [p[0] + 0.01 * i as f64, p[1], p[2] - 0.02])
                .collect(),
        );
        let r = compare(&m, &moved).unwrap();
        for s in [1e-80, 1e80, 1e-200, 1e200] {
            let scaled =
                |x: &Mesh| x.with_positions(x.positions.iter().map(|p| p.map(|c| c * s)).collect());
            let q = compare(&scaled(&m), &scaled(&moved)).unwrap();
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
            assert!(
                close(q.e_a_deg, r.e_a_deg),
                "{s:e}: {} {}",
                q.e_a_deg,
                r.e_a_deg
            );
            assert_eq!(q.degenerate_faces_result, 0);
            for (a, b) in [
                (q.e_v, r.e_v),
                (q.hausdorff, r.hausdorff),
                (q.gt_mean_edge_length, r.gt_mean_edge_length),
                (q.gt_bbox_diag, r.gt_bbox_diag),
            ] {
                assert!(close(a, b * s), "{s:e}: {a:e} vs {:e}", b * s);
            }
            assert!(close(q.e_v_over_le, r.e_v_over_le));
        }
    }

    /// Issue 39: a ground truth of extent 1e-80 with one stray vertex near
    /// 1 kept its bounding box in range and was measured as it was: every
    /// face of the body read as degenerate (90°), in `compare` and in the
    /// per-face errors that `render --gt` colours. Now the pair is measured
    /// scaled by 2^240 (the body's unit, capped so that the stray vertex
    /// stays at most 2^240): exactly the metrics of the pair given at that
    /// scale, its distances scaled back.
    #[test]
    fn issue_39_a_tiny_ground_truth_with_a_stray_vertex_is_rescaled() {
        let body = Mesh::uv_sphere(8, 12);
        let tiny = |m: &Mesh| {
            let mut p = pow2_scaled(&m.positions, -266);
            p[5] = [1.0, 0.0, 0.0];
            m.with_positions(p)
        };
        let moved = body.with_positions(
            body.positions
                .iter()
                .enumerate()
                .map(|(i, p)| [p[0] + 0.01 * (i % 3) as f64, p[1], p[2]])
                .collect(),
        );
        let (gt, result) = (tiny(&body), tiny(&moved));
        let up = |m: &Mesh| m.with_positions(pow2_scaled(&m.positions, 240));
        let (gt_up, result_up) = (up(&gt), up(&result));
        let q = compare(&gt, &result).unwrap();
        let r = compare(&gt_up, &result_up).unwrap();
        assert_eq!(q.e_a_deg, r.e_a_deg);
        assert!(q.e_a_deg < 10.0, "{}", q.e_a_deg);
        assert_eq!(q.degenerate_faces_result, 0);
        assert_eq!(q.e_v, mul_pow2(r.e_v, -240));
        assert_eq!(q.hausdorff, mul_pow2(r.hausdorff, -240));
        assert_eq!(q.e_v_over_le, r.e_v_over_le);
        let errors = per_face_angle_errors(&gt, &result).unwrap();
        assert_eq!(errors, per_face_angle_errors(&gt_up, &result_up).unwrap());
        let body_faces: Vec<f64> = (errors.iter().zip(&gt.faces))
            .filter(|(_, f)| !f.contains(&5))
            .map(|(e, _)| *e)
            .collect();
        assert!(body_faces.len() > 150);
        assert!(body_faces.iter().all(|e| *e < 45.0), "{errors:?}");
    }

    #[test]
    fn degenerate_face_counts_ninety_degrees() {
        let m = Mesh::tetrahedron();
        let mut p = m.positions.clone();
        p[3] = [0.5, 0.5, 0.0]; // faces 1, 2, 3 stay fine, but make 3 collapse:
        p[3] = [1.0, 0.0, 0.0]; // vertex 3 onto vertex 1: face [0,1,3] degenerate
        let r = compare(&m, &m.with_positions(p)).unwrap();
        assert_eq!(r.degenerate_faces_result, 2); // [0,1,3] and [1,2,3]
        assert!(r.max_angle_deg >= 90.0);
        // Degenerate faces have no direction: not counted as flipped.
        assert_eq!(r.flipped_faces, 0);
    }

    #[test]
    fn different_face_counts_are_refused() {
        let m = Mesh::tetrahedron();
        let small = Mesh::new(m.positions.clone(), m.faces[..3].to_vec()).unwrap();
        let e = compare(&m, &small).unwrap_err().to_string();
        assert!(
            e.contains("face counts differ (ground truth 4 vs result 3)"),
            "{e}"
        );
        assert!(per_face_angle_errors(&m, &small).is_err());
    }

    #[test]
    fn collapsed_result_and_degenerate_gt_give_numbers_or_errors_not_nan() {
        let m = Mesh::tetrahedron();
        let collapsed = m.with_positions(vec![[0.0; 3]; 4]);
        let r = compare(&m, &collapsed).unwrap();
        assert!(r.e_v.is_finite() && r.e_v == 0.0, "{}", r.e_v); // (0,0,0) lies on the GT
        assert_eq!(r.e_a_deg, 90.0);
        assert!(r.max_dist_gt_to_result > 0.0);
        let e = compare(&collapsed, &m).unwrap_err().to_string();
        assert!(e.contains("degenerate ground truth"), "{e}");
    }

    #[test]
    fn edge_length_matches_topology() {
        let m = Mesh::tetrahedron();
        let t = crate::Topology::new(4, &m.faces);
        let a = unique_edge_mean_length(&m);
        let b = crate::geometry::mean_edge_length(&m, &t);
        assert!((a - b).abs() <= 1e-15 * b, "{a} {b}");
    }

    #[test]
    fn median_like_numpy() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
    }
}
