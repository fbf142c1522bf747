//! The classical methods of this crate with their reference defaults, for
//! the tests that run every one (the registry that users see lives in
//! `normalnet-denoise`).

#![allow(dead_code)]

use normalnet_filters::{
    BiParams, BnfParams, ClassicalMethod, FilterError, GnfParams, L0Params, Sun07Params, VtParams,
};
use normalnet_mesh::{Mesh, NoProgress, Progress};

/// One method with default parameters.
pub struct Named {
    name: &'static str,
    around: fn(&Mesh, &dyn Progress) -> Result<Mesh, FilterError>,
    all: fn(&Mesh, &dyn Progress) -> Result<Mesh, FilterError>,
}

impl Named {
    /// The method's short name.
    pub fn name(&self) -> &'static str {
        self.name
    }

    /// `normalnet_filters::denoise`: outliers left in place.
    pub fn denoise(&self, mesh: &Mesh, progress: &dyn Progress) -> Result<Mesh, FilterError> {
        (self.around)(mesh, progress)
    }

    /// Every vertex denoised.
    pub fn denoise_all(&self, mesh: &Mesh, progress: &dyn Progress) -> Result<Mesh, FilterError> {
        (self.all)(mesh, progress)
    }
}

fn named<P: ClassicalMethod>(name: &'static str) -> Named {
    Named {
        name,
        around: |m, p| normalnet_filters::denoise(&P::default(), m, p),
        all: |m, p| P::default().denoise_all(m, p),
    }
}

/// gnf, bnf, sun07, l0, bi, vt.
pub fn methods() -> Vec<Named> {
    vec![
        named::<GnfParams>("gnf"),
        named::<BnfParams>("bnf"),
        named::<Sun07Params>("sun07"),
        named::<L0Params>("l0"),
        named::<BiParams>("bi"),
        named::<VtParams>("vt"),
    ]
}

/// The method called `name`.
pub fn method(name: &str) -> Named {
    methods()
        .into_iter()
        .find(|m| m.name == name)
        .unwrap_or_else(|| panic!("no method {name}"))
}

/// Silences the unused-import lint where only `methods` is used.
pub fn _unused() -> NoProgress {
    NoProgress
}
