//! The one parameter mechanism: a method's parameters are a serde struct
//! whose `Default` is its reference defaults; callers give a JSON object of
//! the fields they want to change (CLI flags, `--param key=value`, bench
//! settings, Python keyword arguments all become one), which is laid over
//! the defaults key by key. Unknown keys and wrong types are errors naming
//! the parameter and listing the known ones, a number given as something
//! else (`nan`, `inf`, a word) is named with what was expected, and every
//! pass count (a field named `*iterations`, or one of [`OTHER_PASS_COUNTS`])
//! is bounded by [`MAX_ITERATIONS`].

use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::{Map, Value};

use crate::DenoiseError;

/// Parameters given by a caller: field name → value.
pub type Params = Map<String, Value>;

/// The most passes a `*iterations` parameter may ask for (the defaults are
/// 5 to 40): far beyond any useful count, and a typo or a `-1` cast to
/// unsigned (18446744073709551615) is refused instead of running forever.
pub const MAX_ITERATIONS: u64 = 100_000;

/// Pass counts whose names do not end in `iterations`.
pub const OTHER_PASS_COUNTS: [&str; 1] = ["gnf_after"];

/// Whether parameter `key` counts passes (bounded by [`MAX_ITERATIONS`]).
fn is_pass_count(key: &str) -> bool {
    key.ends_with("iterations") || OTHER_PASS_COUNTS.contains(&key)
}

/// The defaults of `P` as a JSON object.
pub fn defaults_of<P: Default + Serialize>() -> Value {
    serde_json::to_value(P::default()).unwrap_or(Value::Null)
}

/// `given` laid over the defaults of `P`.
///
/// # Errors
/// [`DenoiseError::Parameter`] for an unknown key, a value of the wrong type,
/// or a pass count above [`MAX_ITERATIONS`].
pub fn resolve<P: Default + Serialize + DeserializeOwned>(
    method: &'static str,
    given: &Params,
) -> Result<P, DenoiseError> {
    let bad = |message: String| DenoiseError::Parameter { method, message };
    let mut value = defaults_of::<P>();
    let fields = value
        .as_object_mut()
        .ok_or_else(|| bad("parameters are not a struct".into()))?;
    for (key, v) in given {
        if !fields.contains_key(key) {
            let known: Vec<&str> = fields.keys().map(String::as_str).collect();
            return Err(bad(format!(
                "unknown parameter `{key}` (known: {})",
                known.join(", ")
            )));
        }
        // JSON has no NaN or infinity: `-p mu_g=nan` arrives as a string
        if let (Some(default), Value::String(text)) = (fields.get(key), v)
            && default.is_number()
        {
            let what = match text.parse::<f64>() {
                Ok(x) if !x.is_finite() => "not a finite number",
                Ok(_) => "a number given as text (give it without quotes)",
                Err(_) => "expected a number",
            };
            return Err(bad(format!("`{key}` = {text}: {what}")));
        }
        if is_pass_count(key)
            && let Some(n) = v.as_u64()
            && n > MAX_ITERATIONS
        {
            return Err(bad(format!(
                "`{key}` = {n}: at most {MAX_ITERATIONS} passes"
            )));
        }
        fields.insert(key.clone(), v.clone());
    }
    serde_json::from_value(value).map_err(|e| bad(blame::<P>(given, e)))
}

/// Which given key serde refused, and why: each is tried alone over the
/// defaults (serde names the type, "invalid type: string, expected a
/// boolean", not the field).
fn blame<P: Default + Serialize + DeserializeOwned>(
    given: &Params,
    whole: serde_json::Error,
) -> String {
    for (key, v) in given {
        let mut one = defaults_of::<P>();
        if let Some(fields) = one.as_object_mut() {
            fields.insert(key.clone(), v.clone());
        }
        if let Err(e) = serde_json::from_value::<P>(one) {
            let shown = match v {
                Value::String(text) => text.clone(),
                _ => v.to_string(),
            };
            return format!("bad parameter value `{key}` = {shown}: {e}");
        }
    }
    let keys: Vec<&str> = given.keys().map(String::as_str).collect();
    format!("bad parameter value ({whole}; given: {})", keys.join(", "))
}

/// `KEY=VALUE` → (key, value): the value as JSON when it parses as JSON
/// (numbers, `true`, `null`, arrays), a finite number where Rust reads one
/// that JSON does not (`.5`, `5.`, `+1`, `05`), else as a string.
pub fn parse_assignment(text: &str) -> Result<(String, Value), String> {
    let (key, value) = text
        .split_once('=')
        .ok_or_else(|| format!("`{text}`: expected KEY=VALUE"))?;
    let key = key.trim();
    if key.is_empty() {
        return Err(format!("`{text}`: empty key"));
    }
    let value = value.trim();
    let v = serde_json::from_str(value).unwrap_or_else(|_| {
        match value.parse::<f64>().ok().filter(|x| x.is_finite()) {
            Some(x) if x.fract() == 0.0 && x.abs() < 2f64.powi(53) => {
                if x >= 0.0 {
                    Value::from(x as u64)
                } else {
                    Value::from(x as i64)
                }
            }
            Some(x) => Value::from(x),
            None => Value::String(value.to_string()),
        }
    });
    Ok((key.to_string(), v))
}

