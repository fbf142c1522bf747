//! Classical mesh denoisers on one normal-filter + vertex-update skeleton
//! (SPEC §4, §9): GNF (Zhang et al. 2015), its ground-truth-guided variant
//! (NormalNet's training targets, SPEC §8), and the baselines of the paper's
//! comparison (BNF, Sun07, L0, BI, VT).
//!
//! Input comes from `normalnet_mesh` (`Mesh`, `Topology`, `FaceGeometry`);
//! results go to the CLI (`normalnet denoise`, `normalnet bench`), and
//! [`mod@vertex_update`] / [`gt_guided::gt_guided_normals`] to the voxel and
//! network crates (NormalNet's inference and training targets).
//!
//! Every method has a params struct whose `Default` is the reference
//! defaults, and [`Method`] names them for the CLI and the benchmark.

pub mod bi;
pub mod bilateral;
pub mod driver;
pub mod error;
pub mod gnf;
pub mod gt_guided;
pub mod l0;
pub mod stats;
pub mod sun07;
#[cfg(test)]
mod test_meshes;
pub mod vertex_update;
pub mod vt;

pub use bi::{Bi, BiParams, bi};
pub use bilateral::{Bnf, BnfParams, bnf};
pub use driver::{NormalFilter, Passes, Schedule, run_filter};
pub use error::FilterError;
pub use gnf::{Gnf, GnfParams, gnf};
pub use gt_guided::{
    GT_GUIDED_SIGMA_S, GtGuidedGnfParams, gt_guided_gnf, gt_guided_normals, try_gt_guided_normals,
};
pub use l0::{L0Params, l0};
pub use sun07::{Sun07, Sun07Params, sun07};
pub use vertex_update::{
    FOLD_GUARD_COS, FOLD_GUARD_HALVINGS, VertexUpdate, VertexUpdateBuffers, vertex_update,
    vertex_update_in_place, vertex_update_in_place_fixed, vertex_update_with,
};
pub use vt::{Vt, VtParams, binary_vote, symmetric_eigen, vt};

use normalnet_mesh::{Mesh, Progress};

/// A classical denoiser with its parameters (the registry used by
/// `normalnet denoise` and `normalnet bench`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Method {
    /// Guided mesh normal filtering (Zhang et al. 2015).
    Gnf(GnfParams),
    /// Bilateral normal filtering, local scheme (Zheng et al. 2011).
    Bnf(BnfParams),
    /// Fast and effective feature-preserving denoising (Sun et al. 2007).
    Sun07(Sun07Params),
    /// L0 minimisation, edge-based with area regulariser (He & Schaefer 2013).
    L0(L0Params),
    /// Bi-normal filtering (Wei et al. 2015), core scheme (see [`mod@bi`]).
    Bi(BiParams),
    /// Normal voting tensor with binary optimisation (Yadav et al. 2018).
    Vt(VtParams),
}

impl Method {
    /// Names accepted by [`Method::from_name`], in display order.
    pub const NAMES: &'static [&'static str] = &["gnf", "bnf", "sun07", "l0", "bi", "vt"];

    /// The method called `name` (case-insensitive) with its default
    /// parameters.
    pub fn from_name(name: &str) -> Result<Method, FilterError> {
        match name.to_ascii_lowercase().as_str() {
            "gnf" => Ok(Method::Gnf(GnfParams::default())),
            "bnf" => Ok(Method::Bnf(BnfParams::default())),
            "sun07" => Ok(Method::Sun07(Sun07Params::default())),
            "l0" => Ok(Method::L0(L0Params::default())),
            "bi" => Ok(Method::Bi(BiParams::default())),
            "vt" => Ok(Method::Vt(VtParams::default())),
            _ => Err(FilterError::UnknownMethod(name.to_string())),
        }
    }

    /// The method's short name (as accepted by [`Method::from_name`]).
    pub fn name(&self) -> &'static str {
        match self {
            Method::Gnf(_) => "gnf",
            Method::Bnf(_) => "bnf",
            Method::Sun07(_) => "sun07",
            Method::L0(_) => "l0",
            Method::Bi(_) => "bi",
            Method::Vt(_) => "vt",
        }
    }

    /// Checks the parameters; the error names the field.
    pub fn validate(&self) -> Result<(), FilterError> {
        match self {
            Method::Gnf(p) => p.validate(),
            Method::Bnf(p) => p.validate(),
            Method::Sun07(p) => p.validate(),
            Method::L0(p) => p.validate(),
            Method::Bi(p) => p.validate(),
            Method::Vt(p) => p.validate(),
        }
    }

    /// Denoises `mesh` (the result keeps its vertex and face order).
    ///
    /// Robust to stray vertices (issue 14): the vertices that
    /// [`normalnet_mesh::outliers`] flags (far outside the mesh's robust
    /// extent, or isolated spikes) keep their positions, and the faces
    /// touching them are left out of the denoising
    /// ([`normalnet_mesh::outliers::denoise_around`]): they take no part in
    /// `l_e`, `d_s`, neighbourhoods or vertex updates, so the other
    /// vertices end exactly where they would on the mesh without them.
    /// A mesh without outliers is denoised as it is.
    pub fn denoise(&self, mesh: &Mesh, progress: &dyn Progress) -> Result<Mesh, FilterError> {
        normalnet_mesh::outliers::denoise_around(mesh, |m| self.denoise_all(m, progress))
    }

    /// Denoises every vertex of `mesh`, outliers included (the plain method;
    /// [`Method::denoise`] is what users want).
    pub fn denoise_all(&self, mesh: &Mesh, progress: &dyn Progress) -> Result<Mesh, FilterError> {
        match self {
            Method::Gnf(p) => gnf(mesh, p, progress),
            Method::Bnf(p) => bnf(mesh, p, progress),
            Method::Sun07(p) => sun07(mesh, p, progress),
            Method::L0(p) => l0(mesh, p, progress),
            Method::Bi(p) => bi(mesh, p, progress),
            Method::Vt(p) => vt(mesh, p, progress),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_errors() {
        for &name in Method::NAMES {
            let m = Method::from_name(name).unwrap();
            assert_eq!(m.name(), name);
            m.validate().unwrap();
        }
        assert_eq!(Method::from_name("GNF").unwrap().name(), "gnf");
        let e = Method::from_name("median").unwrap_err();
        assert!(e.to_string().contains("median"), "{e}");
    }

    #[test]
    fn params_deserialise_key_by_key_over_the_defaults() {
        let m: Method = serde_json::from_str(r#"{"Gnf": {"mu_g": 0.25}}"#).unwrap();
        assert_eq!(
            m,
            Method::Gnf(GnfParams {
                mu_g: 0.25,
                ..Default::default()
            })
        );
        assert!(
            serde_json::from_str::<Method>(r#"{"Gnf": {"mu": 0.25}}"#).is_err(),
            "typos are errors"
        );
    }
}
