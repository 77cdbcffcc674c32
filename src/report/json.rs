//! Pretty-printed JSON that refuses NaN and infinities.
//!
//! serde_json turns a non-finite `f64` into `null` without a word (both when writing text and
//! when building a `serde_json::Value`, so a pass over a `Value` cannot see it). A run summary
//! with a silent `null` where a moment should be is worse than no summary, so before writing,
//! the value is walked once by a serialiser that only looks at floats and keeps the JSONPath of
//! where it is.

use std::fmt;
use std::path::PathBuf;

use serde::ser::{self, Serialize};

use super::{OutputDir, ReportError};

/// Writes `value` as pretty-printed JSON (with a final newline) to `name` in `dir`, atomically;
/// returns the file's path.
///
/// ```
/// use fpsolve::report::{write_json, OutputDir, ReportError};
///
/// #[derive(serde::Serialize)]
/// struct Moments { mean: f64, variance: f64 }
///
/// # let tmp = std::env::temp_dir().join(format!("fpsolve-doc-json-{}", std::process::id()));
/// let dir = OutputDir::create(&tmp)?;
/// write_json(&dir, "moments.json", &Moments { mean: 0.4, variance: 0.1 })?;
/// let err = write_json(&dir, "bad.json", &Moments { mean: 0.4, variance: f64::NAN }).unwrap_err();
/// assert!(matches!(err, ReportError::NonFiniteJson { ref field, .. } if field == "$.variance"));
/// # std::fs::remove_dir_all(&tmp).unwrap();
/// # Ok::<(), ReportError>(())
/// ```
///
/// # Errors
/// [`ReportError::NonFiniteJson`] naming the first field (in serialisation order) that holds a
/// NaN or ±∞, [`ReportError::Json`] if serde refuses the value, otherwise as
/// [`OutputDir::write_atomic`]. Nothing is written on error.
pub fn write_json<T: Serialize + ?Sized>(
    dir: &OutputDir,
    name: &str,
    value: &T,
) -> Result<PathBuf, ReportError> {
    let path = dir.file_path(name)?;
    match value.serialize(FiniteCheck {
        path: "$".to_string(),
    }) {
        Ok(()) => {}
        Err(CheckError::NonFinite { path: field, value }) => {
            return Err(ReportError::NonFiniteJson { path, field, value })
        }
        Err(CheckError::Custom(message)) => {
            return Err(ReportError::Json {
                path,
                source: <serde_json::Error as ser::Error>::custom(message),
            })
        }
    }
    let mut bytes =
        serde_json::to_vec_pretty(value).map_err(|source| ReportError::Json { path, source })?;
    bytes.push(b'\n');
    dir.write_atomic(name, &bytes)
}

/// A number in a report that has no finite value (written as `null` by
/// [`write_json_flagging_undefined`], listed beside the data).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct UndefinedField {
    /// JSONPath of the field, e.g. `$.comparisons[1].l1`.
    pub field: String,
    /// What it was: `inf`, `-inf` or `NaN`.
    pub value: String,
}

thread_local! {
    /// While [`write_json_flagging_undefined`] walks a value: where its non-finite floats are.
    static UNDEFINED: std::cell::RefCell<Option<Vec<UndefinedField>>> =
        const { std::cell::RefCell::new(None) };
}

/// The numbers of `value` that have no finite value, with their JSONPath, in serialisation
/// order (what [`write_json_flagging_undefined`] lists under `undefined`); an error (serde's
/// message) when `value` does not serialise.
///
/// ```
/// use fpsolve::report::undefined_fields;
///
/// #[derive(serde::Serialize)]
/// struct Moments { mean: f64, kurtosis: f64 }
///
/// let undefined = undefined_fields(&Moments { mean: 0.4, kurtosis: f64::INFINITY }).unwrap();
/// assert_eq!((undefined[0].field.as_str(), undefined[0].value.as_str()), ("$.kurtosis", "inf"));
/// assert!(undefined_fields(&Moments { mean: 0.4, kurtosis: 3.0 }).unwrap().is_empty());
/// ```
pub fn undefined_fields<T: Serialize + ?Sized>(value: &T) -> Result<Vec<UndefinedField>, String> {
    UNDEFINED.with(|u| *u.borrow_mut() = Some(Vec::new()));
    let checked = value.serialize(FiniteCheck {
        path: "$".to_string(),
    });
    let undefined = UNDEFINED
        .with(|u| u.borrow_mut().take())
        .unwrap_or_default();
    checked.map_err(|e| e.to_string())?;
    Ok(undefined)
}

