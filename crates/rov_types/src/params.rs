//! Validated TOML parameter files.
//!
//! A parameter is either a bare value (`kp = 1.5`) or, in model files where provenance is
//! required, an inline table that carries its unit and source:
//!
//! ```toml
//! [rigid_body]
//! mass_kg = { value = 6.1, unit = "kg", source = "paper (VideoRay spec sheet)" }
//! ```
//!
//! Every read names the key path and the allowed range, so a bad file fails with a message
//! such as `config/models/model3.toml: key rigid_body.mass_kg = -1 is out of range (allowed
//! 0.1..=100)`. Keys that a loader never read can be reported with
//! [`ParamFile::reject_unknown`], so that a typo does not silently fall back to a default.

use std::cell::RefCell;
use std::collections::BTreeSet;
use std::fmt;
use std::ops::RangeInclusive;

/// An error in a configuration or parameter file. Every variant names the file and,
/// where there is one, the key path.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// The text is not valid TOML.
    #[error("{file}: not valid TOML: {message}")]
    Syntax {
        /// File label.
        file: String,
        /// The parser's message, with line and column.
        message: String,
    },
    /// A required key is absent.
    #[error("{file}: key {key} is missing (allowed {allowed})")]
    Missing {
        /// File label.
        file: String,
        /// Full dotted key path.
        key: String,
        /// What would have been accepted.
        allowed: String,
    },
    /// The key holds a value of the wrong type.
    #[error("{file}: key {key} = {value} has the wrong type (expected {expected})")]
    WrongType {
        /// File label.
        file: String,
        /// Full dotted key path.
        key: String,
        /// The value as written.
        value: String,
        /// The expected type.
        expected: String,
    },
    /// The value is non-finite or outside its allowed range.
    #[error("{file}: key {key} = {value} is out of range (allowed {allowed})")]
    OutOfRange {
        /// File label.
        file: String,
        /// Full dotted key path.
        key: String,
        /// The value as written.
        value: String,
        /// The allowed range or set.
        allowed: String,
    },
    /// A parameter table lacks its `unit` or `source`.
    #[error(
        "{file}: key {key} lacks its {field} (every model parameter carries a unit and a source)"
    )]
    MissingProvenance {
        /// File label.
        file: String,
        /// Full dotted key path.
        key: String,
        /// `unit` or `source`.
        field: String,
    },
    /// A key that no loader reads (most likely a typo).
    #[error("{file}: key {key} is not a known setting (allowed keys here: {allowed})")]
    UnknownKey {
        /// File label.
        file: String,
        /// Full dotted key path.
        key: String,
        /// The known keys of the same table.
        allowed: String,
    },
    /// Two values that are each valid but do not fit together.
    #[error("{file}: {message}")]
    Inconsistent {
        /// File label.
        file: String,
        /// What does not fit.
        message: String,
    },
}

/// One parameter as read: its value with its documented unit and source.
#[derive(Debug, Clone, PartialEq)]
pub struct Param<T> {
    /// The value.
    pub value: T,
    /// Unit as written in the file (empty for bare values).
    pub unit: String,
    /// Source as written in the file (empty for bare values).
    pub source: String,
}

/// A parsed TOML parameter file with a label (usually its path) for error messages.
#[derive(Debug)]
pub struct ParamFile {
    file: String,
    root: toml::Table,
    require_provenance: bool,
    read_keys: RefCell<BTreeSet<String>>,
}

fn fmt_range(range: &RangeInclusive<f64>) -> String {
    format!("{}..={}", range.start(), range.end())
}

struct ShowValue<'a>(&'a toml::Value);

impl fmt::Display for ShowValue<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            toml::Value::String(s) => write!(f, "{s:?}"),
            toml::Value::Float(x) => write!(f, "{x}"),
            other => write!(f, "{other}"),
        }
    }
}

