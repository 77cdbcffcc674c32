//! A finished Monte Carlo run read back from its output directory (`fpsolve simulate` or
//! `fpsolve merge`) to serve as a job's reference: checked against the job's model and
//! parameters, and against its own files, before any work.

use std::path::{Path, PathBuf};

use crate::base::input_file::{read_regular_text, MAX_RESULT_FILE_BYTES};
use crate::mc::{McResult, QuantityHistogram};
use crate::model::BoundModel;
use crate::report::PdfTable;
use crate::solve::quantities;

/// A Monte Carlo result read from a directory, checked against a bound model.
#[derive(Clone, Debug, PartialEq)]
pub struct McFrom {
    /// The directory it was read from.
    pub dir: PathBuf,
    /// The result, as `mc_summary.json` holds it.
    pub result: McResult,
}

/// Why a Monte Carlo directory cannot be a job's reference.
#[derive(Debug, thiserror::Error)]
pub enum McFromError {
    /// A file the run writes is missing or cannot be read.
    #[error("{}: {source}", path.display())]
    Unreadable {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// `mc_summary.json` is not a Monte Carlo result.
    #[error("{}: not a Monte Carlo summary ({detail})", path.display())]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        detail: String,
    },
    /// A histogram file does not hold what `mc_summary.json` says.
    #[error("{}: does not match mc_summary.json ({detail})", path.display())]
    Inconsistent {
        /// The file.
        path: PathBuf,
        /// What differs.
        detail: String,
    },
    /// The run is of another model.
    #[error("{}: a run of model `{found}`, not `{expected}`", dir.display())]
    OtherModel {
        /// The directory.
        dir: PathBuf,
        /// The model the job solves.
        expected: String,
        /// The model of the run.
        found: String,
    },
    /// A parameter differs between the run and the job (after `--set`).
    #[error(
        "{}: parameter `{name}` is {} in the run and {} in the job",
        dir.display(),
        show(*found),
        show(*expected)
    )]
    OtherParameter {
        /// The directory.
        dir: PathBuf,
        /// The parameter.
        name: String,
        /// Its value in the job (`None`: the job's model has no such parameter).
        expected: Option<f64>,
        /// Its value in the run (`None`: the run has no such parameter).
        found: Option<f64>,
    },
    /// The run histograms other quantities than the model's states and observables.
    #[error("{}: the run histograms {found:?}, the model has {expected:?}", dir.display())]
    OtherQuantities {
        /// The directory.
        dir: PathBuf,
        /// The model's states, then observables.
        expected: Vec<String>,
        /// The run's.
        found: Vec<String>,
    },
}

fn show(v: Option<f64>) -> String {
    v.map_or_else(|| "absent".into(), crate::model::number)
}

impl McFrom {
    /// Reads `dir/mc_summary.json` and every `dir/mc_<quantity>.csv`, and checks them against
    /// each other and against `model` (its name, every parameter value bit for bit, its
    /// quantities).
    ///
    /// # Errors
    /// A [`McFromError`] naming the file or the parameter.
    ///
    /// ```
    /// use fpsolve::job::{McFrom, McFromError};
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let err = McFrom::read("no/such/dir".as_ref(), &bound).unwrap_err();
    /// assert!(matches!(err, McFromError::Unreadable { .. }));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn read(dir: &Path, model: &BoundModel) -> Result<McFrom, McFromError> {
        let path = dir.join("mc_summary.json");
        let text = read_regular_text(&path, MAX_RESULT_FILE_BYTES).map_err(|source| {
            McFromError::Unreadable {
                path: path.clone(),
                source,
            }
        })?;
        let result = parse_summary(&text).map_err(|detail| McFromError::Corrupt {
            path: path.clone(),
            detail,
        })?;
        let from = McFrom {
            dir: dir.to_path_buf(),
            result,
        };
        from.check(model)?;
        for q in &from.result.quantities {
            check_csv(&dir.join(format!("mc_{}.csv", q.name)), q)?;
        }
        Ok(from)
    }

    /// Checks that the result is of `model` as bound (name, parameters, quantities) and that
    /// its settings and histograms are well formed.
    ///
    /// # Errors
    /// As [`McFrom::read`].
    pub fn check(&self, model: &BoundModel) -> Result<(), McFromError> {
        let dir = &self.dir;
        let st = &self.result.settings;
        let corrupt = |detail: String| McFromError::Corrupt {
            path: dir.join("mc_summary.json"),
            detail,
        };
        st.check().map_err(|e| corrupt(e.to_string()))?;
        if st.model != model.name() {
            return Err(McFromError::OtherModel {
                dir: dir.clone(),
                expected: model.name().to_string(),
                found: st.model.clone(),
            });
        }
        for (name, value) in model.params() {
            let found = st.params.iter().find(|p| p.name == **name).map(|p| p.value);
            if found.map(f64::to_bits) != Some(value.to_bits()) {
                return Err(McFromError::OtherParameter {
                    dir: dir.clone(),
                    name: name.to_string(),
                    expected: Some(*value),
                    found,
                });
            }
        }
        if let Some(p) = st
            .params
            .iter()
            .find(|p| !model.params().iter().any(|(n, _)| **n == p.name))
        {
            return Err(McFromError::OtherParameter {
                dir: dir.clone(),
                name: p.name.clone(),
                expected: None,
                found: Some(p.value),
            });
        }
        let expected: Vec<String> = quantities(model).into_iter().map(|q| q.name).collect();
        let found: Vec<String> = self
            .result
            .quantities
            .iter()
            .map(|q| q.name.clone())
            .collect();
        if expected != found {
            return Err(McFromError::OtherQuantities {
                dir: dir.clone(),
                expected,
                found,
            });
        }
        for q in &self.result.quantities {
            let bins = q.grid.bins;
            let bias = q.time_step_bias.as_ref();
            let lengths_ok = q.density.len() == bins
                && q.stderr.len() == bins
                && bias.is_none_or(|b| b.density.len() == bins && b.density_stderr.len() == bins);
            if !q.grid.well_formed() || !lengths_ok {
                return Err(corrupt(format!(
                    "the histogram of `{}` does not fit its grid of {bins} bins",
                    q.name
                )));
            }
            if q.density.iter().any(|d| !(d.is_finite() && *d >= 0.0)) {
                return Err(corrupt(format!(
                    "the histogram of `{}` has a density that is negative or not finite",
                    q.name
                )));
            }
        }
        Ok(())
    }
}

