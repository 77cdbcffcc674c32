//! Serde helpers writing `f64` as its shortest round-trip decimal string (`"0.1"`, `"inf"`),
//! which Rust parses back to the same bits: shard files and summaries carry every number
//! exactly, so a merge reproduces an unsplit run bit for bit.

use serde::{Deserialize, Deserializer, Serializer};

pub(crate) fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&format!("{v:?}"))
}

pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let text = String::deserialize(d)?;
    text.parse().map_err(serde::de::Error::custom)
}

/// A finite `f64` as a JSON number (exact: serde_json prints the shortest round-trip decimal
/// and, with its `float_roundtrip` feature, parses it back to the same bits), a non-finite one
/// as the string `"inf"`, `"-inf"` or `"NaN"`; either form is read back.
pub(crate) mod number {
    use serde::{Deserialize, Deserializer, Serializer};

    pub(crate) fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        if v.is_finite() {
            s.serialize_f64(*v)
        } else {
            super::serialize(v, s)
        }
    }

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Either {
        Number(f64),
        Text(String),
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        match Either::deserialize(d)? {
            Either::Number(v) => Ok(v),
            Either::Text(t) => t.parse().map_err(serde::de::Error::custom),
        }
    }
}

/// The same for `[f64; 4]`.
pub(crate) mod array4 {
    use serde::{Deserialize, Deserializer, Serializer};

    pub(crate) fn serialize<S: Serializer>(v: &[f64; 4], s: S) -> Result<S::Ok, S::Error> {
        let t: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
        serde::Serialize::serialize(&t, s)
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 4], D::Error> {
        let t = <[String; 4]>::deserialize(d)?;
        let mut out = [0.0; 4];
        for (o, x) in out.iter_mut().zip(&t) {
            *o = x.parse().map_err(serde::de::Error::custom)?;
        }
        Ok(out)
    }
}

/// The same for `[f64; 2]`.
pub(crate) mod array2 {
    use serde::{Deserialize, Deserializer, Serializer};

    pub(crate) fn serialize<S: Serializer>(v: &[f64; 2], s: S) -> Result<S::Ok, S::Error> {
        let t: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
        serde::Serialize::serialize(&t, s)
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
        let t = <[String; 2]>::deserialize(d)?;
        Ok([
            t[0].parse().map_err(serde::de::Error::custom)?,
            t[1].parse().map_err(serde::de::Error::custom)?,
        ])
    }
}

#[cfg(test)]
mod tests {
    use serde::{Deserialize, Serialize};

    /// Parameter values are JSON numbers that read back to the same bits (also the awkward
    /// ones), non-finite values strings; the older string form still reads.
    #[test]
    fn numbers_round_trip_through_json_bit_for_bit() {
        #[derive(Serialize, Deserialize)]
        struct N(#[serde(with = "super::number")] f64);
        for v in [0.1, 1.0 / 3.0, 2.0_f64.sqrt() * 1e-300, 5e-324, 1e308, -0.0] {
            let json = serde_json::to_string(&N(v)).unwrap();
            assert!(!json.contains('"'), "{json}");
            assert_eq!(
                serde_json::from_str::<N>(&json).unwrap().0.to_bits(),
                v.to_bits()
            );
        }
        assert_eq!(
            serde_json::to_string(&N(f64::INFINITY)).unwrap(),
            r#""inf""#
        );
        assert_eq!(serde_json::from_str::<N>(r#""0.1""#).unwrap().0, 0.1);
        assert!(serde_json::from_str::<N>(r#""NaN""#).unwrap().0.is_nan());
    }

    #[test]
    fn exact_floats_round_trip_through_json() {
        #[derive(Serialize, Deserialize)]
        struct W(#[serde(with = "super")] f64);
        for v in [0.1, 1.0 / 3.0, 1e-300, f64::INFINITY, -0.0, 5e-324] {
            let j = serde_json::to_string(&W(v)).unwrap();
            let back: W = serde_json::from_str(&j).unwrap();
            assert_eq!(back.0.to_bits(), v.to_bits(), "{j}");
        }
    }
}

#[cfg(test)]
mod grid_tests {
    use crate::mc::Grid;

    /// Grids are written as numbers, exact to the last bit, and read back from numbers or from
    /// the strings files written before (and non-finite values) use.
    #[test]
    fn numbers_round_trip_and_old_strings_are_read() {
        let grid = Grid::new(-0.1 - 0.2, 1.0 / 3.0, 7).unwrap();
        let text = serde_json::to_string(&grid).unwrap();
        assert!(text.contains("\"lo\":-0.30000000000000004"), "{text}");
        assert_eq!(serde_json::from_str::<Grid>(&text).unwrap(), grid);
        let old = r#"{"lo": "-0.30000000000000004", "hi": "0.3333333333333333", "bins": 7}"#;
        assert_eq!(serde_json::from_str::<Grid>(old).unwrap(), grid);
    }
}
