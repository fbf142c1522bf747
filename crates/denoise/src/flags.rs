//! The shorthand flags of the command line (`--iterations 5` for
//! `normal_iterations = 5`), written once: their names, what they take and
//! their help. Each method's entry in [`crate::METHODS`] says which of them
//! it takes and the parameter each sets; the `normalnet` program builds its
//! flags from this table, so a new flag is one line here plus the methods'
//! `flags` lines. Every other parameter is reachable by its field name
//! (`--param KEY=VALUE`).

use serde_json::Value;

/// What a flag takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlagValue {
    /// a count (a non-negative integer)
    Count,
    /// a finite number
    Number,
    /// a path
    Path,
    /// nothing: given, it sets its boolean parameter to false (`--no-switch`)
    Off,
}

/// One shorthand flag.
#[derive(Debug)]
pub struct Flag {
    /// the flag without its dashes (`vertex-iterations`)
    pub name: &'static str,
    /// what it takes
    pub value: FlagValue,
    /// one paragraph for `--help` (each method's default is added there)
    pub help: &'static str,
}

impl Flag {
    /// The parameter value of a flag given as `text` on the command line
    /// (`Off` flags: any text, they have none), or why it is no value.
    pub fn parse(&self, text: &str) -> Result<Value, String> {
        match self.value {
            FlagValue::Count => text
                .trim()
                .parse::<u64>()
                .map(Value::from)
                .map_err(|_| format!("expected a count (0, 1, 2, ...), got {text:?}")),
            FlagValue::Number => finite_number(text).map(Value::from),
            FlagValue::Path => Ok(Value::from(text)),
            FlagValue::Off => Ok(Value::Bool(false)),
        }
    }
}

/// Parses a finite number, refusing NaN and infinities (serde would turn
/// them into `null`: "invalid type: null, expected f64").
pub fn finite_number(text: &str) -> Result<f64, String> {
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("expected a number, got {text:?}"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("must be a finite number, got {text:?}"))
    }
}

/// The flag called `name`.
pub fn flag(name: &str) -> Option<&'static Flag> {
    FLAGS.iter().find(|f| f.name == name)
}

