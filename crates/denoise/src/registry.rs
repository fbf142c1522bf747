//! The one list of denoisers. Adding a method is one file (its algorithm and
//! params struct: a classical filter in `normalnet-filters` implementing
//! `ClassicalMethod`, or a file here implementing [`Method`]) plus one line
//! in [`METHODS`].

use normalnet_filters::{
    BiParams, BnfParams, ClassicalMethod, FoldReport, GnfParams, L0Params, Sun07Params, VtParams,
};
use normalnet_mesh::{Mesh, Progress};
use normalnet_net::StageTimes;
use serde_json::Value;

use crate::params::{Params, defaults_of, resolve};
use crate::{DenoiseError, cnr, normalnet, oracle};

/// What kind of method an entry is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// a classical filter (no training, no ground truth)
    Classical,
    /// a learned method (reads a model)
    Learned,
    /// reads the ground truth: a ceiling for comparison, never a result
    Oracle,
}

/// Builds a method (name, given parameters) over its defaults.
pub type BuildFn = fn(&'static str, &Params) -> Result<Box<dyn Method>, DenoiseError>;

/// One registered denoiser.
pub struct MethodInfo {
    /// the name users type (`gnf`, `normalnet`, ...)
    pub name: &'static str,
    /// other accepted names
    pub aliases: &'static [&'static str],
    /// one line: what it is, with its paper
    pub summary: &'static str,
    /// classical, learned or oracle
    pub kind: Kind,
    /// the CLI's shorthand flags this method takes and the parameter each
    /// sets (`("iterations", "normal_iterations")`); a boolean parameter
    /// behind a `no-` flag is set to false by it
    pub flags: &'static [(&'static str, &'static str)],
    /// the default parameters as a JSON object
    pub defaults: fn() -> Value,
    /// builds the method from parameters given over the defaults
    pub build: BuildFn,
}

impl MethodInfo {
    /// Whether the method reads the ground truth.
    pub fn needs_gt(&self) -> bool {
        self.kind == Kind::Oracle
    }

    /// The parameter a CLI flag sets for this method, if it takes the flag.
    pub fn flag_field(&self, flag: &str) -> Option<&'static str> {
        self.flags.iter().find(|(f, _)| *f == flag).map(|&(_, p)| p)
    }

    /// A classical filter of `normalnet-filters` with params struct `P`.
    pub const fn classical<P: ClassicalMethod>(
        name: &'static str,
        summary: &'static str,
        flags: &'static [(&'static str, &'static str)],
    ) -> MethodInfo {
        MethodInfo {
            name,
            aliases: &[],
            summary,
            kind: Kind::Classical,
            flags,
            defaults: defaults_of::<P>,
            build: build_classical::<P>,
        }
    }
}

/// The result of one run.
pub struct Outcome {
    /// the denoised mesh (vertex and face order of the input)
    pub mesh: Mesh,
    /// seconds per stage, for methods that report them (NormalNet)
    pub stages: Option<StageTimes>,
    /// what the final fold repair found and did ([`crate::Denoiser::run`]
    /// sets it; `None` when it was off)
    pub folds: Option<FoldReport>,
}

/// A built denoiser: parameters resolved and checked, models loaded.
pub trait Method: Send + Sync {
    /// The resolved parameters, as a JSON object.
    fn parameters(&self) -> Value;

    /// Denoises `mesh`; `gt` is the clean mesh for methods that read it.
    /// Outlier vertices (`normalnet_mesh::outliers`) stay in place, their
    /// faces out of the denoising.
    fn run(
        &self,
        mesh: &Mesh,
        gt: Option<&Mesh>,
        progress: &dyn Progress,
    ) -> Result<Outcome, DenoiseError>;
}

const ITERATIONS: (&str, &str) = ("iterations", "normal_iterations");
const VERTEX_ITERATIONS: (&str, &str) = ("vertex-iterations", "vertex_iterations");
const SIGMA_S: (&str, &str) = ("sigma-s", "sigma_s_over_ds");
const FOLD_GUARD: (&str, &str) = ("no-fold-guard", "fold_guard");

