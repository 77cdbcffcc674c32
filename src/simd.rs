//! The CPU's vector extensions, detected at run time: the Monte Carlo kernels and EPC's
//! vectorised exp each compile one function per extension and call the widest one this CPU
//! has (the arithmetic is the same IEEE operations at every width, so the results are too).

/// A vector extension code can be compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Simd {
    /// The build's baseline (SSE2 on x86-64).
    Baseline,
    /// AVX2 (4 lanes of f64).
    #[cfg(target_arch = "x86_64")]
    Avx2,
    /// AVX-512F (8 lanes of f64).
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

impl Simd {
    /// The widest extension this CPU has.
    pub(crate) fn detect() -> Simd {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                return Simd::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return Simd::Avx2;
            }
        }
        Simd::Baseline
    }
}

#[cfg(test)]
impl Simd {
    /// Every extension this CPU has, the baseline first.
    pub(crate) fn available() -> Vec<Simd> {
        let mut all = vec![Simd::Baseline];
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                all.push(Simd::Avx2);
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                all.push(Simd::Avx512);
            }
        }
        all
    }
}