/// Every shorthand flag, in `--help` order.
pub static FLAGS: &[Flag] = &[
    Flag {
        name: "iterations",
        value: FlagValue::Count,
        help: "Normal-filtering iterations N_f, at most 100000 (normalnet: the most, see --auto-stop)",
    },
    Flag {
        name: "auto-stop",
        value: FlagValue::Number,
        help: "NormalNet stops after an iteration whose normals turned less than this many degrees \
               on average (0: always N_f iterations, the paper's pipeline)",
    },
    Flag {
        name: "vertex-iterations",
        value: FlagValue::Count,
        help: "Vertex-update passes N_v, at most 100000 (per iteration; bnf/sun07: after all normal passes)",
    },
    Flag {
        name: "mu-g",
        value: FlagValue::Number,
        help: "μ_g: width of the guidance range kernel (normalnet: the nearest trained output)",
    },
    Flag {
        name: "sigma-s",
        value: FlagValue::Number,
        help: "Spatial kernel width σ_s in units of the mean centre distance d_s",
    },
    Flag {
        name: "radius",
        value: FlagValue::Number,
        help: "Neighbourhood radius: gnf in units of d_s, vt (r) in units of the mean edge length l_e",
    },
    Flag {
        name: "sigma-r",
        value: FlagValue::Number,
        help: "σ_r: range kernel width on normal differences (bnf) or on the vertex-normal guidance (bi)",
    },
    Flag {
        name: "sigma-n",
        value: FlagValue::Number,
        help: "BI σ_n: width of the kernel keeping a corner's vertex normal on its side of a feature",
    },
    Flag {
        name: "rho",
        value: FlagValue::Number,
        help: "VT ρ: a neighbour votes only if n_i·n_j ≥ ρ",
    },
    Flag {
        name: "tau",
        value: FlagValue::Number,
        help: "VT τ: binary-optimisation threshold on the normalised eigenvalues",
    },
    Flag {
        name: "threshold",
        value: FlagValue::Number,
        help: "Sun07 threshold T on n_i·n_j",
    },
    Flag {
        name: "lambda",
        value: FlagValue::Number,
        help: "L0 λ in units of l_e² (mean edge length squared)",
    },
    Flag {
        name: "kappa",
        value: FlagValue::Number,
        help: "L0 κ: growth of β per iteration",
    },
    Flag {
        name: "beta0",
        value: FlagValue::Number,
        help: "L0 β_0: initial β",
    },
    Flag {
        name: "beta-max",
        value: FlagValue::Number,
        help: "L0 β_max: stop once β exceeds it (at most 1e8)",
    },
    Flag {
        name: "alpha0",
        value: FlagValue::Number,
        help: "L0 α_0 in units of the mean dihedral angle γ̄",
    },
    Flag {
        name: "alpha-decay",
        value: FlagValue::Number,
        help: "L0 μ_α: decay of α per iteration",
    },
    Flag {
        name: "model",
        value: FlagValue::Path,
        help: "The model of a learned method: NormalNet's bundle folder (default: \
               $NORMALNET_MODEL, else the bundle built into the program), CNR's model file \
               (JSON; default: the built-in one)",
    },
    Flag {
        name: "guided-from",
        value: FlagValue::Count,
        help: "NormalNet: from this filtering iteration on, the network's normals guide a \
               joint-bilateral pass over the current normals (range width μ_g, spatial 2·d_s) \
               instead of being the filtered normals (0 = never: the paper's form)",
    },
    Flag {
        name: "no-fold-guard",
        value: FlagValue::Off,
        help: "Switch off the fold guard of the vertex update (on by default: a vertex move may \
               not fold a face over against its filtered normal). Off reproduces the reference \
               implementations and the paper's NormalNet pipeline",
    },
    Flag {
        name: "no-switch",
        value: FlagValue::Off,
        help: "NormalNet: the paper's form instead of the bundle's learned switch (which blends, \
               per face, the network's normal, a pass guided by it, a GNF pass and the current \
               normal)",
    },
    Flag {
        name: "f32",
        value: FlagValue::Off,
        help: "NormalNet: f32 arithmetic throughout (default: the residual blocks' 3³ \
               convolutions in 8-bit integers where the CPU has AVX2 or AVX-512 VNNI)",
    },
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::METHODS;
    use crate::params::MAX_ITERATIONS;

    /// Every flag a method takes is in the table, sets a parameter the
    /// method has, with a value of the parameter's type; every flag in the
    /// table is taken by some method.
    #[test]
    fn the_methods_flags_are_the_table_s() {
        for m in METHODS {
            let defaults = (m.defaults)();
            for &(name, field) in m.flags {
                let f = flag(name).unwrap_or_else(|| panic!("{}: --{name} not in FLAGS", m.name));
                let default = defaults.get(field);
                let fits = match f.value {
                    FlagValue::Count => default.is_some_and(|d| d.is_u64()),
                    FlagValue::Number => default.is_some_and(|d| d.is_number()),
                    FlagValue::Off => default.is_some_and(|d| d.is_boolean()),
                    // an optional path: null by default
                    FlagValue::Path => default.is_some_and(|d| d.is_null() || d.is_string()),
                };
                assert!(fits, "{}: --{name} sets {field} = {default:?}", m.name);
            }
        }
        for f in FLAGS {
            assert!(
                METHODS.iter().any(|m| m.flag_field(f.name).is_some()),
                "--{} is taken by no method",
                f.name
            );
        }
    }

    #[test]
    fn the_pass_caps_in_the_help_are_the_code_s() {
        for name in ["iterations", "vertex-iterations"] {
            assert!(
                flag(name)
                    .unwrap()
                    .help
                    .contains(&MAX_ITERATIONS.to_string())
            );
        }
    }

    #[test]
    fn values_are_parsed_by_kind() {
        let count = flag("iterations").unwrap();
        assert_eq!(count.parse("7"), Ok(Value::from(7u64)));
        assert!(count.parse("-1").unwrap_err().contains("count"));
        let number = flag("mu-g").unwrap();
        assert_eq!(number.parse("0.3"), Ok(Value::from(0.3)));
        assert!(number.parse("nan").unwrap_err().contains("finite"));
        assert_eq!(flag("no-switch").unwrap().parse(""), Ok(Value::Bool(false)));
    }
}