/// Writes `value` like [`write_json`], except that a non-finite number does not stop the
/// write: it becomes `null`, and the value's top-level object gains a member `undefined`
/// listing every such field with what it was, so the file says which numbers are undefined
/// instead of losing the run. Returns the path and the list (empty when every number is
/// finite). For results that must be read back exactly (shard files), use [`write_json`].
///
/// The members of every object are written in the order of their names, but for a
/// top-level `provenance`, which opens the file.
///
/// ```
/// use fpsolve::report::{write_json_flagging_undefined, OutputDir};
///
/// #[derive(serde::Serialize)]
/// struct Moments { mean: f64, kurtosis: f64 }
///
/// # let tmp = std::env::temp_dir().join(format!("fpsolve-doc-json-undef-{}", std::process::id()));
/// let dir = OutputDir::create(&tmp)?;
/// let (path, undefined) =
///     write_json_flagging_undefined(&dir, "m.json", &Moments { mean: 0.4, kurtosis: f64::NAN })?;
/// assert_eq!(undefined[0].field, "$.kurtosis");
/// let text = std::fs::read_to_string(path).unwrap();
/// assert!(text.contains("\"kurtosis\": null") && text.contains("\"undefined\""));
///
/// #[derive(serde::Serialize)]
/// struct Summary { mean: f64, provenance: &'static str }
/// let (path, _) = write_json_flagging_undefined(&dir, "s.json", &Summary { mean: 0.4, provenance: "here" })?;
/// let text = std::fs::read_to_string(path).unwrap();
/// assert_eq!(text, "{\n  \"provenance\": \"here\",\n  \"mean\": 0.4\n}\n");
/// # std::fs::remove_dir_all(&tmp).unwrap();
/// # Ok::<(), fpsolve::report::ReportError>(())
/// ```
///
/// # Errors
/// [`ReportError::Json`] if serde refuses the value, otherwise as [`OutputDir::write_atomic`].
pub fn write_json_flagging_undefined<T: Serialize + ?Sized>(
    dir: &OutputDir,
    name: &str,
    value: &T,
) -> Result<(PathBuf, Vec<UndefinedField>), ReportError> {
    let path = dir.file_path(name)?;
    let (text, undefined) =
        json_flagging_undefined(value).map_err(|source| ReportError::Json { path, source })?;
    Ok((dir.write_atomic(name, text.as_bytes())?, undefined))
}

/// The text [`write_json_flagging_undefined`] writes (a final newline included) and the
/// fields it lists under `undefined`, for a caller that keeps or writes the text itself.
///
/// ```
/// use fpsolve::report::json_flagging_undefined;
///
/// #[derive(serde::Serialize)]
/// struct Moments { mean: f64, kurtosis: f64 }
///
/// let (text, undefined) = json_flagging_undefined(&Moments { mean: 0.4, kurtosis: f64::NAN })?;
/// assert_eq!(undefined[0].field, "$.kurtosis");
/// assert!(text.contains("\"kurtosis\": null") && text.ends_with("]\n}\n"));
/// # Ok::<(), serde_json::Error>(())
/// ```
///
/// # Errors
/// serde's, if it refuses the value.
pub fn json_flagging_undefined<T: Serialize + ?Sized>(
    value: &T,
) -> Result<(String, Vec<UndefinedField>), serde_json::Error> {
    let undefined = undefined_fields(value).map_err(<serde_json::Error as ser::Error>::custom)?;
    let mut json = serde_json::to_value(value)?;
    if !undefined.is_empty() {
        if let serde_json::Value::Object(map) = &mut json {
            map.insert("undefined".to_string(), serde_json::to_value(&undefined)?);
        }
    }
    let mut text = serde_json::to_string_pretty(&ProvenanceFirst(&json))?;
    text.push('\n');
    Ok((text, undefined))
}

