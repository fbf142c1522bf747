//! Every denoiser of the project behind one type, [`Denoiser`]: the
//! classical filters of `normalnet-filters`, the GT-guided oracle and
//! NormalNet. One list of names ([`registry::METHODS`]), one parameter
//! mechanism ([`params`]: a JSON object laid over the method's defaults) for
//! the CLI's flags, `bench.toml`, and the bindings, one `denoise` call.
//! No deep-learning framework is needed: NormalNet runs on the CPU engine of
//! `normalnet-cnn`.
//!
//! ```no_run
//! use normalnet_denoise::{Denoiser, Params};
//! use normalnet_mesh::{NoProgress, read_mesh};
//!
//! let mesh = read_mesh("noisy.obj")?;
//! let mut params = Params::new();
//! params.insert("mu_g".into(), 0.3.into());
//! let gnf = Denoiser::new("gnf", &params)?;
//! let out = gnf.denoise(&mesh, None, &NoProgress)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Adding a method: one file (a classical filter implementing
//! `normalnet_filters::ClassicalMethod`, or a [`registry::Method`] here)
//! and one line in [`registry::METHODS`].

pub mod cnr;
pub mod error;
pub mod flags;
pub mod normalnet;
pub mod oracle;
pub mod params;
pub mod recipe;
pub mod registry;
mod scale;
pub mod suite;

pub use error::DenoiseError;
/// The kernel path (`NORMALNET_ISA`), re-exported for the CLI and bindings.
pub use normalnet_isa as isa;
pub use params::Params;
pub use registry::{Kind, METHODS, Method, MethodInfo, Outcome, find, names};

use normalnet_filters::repair_mesh_folds;
use normalnet_mesh::scale::pow2_scaled;
use normalnet_mesh::{Mesh, Progress};
use serde_json::Value;

/// A denoiser ready to run: a registered method with its parameters
/// resolved and checked, and its model loaded.
pub struct Denoiser {
    info: &'static MethodInfo,
    method: Box<dyn Method>,
    fold_repair: bool,
}

impl std::fmt::Debug for Denoiser {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Denoiser")
            .field("method", &self.info.name)
            .field("parameters", &self.parameters())
            .field("fold_repair", &self.fold_repair)
            .finish()
    }
}

impl Denoiser {
    /// The method called `name` with `params` laid over its defaults.
    ///
    /// # Errors
    /// An unknown name, an unknown or ill-typed or out-of-range parameter
    /// (the message names it), or a model that cannot be loaded — all before
    /// any mesh is read.
    pub fn new(name: &str, params: &Params) -> Result<Denoiser, DenoiseError> {
        normalnet_isa::from_env()?;
        let info = find(name)?;
        let method = (info.build)(info.name, params)?;
        let fold_repair = method.parameters().get("fold_guard") != Some(&Value::Bool(false));
        Ok(Denoiser {
            info,
            method,
            fold_repair,
        })
    }

    /// The method called `name` with its default parameters.
    pub fn with_defaults(name: &str) -> Result<Denoiser, DenoiseError> {
        Denoiser::new(name, &Params::new())
    }

