//! A setting outside the range its model accepts: the error every configuration's `validate`
//! returns, so that a command line, a pipeline file and library code report a bad value alike.
//!
//! The name is the setting's key as it is written in configuration files (`window_s`); a
//! command-line flag is the same key with dashes (`--window-s`).

/// A setting outside its valid range: its key, the value given and the rule it breaks.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{name} = {value}: {rule}")]
pub struct InvalidSetting {
    /// Key of the setting, with its unit suffix (`window_s`, `min_km`).
    pub name: &'static str,
    /// The value given, as text.
    pub value: String,
    /// The rule it breaks, in words (`must be positive`).
    pub rule: &'static str,
}

impl InvalidSetting {
    /// `name = value` breaks `rule`.
    pub fn new(name: &'static str, value: impl ToString, rule: &'static str) -> Self {
        Self {
            name,
            value: value.to_string(),
            rule,
        }
    }

    /// The setting as a command-line flag: `--window-s`.
    pub fn flag(&self) -> String {
        format!("--{}", self.name.replace('_', "-"))
    }
}

/// `Ok` when `check` holds for `value`, else the [`InvalidSetting`].
pub fn require<T: ToString>(
    check: bool,
    name: &'static str,
    value: T,
    rule: &'static str,
) -> Result<(), InvalidSetting> {
    if check {
        Ok(())
    } else {
        Err(InvalidSetting::new(name, value, rule))
    }
}
