//! JSON for floating-point fields that may be NaN: JSON has no NaN, and `serde_json` writes a
//! non-finite number as `null`, which it then refuses to read back into an `f64`. With
//! `#[serde(with = "crate::io::json_f64")]` a field writes `null` for a non-finite value and
//! reads `null` back as NaN; [`mod@array`] does the same for a fixed-size array.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Writes `x`, or `null` when it is not finite.
pub fn serialize<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
    x.is_finite().then_some(*x).serialize(s)
}

/// Reads a number, or NaN for `null`.
pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// The same for `[f64; N]`.
pub mod array {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// Writes each element, `null` for one that is not finite.
    pub fn serialize<S: Serializer, const N: usize>(x: &[f64; N], s: S) -> Result<S::Ok, S::Error> {
        let v: Vec<Option<f64>> = x.iter().map(|x| x.is_finite().then_some(*x)).collect();
        v.serialize(s)
    }

    /// Reads `N` numbers, NaN for each `null`.
    pub fn deserialize<'de, D: Deserializer<'de>, const N: usize>(
        d: D,
    ) -> Result<[f64; N], D::Error> {
        let v = Vec::<Option<f64>>::deserialize(d)?;
        let n = v.len();
        let mut out = [f64::NAN; N];
        if n != N {
            return Err(serde::de::Error::invalid_length(n, &"the array's length"));
        }
        for (o, x) in out.iter_mut().zip(v) {
            *o = x.unwrap_or(f64::NAN);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use serde::{Deserialize, Serialize};

    #[derive(Debug, Serialize, Deserialize)]
    struct T {
        #[serde(with = "super")]
        x: f64,
        #[serde(with = "super::array")]
        a: [f64; 3],
    }

    #[test]
    fn nan_round_trips_through_null() {
        let t = T {
            x: f64::NAN,
            a: [1.5, f64::NAN, -2.0],
        };
        let s = serde_json::to_string(&t).unwrap();
        assert_eq!(s, r#"{"x":null,"a":[1.5,null,-2.0]}"#);
        let back: T = serde_json::from_str(&s).unwrap();
        assert!(back.x.is_nan() && back.a[1].is_nan());
        assert_eq!((back.a[0], back.a[2]), (1.5, -2.0));
        assert!(serde_json::from_str::<T>(r#"{"x":1.0,"a":[1.0]}"#).is_err());
    }
}