    /// The method's registered name.
    pub fn name(&self) -> &'static str {
        self.info.name
    }

    /// The method's registry entry.
    pub fn info(&self) -> &'static MethodInfo {
        self.info
    }

    /// The resolved parameters (every field, defaults included).
    pub fn parameters(&self) -> Value {
        self.method.parameters()
    }

    /// Denoises `mesh`. `gt` (the clean mesh, face by face) is read only by
    /// the oracle. The result keeps the input's vertex and face order;
    /// outlier vertices stay in place.
    ///
    /// # Extreme scales
    /// Every method measures normals and areas through products of lengths
    /// (~L⁴), which underflow or overflow for a mesh at ~1e-80 or ~1e80.
    /// A mesh whose robust radius (ignoring 1 % of the vertices, so that a
    /// stray vertex does not set the unit, issue 39) lies outside
    /// [`normalnet_mesh::scale::SAFE_DIAGONAL_MIN`] ..=
    /// [`normalnet_mesh::scale::SAFE_DIAGONAL_MAX`] (`2^-40 ≈ 9.1e-13` to
    /// `2^40 ≈ 1.1e12`) is therefore denoised in another unit, whatever its
    /// bounding box: its positions (and `gt`'s, which must stay in the
    /// mesh's frame for the oracle) times an exact power of two `2^k` chosen
    /// so that the robust radius is ~1, the result times `2^-k`. Multiplying by a power of two is exact (barring
    /// subnormal results), and every method parameter is relative (to `d_s`,
    /// `l_e`, `l_e²`, or an angle), so the result is the one the method gives
    /// the mesh in that unit, scaled back. A mesh inside the range is
    /// denoised as it is: its results keep their bits.
    ///
    /// # Folds
    /// After the method's last vertex update, the folds of its result are
    /// found and repaired ([`normalnet_filters::fold_repair`], issue 39):
    /// the result has no more folded faces than the input (faces opposing
    /// their neighbours or turned far from the input's local orientation;
    /// the ground truth is not read). Off only with a method's
    /// `fold_guard = false` or [`Denoiser::with_fold_repair`].
    ///
    /// # Errors
    /// As [`Denoiser::run`].
    pub fn denoise(
        &self,
        mesh: &Mesh,
        gt: Option<&Mesh>,
        progress: &dyn Progress,
    ) -> Result<Mesh, DenoiseError> {
        self.run(mesh, gt, progress).map(|o| o.mesh)
    }

    /// [`Denoiser::denoise`] that also returns what the method reports
    /// (NormalNet: seconds per stage). The one entry point of every method:
    /// extreme scales are handled here (see [`Denoiser::denoise`]).
    ///
    /// # Errors
    /// [`DenoiseError::NeedsGroundTruth`] for the oracle without `gt`;
    /// [`DenoiseError::ExtentOverflow`] when the mesh's bounding-box
    /// diagonal overflows f64 (coordinates of both signs near ±1.8e308);
    /// whatever the method returns.
    pub fn run(
        &self,
        mesh: &Mesh,
        gt: Option<&Mesh>,
        progress: &dyn Progress,
    ) -> Result<Outcome, DenoiseError> {
        if self.info.needs_gt() && gt.is_none() {
            return Err(DenoiseError::NeedsGroundTruth {
                method: self.info.name,
            });
        }
        let Some(k) = scale::working_exponent(mesh)? else {
            return self.run_and_repair(mesh, gt, progress);
        };
        let scaled = |m: &Mesh| m.with_positions(pow2_scaled(&m.positions, k));
        let gt = gt.map(scaled);
        let mut outcome = self.run_and_repair(&scaled(mesh), gt.as_ref(), progress)?;
        outcome.mesh = outcome
            .mesh
            .with_positions(pow2_scaled(&outcome.mesh.positions, -k));
        Ok(outcome)
    }

    /// Whether [`Denoiser::run`] repairs the folds of the method's result:
    /// by default unless the method has a `fold_guard` parameter and it is
    /// off; [`Denoiser::with_fold_repair`] sets it.
    pub fn repairs_folds(&self) -> bool {
        self.fold_repair
    }

    /// This denoiser with the final fold repair on or off (off: the
    /// method's result as it is, e.g. the paper's pipeline).
    pub fn with_fold_repair(mut self, on: bool) -> Denoiser {
        self.fold_repair = on;
        self
    }

    /// The method's run, then the fold check and repair of
    /// [`normalnet_filters::fold_repair`] on its result.
    fn run_and_repair(
        &self,
        mesh: &Mesh,
        gt: Option<&Mesh>,
        progress: &dyn Progress,
    ) -> Result<Outcome, DenoiseError> {
        let mut outcome = self.method.run(mesh, gt, progress)?;
        if self.repairs_folds()
            && outcome.mesh.faces == mesh.faces
            && outcome.mesh.num_vertices() == mesh.num_vertices()
        {
            outcome.folds = Some(repair_mesh_folds(mesh, &mut outcome.mesh.positions));
        }
        Ok(outcome)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use normalnet_mesh::NoProgress;

    fn plane() -> Mesh {
        Mesh::height_grid(6, |i, j| 0.01 * ((i * 7 + j * 3) % 5) as f64)
    }

    #[test]
    fn every_registered_method_builds_with_its_defaults_and_names_round_trip() {
        for info in METHODS {
            let d = Denoiser::with_defaults(info.name).unwrap();
            assert_eq!(d.name(), info.name);
            assert!(d.parameters().is_object(), "{}", info.name);
            // every flag maps onto a real parameter
            let defaults = (info.defaults)();
            for (flag, field) in info.flags {
                assert!(
                    defaults.get(field).is_some(),
                    "{}: --{flag} -> {field}",
                    info.name
                );
            }
            for alias in info.aliases {
                assert_eq!(find(alias).unwrap().name, info.name);
            }
        }
        assert_eq!(find("GNF").unwrap().name, "gnf");
        assert_eq!(find("gt-gnf").unwrap().name, "oracle");
        let e = Denoiser::with_defaults("median").unwrap_err().to_string();
        assert!(
            e.contains("median") && e.contains("gnf") && e.contains("normalnet"),
            "{e}"
        );
    }

    #[test]
    fn parameters_are_checked_before_any_mesh() {
        let mut p = Params::new();
        p.insert("mu_g".into(), (-1.0).into());
        let e = Denoiser::new("gnf", &p).unwrap_err().to_string();
        assert!(e.starts_with("gnf: ") && e.contains("mu_g"), "{e}");
        let mut p = Params::new();
        p.insert("vertex_iterations".into(), 0.into());
        let e = Denoiser::new("normalnet", &p).unwrap_err().to_string();
        assert!(e.contains("vertex_iterations = 0"), "{e}");
        let mut p = Params::new();
        p.insert("model".into(), "/no/such/bundle".into());
        let e = Denoiser::new("normalnet", &p).unwrap_err().to_string();
        assert!(e.contains("/no/such/bundle"), "{e}");
    }

    #[test]
    fn the_oracle_needs_the_ground_truth_and_the_others_ignore_it() {
        let mesh = plane();
        let oracle = Denoiser::with_defaults("oracle").unwrap();
        assert!(matches!(
            oracle.denoise(&mesh, None, &NoProgress),
            Err(DenoiseError::NeedsGroundTruth { .. })
        ));
        let out = oracle.denoise(&mesh, Some(&mesh), &NoProgress).unwrap();
        assert_eq!(out.faces, mesh.faces);
        let gnf = Denoiser::with_defaults("gnf").unwrap();
        assert_eq!(
            gnf.denoise(&mesh, Some(&mesh), &NoProgress)
                .unwrap()
                .positions,
            gnf.denoise(&mesh, None, &NoProgress).unwrap().positions
        );
    }

    #[test]
    fn normalnet_reports_its_stages_and_bundle() {
        let mut p = Params::new();
        p.insert("iterations".into(), 1.into());
        p.insert("vertex_iterations".into(), 2.into());
        let d = Denoiser::new("normalnet", &p).unwrap();
        let o = d.run(&plane(), None, &NoProgress).unwrap();
        assert!(o.stages.is_some_and(|s| s.faces_processed == 72));
        assert_eq!(d.parameters()["model"], "<built-in models/lite>");
        assert_eq!(d.parameters()["iterations"], 1);
    }
}
