//! Ground-truth-guided GNF: NormalNet's training targets and the "oracle"
//! denoiser (Zhao et al., "NormalNet: Learning-based normal filtering for
//! mesh denoising", §4; SPEC §4 and §8). Built on the joint-bilateral pass of
//! Zhang et al. (2015), "Guided mesh normal filtering", doi:10.1111/cgf.12742.
//!
//! One pass: `n'_i = normalize( Σ_{j∈N(i)} a_j G_d(c_i, c_j) G_g(g_i, g_j) n_j )`
//! with `g` = the ground-truth face normals, `n` = the current (noisy) face
//! normals of the mesh, `N(i)` the radius-`2·d_s` neighbourhood of the current
//! mesh (as in [`crate::gnf::radius_neighbourhood`]) and `μ_d = σ_s =
//! sigma_s_over_ds · d_s` (the paper's `2·d_s` by default,
//! [`GT_GUIDED_SIGMA_S`]). [`gt_guided_normals`] evaluates it for several
//! `μ_g` at once (the six network outputs of SPEC §6) sharing the
//! neighbourhood and spatial weights.
//!
//! The oracle ([`gt_guided_gnf`]) repeats: one GT-guided pass on the current
//! mesh (neighbourhood and `d_s` rebuilt from it, as the training targets
//! are), then `N_v` vertex updates.

use crate::driver::{NormalFilter, Passes, run_filter};
use crate::error::{FilterError, check_range};
use crate::gnf::radius_neighbourhood;
use crate::stats::mean_centre_distance;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{FaceGeometry, Mesh, Progress, Topology};
use rayon::prelude::*;

/// Default spatial width `σ_s / d_s` of the training targets (the paper's
/// `μ_d ≈ 2·d_s`, SPEC §4).
pub const GT_GUIDED_SIGMA_S: f64 = 2.0;

/// Radius of the neighbourhood `N(i)` in units of `d_s` (as GNF).
pub const GT_GUIDED_RADIUS: f64 = 2.0;

/// One GT-guided GNF pass for every face and every `μ_g` in `mu_gs`:
/// face-major, entry `f * mu_gs.len() + k` is face f's unit filtered normal
/// for `mu_gs[k]` (len #F · |mu_gs|). `gt_normals`: one ground-truth unit (or
/// zero) normal per face (len #F). Parallel over faces; the result does not
/// depend on the thread count. A face whose sum vanishes gets a zero normal.
///
/// # Panics
/// If `gt_normals.len() != mesh.num_faces()` or `topology` belongs to another
/// mesh; [`try_gt_guided_normals`] returns an error instead.
pub fn gt_guided_normals(
    mesh: &Mesh,
    topology: &Topology,
    gt_normals: &[[f64; 3]],
    mu_gs: &[f64],
    sigma_s_over_ds: f64,
) -> Vec<[f64; 3]> {
    assert_eq!(
        gt_normals.len(),
        mesh.num_faces(),
        "one ground-truth normal per face"
    );
    assert_eq!(
        topology.num_faces(),
        mesh.num_faces(),
        "topology of another mesh"
    );
    let geometry = FaceGeometry::new(mesh);
    gt_guided_pass(topology, &geometry, gt_normals, mu_gs, sigma_s_over_ds)
}

/// [`gt_guided_normals`] with its inputs checked: lengths, finite GT normals,
/// every `μ_g > 0` and `sigma_s_over_ds > 0`.
pub fn try_gt_guided_normals(
    mesh: &Mesh,
    topology: &Topology,
    gt_normals: &[[f64; 3]],
    mu_gs: &[f64],
    sigma_s_over_ds: f64,
) -> Result<Vec<[f64; 3]>, FilterError> {
    check_inputs(mesh, topology, gt_normals)?;
    for &mu_g in mu_gs {
        check_range("mu_g", mu_g, Some(0.0), None, true)?;
    }
    check_range("sigma_s_over_ds", sigma_s_over_ds, Some(0.0), None, true)?;
    Ok(gt_guided_normals(
        mesh,
        topology,
        gt_normals,
        mu_gs,
        sigma_s_over_ds,
    ))
}

fn check_inputs(mesh: &Mesh, topology: &Topology, gt_normals: &[Vec3]) -> Result<(), FilterError> {
    if gt_normals.len() != mesh.num_faces() {
        return Err(FilterError::LengthMismatch {
            what: "ground-truth normals",
            expected: mesh.num_faces(),
            found: gt_normals.len(),
        });
    }
    if topology.num_faces() != mesh.num_faces() {
        return Err(FilterError::LengthMismatch {
            what: "topology",
            expected: mesh.num_faces(),
            found: topology.num_faces(),
        });
    }
    if let Some((face, value)) = gt_normals
        .iter()
        .enumerate()
        .find(|(_, n)| !n.iter().all(|c| c.is_finite()))
    {
        return Err(FilterError::NonFinite {
            what: "ground-truth normal",
            face,
            value: *value,
        });
    }
    Ok(())
}

