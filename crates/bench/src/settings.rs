//! The bench's settings: per method defaults and per model overrides of the
//! methods' parameters, pictures' cameras and skipped methods.

use anyhow::{Context, bail};
use normalnet_denoise::params::describe;
use normalnet_denoise::{Denoiser, Params};
use std::path::Path;

/// The settings shipped with the repository (used when no settings file is
/// given and `configs/bench.toml` is not in the working directory).
pub const BUILTIN_SETTINGS: &str = include_str!("../../../configs/bench.toml");

/// The NormalNet method's name in the method list.
pub const NORMALNET: &str = "normalnet";

/// The oracle's name in the method list: GT-guided GNF (guidance = the
/// ground truth's normals), NormalNet's training target run as a denoiser,
/// i.e. the ceiling a perfect CNN would reach (MEASURED.md). It reads the
/// ground truth, so it is shown for reference and never ranked.
pub const ORACLE: &str = "oracle";

/// Parsed settings file.
#[derive(Debug, Default)]
pub struct Settings {
    pub(crate) source: String,
    defaults: toml::Table,
    models: toml::Table,
}

impl Settings {
    /// Parses settings text; `source` names it in errors.
    pub fn parse(text: &str, source: &str) -> anyhow::Result<Settings> {
        let mut table: toml::Table = text
            .parse()
            .with_context(|| format!("{source}: invalid TOML"))?;
        let take = |table: &mut toml::Table, key: &str| -> anyhow::Result<toml::Table> {
            match table.remove(key) {
                None => Ok(toml::Table::new()),
                Some(toml::Value::Table(t)) => Ok(t),
                Some(_) => bail!("{source}: `{key}` must be a table"),
            }
        };
        let defaults = take(&mut table, "defaults")?;
        let models = take(&mut table, "models")?;
        if let Some(key) = table.keys().next() {
            bail!(
                "{source}: unknown top-level key `{key}` (expected [defaults.METHOD] or [models.\"MODEL\".METHOD])"
            );
        }
        let known = |m: &str| base_method(m).is_some();
        for (method, v) in &defaults {
            if !known(method) {
                bail!("{source}: [defaults.{method}]: unknown method `{method}`");
            }
            if !v.is_table() {
                bail!("{source}: [defaults.{method}] must be a table");
            }
        }
        for (model, v) in &models {
            let Some(t) = v.as_table() else {
                bail!("{source}: [models.\"{model}\"] must be a table");
            };
            for (key, v) in t {
                if key == "view" {
                    view_from_toml(v)
                        .with_context(|| format!("{source}: [models.\"{model}\"] view"))?;
                } else if key == "skip" {
                    let names = v
                        .as_array()
                        .map(|a| a.iter().map(|x| x.as_str()).collect::<Option<Vec<_>>>());
                    let Some(Some(names)) = names else {
                        bail!("{source}: [models.\"{model}\"] skip must be a list of method names");
                    };
                    if let Some(bad) = names.iter().find(|m| !known(m)) {
                        bail!("{source}: [models.\"{model}\"] skip: unknown method `{bad}`");
                    }
                } else if !known(key) {
                    bail!("{source}: [models.\"{model}\"]: unknown method `{key}`");
                } else if !v.is_table() {
                    bail!("{source}: [models.\"{model}\".{key}] must be a table");
                }
            }
        }
        Ok(Settings {
            source: source.to_string(),
            defaults,
            models,
        })
    }

    /// Loads `path`, or `./configs/bench.toml`, or the built-in copy.
    pub fn load(path: Option<&Path>) -> anyhow::Result<Settings> {
        match path {
            Some(p) => {
                let text = std::fs::read_to_string(p)
                    .with_context(|| format!("reading settings {}", p.display()))?;
                Settings::parse(&text, &p.display().to_string())
            }
            None => {
                let local = Path::new("configs/bench.toml");
                if local.is_file() {
                    Settings::load(Some(local))
                } else {
                    Settings::parse(BUILTIN_SETTINGS, "built-in configs/bench.toml")
                }
            }
        }
    }

    /// The overrides for `method` on `model`: defaults, then the model's own,
    /// each with where it came from (for error messages).
    fn overrides(&self, model: &str, method: &str) -> Vec<(String, toml::Table)> {
        let mut out = Vec::new();
        if let Some(t) = self.defaults.get(method).and_then(|v| v.as_table()) {
            out.push((format!("{}: [defaults.{method}]", self.source), t.clone()));
        }
        if let Some(t) = self
            .models
            .get(model)
            .and_then(|m| m.get(method))
            .and_then(|v| v.as_table())
        {
            out.push((
                format!("{}: [models.\"{model}\".{method}]", self.source),
                t.clone(),
            ));
        }
        out
    }