/// Every denoiser, in display order (NormalNet first: the default).
pub static METHODS: &[MethodInfo] = &[
    normalnet::INFO,
    MethodInfo::classical::<GnfParams>(
        "gnf",
        "guided mesh normal filtering (Zhang et al. 2015)",
        &[
            ITERATIONS,
            VERTEX_ITERATIONS,
            ("mu-g", "mu_g"),
            SIGMA_S,
            ("radius", "radius_over_ds"),
            FOLD_GUARD,
        ],
    ),
    MethodInfo::classical::<BnfParams>(
        "bnf",
        "bilateral normal filtering, local scheme (Zheng et al. 2011)",
        &[
            ITERATIONS,
            VERTEX_ITERATIONS,
            SIGMA_S,
            ("sigma-r", "sigma_r"),
            FOLD_GUARD,
        ],
    ),
    MethodInfo::classical::<Sun07Params>(
        "sun07",
        "fast and effective feature-preserving denoising (Sun et al. 2007)",
        &[
            ITERATIONS,
            VERTEX_ITERATIONS,
            ("threshold", "threshold"),
            FOLD_GUARD,
        ],
    ),
    MethodInfo::classical::<L0Params>(
        "l0",
        "L0 minimisation (He & Schaefer 2013)",
        &[
            ("lambda", "lambda_over_le2"),
            ("kappa", "kappa"),
            ("beta0", "beta0"),
            ("beta-max", "beta_max"),
            ("alpha0", "alpha0_over_gamma"),
            ("alpha-decay", "alpha_decay"),
        ],
    ),
    MethodInfo::classical::<BiParams>(
        "bi",
        "bi-normal filtering, core scheme (Wei et al. 2015)",
        &[
            ITERATIONS,
            VERTEX_ITERATIONS,
            SIGMA_S,
            ("sigma-r", "sigma_r"),
            ("sigma-n", "sigma_n"),
            FOLD_GUARD,
        ],
    ),
    MethodInfo::classical::<VtParams>(
        "vt",
        "normal voting tensor + binary optimisation (Yadav et al. 2018)",
        &[
            ITERATIONS,
            VERTEX_ITERATIONS,
            ("radius", "radius_over_le"),
            ("rho", "rho"),
            ("tau", "tau"),
            FOLD_GUARD,
        ],
    ),
    cnr::INFO,
    oracle::INFO,
];

/// The entry called `name` (case-insensitive; aliases too).
pub fn find(name: &str) -> Result<&'static MethodInfo, DenoiseError> {
    let lower = name.to_ascii_lowercase();
    METHODS
        .iter()
        .find(|m| m.name == lower || m.aliases.contains(&lower.as_str()))
        .ok_or_else(|| DenoiseError::UnknownMethod {
            name: name.to_string(),
            known: names().join(", "),
        })
}

/// The registered names, in display order.
pub fn names() -> Vec<&'static str> {
    METHODS.iter().map(|m| m.name).collect()
}

struct Classical<P> {
    params: P,
}

fn build_classical<P: ClassicalMethod>(
    name: &'static str,
    given: &Params,
) -> Result<Box<dyn Method>, DenoiseError> {
    let params: P = resolve(name, given)?;
    params.check().map_err(|e| DenoiseError::Parameter {
        method: name,
        message: e.to_string(),
    })?;
    Ok(Box::new(Classical { params }))
}

impl<P: ClassicalMethod> Method for Classical<P> {
    fn parameters(&self) -> Value {
        serde_json::to_value(&self.params).unwrap_or(Value::Null)
    }

    fn run(
        &self,
        mesh: &Mesh,
        _gt: Option<&Mesh>,
        progress: &dyn Progress,
    ) -> Result<Outcome, DenoiseError> {
        Ok(Outcome {
            mesh: normalnet_filters::denoise(&self.params, mesh, progress)?,
            stages: None,
            folds: None,
        })
    }
}
