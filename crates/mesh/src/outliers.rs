//! Stray vertices: vertices far outside the robust extent of a mesh, and
//! isolated spikes (issue 14). Raw scans often carry one vertex at 1e30 or a
//! few far away; a single such vertex inflates the mesh-wide statistics
//! (`l_e`, `d_s`, neighbourhood radii) and, through the vertex update, can
//! drag the rest of the mesh with it.
//!
//! Two tests, both O(#V + #F) (selection, not sorting; distances in
//! parallel with rayon), with the thresholds of [`OutlierParams`]:
//! - **far**: `|x_i − m| > distance_factor · q`, where `m` is the
//!   per-coordinate median of all vertices and `q` the `quantile`-th
//!   (default 99th) percentile of the distances `|x_k − m|`. Up to 1 % of
//!   the vertices may be anywhere without moving `m` or `q`.
//! - **spike**: every edge incident to the vertex is longer than
//!   `spike_factor · l_med`, `l_med` the median face-edge length (each face
//!   contributes its three edges). An isolated spike is a vertex pulled away
//!   from an otherwise fine surface: all its edges are long.
//!
//! The defaults keep a wide margin over what clean meshes show (the largest
//! ratios on `examples/` and the 48 meshes of `shared/data` tested: 1.11 q from the
//! median centre, a shortest incident edge of 9.3 l_med (c3d/ogre); printed by
//! `tests/outliers_data.rs`), so that a clean mesh reports nothing, while a
//! coarse CAD tessellation next to a fine one (a few long-edged corners)
//! stays below 50 l_med.
//!
//! [`without_vertices`] builds the mesh without flagged vertices (and their
//! faces) and the map back: `normalnet denoise --remove-outliers` writes
//! it, and the classical methods denoise it and put the result back
//! ([`denoise_around`]), so that an outlier and its faces stay in place.

use crate::mesh::Mesh;
use crate::vec3::{self, Vec3};
use rayon::prelude::*;

/// Thresholds of [`outlier_vertices`]; `Default` is what every command uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutlierParams {
    /// A vertex farther than `distance_factor · q` from the median centre is
    /// far; default 10.
    pub distance_factor: f64,
    /// The quantile of the distances to the median centre that gives the
    /// robust radius `q`; default 0.99.
    pub quantile: f64,
    /// A vertex whose incident edges are all longer than `spike_factor ·
    /// l_med` (median face-edge length) is a spike; default 50.
    pub spike_factor: f64,
}

impl Default for OutlierParams {
    fn default() -> Self {
        OutlierParams {
            distance_factor: 10.0,
            quantile: 0.99,
            spike_factor: 50.0,
        }
    }
}

/// The result of [`outlier_vertices`].
#[derive(Clone, Debug, PartialEq)]
pub struct Outliers {
    /// one flag per vertex (len #V): far or spike
    pub mask: Vec<bool>,
    /// flagged vertices, increasing
    pub vertices: Vec<u32>,
    /// how many are far from the median centre
    pub far: usize,
    /// how many are spikes (and not far)
    pub spikes: usize,
    /// the per-coordinate median of the vertices
    pub centre: Vec3,
    /// the robust radius `q` (the quantile distance to `centre`)
    pub robust_radius: f64,
    /// the median face-edge length `l_med`
    pub median_edge_length: f64,
}

impl Outliers {
    /// Number of flagged vertices.
    pub fn count(&self) -> usize {
        self.vertices.len()
    }

    /// One line for a warning, e.g. "1 outlier vertex (1 far from the
    /// mesh, 0 isolated spikes; first: vertex 17 at 1e30 from the median
    /// centre, robust radius 0.92)"; `None` when there is none.
    pub fn describe(&self, positions: &[Vec3]) -> Option<String> {
        let &first = self.vertices.first()?;
        let n = self.count();
        let d = vec3::dist2(positions[first as usize], self.centre).sqrt();
        Some(format!(
            "{n} outlier vertex{} ({} far from the mesh, {} isolated spike{}; first: vertex {first} \
             at {d:.3e} from the median centre, robust radius {:.3e})",
            if n == 1 { "" } else { "es" },
            self.far,
            self.spikes,
            if self.spikes == 1 { "" } else { "s" },
            self.robust_radius
        ))
    }
}

