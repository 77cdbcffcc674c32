//! The CPU's vector extensions, detected at run time: the Monte Carlo kernels and EPC's
//! vectorised exp each compile one function per extension and call the widest one this CPU
//! has (the arithmetic is the same IEEE operations at every width, so the results are too).

/// A vector extension code can be compiled for, and this CPU has: the widths beyond the
/// baseline carry a token that only [`Simd::detect`] constructs, so holding `Simd::Avx2(_)`
/// proves the check was made and a kernel may call its `#[target_feature]` function.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Simd {
    /// The build's baseline (SSE2 on x86-64).
    Baseline,
    /// AVX2 (4 lanes of f64).
    #[cfg(target_arch = "x86_64")]
    Avx2(Avx2),
    /// AVX-512F (8 lanes of f64).
    #[cfg(target_arch = "x86_64")]
    Avx512(Avx512),
}

/// Proof that this CPU has AVX2: its field is private, so only detection makes one.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Avx2(());

/// Proof that this CPU has AVX-512F: its field is private, so only detection makes one.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Avx512(());

/// The environment variable that caps the vector extension the kernels run with:
/// `baseline`, `avx2` or `avx512` (the widest this CPU has when unset). The results are the
/// same bits at every extension; the cap is for measuring the narrower kernels on a wide
/// machine (`FPSOLVE_SIMD=avx2 cargo bench --bench mc`) and for checking that claim.
///
/// ```
/// assert_eq!(fpsolve::base::simd::SIMD_VAR, "FPSOLVE_SIMD");
/// ```
pub const SIMD_VAR: &str = "FPSOLVE_SIMD";

/// The values [`SIMD_VAR`] takes, narrowest first.
const NAMES: [&str; 3] = ["baseline", "avx2", "avx512"];

/// Checks [`SIMD_VAR`]: `Ok` when it is unset or names an extension, else the message to
/// refuse the run with (the kernels themselves ignore a value they do not know).
///
/// ```
/// // Unset here, so accepted.
/// assert!(fpsolve::base::simd::check_env().is_ok());
/// ```
pub fn check_env() -> Result<(), String> {
    match std::env::var_os(SIMD_VAR) {
        None => Ok(()),
        Some(v) if NAMES.iter().any(|n| v == *n) => Ok(()),
        Some(v) => Err(format!(
            "{SIMD_VAR}={}: expected one of {}",
            v.to_string_lossy(),
            NAMES.join(", ")
        )),
    }
}

impl Simd {
    /// The widest extension this CPU has, at most the one [`SIMD_VAR`] names.
    pub(crate) fn detect() -> Simd {
        // The cap's place in NAMES (the widest when unset or unknown).
        let cap = std::env::var_os(SIMD_VAR)
            .and_then(|v| NAMES.iter().position(|n| v == *n))
            .unwrap_or(NAMES.len() - 1);
        #[cfg(target_arch = "x86_64")]
        {
            if cap >= 2 && std::arch::is_x86_feature_detected!("avx512f") {
                return Simd::Avx512(Avx512(()));
            }
            if cap >= 1 && std::arch::is_x86_feature_detected!("avx2") {
                return Simd::Avx2(Avx2(()));
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = cap;
        Simd::Baseline
    }
}

#[cfg(test)]
impl Simd {
    /// Every extension this CPU has, the baseline first (each checked like [`Simd::detect`],
    /// without the cap), for tests that run every kernel.
    pub(crate) fn available() -> Vec<Simd> {
        let mut all = vec![Simd::Baseline];
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                all.push(Simd::Avx2(Avx2(())));
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                all.push(Simd::Avx512(Avx512(())));
            }
        }
        all
    }
}

#[cfg(test)]
mod tests {
    use super::Simd;

    /// Detection hands out only extensions this CPU has, and the baseline is always one.
    #[test]
    fn detection_picks_an_extension_this_cpu_has() {
        let available = Simd::available();
        assert_eq!(available[0], Simd::Baseline);
        assert!(available.contains(&Simd::detect()));
    }
}