    /// Whether the settings skip `method` on `model` (`[models."MODEL"] skip = [...]`).
    pub(crate) fn skips(&self, model: &str, method: &str) -> bool {
        self.models
            .get(model)
            .and_then(|m| m.get("skip"))
            .and_then(|v| v.as_array())
            .is_some_and(|a| a.iter().any(|x| x.as_str() == Some(method)))
    }

    /// The picture camera of `model`, if the settings give one.
    pub(crate) fn view(&self, model: &str) -> Option<(f64, f64)> {
        self.models
            .get(model)
            .and_then(|m| m.get("view"))
            .and_then(|v| view_from_toml(v).ok())
    }

    /// The parameters column `column` gives on `model`: its base method
    /// (the column's name, or the method a variant `METHOD-NAME` runs), the
    /// settings laid over each other (defaults, then the model's), and where
    /// they came from. The oracle starts from the N_f / N_v / μ_g of the
    /// model's NormalNet settings (it is a perfect NormalNet).
    pub fn params(
        &self,
        model: &str,
        column: &str,
    ) -> anyhow::Result<(&'static str, Params, String)> {
        let base = base_method(column).with_context(|| format!("unknown method `{column}`"))?;
        let mut params = Params::new();
        let mut sources = Vec::new();
        if base == ORACLE {
            for (source, table) in self.overrides(model, NORMALNET) {
                for (key, v) in table {
                    if ["iterations", "vertex_iterations", "mu_g"].contains(&key.as_str()) {
                        params.insert(key, serde_json::to_value(v)?);
                        sources.push(source.clone());
                    }
                }
            }
        }
        for (source, table) in self.overrides(model, column) {
            for (key, v) in table {
                params.insert(key, serde_json::to_value(v)?);
            }
            sources.push(source);
        }
        sources.dedup();
        Ok((base, params, sources.join(", ")))
    }

    /// The denoiser column `column` runs on `model` ([`Settings::params`]),
    /// and a one-line description of its parameters.
    pub fn denoiser(&self, model: &str, column: &str) -> anyhow::Result<(Denoiser, String)> {
        let (base, params, sources) = self.params(model, column)?;
        let d = Denoiser::new(base, &params).with_context(|| {
            format!(
                "settings for {column} on {model} (from {})",
                if sources.is_empty() {
                    "defaults"
                } else {
                    &sources
                }
            )
        })?;
        let described = describe(&d.parameters());
        Ok((d, described))
    }
}

/// The method a column name runs: the name itself when it is `normalnet` or
/// a classical method, else the part before the first `-` when that is one
/// (a variant such as `gnf-ref` or `l0-lambda0.1`, with its own settings).
pub fn base_method(name: &str) -> Option<&'static str> {
    let known = |m: &str| normalnet_denoise::find(m).ok().map(|i| i.name);
    if let Some(base) = known(name) {
        return Some(base);
    }
    let (prefix, _) = name.split_once('-')?;
    known(prefix)
}