/// The `q`-quantile (0 ≤ q ≤ 1, nearest rank, `floor(q·(n−1))`) of
/// `values`, reordering them; 0 when empty. O(n).
fn quantile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let k =
        ((q.clamp(0.0, 1.0) * (values.len() - 1) as f64).floor() as usize).min(values.len() - 1);
    *values.select_nth_unstable_by(k, f64::total_cmp).1
}

/// The vertices of `mesh` far outside its robust extent or isolated as
/// spikes (see the module docs), with the statistics used. Deterministic,
/// O(#V + #F). A mesh of fewer than 4 vertices reports none.
pub fn outlier_vertices(mesh: &Mesh, params: &OutlierParams) -> Outliers {
    let n = mesh.num_vertices();
    let mut scratch: Vec<f64> = Vec::with_capacity(n.max(3 * mesh.num_faces()));
    let mut centre = [0.0; 3];
    for (k, c) in centre.iter_mut().enumerate() {
        scratch.clear();
        scratch.extend(mesh.positions.iter().map(|p| p[k]));
        *c = quantile(&mut scratch, 0.5);
    }
    let dist: Vec<f64> = mesh
        .positions
        .par_iter()
        .map(|&p| vec3::dist2(p, centre).sqrt())
        .collect();
    scratch.clear();
    scratch.extend_from_slice(&dist);
    let robust_radius = quantile(&mut scratch, params.quantile);

    // Shortest incident edge per vertex (infinite without faces).
    let mut shortest = vec![f64::INFINITY; n];
    scratch.clear();
    for t in &mesh.faces {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let l = vec3::dist2(mesh.positions[a], mesh.positions[b]).sqrt();
            scratch.push(l);
            shortest[a] = shortest[a].min(l);
            shortest[b] = shortest[b].min(l);
        }
    }
    let median_edge_length = quantile(&mut scratch, 0.5);

    let mut mask = vec![false; n];
    let (mut far, mut spikes) = (0, 0);
    if n >= 4 {
        let far_limit = params.distance_factor * robust_radius;
        let spike_limit = params.spike_factor * median_edge_length;
        for i in 0..n {
            if robust_radius > 0.0 && dist[i] > far_limit {
                mask[i] = true;
                far += 1;
            } else if median_edge_length > 0.0
                && shortest[i].is_finite()
                && shortest[i] > spike_limit
            {
                mask[i] = true;
                spikes += 1;
            }
        }
    }
    let vertices = (0..n as u32).filter(|&i| mask[i as usize]).collect();
    Outliers {
        mask,
        vertices,
        far,
        spikes,
        centre,
        robust_radius,
        median_edge_length,
    }
}

/// `mesh` without the vertices flagged in `remove` (len #V) and without
/// every face that uses one, vertex and face order otherwise kept, with the
/// old index of each kept vertex (len #V of the new mesh). Vertices left
/// without faces stay (unreferenced). `None` when no face is left.
///
/// # Panics
/// If `remove.len() != mesh.num_vertices()`.
pub fn without_vertices(mesh: &Mesh, remove: &[bool]) -> Option<(Mesh, Vec<u32>)> {
    assert_eq!(remove.len(), mesh.num_vertices(), "one flag per vertex");
    let mut new_index = vec![u32::MAX; mesh.num_vertices()];
    let mut kept = Vec::with_capacity(mesh.num_vertices());
    for (i, &r) in remove.iter().enumerate() {
        if !r {
            new_index[i] = kept.len() as u32;
            kept.push(i as u32);
        }
    }
    let faces: Vec<[u32; 3]> = mesh
        .faces
        .iter()
        .filter(|t| t.iter().all(|&v| !remove[v as usize]))
        .map(|t| t.map(|v| new_index[v as usize]))
        .collect();
    let positions = kept.iter().map(|&i| mesh.positions[i as usize]).collect();
    let inner = Mesh::new(positions, faces).ok()?;
    Some((inner, kept))
}