/// [`gt_guided_normals`] for geometry already computed from the mesh
/// (`geometry = FaceGeometry::new(mesh)`): the same output, one geometry
/// pass fewer for a caller that needs the geometry anyway.
pub fn gt_guided_pass(
    topology: &Topology,
    geometry: &FaceGeometry,
    gt_normals: &[Vec3],
    mu_gs: &[f64],
    sigma_s_over_ds: f64,
) -> Vec<Vec3> {
    let k = mu_gs.len();
    let n_faces = topology.num_faces();
    let mut out = vec![[0.0; 3]; n_faces * k];
    if k == 0 {
        return out;
    }
    let d_s = mean_centre_distance(topology, &geometry.centres);
    let mu_d = sigma_s_over_ds * d_s;
    if !(mu_d > 0.0 && mu_d.is_finite()) {
        for (f, chunk) in out.chunks_mut(k).enumerate() {
            chunk.fill(geometry.normals[f]);
        }
        return out;
    }
    let neighbourhood = radius_neighbourhood(topology, &geometry.centres, GT_GUIDED_RADIUS * d_s);
    let inv_2mu_d2 = 1.0 / (2.0 * mu_d * mu_d);
    let inv_2mu_g2: Vec<f64> = mu_gs.iter().map(|m| 1.0 / (2.0 * m * m)).collect();
    out.par_chunks_mut(k)
        .enumerate()
        .with_min_len(128)
        .for_each_init(
            || vec![[0.0f64; 3]; k],
            |sums, (i, chunk)| {
                sums.fill([0.0; 3]);
                let c_i = geometry.centres[i];
                let g_i = gt_normals[i];
                for &j in neighbourhood.row(i) {
                    let j = j as usize;
                    let w_d = geometry.areas[j]
                        * (-vec3::dist2(c_i, geometry.centres[j]) * inv_2mu_d2).exp();
                    let dg2 = vec3::dist2(g_i, gt_normals[j]);
                    let n_j = geometry.normals[j];
                    for (s, inv) in sums.iter_mut().zip(&inv_2mu_g2) {
                        *s = vec3::add(*s, vec3::scale(n_j, w_d * (-dg2 * inv).exp()));
                    }
                }
                for (o, s) in chunk.iter_mut().zip(sums.iter()) {
                    *o = vec3::normalize_or_zero(*s);
                }
            },
        );
    out
}

/// Parameters of the GT-guided denoiser (the oracle of MEASURED.md).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GtGuidedGnfParams {
    /// μ_g: width of the range kernel on ground-truth normal differences;
    /// default 0.35 (NormalNet's default, SPEC §7).
    pub mu_g: f64,
    /// σ_s / d_s: spatial width in units of the current d_s; default 2.0
    /// ([`GT_GUIDED_SIGMA_S`]).
    pub sigma_s_over_ds: f64,
    /// N_f: filtering iterations; default 10 (SPEC §7).
    pub iterations: usize,
    /// N_v: vertex-update passes per iteration; default 20 (SPEC §7).
    pub vertex_iterations: usize,
}

impl Default for GtGuidedGnfParams {
    fn default() -> Self {
        GtGuidedGnfParams {
            mu_g: 0.35,
            sigma_s_over_ds: GT_GUIDED_SIGMA_S,
            iterations: 10,
            vertex_iterations: 20,
        }
    }
}

impl GtGuidedGnfParams {
    /// Checks every field; the error names the field.
    pub fn validate(&self) -> Result<(), FilterError> {
        check_range("mu_g", self.mu_g, Some(0.0), None, true)?;
        check_range(
            "sigma_s_over_ds",
            self.sigma_s_over_ds,
            Some(0.0),
            None,
            true,
        )?;
        Ok(())
    }
}

/// One GT-guided pass as a [`NormalFilter`] of the shared driver: the
/// guidance is fixed (the ground truth), the neighbourhood and `d_s` come
/// from the current geometry of each pass.
struct GtGuided<'a> {
    gt_normals: &'a [Vec3],
    mu_g: f64,
    sigma_s_over_ds: f64,
}

impl NormalFilter for GtGuided<'_> {
    fn pass(
        &mut self,
        topology: &Topology,
        geometry: &FaceGeometry,
        _normals: &[Vec3],
        out: &mut [Vec3],
    ) {
        let filtered = gt_guided_pass(
            topology,
            geometry,
            self.gt_normals,
            &[self.mu_g],
            self.sigma_s_over_ds,
        );
        out.copy_from_slice(&filtered);
    }
}

