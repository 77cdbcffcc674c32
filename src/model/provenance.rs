//! Where a result file came from: the version and schema that wrote it, the command, the
//! time, the model's text, the threads — written into every JSON result as `provenance`.

use std::sync::OnceLock;
use std::time::{SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};

use super::{BoundModel, Model, Origin};

/// The version of the JSON results' layout; raised with every change a reader must know of
/// (2: the distances between methods are one `comparisons` list).
pub const SCHEMA_VERSION: u32 = 2;

static COMMAND: OnceLock<String> = OnceLock::new();

/// Records the command line of this process (the program and its arguments), for every
/// result written after it; the first call wins. An embedding that does not call it writes
/// no `command`.
///
/// ```
/// fpsolve::report::set_command(["fpsolve", "models/linear.sde", "--out", "my dir"]);
/// let p = fpsolve::report::Provenance::now(None);
/// assert_eq!(p.command.as_deref(), Some("fpsolve models/linear.sde --out 'my dir'"));
/// ```
pub fn set_command<I, S>(args: I)
where
    I: IntoIterator<Item = S>,
    S: AsRef<str>,
{
    let words: Vec<String> = args.into_iter().map(|a| quoted(a.as_ref())).collect();
    let _ = COMMAND.set(words.join(" "));
}

/// A word as a POSIX shell reads it back: bare when it is safe, else in single quotes.
fn quoted(word: &str) -> String {
    let safe = !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c));
    if safe {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', "'\\''"))
    }
}

/// The `provenance` block of a JSON result.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Provenance {
    /// The fpsolve version that wrote the file.
    pub fpsolve_version: &'static str,
    /// [`SCHEMA_VERSION`].
    pub schema_version: u32,
    /// The command line ([`set_command`]), when the process recorded one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub command: Option<String>,
    /// When the file was written, UTC, ISO 8601 to the second.
    pub created: String,
    /// The worker threads of the run; for a merge of a split run's parts, the threads each
    /// part ran with (the most, when they differ), see [`Provenance::merged`].
    pub threads: usize,
    /// The model, when the result is of one model.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<ModelSource>,
}

/// A model as its file gave it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelSource {
    /// Its name.
    pub name: String,
    /// The file it was read from, as given (none for a model parsed from text).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Its text, whole (none for a model built without text).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub text: Option<String>,
}

impl Provenance {
    /// The provenance of a result written now, of `model` when it is of one.
    ///
    /// ```
    /// let model = fpsolve::model::parse_model("model m\nstate z, v\ndrift z: v\n\
    ///     drift v: -v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?;
    /// let p = fpsolve::report::Provenance::now(Some(&model));
    /// assert_eq!(p.schema_version, fpsolve::report::SCHEMA_VERSION);
    /// assert!(p.created.ends_with('Z') && p.created.len() == 20);
    /// assert!(p.model.unwrap().text.unwrap().starts_with("model m"));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn now(model: Option<&Model>) -> Provenance {
        Provenance::with(
            model.map(|m| source(&m.name, m.origin.as_deref())),
            rayon::current_num_threads(),
        )
    }

    /// [`Provenance::now`] of a bound model (its file and text; the values bound are in the
    /// result itself and in the command).
    pub fn now_bound(model: &BoundModel) -> Provenance {
        Provenance::now_of(ModelSource::of_bound(model))
    }

    /// The provenance of a merge of a split run's parts, written now: the merge's version,
    /// schema, command and time, with what the parts' own `provenance` blocks say of the run:
    /// the `model` (the first part's that names one) and the `threads` each part ran with
    /// (the most, when they differ). A part without a block (a file of an older fpsolve)
    /// says nothing; when none says how many threads, `threads` is the merging process's.
    ///
    /// ```
    /// use fpsolve::report::Provenance;
    /// let part = serde_json::json!({ "threads": 1, "model": { "name": "m", "text": "model m" } });
    /// let p = Provenance::merged([Some(&part), None]);
    /// assert_eq!(p.threads, 1);
    /// assert_eq!(p.model.unwrap().text.as_deref(), Some("model m"));
    /// ```
    pub fn merged<'a, I>(parts: I) -> Provenance
    where
        I: IntoIterator<Item = Option<&'a serde_json::Value>>,
    {
        let mut threads: Option<usize> = None;
        let mut model: Option<ModelSource> = None;
        for part in parts.into_iter().flatten() {
            let ran = part
                .get("threads")
                .and_then(serde_json::Value::as_u64)
                .and_then(|t| usize::try_from(t).ok())
                .filter(|&t| t > 0);
            if let Some(t) = ran {
                threads = Some(threads.map_or(t, |m| m.max(t)));
            }
            if model.is_none() {
                model = part
                    .get("model")
                    .and_then(|m| ModelSource::deserialize(m).ok());
            }
        }
        Provenance::with(model, threads.unwrap_or_else(rayon::current_num_threads))
    }

    /// [`Provenance::now`] of a model described already (a simulation's, kept for its shards).
    pub(crate) fn now_of(model: ModelSource) -> Provenance {
        Provenance::with(Some(model), rayon::current_num_threads())
    }

    fn with(model: Option<ModelSource>, threads: usize) -> Provenance {
        Provenance {
            fpsolve_version: env!("CARGO_PKG_VERSION"),
            schema_version: SCHEMA_VERSION,
            command: COMMAND.get().cloned(),
            created: utc(SystemTime::now()),
            threads,
            model,
        }
    }
}

impl ModelSource {
    /// The source of a bound model: its name, file and text.
    pub(crate) fn of_bound(model: &BoundModel) -> ModelSource {
        source(&model.name, model.origin.as_deref())
    }
}

fn source(name: &str, origin: Option<&Origin>) -> ModelSource {
    ModelSource {
        name: name.to_string(),
        file: origin.and_then(|o| o.path.clone()),
        text: origin.map(|o| o.source.clone()),
    }
}

/// `t` as `YYYY-MM-DDTHH:MM:SSZ` (the proleptic Gregorian calendar; days to a civil date by
/// Howard Hinnant's algorithm).
fn utc(t: SystemTime) -> String {
    let secs = t.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn dates_are_the_civil_calendar() {
        let at = |s: u64| utc(UNIX_EPOCH + Duration::from_secs(s));
        assert_eq!(at(0), "1970-01-01T00:00:00Z");
        assert_eq!(at(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(at(1_795_851_123), "2026-11-28T07:32:03Z");
        assert_eq!(at(4_107_542_399), "2100-02-28T23:59:59Z");
    }

    #[test]
    fn words_are_quoted_only_when_a_shell_needs_it() {
        assert_eq!(quoted("--set"), "--set");
        assert_eq!(quoted("mu=0.5"), "mu=0.5");
        assert_eq!(quoted("a b"), "'a b'");
        assert_eq!(quoted("it's"), "'it'\\''s'");
        assert_eq!(quoted(""), "''");
    }
}