impl ParamFile {
    /// Parses `text`; `file` labels every error. With `require_provenance`, numeric
    /// parameters must be `{ value, unit, source }` tables.
    pub fn parse(text: &str, file: &str, require_provenance: bool) -> Result<Self, ConfigError> {
        let root: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| ConfigError::Syntax {
                file: file.to_string(),
                message: e.to_string().trim().to_string(),
            })?;
        Ok(Self {
            file: file.to_string(),
            root,
            require_provenance,
            read_keys: RefCell::new(BTreeSet::new()),
        })
    }

    /// The label used in errors.
    pub fn file(&self) -> &str {
        &self.file
    }

    fn lookup(&self, key: &str) -> Option<&toml::Value> {
        let mut parts = key.split('.');
        let first = parts.next()?;
        let mut value = self.root.get(first)?;
        for part in parts {
            value = value.as_table()?.get(part)?;
        }
        Some(value)
    }

    /// Whether `key` is present.
    pub fn has(&self, key: &str) -> bool {
        self.lookup(key).is_some()
    }

    fn mark(&self, key: &str) {
        self.read_keys.borrow_mut().insert(key.to_string());
    }

    fn err_missing(&self, key: &str, allowed: String) -> ConfigError {
        ConfigError::Missing {
            file: self.file.clone(),
            key: key.to_string(),
            allowed,
        }
    }

    fn err_type(&self, key: &str, value: &toml::Value, expected: &str) -> ConfigError {
        ConfigError::WrongType {
            file: self.file.clone(),
            key: key.to_string(),
            value: ShowValue(value).to_string(),
            expected: expected.to_string(),
        }
    }

    /// Splits a parameter into (value, unit, source), enforcing provenance if required.
    fn unpack<'a>(
        &self,
        key: &str,
        raw: &'a toml::Value,
    ) -> Result<(&'a toml::Value, String, String), ConfigError> {
        if let Some(table) = raw.as_table()
            && let Some(v) = table.get("value")
        {
            let unit = table
                .get("unit")
                .and_then(|u| u.as_str())
                .map(str::to_string);
            let source = table
                .get("source")
                .and_then(|u| u.as_str())
                .map(str::to_string);
            if self.require_provenance {
                if unit.is_none() {
                    return Err(ConfigError::MissingProvenance {
                        file: self.file.clone(),
                        key: key.to_string(),
                        field: "unit".into(),
                    });
                }
                if source.as_deref().is_none_or(str::is_empty) {
                    return Err(ConfigError::MissingProvenance {
                        file: self.file.clone(),
                        key: key.to_string(),
                        field: "source".into(),
                    });
                }
            }
            return Ok((v, unit.unwrap_or_default(), source.unwrap_or_default()));
        }
        if self.require_provenance {
            return Err(ConfigError::MissingProvenance {
                file: self.file.clone(),
                key: key.to_string(),
                field: "unit".into(),
            });
        }
        Ok((raw, String::new(), String::new()))
    }

    fn to_f64(&self, key: &str, v: &toml::Value) -> Result<f64, ConfigError> {
        match v {
            toml::Value::Float(x) => Ok(*x),
            toml::Value::Integer(i) => Ok(*i as f64),
            other => Err(self.err_type(key, other, "a number")),
        }
    }

    fn check_range(
        &self,
        key: &str,
        x: f64,
        range: &RangeInclusive<f64>,
    ) -> Result<(), ConfigError> {
        if !x.is_finite() || !range.contains(&x) {
            return Err(ConfigError::OutOfRange {
                file: self.file.clone(),
                key: key.to_string(),
                value: format!("{x}"),
                allowed: fmt_range(range),
            });
        }
        Ok(())
    }

    /// A required finite number within `range`, with its unit and source.
    pub fn param(&self, key: &str, range: RangeInclusive<f64>) -> Result<Param<f64>, ConfigError> {
        self.mark(key);
        let raw = self
            .lookup(key)
            .ok_or_else(|| self.err_missing(key, fmt_range(&range)))?;
        let (v, unit, source) = self.unpack(key, raw)?;
        let x = self.to_f64(key, v)?;
        self.check_range(key, x, &range)?;
        Ok(Param {
            value: x,
            unit,
            source,
        })
    }

    /// A required finite number within `range`.
    pub fn f64(&self, key: &str, range: RangeInclusive<f64>) -> Result<f64, ConfigError> {
        self.param(key, range).map(|p| p.value)
    }

    /// An optional number: `default` when absent, else checked like [`Self::f64`].
    pub fn f64_or(
        &self,
        key: &str,
        range: RangeInclusive<f64>,
        default: f64,
    ) -> Result<f64, ConfigError> {
        if self.has(key) {
            self.f64(key, range)
        } else {
            self.mark(key);
            Ok(default)
        }
    }

    /// A required array of exactly `N` finite numbers, each within `range`.
    pub fn array<const N: usize>(
        &self,
        key: &str,
        range: RangeInclusive<f64>,
    ) -> Result<[f64; N], ConfigError> {
        self.mark(key);
        let raw = self.lookup(key).ok_or_else(|| {
            self.err_missing(key, format!("{N} numbers in {}", fmt_range(&range)))
        })?;
        let (v, _, _) = self.unpack(key, raw)?;
        let arr = v
            .as_array()
            .ok_or_else(|| self.err_type(key, v, &format!("an array of {N} numbers")))?;
        if arr.len() != N {
            return Err(self.err_type(key, v, &format!("an array of {N} numbers")));
        }
        let mut out = [0.0; N];
        for (i, (slot, item)) in out.iter_mut().zip(arr.iter()).enumerate() {
            let item_key = format!("{key}[{i}]");
            let x = self.to_f64(&item_key, item)?;
            self.check_range(&item_key, x, &range)?;
            *slot = x;
        }
        Ok(out)
    }

    /// A required string.
    pub fn string(&self, key: &str) -> Result<String, ConfigError> {
        self.mark(key);
        let raw = self
            .lookup(key)
            .ok_or_else(|| self.err_missing(key, "a string".into()))?;
        raw.as_str()
            .map(str::to_string)
            .ok_or_else(|| self.err_type(key, raw, "a string"))
    }

    /// An optional string.
    pub fn string_or(&self, key: &str, default: &str) -> Result<String, ConfigError> {
        if self.has(key) {
            self.string(key)
        } else {
            self.mark(key);
            Ok(default.to_string())
        }
    }

    /// A string that must be one of `choices`.
    pub fn choice(
        &self,
        key: &str,
        choices: &[&str],
        default: Option<&str>,
    ) -> Result<String, ConfigError> {
        let s = match (self.has(key), default) {
            (false, Some(d)) => {
                self.mark(key);
                return Ok(d.to_string());
            }
            _ => self.string(key)?,
        };
        if choices.contains(&s.as_str()) {
            Ok(s)
        } else {
            Err(ConfigError::OutOfRange {
                file: self.file.clone(),
                key: key.to_string(),
                value: format!("{s:?}"),
                allowed: format!("one of {}", choices.join(", ")),
            })
        }
    }

    /// An optional boolean.
    pub fn bool_or(&self, key: &str, default: bool) -> Result<bool, ConfigError> {
        self.mark(key);
        match self.lookup(key) {
            None => Ok(default),
            Some(raw) => {
                let (v, _, _) = self
                    .unpack(key, raw)
                    .or_else(|_| Ok((raw, String::new(), String::new())))?;
                v.as_bool()
                    .ok_or_else(|| self.err_type(key, v, "true or false"))
            }
        }
    }

    /// Reports the first key under `table` (a dotted path, or "" for the root) that was
    /// never read. Parameter tables (`{ value, unit, source }`) count as one key.
    pub fn reject_unknown(&self, table: &str) -> Result<(), ConfigError> {
        let read = self.read_keys.borrow();
        let base = if table.is_empty() {
            Some(&self.root)
        } else {
            self.lookup(table).and_then(|v| v.as_table())
        };
        let Some(base) = base else { return Ok(()) };
        let mut stack: Vec<(String, &toml::Table)> = vec![(table.to_string(), base)];
        while let Some((prefix, tbl)) = stack.pop() {
            for (k, v) in tbl {
                let path = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                if read.contains(&path) {
                    continue;
                }
                match v.as_table() {
                    Some(sub) if !sub.contains_key("value") => stack.push((path, sub)),
                    _ => {
                        let allowed: Vec<String> = read
                            .iter()
                            .filter(|r| {
                                r.rsplit_once('.').map(|(p, _)| p).unwrap_or("") == prefix.as_str()
                            })
                            .map(|r| r.rsplit('.').next().unwrap_or(r).to_string())
                            .collect();
                        return Err(ConfigError::UnknownKey {
                            file: self.file.clone(),
                            key: path,
                            allowed: if allowed.is_empty() {
                                "none".into()
                            } else {
                                allowed.join(", ")
                            },
                        });
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODEL: &str = r#"
[rigid_body]
mass_kg = { value = 6.1, unit = "kg", source = "paper" }
bad = { value = nan, unit = "kg", source = "x" }
nounit = { value = 1.0, source = "x" }
r_g_m = { value = [0.0, 0.0, 0.00559], unit = "m", source = "paper" }
"#;

    #[test]
    fn reads_param_with_provenance() {
        let f = ParamFile::parse(MODEL, "model3.toml", true).unwrap();
        let p = f.param("rigid_body.mass_kg", 0.1..=100.0).unwrap();
        assert_eq!(p.value, 6.1);
        assert_eq!(p.unit, "kg");
        assert_eq!(p.source, "paper");
        let r: [f64; 3] = f.array("rigid_body.r_g_m", -1.0..=1.0).unwrap();
        assert_eq!(r[2], 0.00559);
    }

    #[test]
    fn errors_name_file_key_value_and_range() {
        let f = ParamFile::parse(MODEL, "model3.toml", true).unwrap();
        let e = f.f64("rigid_body.mass_kg", 10.0..=100.0).unwrap_err();
        assert_eq!(
            e.to_string(),
            "model3.toml: key rigid_body.mass_kg = 6.1 is out of range (allowed 10..=100)"
        );
        let e = f.f64("rigid_body.bad", 0.0..=1.0).unwrap_err();
        assert!(e.to_string().contains("rigid_body.bad = NaN"), "{e}");
        let e = f.f64("rigid_body.missing", 0.0..=1.0).unwrap_err();
        assert!(matches!(e, ConfigError::Missing { .. }));
        assert!(e.to_string().contains("rigid_body.missing"));
        let e = f.f64("rigid_body.nounit", 0.0..=2.0).unwrap_err();
        assert!(matches!(e, ConfigError::MissingProvenance { .. }), "{e}");
    }

    #[test]
    fn syntax_error_is_reported_with_file() {
        let e = ParamFile::parse("a = [1, ", "x.toml", false).unwrap_err();
        assert!(e.to_string().starts_with("x.toml: not valid TOML"), "{e}");
    }

    #[test]
    fn unknown_keys_are_rejected() {
        let text = "[control]\nkp = 1.0\nkq = 2.0\n";
        let f = ParamFile::parse(text, "station.toml", false).unwrap();
        assert_eq!(f.f64("control.kp", 0.0..=10.0).unwrap(), 1.0);
        let e = f.reject_unknown("").unwrap_err();
        assert_eq!(
            e.to_string(),
            "station.toml: key control.kq is not a known setting (allowed keys here: kp)"
        );
    }

    #[test]
    fn choices_and_defaults() {
        let f = ParamFile::parse("mode = \"fast\"\n", "s.toml", false).unwrap();
        assert!(f.choice("mode", &["rk4", "euler"], None).is_err());
        assert_eq!(f.f64_or("gain", 0.0..=1.0, 0.5).unwrap(), 0.5);
        assert!(f.bool_or("flag", true).unwrap());
    }
}
