//! Bilateral normal filtering (BNF), local iterative scheme: Zheng, Fu, Au,
//! Tai (2011), "Bilateral normal filtering for mesh denoising", IEEE TVCG
//! 17(10), doi:10.1109/TVCG.2010.264, Eq. (5); SPEC §9.
//!
//! One pass: `n'_i = normalize( Σ_{j∈N(i)} a_j W_s(|c_i − c_j|) W_r(|n_i − n_j|) n_j )`
//! with Gaussians `W_s(x) = exp(−x²/(2σ_s²))`, `W_r(x) = exp(−x²/(2σ_r²))`.
//! As in the reference implementation (GuidedDenoising's
//! `BilateralNormalFiltering`, local scheme): `N(i)` is the vertex-1-ring
//! of face i (faces sharing a vertex with it, face i excluded), `σ_s = 1·d_s`
//! (mean distance between adjacent face centres) and `σ_r = 0.35`; 20 normal
//! passes on the input geometry, each reading the previous pass's normals,
//! then 10 vertex passes ([`Schedule::NormalsThenVertices`]). These choices
//! reproduce the reference figure on Fandisk0.3 (E_a 3.49°); the centre
//! face's own term and the schedule are parameters (see [`BnfParams`]).

use crate::driver::{NormalFilter, Passes, Schedule, run_filter};
use crate::error::{FilterError, check_range};
use crate::stats::spatial_sigma;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{FaceGeometry, Mesh, Progress, Topology};
use rayon::prelude::*;

/// The fold guard's cone for BNF: 0, only the flip itself is forbidden. Its
/// normals are all filtered on the input geometry first, so many noisy faces
/// start beyond the default 60° cone ([`crate::vertex_update::FOLD_GUARD_COS`])
/// and holding them there slowed its vertex passes (noise 0.3, E_a +0.1° to
/// +0.4° on spot / homer / the example, against +0.01° to +0.12° with 0).
pub const BNF_FOLD_GUARD_COS: f64 = 0.0;

/// Parameters of BNF; `Default` is the reference defaults.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BnfParams {
    /// σ_r: width of the range kernel W_r on normal differences; default 0.35.
    pub sigma_r: f64,
    /// σ_s / d_s (σ_c multiple in the reference code): width of the spatial
    /// kernel W_s in units of the mean centre distance d_s; default 1.0.
    pub sigma_s_over_ds: f64,
    /// N_f: normal-filtering passes; default 20.
    pub normal_iterations: usize,
    /// N_v: vertex-update passes; default 10.
    pub vertex_iterations: usize,
    /// Whether face i's own term (weight a_i) is part of its sum; default
    /// false (N(i) is the ring without the face, as in the reference code).
    pub include_centre: bool,
    /// Keep boundary vertices fixed during vertex updates; default true (as
    /// the reference code's BNF).
    pub fix_boundary: bool,
    /// When vertices move; default [`Schedule::NormalsThenVertices`] (the
    /// reference code's local scheme: all normal passes on the input
    /// geometry, then the vertex passes).
    pub schedule: Schedule,
    /// Damp vertex moves that fold a face against its filtered normal (the
    /// fold guard of [`mod@crate::vertex_update`]); default true. The
    /// reference code has no guard: false reproduces it.
    pub fold_guard: bool,
}

impl Default for BnfParams {
    fn default() -> Self {
        BnfParams {
            sigma_r: 0.35,
            sigma_s_over_ds: 1.0,
            normal_iterations: 20,
            vertex_iterations: 10,
            include_centre: false,
            schedule: Schedule::NormalsThenVertices,
            fix_boundary: true,
            fold_guard: true,
        }
    }
}

impl BnfParams {
    /// Checks every field; the error names the field.
    pub fn validate(&self) -> Result<(), FilterError> {
        check_range("sigma_r", self.sigma_r, Some(0.0), None, true)?;
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

/// BNF as a [`NormalFilter`] (no precomputation: the neighbourhood is the
/// topology's vertex-1-ring).
pub struct Bnf {
    params: BnfParams,
}

impl Bnf {
    /// Validates `params`.
    pub fn new(params: &BnfParams) -> Result<Bnf, FilterError> {
        params.validate()?;
        Ok(Bnf {
            params: params.clone(),
        })
    }
}

impl NormalFilter for Bnf {
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
        bilateral_normals(
            topology,
            geometry,
            normals,
            normals,
            [inv_s, inv_r],
            self.params.include_centre,
            out,
        );
    }
}

/// One bilateral normal-filtering pass over the vertex-1-ring face
/// neighbourhood: `out_i = normalize(Σ_j a_j exp(−|c_i−c_j|²·inv_s −
/// |r_i−r_j|²·inv_r) n_j)`, the centre face included when `include_centre`.
/// The range term compares `range` vectors: the normals themselves (BNF) or
/// a guidance field (BI). `[inv_s, inv_r]` = `1/(2σ_s²)`, `1/(2σ_r²)`.
pub(crate) fn bilateral_normals(
    topology: &Topology,
    geometry: &FaceGeometry,
    normals: &[Vec3],
    range: &[Vec3],
    [inv_s, inv_r]: [f64; 2],
    include_centre: bool,
    out: &mut [Vec3],
) {
    out.par_iter_mut()
        .enumerate()
        .with_min_len(256)
        .for_each(|(i, o)| {
            let c_i = geometry.centres[i];
            let r_i = range[i];
            let mut sum = if include_centre {
                vec3::scale(normals[i], geometry.areas[i])
            } else {
                [0.0; 3]
            };
            for &j in topology.face_neighbours.row(i) {
                let j = j as usize;
                let w = geometry.areas[j]
                    * (-vec3::dist2(c_i, geometry.centres[j]) * inv_s
                        - vec3::dist2(r_i, range[j]) * inv_r)
                        .exp();
                sum = vec3::add(sum, vec3::scale(normals[j], w));
            }
            *o = vec3::normalize_or_zero(sum);
        });
}

/// Denoises `mesh` with BNF.
pub fn bnf(mesh: &Mesh, params: &BnfParams, progress: &dyn Progress) -> Result<Mesh, FilterError> {
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let mut filter = Bnf::new(params)?;
    Ok(run_filter(
        &mut filter,
        mesh,
        &topology,
        Passes {
            normal_iterations: params.normal_iterations,
            vertex_iterations: params.vertex_iterations,
            schedule: params.schedule,
            fix_boundary: params.fix_boundary,
            fold_guard: params.fold_guard.then_some(BNF_FOLD_GUARD_COS),
        },
        "BNF",
        progress,
    ))
}

crate::classical_method!(BnfParams, bnf);
