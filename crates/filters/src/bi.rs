//! Bi-normal filtering (BI): Wei, Yu, Pang, Wang, Qin, Liu, Heng (2015),
//! "Bi-normal filtering for mesh denoising", IEEE TVCG 21(1):43–55,
//! doi:10.1109/TVCG.2014.2326872; SPEC §9 (the paper's comparison set).
//!
//! The paper filters two normal fields, the face normals and the vertex
//! normals, and lets the vertex-normal field decide which faces belong
//! together (features are where the vertex normals of the two sides
//! disagree). This file implements that core *bi-normal* scheme on the
//! crate's normal-filter + vertex-update skeleton; one normal pass is:
//!
//! 1. **Vertex-normal filtering, feature-aware (per corner).** At vertex `v`
//!    of face `i` the corner normal is
//!    `m_{i,v} = normalize( Σ_{j∈F(v)} a_j W_n(|n_i − n_j|) n_j )`,
//!    `W_n(x) = exp(−x²/(2σ_n²))`: the area-weighted vertex normal of `v`
//!    restricted (softly) to the faces on face i's side of a feature, so a
//!    vertex on a sharp edge gets one normal per side instead of a blurred
//!    average.
//! 2. **Vertex-normal guidance of the face normals.** `g_i =
//!    normalize(m_{i,v0} + m_{i,v1} + m_{i,v2})`, the face normal
//!    re-estimated from the filtered vertex-normal field.
//! 3. **Face-normal bilateral filtering guided by the vertex normals**
//!    (joint bilateral, as Eq. 2 of Zheng et al. 2011 with the range kernel
//!    on the guidance): `n'_i = normalize( Σ_{j∈{i}∪N(i)} a_j W_s(|c_i − c_j|)
//!    W_r(|g_i − g_j|) n_j )`, `W_s(x) = exp(−x²/(2σ_s²))`,
//!    `W_r(x) = exp(−x²/(2σ_r²))`, `N(i)` the vertex-1-ring of face i.
//!
//! Each normal pass is followed by `N_v` passes of the Sun et al. (2007)
//! vertex update ([`Schedule::Interleaved`](crate::driver::Schedule::Interleaved)).
//!
//! Simplifications (documented deviations from the paper):
//! - The paper first clusters the faces into piecewise-smooth patches and
//!   restricts both filters to a face's own patch; here the hard patch
//!   membership is replaced by the soft range kernel `W_n` on face-normal
//!   differences (no global clustering step).
//! - The paper's vertex update uses both normal fields; here the vertex
//!   positions follow the filtered face normals only (Sun et al. 2007,
//!   [`mod@crate::vertex_update`]), like every other method of this crate.
//! - Defaults: the paper's exact parameter values are not reproduced from
//!   memory; σ_s = 1·d_s and σ_r = σ_n = 0.35 are the bilateral defaults of
//!   the reference code of this comparison (GuidedDenoising, as BNF and
//!   GNF here), with `N_f = 20` normal passes and `N_v = 10` vertex passes
//!   (GNF's reference schedule). They were not tuned on any test model (on
//!   the training sources SharpSphere0.3, Nicolo0.2, Julius0.2 they give a
//!   mean E_a of 7.2°, 10 passes 7.4°).

use crate::bilateral::bilateral_normals;
use crate::driver::{NormalFilter, Passes, run_filter};
use crate::error::{FilterError, check_range};
use crate::stats::spatial_sigma;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{FaceGeometry, Mesh, Progress, Topology};
use rayon::prelude::*;

/// Parameters of BI; `Default` is documented in the module docs.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BiParams {
    /// σ_r: width of the face-normal range kernel W_r on differences of the
    /// vertex-normal guidance g; default 0.35.
    pub sigma_r: f64,
    /// σ_n: width of the kernel W_n that keeps a corner's vertex normal on
    /// its face's side of a feature; default 0.35.
    pub sigma_n: f64,
    /// σ_s / d_s: width of the spatial kernel W_s in units of the current
    /// mean centre distance d_s; default 1.0.
    pub sigma_s_over_ds: f64,
    /// N_f: normal-filtering passes; default 20.
    pub normal_iterations: usize,
    /// N_v: vertex-update passes after each normal pass; default 10.
    pub vertex_iterations: usize,
    /// Keep boundary vertices fixed during vertex updates; default false.
    pub fix_boundary: bool,
    /// Damp vertex moves that fold a face against its filtered normal (the
    /// fold guard of [`mod@crate::vertex_update`]); default true. The
    /// reference code has no guard: false reproduces it.
    pub fold_guard: bool,
}

impl Default for BiParams {
    fn default() -> Self {
        BiParams {
            sigma_r: 0.35,
            sigma_n: 0.35,
            sigma_s_over_ds: 1.0,
            normal_iterations: 20,
            vertex_iterations: 10,
            fix_boundary: false,
            fold_guard: true,
        }
    }
}

