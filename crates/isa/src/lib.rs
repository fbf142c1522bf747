//! The instruction set every SIMD kernel of the project runs, decided once
//! per process: the best one the CPU has, or the one the environment
//! variable [`ENV`] (`NORMALNET_ISA=avx512vnni|avx512|avxvnni|avx2|scalar`) asks
//! for. Every kernel that dispatches at run time asks [`active`], so one
//! variable forces one path through the whole program (voxelizer, f32 and
//! int8 convolutions, the head, training), and a machine with AVX-512 runs
//! the AVX2 and scalar paths exactly as a machine that has nothing better.
//!
//! A choice the CPU cannot run, or a name that is no path, is refused by
//! [`from_env`] with an [`IsaError`]; the programs call it before any work
//! (the CLI at start, `Denoiser::new` in the library). [`active`] itself
//! never fails: with an unusable variable it falls back to the detected
//! path.

use std::fmt;
use std::sync::OnceLock;

/// The environment variable that forces a path.
pub const ENV: &str = "NORMALNET_ISA";

/// A kernel path, from the most portable to the fastest. Each includes the
/// ones before it, except [`Isa::AvxVnni`]: the AVX-512 paths need not have
/// it (Skylake-X, Ice Lake and Zen 4 have AVX-512 but not AVX-VNNI), and
/// [`Isa::runs_here`] asks the CPU for it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Isa {
    /// Plain Rust, no target features: compiles and runs on any target.
    Scalar,
    /// x86-64 AVX2 with FMA.
    Avx2,
    /// [`Isa::Avx2`] with AVX-VNNI (`vpdpbusd` on 256-bit vectors, the
    /// Intel client CPUs since Alder Lake, which have no AVX-512): the int8
    /// convolutions of the residual blocks; everything else as `Avx2`.
    AvxVnni,
    /// x86-64 AVX-512 F, BW and VL (with AVX2 and FMA).
    Avx512,
    /// [`Isa::Avx512`] with VNNI (`vpdpbusd`): the int8 convolutions.
    Avx512Vnni,
}

impl Isa {
    /// Every path, most portable first.
    pub const ALL: [Isa; 5] = [
        Isa::Scalar,
        Isa::Avx2,
        Isa::AvxVnni,
        Isa::Avx512,
        Isa::Avx512Vnni,
    ];

    /// The name [`ENV`] takes and reports print.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Scalar => "scalar",
            Isa::Avx2 => "avx2",
            Isa::AvxVnni => "avxvnni",
            Isa::Avx512 => "avx512",
            Isa::Avx512Vnni => "avx512vnni",
        }
    }

    /// The path named `name` (as [`Isa::name`] writes it, case-insensitive).
    pub fn from_name(name: &str) -> Option<Isa> {
        Isa::ALL
            .into_iter()
            .find(|isa| isa.name().eq_ignore_ascii_case(name.trim()))
    }

    /// The best path this CPU runs (detected once).
    pub fn detected() -> Isa {
        static DETECTED: OnceLock<Isa> = OnceLock::new();
        *DETECTED.get_or_init(detect)
    }

    /// Whether this CPU runs the path.
    pub fn runs_here(self) -> bool {
        match self {
            Isa::AvxVnni => has_avx_vnni(),
            _ => self <= Isa::detected(),
        }
    }

    /// Every path this CPU runs, most portable first.
    pub fn all_here() -> impl Iterator<Item = Isa> {
        Isa::ALL.into_iter().filter(|isa| isa.runs_here())
    }

    /// AVX2 and FMA kernels may run.
    pub fn has_avx2(self) -> bool {
        self >= Isa::Avx2
    }

    /// AVX-512 F/BW/VL kernels may run.
    pub fn has_avx512(self) -> bool {
        self >= Isa::Avx512
    }

    /// AVX-512 VNNI kernels may run.
    pub fn has_vnni(self) -> bool {
        self >= Isa::Avx512Vnni
    }

    /// The 256-bit VNNI kernels run (only on this path: the AVX-512 paths
    /// have their own).
    pub fn uses_avx_vnni(self) -> bool {
        self == Isa::AvxVnni
    }
}

impl fmt::Display for Isa {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(target_arch = "x86_64")]
fn detect() -> Isa {
    use std::arch::is_x86_feature_detected as has;
    let avx2 = has!("avx2") && has!("fma");
    let avx512 = avx2 && has!("avx512f") && has!("avx512bw") && has!("avx512vl");
    match (avx2, avx512, avx512 && has!("avx512vnni")) {
        (_, _, true) => Isa::Avx512Vnni,
        (_, true, _) => Isa::Avx512,
        (true, ..) if has_avx_vnni() => Isa::AvxVnni,
        (true, ..) => Isa::Avx2,
        _ => Isa::Scalar,
    }
}