fn view_from_toml(v: &toml::Value) -> anyhow::Result<(f64, f64)> {
    let a = v
        .as_array()
        .filter(|a| a.len() == 2)
        .context("expected [azimuth, elevation]")?;
    let num = |x: &toml::Value| x.as_float().or_else(|| x.as_integer().map(|i| i as f64));
    let az = num(&a[0]).context("azimuth must be a number")?;
    let el = num(&a[1]).context("elevation must be a number")?;
    if !az.is_finite() || !(-90.0..=90.0).contains(&el) {
        bail!("elevation must be within -90..=90, got {el}");
    }
    Ok((az, el))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn given(s: &Settings, model: &str, column: &str) -> Params {
        s.params(model, column).unwrap().1
    }

    /// A recipe's `evaluate` stage runs NormalNet as `normalnet bench
    /// --suite` does, so its figures compare with bench runs.
    #[test]
    fn recipe_evaluation_runs_the_bench_settings() {
        let s = Settings::parse(BUILTIN_SETTINGS, "builtin").unwrap();
        let (bench, _) = s.denoiser("a-suite-pair", NORMALNET).unwrap();
        let params = normalnet_denoise::recipe::evaluate_params(&Params::new());
        let stage = Denoiser::new(NORMALNET, &params).unwrap();
        assert_eq!(bench.parameters(), stage.parameters());
        assert_eq!(stage.parameters()["auto_stop_deg"], 0.0);
    }

    #[test]
    fn builtin_settings_parse_and_apply_table_2() {
        let s = Settings::parse(BUILTIN_SETTINGS, "builtin").unwrap();
        let nn = |model: &str| {
            let p = given(&s, model, NORMALNET);
            (
                p["iterations"].clone(),
                p["vertex_iterations"].clone(),
                p["mu_g"].clone(),
            )
        };
        assert_eq!(nn("Fandisk0.3"), (10.into(), 20.into(), 0.25.into()));
        assert_eq!(nn("Bunny0.2"), (2.into(), 5.into(), 0.3.into()));
        assert_eq!(nn("SharpSphere0.3"), (10.into(), 20.into(), 0.35.into()));
        let (d, desc) = s.denoiser("Fandisk0.3", NORMALNET).unwrap();
        assert_eq!(d.name(), NORMALNET);
        assert!(desc.contains("mu_g=0.25"), "{desc}");
        let (_, desc) = s.denoiser("Twelve0.5Impulsive", "gnf").unwrap();
        assert!(
            desc.contains("normal_iterations=25") && desc.contains("mu_g=0.3"),
            "{desc}"
        );
    }

    #[test]
    fn variants_run_their_base_method_with_their_own_settings() {
        assert_eq!(base_method("gnf"), Some("gnf"));
        assert_eq!(base_method("gnf-ref"), Some("gnf"));
        assert_eq!(base_method("normalnet-fast"), Some(NORMALNET));
        assert_eq!(base_method("gt-gnf"), Some(ORACLE));
        assert_eq!(base_method("nosuch-x"), None);
        assert_eq!(base_method("gnfx"), None);
        let s = Settings::parse(
            "[defaults.gnf]\nmu_g = 0.25\n[defaults.\"gnf-ref\"]\nnormal_iterations = 3\n",
            "f.toml",
        )
        .unwrap();
        let (_, plain) = s.denoiser("M", "gnf").unwrap();
        let (_, variant) = s.denoiser("M", "gnf-ref").unwrap();
        assert!(
            plain.contains("mu_g=0.25") && plain.contains("normal_iterations=20"),
            "{plain}"
        );
        assert!(
            variant.contains("mu_g=0.35") && variant.contains("normal_iterations=3"),
            "{variant}"
        );
    }

    #[test]
    fn oracle_follows_the_normalnet_settings_then_its_own() {
        let s = Settings::parse(BUILTIN_SETTINGS, "builtin").unwrap();
        let (d, desc) = s.denoiser("Block0.4", ORACLE).unwrap();
        let p = d.parameters();
        assert_eq!(
            (
                p["iterations"].clone(),
                p["vertex_iterations"].clone(),
                p["mu_g"].clone()
            ),
            (20.into(), 30.into(), 0.3.into())
        );
        assert!(desc.contains("sigma_s_over_ds=2.0"), "{desc}");
        let s = Settings::parse(
            "[defaults.normalnet]\niterations = 4\nmodel = \"x\"\n[defaults.oracle]\nmu_g = 0.5\n",
            "f.toml",
        )
        .unwrap();
        let p = given(&s, "M", ORACLE);
        assert_eq!(
            (p["iterations"].clone(), p["mu_g"].clone()),
            (4.into(), 0.5.into())
        );
        assert!(p.get("model").is_none());
        let s = Settings::parse("[defaults.oracle]\nbogus = 1\n", "f.toml").unwrap();
        assert!(s.denoiser("M", ORACLE).is_err());
    }

    #[test]
    fn bad_settings_name_the_place() {
        let e = Settings::parse("[defaults.nosuch]\nx = 1\n", "f.toml").unwrap_err();
        assert!(
            format!("{e:#}").contains("f.toml: [defaults.nosuch]"),
            "{e:#}"
        );
        let s = Settings::parse("[models.\"M\".gnf]\nitersx = 3\n", "f.toml").unwrap();
        let e = s.denoiser("M", "gnf").unwrap_err();
        let e = format!("{e:#}");
        assert!(
            e.contains("unknown parameter `itersx`") && e.contains("f.toml: [models.\"M\".gnf]"),
            "{e}"
        );
        let s = Settings::parse("[defaults.normalnet]\nmu_g = \"a\"\n", "f.toml").unwrap();
        assert!(s.denoiser("M", NORMALNET).is_err());
        assert!(Settings::parse("[models.\"M\"]\nview = [0, 100]\n", "f.toml").is_err());
        assert!(Settings::parse("[models.\"M\"]\nskip = [\"nosuch\"]\n", "f.toml").is_err());
        let s = Settings::parse("[models.\"M\"]\nskip = [\"normalnet\"]\n", "f.toml").unwrap();
        assert!(s.skips("M", "normalnet") && !s.skips("M", "gnf") && !s.skips("N", "normalnet"));
    }
}