/// The `mc` and `mc_stderr` columns of a histogram file against the summary's, bit for bit
/// (both are written in shortest round-trip form).
fn check_csv(path: &Path, q: &QuantityHistogram) -> Result<(), McFromError> {
    let table = PdfTable::read_csv(path).map_err(|e| match e {
        crate::report::ReportError::Io { path, source } => McFromError::Unreadable { path, source },
        other => McFromError::Inconsistent {
            path: path.to_path_buf(),
            detail: other.to_string(),
        },
    })?;
    let inconsistent = |detail: String| McFromError::Inconsistent {
        path: path.to_path_buf(),
        detail,
    };
    let same = |a: &[f64], b: &[f64]| {
        a.len() == b.len()
            && a.iter()
                .zip(b)
                .all(|(u, v)| u.to_bits() == v.to_bits() || (u.is_nan() && v.is_nan()))
    };
    if table.variable != q.name || !same(&table.x, &q.grid.centers()) {
        return Err(inconsistent(format!(
            "its grid is not the {} bins of `{}` on [{}, {}]",
            q.grid.bins, q.name, q.grid.lo, q.grid.hi
        )));
    }
    for (name, values) in [("mc", &q.density), ("mc_stderr", &q.stderr)] {
        match table.columns.iter().find(|(n, _)| n == name) {
            Some((_, column)) if same(column, values) => {}
            Some(_) => return Err(inconsistent(format!("column `{name}` differs"))),
            None => return Err(inconsistent(format!("no column `{name}`"))),
        }
    }
    Ok(())
}

/// A stand-in for a number written as `null` (listed under `undefined`) while the text is
/// read, restored to NaN afterwards: no finite statistic of a run is this large.
const UNDEFINED: f64 = f64::MAX;

/// Reads `mc_summary.json`: numbers with no finite value are written there as `null` and
/// listed under `undefined`; each comes back as NaN where the result has room for one (a bin
/// of a histogram, a moment), and a file with a `null` anywhere else is not a result.
fn parse_summary(text: &str) -> Result<McResult, String> {
    let mut json: serde_json::Value = serde_json::from_str(text).map_err(|e| e.to_string())?;
    let undefined: Vec<String> = match json.as_object_mut().and_then(|m| m.remove("undefined")) {
        None => Vec::new(),
        Some(list) => serde_json::from_value::<Vec<serde_json::Value>>(list)
            .map_err(|e| format!("`undefined`: {e}"))?
            .iter()
            .map(|u| {
                u.get("field")
                    .and_then(|f| f.as_str())
                    .map(str::to_string)
                    .ok_or_else(|| "`undefined` lists an entry without a field".to_string())
            })
            .collect::<Result<_, _>>()?,
    };
    for field in &undefined {
        let slot = pointer(field)
            .and_then(|p| json.pointer_mut(&p))
            .filter(|v| v.is_null())
            .ok_or_else(|| format!("`undefined` lists {field}, which is not a null there"))?;
        *slot = serde_json::Value::from(UNDEFINED);
    }
    let mut result: McResult = serde_json::from_value(json).map_err(|e| e.to_string())?;
    for field in &undefined {
        let slot = nan_slot(&mut result, field)
            .ok_or_else(|| format!("{field} has no finite value, and the result needs one"))?;
        *slot = f64::NAN;
    }
    Ok(result)
}