impl BiParams {
    /// Checks every field; the error names the field.
    pub fn validate(&self) -> Result<(), FilterError> {
        check_range("sigma_r", self.sigma_r, Some(0.0), None, true)?;
        check_range("sigma_n", self.sigma_n, Some(0.0), None, true)?;
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

/// BI as a [`NormalFilter`]; keeps the faces (for the corners) and a guidance
/// buffer.
pub struct Bi {
    params: BiParams,
    faces: Vec<[u32; 3]>,
    guidance: Vec<Vec3>,
}

impl Bi {
    /// Validates `params`; `faces` are the mesh's triangles.
    pub fn new(params: &BiParams, faces: &[[u32; 3]]) -> Result<Bi, FilterError> {
        params.validate()?;
        Ok(Bi {
            params: params.clone(),
            faces: faces.to_vec(),
            guidance: vec![[0.0; 3]; faces.len()],
        })
    }
}

impl NormalFilter for Bi {
    fn pass(
        &mut self,
        topology: &Topology,
        geometry: &FaceGeometry,
        normals: &[Vec3],
        out: &mut [Vec3],
    ) {
        let Some(sigma_s) = spatial_sigma(topology, &geometry.centres, self.params.sigma_s_over_ds)
        else {
            out.copy_from_slice(normals);
            return;
        };
        let inv_s = 1.0 / (2.0 * sigma_s * sigma_s);
        let inv_r = 1.0 / (2.0 * self.params.sigma_r * self.params.sigma_r);
        let inv_n = 1.0 / (2.0 * self.params.sigma_n * self.params.sigma_n);
        let faces = &self.faces;
        // Steps 1–2: feature-aware corner normals, summed into the guidance.
        self.guidance
            .par_iter_mut()
            .enumerate()
            .with_min_len(256)
            .for_each(|(i, g)| {
                let n_i = normals[i];
                let mut sum = [0.0; 3];
                for &v in &faces[i] {
                    let mut m = [0.0; 3];
                    for &j in topology.vertex_faces.row(v as usize) {
                        let j = j as usize;
                        let w = geometry.areas[j] * (-vec3::dist2(n_i, normals[j]) * inv_n).exp();
                        m = vec3::add(m, vec3::scale(normals[j], w));
                    }
                    sum = vec3::add(sum, vec3::normalize_or_zero(m));
                }
                *g = vec3::normalize_or_zero(sum);
            });
        // Step 3: face normals, bilateral with the vertex-normal guidance.
        bilateral_normals(
            topology,
            geometry,
            normals,
            &self.guidance,
            [inv_s, inv_r],
            true,
            out,
        );
    }
}

/// Denoises `mesh` with BI.
pub fn bi(mesh: &Mesh, params: &BiParams, progress: &dyn Progress) -> Result<Mesh, FilterError> {
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let mut filter = Bi::new(params, &mesh.faces)?;
    Ok(run_filter(
        &mut filter,
        mesh,
        &topology,
        Passes::interleaved(
            [params.normal_iterations, params.vertex_iterations],
            params.fix_boundary,
            params.fold_guard,
        ),
        "BI",
        progress,
    ))
}

crate::classical_method!(BiParams, bi);

#[cfg(test)]
mod tests {
    use super::*;

    /// A noise-free V-shaped grid `z = |x − k/2|` (a 90° valley along x = k/2).
    fn valley(k: usize) -> Mesh {
        Mesh::height_grid(k, |x, _| (x as f64 - k as f64 / 2.0).abs())
    }

    #[test]
    fn vertex_normal_guidance_stays_on_its_side_of_an_edge() {
        let mesh = valley(8);
        let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
        let geometry = FaceGeometry::new(&mesh);
        let mut filter = Bi::new(&BiParams::default(), &mesh.faces).unwrap();
        let mut out = vec![[0.0; 3]; mesh.num_faces()];
        filter.pass(&topology, &geometry, &geometry.normals, &mut out);
        // Plain (unweighted) vertex normals at the valley would be vertical,
        // 45° from either side; the feature-aware ones stay within 1°.
        for (g, n) in filter.guidance.iter().zip(&geometry.normals) {
            let a = vec3::angle(*g, *n).to_degrees();
            assert!(a < 1.0, "guidance {a}° from the face normal");
        }
        for (o, n) in out.iter().zip(&geometry.normals) {
            assert!(vec3::angle(*o, *n).to_degrees() < 0.1);
        }
    }

    #[test]
    fn validate_names_the_field() {
        let p = BiParams {
            sigma_n: 0.0,
            ..Default::default()
        };
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("sigma_n"), "{e}");
        let p = BiParams {
            sigma_r: f64::INFINITY,
            ..Default::default()
        };
        assert!(p.validate().unwrap_err().to_string().contains("sigma_r"));
    }
}