/// A JSON value written as serde_json writes it, except that a top-level member
/// `provenance` comes first: where a result came from opens its file. The other members keep
/// their order (a `serde_json::Map`'s: by name).
struct ProvenanceFirst<'a>(&'a serde_json::Value);

impl Serialize for ProvenanceFirst<'_> {
    fn serialize<S: ser::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use ser::SerializeMap;
        let serde_json::Value::Object(map) = self.0 else {
            return self.0.serialize(serializer);
        };
        let Some(provenance) = map.get("provenance") else {
            return self.0.serialize(serializer);
        };
        let mut out = serializer.serialize_map(Some(map.len()))?;
        out.serialize_entry("provenance", provenance)?;
        for (key, value) in map.iter().filter(|(key, _)| *key != "provenance") {
            out.serialize_entry(key, value)?;
        }
        out.end()
    }
}

#[derive(Debug)]
enum CheckError {
    NonFinite { path: String, value: f64 },
    Custom(String),
}

impl fmt::Display for CheckError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NonFinite { path, value } => write!(f, "{path} is {value}"),
            Self::Custom(message) => f.write_str(message),
        }
    }
}

impl std::error::Error for CheckError {}

impl ser::Error for CheckError {
    fn custom<M: fmt::Display>(msg: M) -> Self {
        Self::Custom(msg.to_string())
    }
}

/// Checks that `value` serialises without a non-finite float (as [`write_json`] does before
/// writing), for a caller that renders the JSON text itself; `path` names the file in errors.
pub(crate) fn check_finite<T: Serialize + ?Sized>(
    path: &std::path::Path,
    value: &T,
) -> Result<(), ReportError> {
    let path = path.to_path_buf();
    match value.serialize(FiniteCheck {
        path: "$".to_string(),
    }) {
        Ok(()) => Ok(()),
        Err(CheckError::NonFinite { path: field, value }) => {
            Err(ReportError::NonFiniteJson { path, field, value })
        }
        Err(CheckError::Custom(message)) => Err(ReportError::Json {
            path,
            source: <serde_json::Error as ser::Error>::custom(message),
        }),
    }
}

/// A serialiser that produces nothing and fails at the first non-finite float; `path` is the
/// JSONPath of the value it is given.
struct FiniteCheck {
    path: String,
}

/// Extends a JSONPath by a member name: `.name` for identifier-like names, `["…"]` otherwise.
fn member(path: &str, name: &str) -> String {
    let identifier = name
        .chars()
        .next()
        .is_some_and(|c| c.is_alphabetic() || c == '_')
        && name.chars().all(|c| c.is_alphanumeric() || c == '_');
    if identifier {
        format!("{path}.{name}")
    } else {
        format!("{path}[{}]", serde_json::Value::from(name))
    }
}

impl FiniteCheck {
    fn float(self, value: f64) -> Result<(), CheckError> {
        if value.is_finite() {
            Ok(())
        } else if UNDEFINED.with(|u| u.borrow().is_some()) {
            let value = if value.is_nan() {
                "NaN".to_string()
            } else {
                value.to_string()
            };
            UNDEFINED.with(|u| {
                if let Some(list) = u.borrow_mut().as_mut() {
                    list.push(UndefinedField {
                        field: self.path,
                        value,
                    });
                }
            });
            Ok(())
        } else {
            Err(CheckError::NonFinite {
                path: self.path,
                value,
            })
        }
    }

    fn compound(self) -> Compound {
        Compound {
            path: self.path,
            index: 0,
            key: None,
        }
    }
}

/// The state of a sequence, map or struct being walked.
struct Compound {
    path: String,
    index: usize,
    key: Option<String>,
}