#[cfg(not(target_arch = "x86_64"))]
fn detect() -> Isa {
    Isa::Scalar
}

/// The CPU has AVX2, FMA and AVX-VNNI.
#[cfg(target_arch = "x86_64")]
fn has_avx_vnni() -> bool {
    use std::arch::is_x86_feature_detected as has;
    has!("avx2") && has!("fma") && has!("avxvnni")
}

#[cfg(not(target_arch = "x86_64"))]
fn has_avx_vnni() -> bool {
    false
}

/// Why [`ENV`] cannot be followed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum IsaError {
    /// The value names no path.
    Unknown(String),
    /// The path exists but this CPU does not run it.
    Unsupported {
        /// the path asked for
        asked: Isa,
        /// the best path this CPU runs
        detected: Isa,
    },
}

impl fmt::Display for IsaError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<&str> = Isa::ALL.iter().map(|isa| isa.name()).collect();
        match self {
            IsaError::Unknown(value) => write!(
                f,
                "{ENV}={value:?} is no kernel path (expected one of {})",
                names.join(", ")
            ),
            IsaError::Unsupported { asked, detected } => write!(
                f,
                "{ENV}={asked}: this CPU does not run it (the best it runs is {detected})"
            ),
        }
    }
}

impl std::error::Error for IsaError {}

/// The path `value` asks for, checked against this CPU; `None` (unset or
/// empty) is the detected path.
pub fn choose(value: Option<&str>) -> Result<Isa, IsaError> {
    let value = value.map(str::trim).filter(|v| !v.is_empty());
    let Some(value) = value else {
        return Ok(Isa::detected());
    };
    let asked = Isa::from_name(value).ok_or_else(|| IsaError::Unknown(value.to_string()))?;
    if !asked.runs_here() {
        return Err(IsaError::Unsupported {
            asked,
            detected: Isa::detected(),
        });
    }
    Ok(asked)
}

/// The path [`ENV`] asks for (the detected one when it is unset), or why
/// it cannot be followed.
pub fn from_env() -> Result<Isa, IsaError> {
    let value = std::env::var_os(ENV).map(|v| v.to_string_lossy().into_owned());
    choose(value.as_deref())
}

/// The path every kernel runs in this process: [`from_env`], or the
/// detected path where the variable cannot be followed. Decided at the
/// first call.
pub fn active() -> Isa {
    static ACTIVE: OnceLock<Isa> = OnceLock::new();
    *ACTIVE.get_or_init(|| from_env().unwrap_or_else(|_| Isa::detected()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_order_is_by_capability() {
        for isa in Isa::ALL {
            assert_eq!(Isa::from_name(isa.name()), Some(isa));
            assert_eq!(Isa::from_name(&isa.name().to_uppercase()), Some(isa));
        }
        assert_eq!(Isa::from_name("sse2"), None);
        assert!(Isa::Scalar < Isa::Avx2 && Isa::Avx512 < Isa::Avx512Vnni);
        assert!(Isa::Avx512Vnni.has_avx512() && !Isa::Avx2.has_avx512());
        assert!(Isa::Avx2.has_avx2() && !Isa::Scalar.has_avx2());
        assert!(Isa::AvxVnni.has_avx2() && !Isa::AvxVnni.has_avx512());
        assert!(Isa::AvxVnni.uses_avx_vnni() && !Isa::Avx512Vnni.uses_avx_vnni());
    }

    #[test]
    fn choose_follows_the_value_or_says_why_not() {
        assert_eq!(choose(None), Ok(Isa::detected()));
        assert_eq!(choose(Some("  ")), Ok(Isa::detected()));
        assert_eq!(choose(Some("scalar")), Ok(Isa::Scalar));
        let err = choose(Some("neon")).unwrap_err();
        assert_eq!(err, IsaError::Unknown("neon".into()));
        assert!(
            err.to_string()
                .contains("scalar, avx2, avxvnni, avx512, avx512vnni")
        );
        for isa in Isa::ALL {
            match choose(Some(isa.name())) {
                Ok(got) => assert!(got == isa && isa.runs_here()),
                Err(e) => {
                    assert!(!isa.runs_here());
                    assert!(e.to_string().contains("does not run it"), "{e}");
                }
            }
        }
    }

    #[test]
    fn every_path_up_to_the_detected_one_runs_here() {
        let here: Vec<Isa> = Isa::all_here().collect();
        assert_eq!(here.first(), Some(&Isa::Scalar));
        assert_eq!(here.last(), Some(&Isa::detected()));
    }
}