/// A JSONPath as the writer spells it (`$.a.b[3].c`) as a JSON pointer (`/a/b/3/c`).
fn pointer(path: &str) -> Option<String> {
    let rest = path.strip_prefix('$')?;
    let mut out = String::new();
    for part in rest.split('.').skip(1) {
        let mut pieces = part.split('[');
        out.push('/');
        out.push_str(pieces.next()?);
        for index in pieces {
            out.push('/');
            out.push_str(index.strip_suffix(']')?);
        }
    }
    Some(out)
}

/// The number a path names in a result, where the result may hold NaN: a bin of a histogram
/// or of its time-step bias, a moment estimate, the impact rate.
fn nan_slot<'a>(result: &'a mut McResult, path: &str) -> Option<&'a mut f64> {
    let p = pointer(path)?;
    let parts: Vec<&str> = p.split('/').skip(1).collect();
    let index = |s: &str| s.parse::<usize>().ok();
    match parts.as_slice() {
        ["impacts", "rate", which] => {
            let rate = &mut result.impacts.as_mut()?.rate;
            estimate_part(rate, which)
        }
        ["quantities", q, rest @ ..] => {
            let q = result.quantities.get_mut(index(q)?)?;
            match rest {
                ["density", b] => q.density.get_mut(index(b)?),
                ["stderr", b] => q.stderr.get_mut(index(b)?),
                ["moments", m @ ..] => moment_slot(&mut q.moments, m),
                ["time_step_bias", rest @ ..] => {
                    let bias = q.time_step_bias.as_mut()?;
                    match rest {
                        ["density", b] => bias.density.get_mut(index(b)?),
                        ["density_stderr", b] => bias.density_stderr.get_mut(index(b)?),
                        ["moments", m @ ..] => moment_slot(&mut bias.moments, m),
                        _ => None,
                    }
                }
                _ => None,
            }
        }
        _ => None,
    }
}

fn moment_slot<'a>(
    m: &'a mut crate::stats::Moments<crate::stats::Estimate>,
    path: &[&str],
) -> Option<&'a mut f64> {
    let e = match path {
        ["raw", k, _] => m.raw.get_mut(k.parse::<usize>().ok()?)?,
        ["mean", _] => &mut m.mean,
        ["variance", _] => &mut m.variance,
        ["kurtosis", _] => &mut m.kurtosis,
        _ => return None,
    };
    estimate_part(e, path.last()?)
}

fn estimate_part<'a>(e: &'a mut crate::stats::Estimate, which: &str) -> Option<&'a mut f64> {
    match which {
        "value" => Some(&mut e.value),
        "stderr" => Some(&mut e.stderr),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_paths_become_pointers() {
        assert_eq!(
            pointer("$.quantities[2].time_step_bias.density[17]").as_deref(),
            Some("/quantities/2/time_step_bias/density/17")
        );
        assert_eq!(pointer("$.a").as_deref(), Some("/a"));
        assert_eq!(pointer("a.b"), None);
    }

    /// A run whose summary has numbers written as `null` (listed under `undefined`) reads back
    /// with NaN in their place and every other number bit for bit; a `null` the result has no
    /// room for is refused.
    #[test]
    fn undefined_numbers_come_back_as_nan() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
        let bound = crate::model::load_model(&path).unwrap().bind(&[]).unwrap();
        let config = crate::mc::McConfig {
            trajectories: 256,
            samples: 40,
            lanes: 64,
            ..crate::mc::McConfig::default()
        };
        let mut result = crate::mc::Simulation::new(&bound, &config)
            .unwrap()
            .run()
            .unwrap();
        result.quantities[1].stderr[3] = f64::NAN;
        result.quantities[0].moments.kurtosis.stderr = f64::INFINITY;
        let dir = std::env::temp_dir().join(format!("fpsolve-mc-from-{}", std::process::id()));
        let out = crate::report::OutputDir::create(&dir).unwrap();
        let (file, undefined) =
            crate::report::write_json_flagging_undefined(&out, "mc_summary.json", &result).unwrap();
        assert_eq!(undefined.len(), 2);
        let text = std::fs::read_to_string(&file).unwrap();
        let back = parse_summary(&text).unwrap();
        assert!(back.quantities[1].stderr[3].is_nan());
        assert!(back.quantities[0].moments.kurtosis.stderr.is_nan());
        let mut expected = result.clone();
        expected.quantities[1].stderr[3] = 0.0;
        expected.quantities[0].moments.kurtosis.stderr = 0.0;
        let mut got = back;
        got.quantities[1].stderr[3] = 0.0;
        got.quantities[0].moments.kurtosis.stderr = 0.0;
        assert_eq!(got, expected);
        // A null listed where the result holds no number that may be undefined.
        let bad = text.replacen("\"seed\": ", "\"seed\": null, \"was\": ", 1);
        assert!(parse_summary(&bad).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