/// Runs `denoise` on `mesh` without its [`outlier_vertices`] (default
/// thresholds) and puts the result back: the outliers, and the vertices
/// only they connect to, keep their positions; every face touching an
/// outlier is left out of the denoising (its other vertices move only
/// through their other faces). Without outliers, or when no face would be
/// left, `denoise` gets `mesh` itself.
///
/// # Errors
/// Whatever `denoise` returns.
///
/// # Panics
/// If `denoise` returns a mesh with another vertex count than it was given.
pub fn denoise_around<E>(
    mesh: &Mesh,
    denoise: impl FnOnce(&Mesh) -> Result<Mesh, E>,
) -> Result<Mesh, E> {
    let outliers = outlier_vertices(mesh, &OutlierParams::default());
    if outliers.count() == 0 {
        return denoise(mesh);
    }
    let Some((inner, kept)) = without_vertices(mesh, &outliers.mask) else {
        return denoise(mesh);
    };
    let out = denoise(&inner)?;
    assert_eq!(out.num_vertices(), inner.num_vertices(), "same vertices");
    let mut positions = mesh.positions.clone();
    for (p, &old) in out.positions.iter().zip(&kept) {
        positions[old as usize] = *p;
    }
    Ok(mesh.with_positions(positions))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `k × k` grid in z = 0 with a gentle bump, unit spacing.
    fn grid(k: usize) -> Mesh {
        Mesh::height_grid(k, |x, y| {
            0.1 * ((x as f64 * 0.7).sin() + (y as f64 * 0.5).cos())
        })
    }

    #[test]
    fn a_clean_grid_has_none() {
        let o = outlier_vertices(&grid(20), &OutlierParams::default());
        assert_eq!(o.count(), 0, "{o:?}");
        assert!((o.median_edge_length - 1.0).abs() < 0.05);
        assert!(o.describe(&grid(20).positions).is_none());
    }

    #[test]
    fn finds_a_vertex_at_1e30_and_far_and_spike_vertices() {
        let base = grid(20);
        for (v, p) in [
            (17usize, [1e30, 0.0, 0.0]),
            (200, [0.0, -3e7, 1e7]),
            (221, [10.0, 10.0, 120.0]), // a spike: inside 10× the radius, edges ~120
        ] {
            let mut m = base.clone();
            m.positions[v] = p;
            let o = outlier_vertices(&m, &OutlierParams::default());
            assert_eq!(o.vertices, vec![v as u32], "{p:?}");
            let text = o.describe(&m.positions).unwrap();
            assert!(text.contains(&format!("vertex {v}")), "{text}");
        }
        let mut m = base.clone();
        m.positions[221] = [10.0, 10.0, 120.0];
        let o = outlier_vertices(&m, &OutlierParams::default());
        assert_eq!((o.far, o.spikes), (0, 1));
    }

    #[test]
    fn without_vertices_drops_their_faces_and_keeps_order() {
        let m = grid(3);
        let mut remove = vec![false; m.num_vertices()];
        remove[5] = true;
        let (inner, kept) = without_vertices(&m, &remove).unwrap();
        assert_eq!(inner.num_vertices(), m.num_vertices() - 1);
        assert_eq!(kept.len(), inner.num_vertices());
        assert!(!kept.contains(&5));
        let expected: Vec<[u32; 3]> = m
            .faces
            .iter()
            .filter(|t| !t.contains(&5))
            .copied()
            .collect();
        let back: Vec<[u32; 3]> = inner
            .faces
            .iter()
            .map(|t| t.map(|v| kept[v as usize]))
            .collect();
        assert_eq!(back, expected);
        // Removing every vertex of the only face leaves nothing.
        let one = Mesh::new(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        )
        .unwrap();
        assert!(without_vertices(&one, &[true, false, false]).is_none());
    }

    #[test]
    fn denoise_around_keeps_the_outlier_and_hides_it_from_the_method() {
        let mut m = grid(10);
        m.positions[40] = [1e30, 1e30, 0.0];
        let out = denoise_around(&m, |inner| -> Result<Mesh, ()> {
            assert!(inner.positions.iter().all(|p| p[0] < 1e3), "outlier hidden");
            // A "method" that lifts every vertex it sees by 1.
            Ok(inner.with_positions(
                inner
                    .positions
                    .iter()
                    .map(|p| [p[0], p[1], p[2] + 1.0])
                    .collect(),
            ))
        })
        .unwrap();
        assert_eq!(out.positions[40], [1e30, 1e30, 0.0]);
        for (i, (a, b)) in out.positions.iter().zip(&m.positions).enumerate() {
            if i != 40 {
                assert_eq!(a[2], b[2] + 1.0, "vertex {i}");
            }
        }
        assert_eq!(out.faces, m.faces);
    }
}
