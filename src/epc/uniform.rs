//! A reproducible stream of uniform numbers in [0, 1) (xorshift64, 53 bits per number): the
//! solver's deterministic multistart perturbations and the tests' random cases.

/// The stream: the same numbers for the same seed on every machine.
pub(crate) struct Uniform(u64);

impl Uniform {
    /// The stream from a nonzero `seed`.
    pub(crate) fn new(seed: u64) -> Uniform {
        debug_assert!(seed != 0, "xorshift stays at 0");
        Uniform(seed)
    }

    /// The next number, in [0, 1).
    pub(crate) fn next(&mut self) -> f64 {
        let s = &mut self.0;
        *s ^= *s << 13;
        *s ^= *s >> 7;
        *s ^= *s << 17;
        (*s >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_in_the_unit_interval_and_spread() {
        let mut u = Uniform::new(0x2545_f491_4f6c_dd1d);
        let x: Vec<f64> = (0..10_000).map(|_| u.next()).collect();
        assert!(x.iter().all(|&v| (0.0..1.0).contains(&v)));
        let mean = x.iter().sum::<f64>() / x.len() as f64;
        assert!((mean - 0.5).abs() < 0.02, "{mean}");
        let mut again = Uniform::new(0x2545_f491_4f6c_dd1d);
        assert_eq!(again.next(), x[0]);
    }
}
