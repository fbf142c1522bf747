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
//! defaults and which implements [`ClassicalMethod`]; the registry of
//! `normalnet-denoise` names them for the CLI, the benchmark and the
//! bindings.

pub mod bi;
pub mod bilateral;
pub mod cnr;
pub mod driver;
pub mod error;
pub mod fold_repair;
pub mod gnf;
pub mod gt_guided;
pub mod l0;
pub mod stats;
pub mod sun07;
pub mod vertex_update;
pub mod vt;

pub use bi::{Bi, BiParams, bi};
pub use bilateral::{Bnf, BnfParams, bnf};
pub use driver::{NormalFilter, Passes, Schedule, run_filter};
pub use error::FilterError;
pub use fold_repair::{FoldCheck, FoldReport, repair_folds, repair_mesh_folds, self_folded_faces};
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

/// What the method registry of `normalnet-denoise` needs of a classical
/// method: its parameters (serde, `Default` = the reference defaults) know
/// how to check themselves and how to denoise. Each filter's file implements
/// it for its params struct; the registry lists them (one line per method).
pub trait ClassicalMethod:
    Clone + Default + serde::Serialize + serde::de::DeserializeOwned + Send + Sync + 'static
{
    /// Checks the parameters; the error names the field.
    fn check(&self) -> Result<(), FilterError>;

    /// Denoises every vertex of `mesh` (the result keeps its vertex and face
    /// order).
    fn denoise_all(&self, mesh: &Mesh, progress: &dyn Progress) -> Result<Mesh, FilterError>;
}

/// [`ClassicalMethod`] for a parameter struct with a `validate` method and
/// its method's function `fn(&Mesh, &Params, &dyn Progress)`: the one
/// implementation every filter file shares.
macro_rules! classical_method {
    ($params:ty, $denoise:path) => {
        impl $crate::ClassicalMethod for $params {
            fn check(&self) -> Result<(), $crate::FilterError> {
                self.validate()
            }

            fn denoise_all(
                &self,
                mesh: &normalnet_mesh::Mesh,
                progress: &dyn normalnet_mesh::Progress,
            ) -> Result<normalnet_mesh::Mesh, $crate::FilterError> {
                $denoise(mesh, self, progress)
            }
        }
    };
}
pub(crate) use classical_method;

/// Denoises `mesh` with `method`, robust to stray vertices (issue 14): the
/// vertices that [`normalnet_mesh::outliers`] flags (far outside the mesh's
/// robust extent, or isolated spikes) keep their positions, and the faces
/// touching them are left out of the denoising
/// ([`normalnet_mesh::outliers::denoise_around`]): they take no part in
/// `l_e`, `d_s`, neighbourhoods or vertex updates, so the other vertices end
/// exactly where they would on the mesh without them. A mesh without
/// outliers is denoised as it is.
pub fn denoise<M: ClassicalMethod>(
    method: &M,
    mesh: &Mesh,
    progress: &dyn Progress,
) -> Result<Mesh, FilterError> {
    normalnet_mesh::outliers::denoise_around(mesh, |m| method.denoise_all(m, progress))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn params_deserialise_key_by_key_over_the_defaults() {
        let m: GnfParams = serde_json::from_str(r#"{"mu_g": 0.25}"#).unwrap();
        assert_eq!(
            m,
            GnfParams {
                mu_g: 0.25,
                ..Default::default()
            }
        );
        assert!(
            serde_json::from_str::<GnfParams>(r#"{"mu": 0.25}"#).is_err(),
            "typos are errors"
        );
    }
}
