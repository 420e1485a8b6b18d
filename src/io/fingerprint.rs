//! Canonical text of settings for a configuration hash ([`super::config_hash`]).
//!
//! A setting enters as `tag` followed by its JSON form: struct fields in declaration order, enum
//! variants by name, numbers in their shortest round-trip decimal form (so equal settings give
//! equal text and any change to a value changes it), non-finite numbers as `null`. The form does
//! not depend on the compiler's `Debug` output. `tag` names the setting and its layout version
//! (`slope:v2`): a change of layout changes the tag.

use serde::Serialize;

/// `tag` and the canonical JSON of `value`, separated by a space.
pub fn canonical<T: Serialize + ?Sized>(tag: &str, value: &T) -> String {
    let json = serde_json::to_string(value).expect("settings serialise to JSON");
    format!("{tag} {json}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize)]
    struct S {
        step_m: f64,
        order: usize,
        edge: Option<&'static str>,
    }

    #[test]
    fn canonical_text_is_tagged_json_with_round_trip_numbers() {
        let s = S {
            step_m: 0.1 + 0.2,
            order: 2,
            edge: None,
        };
        assert_eq!(
            canonical("x:v1", &s),
            r#"x:v1 {"step_m":0.30000000000000004,"order":2,"edge":null}"#
        );
        assert_eq!(canonical("y:v1", &f64::NAN), "y:v1 null");
    }
}
