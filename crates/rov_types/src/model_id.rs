//! Which vehicle model: the one identity type and its one parser.
//!
//! A model is one of the three published base models, named `model1`, `model2` or
//! `model3` ([`BaseModel`]), or a model file (`FILE.toml`, for example one the model lab
//! extended and saved) ([`ModelId::File`]). Every command line and configuration that
//! names a model parses it with [`ModelId`]'s `FromStr`; the controller's
//! `ModelChoice` is [`BaseModel`]. No I/O: a file is only named here.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

/// One of the three published VideoRay Pro 4 models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum BaseModel {
    /// Enevoldsen et al. 2018: decoupled 1-DOF equations with α/β tuning factors.
    Model1,
    /// Arnesen 2016: Fossen 3-DOF with a linear thrust map.
    Model2,
    /// Mai et al. 2017: 6-DOF Fossen model.
    #[default]
    Model3,
}

impl BaseModel {
    /// All three, in order.
    pub const ALL: [BaseModel; 3] = [BaseModel::Model1, BaseModel::Model2, BaseModel::Model3];

    /// Their names, in the same order.
    pub const NAMES: [&'static str; 3] = ["model1", "model2", "model3"];

    /// `model1`, `model2` or `model3`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            BaseModel::Model1 => "model1",
            BaseModel::Model2 => "model2",
            BaseModel::Model3 => "model3",
        }
    }

    /// Parses `model1`, `model2` or `model3` (exactly).
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }
}

impl fmt::Display for BaseModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A model: a base model by name or a model file.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum ModelId {
    /// A shipped base model.
    Base(BaseModel),
    /// A model file (TOML), for example one the model lab saved.
    File(PathBuf),
}

/// A model name that is neither a base model nor a `.toml` file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown model {value:?}: expected model1, model2, model3 or a FILE.toml")]
pub struct ModelIdError {
    /// What was given.
    pub value: String,
}

impl FromStr for ModelId {
    type Err = ModelIdError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if let Some(base) = BaseModel::from_name(s) {
            return Ok(ModelId::Base(base));
        }
        let is_toml = std::path::Path::new(s)
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
        if is_toml {
            Ok(ModelId::File(PathBuf::from(s)))
        } else {
            Err(ModelIdError {
                value: s.to_string(),
            })
        }
    }
}

impl fmt::Display for ModelId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ModelId::Base(b) => b.fmt(f),
            ModelId::File(p) => write!(f, "{}", p.display()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_four_forms_parse_and_print_back() {
        for b in BaseModel::ALL {
            let id: ModelId = b.name().parse().unwrap();
            assert_eq!(id, ModelId::Base(b));
            assert_eq!(id.to_string(), b.name());
        }
        let f: ModelId = "lab/learned.TOML".parse().unwrap();
        assert_eq!(f, ModelId::File(PathBuf::from("lab/learned.TOML")));
        assert_eq!(f.to_string(), "lab/learned.TOML");
        assert_eq!(
            BaseModel::NAMES
                .map(BaseModel::from_name)
                .map(Option::unwrap),
            BaseModel::ALL
        );
        assert_eq!(BaseModel::default(), BaseModel::Model3);
    }

    #[test]
    fn anything_else_is_refused_with_the_value() {
        for bad in ["model4", "Model1", "", "learned.json", "toml"] {
            let e = bad.parse::<ModelId>().unwrap_err();
            assert_eq!(e.value, bad);
            assert!(
                e.to_string()
                    .contains("model1, model2, model3 or a FILE.toml")
            );
        }
    }
}