/// The oracle: denoises `mesh` with GT-guided GNF passes (guidance = the
/// ground-truth normals `gt_normals`, one per face), each followed by
/// `vertex_iterations` vertex updates, on the shared driver
/// ([`run_filter`], interleaved schedule, no fold guard: the reference).
pub fn gt_guided_gnf(
    mesh: &Mesh,
    gt_normals: &[Vec3],
    params: &GtGuidedGnfParams,
    progress: &dyn Progress,
) -> Result<Mesh, FilterError> {
    params.validate()?;
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    check_inputs(mesh, &topology, gt_normals)?;
    let mut filter = GtGuided {
        gt_normals,
        mu_g: params.mu_g,
        sigma_s_over_ds: params.sigma_s_over_ds,
    };
    let passes = Passes::interleaved([params.iterations, params.vertex_iterations], false, false);
    Ok(run_filter(
        &mut filter,
        mesh,
        &topology,
        passes,
        "GT-guided GNF",
        progress,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use normalnet_mesh::geometry::face_normals;

    /// A `k × k` grid with small deterministic bumps.
    fn bumpy_grid(k: usize) -> Mesh {
        Mesh::height_grid(k, |x, y| 0.05 * (((x * 7 + y * 13) % 5) as f64 - 2.0))
    }

    #[test]
    fn face_major_layout_and_unit_normals() {
        let m = bumpy_grid(6);
        let t = Topology::new(m.num_vertices(), &m.faces);
        let gt = vec![[0.0, 0.0, 1.0]; m.num_faces()];
        let mus = [0.25, 0.35, 0.5];
        let out = gt_guided_normals(&m, &t, &gt, &mus, GT_GUIDED_SIGMA_S);
        assert_eq!(out.len(), m.num_faces() * 3);
        for n in &out {
            assert!((vec3::norm(*n) - 1.0).abs() < 1e-12);
        }
        // Entry f*3+k is the single-μ result for mus[k].
        for (k, &mu) in mus.iter().enumerate() {
            let single = gt_guided_normals(&m, &t, &gt, &[mu], GT_GUIDED_SIGMA_S);
            for f in 0..m.num_faces() {
                assert_eq!(single[f], out[f * 3 + k]);
            }
        }
    }

    #[test]
    fn constant_guidance_smooths_towards_the_mean() {
        let m = bumpy_grid(8);
        let t = Topology::new(m.num_vertices(), &m.faces);
        let n = face_normals(&m);
        let gt = vec![[0.0, 0.0, 1.0]; m.num_faces()];
        let out = gt_guided_normals(&m, &t, &gt, &[0.3], GT_GUIDED_SIGMA_S);
        let err = |v: &[Vec3]| {
            v.iter()
                .map(|x| vec3::angle(*x, [0.0, 0.0, 1.0]))
                .sum::<f64>()
        };
        assert!(err(&out) < 0.5 * err(&n), "{} vs {}", err(&out), err(&n));
    }

    #[test]
    fn oracle_denoises_a_bumpy_plane() {
        let m = bumpy_grid(8);
        let gt = vec![[0.0, 0.0, 1.0]; m.num_faces()];
        let out = gt_guided_gnf(
            &m,
            &gt,
            &GtGuidedGnfParams::default(),
            &normalnet_mesh::NoProgress,
        )
        .unwrap();
        let n0 = face_normals(&m);
        let n1 = face_normals(&out);
        let err = |v: &[Vec3]| {
            v.iter()
                .map(|x| vec3::angle(*x, [0.0, 0.0, 1.0]))
                .sum::<f64>()
        };
        assert!(err(&n1) < 0.2 * err(&n0));
    }

    #[test]
    fn bad_inputs_are_errors() {
        let m = bumpy_grid(2);
        let t = Topology::new(m.num_vertices(), &m.faces);
        let e = try_gt_guided_normals(&m, &t, &[[0.0; 3]], &[0.3], 2.0).unwrap_err();
        assert!(e.to_string().contains("ground-truth normals"), "{e}");
        let gt = vec![[0.0, 0.0, 1.0]; m.num_faces()];
        let e = try_gt_guided_normals(&m, &t, &gt, &[-0.3], 2.0).unwrap_err();
        assert!(e.to_string().contains("mu_g"), "{e}");
        let mut bad = gt.clone();
        bad[3][1] = f64::NAN;
        let e = try_gt_guided_normals(&m, &t, &bad, &[0.3], 2.0).unwrap_err();
        assert!(e.to_string().contains("face 3"), "{e}");
    }
}