impl Compound {
    fn element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CheckError> {
        let path = format!("{}[{}]", self.path, self.index);
        self.index += 1;
        value.serialize(FiniteCheck { path })
    }

    fn field<T: Serialize + ?Sized>(&mut self, name: &str, value: &T) -> Result<(), CheckError> {
        value.serialize(FiniteCheck {
            path: member(&self.path, name),
        })
    }
}

impl ser::Serializer for FiniteCheck {
    type Ok = ();
    type Error = CheckError;
    type SerializeSeq = Compound;
    type SerializeTuple = Compound;
    type SerializeTupleStruct = Compound;
    type SerializeTupleVariant = Compound;
    type SerializeMap = Compound;
    type SerializeStruct = Compound;
    type SerializeStructVariant = Compound;

    fn serialize_bool(self, _: bool) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_i8(self, _: i8) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_i16(self, _: i16) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_i32(self, _: i32) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_i64(self, _: i64) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_i128(self, _: i128) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_u8(self, _: u8) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_u16(self, _: u16) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_u32(self, _: u32) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_u64(self, _: u64) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_u128(self, _: u128) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_f32(self, v: f32) -> Result<(), CheckError> {
        self.float(f64::from(v))
    }
    fn serialize_f64(self, v: f64) -> Result<(), CheckError> {
        self.float(v)
    }
    fn serialize_char(self, _: char) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_str(self, _: &str) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_bytes(self, _: &[u8]) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_none(self) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_some<T: Serialize + ?Sized>(self, value: &T) -> Result<(), CheckError> {
        value.serialize(self)
    }
    fn serialize_unit(self) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_unit_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
    ) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        value: &T,
    ) -> Result<(), CheckError> {
        value.serialize(self)
    }
    // serde_json writes enum variants with data as `{"Variant": data}`, so the variant name is a
    // path member.
    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
        value: &T,
    ) -> Result<(), CheckError> {
        value.serialize(FiniteCheck {
            path: member(&self.path, variant),
        })
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Compound, CheckError> {
        Ok(self.compound())
    }
    fn serialize_tuple(self, _: usize) -> Result<Compound, CheckError> {
        Ok(self.compound())
    }
    fn serialize_tuple_struct(self, _: &'static str, _: usize) -> Result<Compound, CheckError> {
        Ok(self.compound())
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
        _: usize,
    ) -> Result<Compound, CheckError> {
        let path = member(&self.path, variant);
        Ok(FiniteCheck { path }.compound())
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Compound, CheckError> {
        Ok(self.compound())
    }
    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Compound, CheckError> {
        Ok(self.compound())
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
        _: usize,
    ) -> Result<Compound, CheckError> {
        let path = member(&self.path, variant);
        Ok(FiniteCheck { path }.compound())
    }
}

impl ser::SerializeSeq for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CheckError> {
        self.element(value)
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

impl ser::SerializeTuple for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CheckError> {
        self.element(value)
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

impl ser::SerializeTupleStruct for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CheckError> {
        self.element(value)
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

impl ser::SerializeTupleVariant for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CheckError> {
        self.element(value)
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

impl ser::SerializeMap for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_key<T: Serialize + ?Sized>(&mut self, key: &T) -> Result<(), CheckError> {
        // Keys are rendered the way serde_json would write them; a key serde_json refuses is
        // reported when the value is finally written.
        self.key = Some(match serde_json::to_value(key) {
            Ok(serde_json::Value::String(s)) => s,
            Ok(other) => other.to_string(),
            Err(_) => "?".to_string(),
        });
        Ok(())
    }
    fn serialize_value<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CheckError> {
        let key = self.key.take().unwrap_or_else(|| "?".to_string());
        self.field(&key, value)
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

impl ser::SerializeStruct for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_field<T: Serialize + ?Sized>(
        &mut self,
        name: &'static str,
        value: &T,
    ) -> Result<(), CheckError> {
        self.field(name, value)
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

impl ser::SerializeStructVariant for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_field<T: Serialize + ?Sized>(
        &mut self,
        name: &'static str,
        value: &T,
    ) -> Result<(), CheckError> {
        self.field(name, value)
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    #[derive(serde::Serialize)]
    enum Stop {
        Converged { residual: f64 },
        Stalled(u32, f64),
        Diverged(f64),
    }

    #[derive(serde::Serialize)]
    struct Summary {
        name: String,
        degrees: Vec<u32>,
        moments: BTreeMap<String, Vec<f64>>,
        stop: Stop,
        extra: Option<f32>,
        pair: (f64, f64),
    }

    fn summary() -> Summary {
        let mut moments = BTreeMap::new();
        moments.insert("mean".to_string(), vec![0.1, 0.2]);
        moments.insert("E[y^2]".to_string(), vec![0.3]);
        Summary {
            name: "duffing".into(),
            degrees: vec![2, 4],
            moments,
            stop: Stop::Converged { residual: 1e-12 },
            extra: Some(1.5),
            pair: (1.0, 2.0),
        }
    }

    fn field_of(value: &impl Serialize) -> Option<(String, f64)> {
        match value.serialize(FiniteCheck { path: "$".into() }) {
            Ok(()) => None,
            Err(CheckError::NonFinite { path, value }) => Some((path, value)),
            Err(CheckError::Custom(m)) => panic!("unexpected custom error {m}"),
        }
    }

    #[test]
    fn finite_values_pass() {
        assert_eq!(field_of(&summary()), None);
    }

    #[test]
    fn paths_name_the_offending_field() {
        let mut s = summary();
        s.moments.get_mut("mean").unwrap()[1] = f64::NAN;
        let (path, value) = field_of(&s).unwrap();
        assert_eq!(path, "$.moments.mean[1]");
        assert!(value.is_nan());

        let mut s = summary();
        s.moments.get_mut("E[y^2]").unwrap()[0] = f64::INFINITY;
        assert_eq!(
            field_of(&s),
            Some((r#"$.moments["E[y^2]"][0]"#.into(), f64::INFINITY))
        );

        let mut s = summary();
        s.stop = Stop::Converged {
            residual: f64::NEG_INFINITY,
        };
        assert_eq!(field_of(&s).unwrap().0, "$.stop.Converged.residual");
        s.stop = Stop::Stalled(3, f64::NAN);
        assert_eq!(field_of(&s).unwrap().0, "$.stop.Stalled[1]");
        s.stop = Stop::Diverged(f64::INFINITY);
        assert_eq!(field_of(&s).unwrap().0, "$.stop.Diverged");

        let mut s = summary();
        s.extra = Some(f32::NAN);
        assert_eq!(field_of(&s).unwrap().0, "$.extra");
        let mut s = summary();
        s.pair.1 = f64::NAN;
        assert_eq!(field_of(&s).unwrap().0, "$.pair[1]");
        assert_eq!(field_of(&vec![f64::NAN]).unwrap().0, "$[0]");
    }

    #[test]
    fn writes_pretty_json_that_parses_back() {
        let root = std::env::temp_dir().join(format!("fpsolve-json-{}", std::process::id()));
        let dir = OutputDir::create(&root).unwrap();
        let path = write_json(&dir, "summary.json", &summary()).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.ends_with("}\n") && text.contains("\n  \"name\": \"duffing\""));
        let back: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(back["moments"]["mean"][1].as_f64(), Some(0.2));
        assert_eq!(back["stop"]["Converged"]["residual"].as_f64(), Some(1e-12));

        let mut bad = summary();
        bad.degrees.clear();
        bad.pair.0 = f64::NAN;
        match write_json(&dir, "bad.json", &bad) {
            Err(ReportError::NonFiniteJson { path, field, .. }) => {
                assert_eq!(path, root.join("bad.json"));
                assert_eq!(field, "$.pair[0]");
            }
            other => panic!("expected NonFiniteJson, got {other:?}"),
        }
        assert!(!root.join("bad.json").exists());
        std::fs::remove_dir_all(&root).unwrap();
    }
}
