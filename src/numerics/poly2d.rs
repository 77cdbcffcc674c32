//! Polynomials in two variables as the closure methods write them: the monomials x1^i x2^j
//! of a degree in the order of the paper's Eq. 16.

/// The exponents (i, j) of the monomials x1^i x2^j with 1 ≤ i + j ≤ n, by total degree and then
/// by the power of x2 (the order of Eq. 16): for degree 2, (1, 0), (0, 1), (2, 0), (1, 1),
/// (0, 2).
pub(crate) fn exponents(degree: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for d in 1..=degree {
        for j in 0..=d {
            out.push((d - j, j));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exponents_by_total_degree_then_power_of_x2() {
        assert_eq!(exponents(2), vec![(1, 0), (0, 1), (2, 0), (1, 1), (0, 2)]);
        // n(n + 3)/2 monomials of degree 1 to n.
        assert!((1..=12).all(|n| exponents(n).len() == n * (n + 3) / 2));
    }
}