/// `key=value key=value` of the parameters, for tables and logs.
pub fn describe(params: &Value) -> String {
    match params.as_object() {
        Some(o) => o
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" "),
        None => params.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use normalnet_filters::GnfParams;

    #[test]
    fn given_keys_override_the_defaults_and_typos_are_named() {
        let mut given = Params::new();
        given.insert("mu_g".into(), 0.25.into());
        let p: GnfParams = resolve("gnf", &given).unwrap();
        assert_eq!(p.mu_g, 0.25);
        assert_eq!(p.normal_iterations, GnfParams::default().normal_iterations);
        given.insert("mu".into(), 0.25.into());
        let e = resolve::<GnfParams>("gnf", &given).unwrap_err().to_string();
        assert!(e.contains("`mu`") && e.contains("mu_g"), "{e}");
        let mut wrong = Params::new();
        wrong.insert("mu_g".into(), "wide".into());
        let e = resolve::<GnfParams>("gnf", &wrong).unwrap_err().to_string();
        assert!(e.contains("`mu_g` = wide: expected a number"), "{e}");
        let mut wrong = Params::new();
        wrong.insert("fold_guard".into(), 3.into());
        let e = resolve::<GnfParams>("gnf", &wrong).unwrap_err().to_string();
        assert!(
            e.starts_with("gnf: bad parameter value") && e.contains("fold_guard"),
            "{e}"
        );
    }

    /// Audit: `-p mu_g=nan` said "invalid type: string \"nan\", expected f64".
    #[test]
    fn non_finite_numbers_are_named() {
        for text in ["nan", "inf", "-inf", "NaN"] {
            let (key, v) = parse_assignment(&format!("mu_g={text}")).unwrap();
            let given = Params::from_iter([(key, v)]);
            let e = resolve::<GnfParams>("gnf", &given).unwrap_err().to_string();
            assert!(
                e.contains(&format!("`mu_g` = {text}: not a finite number")),
                "{e}"
            );
        }
    }

    /// Audit: `-p freeze_deg=0.5 -p fold_guard=nan` said "invalid type:
    /// string \"nan\", expected a boolean; given: freeze_deg, fold_guard".
    #[test]
    fn the_refused_key_is_named() {
        let given = Params::from_iter([
            ("freeze_deg".to_string(), Value::from(0.5)),
            parse_assignment("fold_guard=nan").unwrap(),
        ]);
        let e = resolve::<crate::normalnet::NormalnetParams>("normalnet", &given)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("normalnet: bad parameter value `fold_guard` = nan: invalid type"),
            "{e}"
        );
        assert!(
            e.contains("expected a boolean") && !e.contains("freeze_deg"),
            "{e}"
        );
    }

    /// Review: `"0.5"` as text (Python, or quoted JSON) was called "not a
    /// finite number".
    #[test]
    fn numbers_given_as_text_are_named_so() {
        let given = Params::from_iter([("mu_g".to_string(), Value::from("0.5"))]);
        let e = resolve::<GnfParams>("gnf", &given).unwrap_err().to_string();
        assert!(e.contains("`mu_g` = 0.5: a number given as text"), "{e}");
        let (key, v) = parse_assignment("mu_g=.5").unwrap();
        let p: GnfParams = resolve("gnf", &Params::from_iter([(key, v)])).unwrap();
        assert_eq!(p.mu_g, 0.5);
    }

    /// Audit: `--vertex-iterations 18446744073709551615` ran forever.
    #[test]
    fn pass_counts_are_bounded() {
        let mut given = Params::new();
        given.insert("vertex_iterations".into(), MAX_ITERATIONS.into());
        assert!(resolve::<GnfParams>("gnf", &given).is_ok());
        given.insert("vertex_iterations".into(), u64::MAX.into());
        let e = resolve::<GnfParams>("gnf", &given).unwrap_err().to_string();
        assert!(
            e.contains("`vertex_iterations` = 18446744073709551615: at most 100000"),
            "{e}"
        );
    }

    /// Audit: `-p gnf_after=100000000` (NormalNet) ran GNF for hours.
    #[test]
    fn gnf_after_is_a_bounded_pass_count() {
        let given = Params::from_iter([("gnf_after".to_string(), Value::from(100_000_000u64))]);
        let e = resolve::<crate::normalnet::NormalnetParams>("normalnet", &given)
            .unwrap_err()
            .to_string();
        assert!(e.contains("`gnf_after` = 100000000: at most 100000"), "{e}");
    }

    #[test]
    fn assignments_parse_json_or_strings() {
        assert_eq!(
            parse_assignment("mu_g=0.3").unwrap(),
            ("mu_g".into(), 0.3.into())
        );
        assert_eq!(
            parse_assignment("model=models/x").unwrap(),
            ("model".into(), "models/x".into())
        );
        assert_eq!(
            parse_assignment("fold_guard=false").unwrap(),
            ("fold_guard".into(), false.into())
        );
        // numbers JSON does not read, as Rust reads them
        for (text, v) in [
            ("mu_g=.5", Value::from(0.5)),
            ("mu_g=5.", Value::from(5u64)),
            ("n=+1", Value::from(1u64)),
            ("n=05", Value::from(5u64)),
            ("x=-.25", Value::from(-0.25)),
        ] {
            assert_eq!(parse_assignment(text).unwrap().1, v, "{text}");
        }
        assert_eq!(parse_assignment("mu_g=nan").unwrap().1, Value::from("nan"));
        assert!(parse_assignment("nothing").is_err());
        assert!(parse_assignment("=1").is_err());
    }
}
