//! The joint density of the two states, as every method hands it to the observables: point
//! values, a box outside which it is negligible, and what it can say about its own smoothness
//! along coordinate lines (so that line integrals can take fixed rules where it is analytic).

use super::{LinePiece, PieceKind};

/// A joint density of the two states that observables can be computed from.
pub trait JointDensity: Sync {
    /// p(x1, x2); zero outside the density's support.
    fn pdf(&self, x: [f64; 2]) -> f64;
    /// A box `[[lo1, hi1], [lo2, hi2]]` outside which the density is negligible (below about
    /// 1e−16 of its peak) or zero.
    fn extent(&self) -> [[f64; 2]; 2];
    /// ∫ p dx_other over `range` on the line x_axis = `at`, when the density can give it
    /// exactly (a piecewise-polynomial density, e.g. the grid solver's); `None` (the default)
    /// and the caller integrates [`JointDensity::pdf`] along the line by adaptive quadrature.
    fn line_integral(&self, axis: usize, at: f64, range: [f64; 2]) -> Option<f64> {
        let _ = (axis, at, range);
        None
    }
    /// p at the points of the tensor grid `x1` × `x2`, into `out` (row-major in x1:
    /// `out[i·x2.len() + j]` = p(`x1[i]`, `x2[j]`)), each value equal to
    /// [`JointDensity::pdf`]'s. The default calls `pdf` point by point; a density that can
    /// share work along a row (an EPC density: the powers of x1) overrides it. The
    /// observables' quadratures ask for whole rows, lines and panels this way.
    ///
    /// # Panics
    /// If `out.len()` is not `x1.len()·x2.len()`.
    ///
    /// ```
    /// use fpsolve::density::JointDensity;
    /// struct Normal;
    /// impl JointDensity for Normal {
    ///     fn pdf(&self, x: [f64; 2]) -> f64 {
    ///         (-(x[0] * x[0] + x[1] * x[1]) / 2.0).exp() / (2.0 * std::f64::consts::PI)
    ///     }
    ///     fn extent(&self) -> [[f64; 2]; 2] {
    ///         [[-9.0, 9.0], [-9.0, 9.0]]
    ///     }
    /// }
    /// let mut out = [0.0; 6];
    /// Normal.pdf_on_grid(&[0.0, 1.0], &[-1.0, 0.0, 1.0], &mut out);
    /// assert_eq!(out[3], Normal.pdf([1.0, -1.0]));
    /// ```
    fn pdf_on_grid(&self, x1: &[f64], x2: &[f64], out: &mut [f64]) {
        assert_eq!(out.len(), x1.len() * x2.len(), "pdf_on_grid: output size");
        for (i, &a) in x1.iter().enumerate() {
            for (j, &b) in x2.iter().enumerate() {
                out[i * x2.len() + j] = self.pdf([a, b]);
            }
        }
    }
    /// The points along axis `axis` (sorted, the extent's ends first and last) between which
    /// p is a polynomial of degree ≤ 3 in that coordinate at every value of the other, as a
    /// piecewise-bicubic interpolant is: a fixed Gauss rule on each piece of both axes then
    /// integrates p times a polynomial exactly, where a composite rule that ignores the kinks
    /// would not. `None` (the default): p is not piecewise polynomial.
    ///
    /// ```
    /// use fpsolve::density::JointDensity;
    /// /// The tent p = (1 − |x|)(1 − |v|) on [−1, 1]²: linear on each half of each axis.
    /// struct Tent;
    /// impl JointDensity for Tent {
    ///     fn pdf(&self, x: [f64; 2]) -> f64 {
    ///         (1.0 - x[0].abs()).max(0.0) * (1.0 - x[1].abs()).max(0.0)
    ///     }
    ///     fn extent(&self) -> [[f64; 2]; 2] {
    ///         [[-1.0, 1.0], [-1.0, 1.0]]
    ///     }
    ///     fn breakpoints(&self, _axis: usize) -> Option<Vec<f64>> {
    ///         Some(vec![-1.0, 0.0, 1.0])
    ///     }
    /// }
    /// assert_eq!(Tent.breakpoints(1), Some(vec![-1.0, 0.0, 1.0]));
    /// ```
    fn breakpoints(&self, axis: usize) -> Option<Vec<f64>> {
        let _ = axis;
        None
    }
    /// Whether p is analytic on the whole of [`JointDensity::extent`] (no cut-off, mask, wall
    /// or kink), so that its integral along a half-line from an axis to the box's edge may be
    /// taken by a fixed polynomial rule (checked by a doubling test, adaptive when that fails).
    /// `false` (the default): adaptive quadrature only.
    ///
    /// ```
    /// use fpsolve::density::JointDensity;
    /// struct Normal;
    /// impl JointDensity for Normal {
    ///     fn pdf(&self, x: [f64; 2]) -> f64 {
    ///         (-(x[0] * x[0] + x[1] * x[1]) / 2.0).exp() / (2.0 * std::f64::consts::PI)
    ///     }
    ///     fn extent(&self) -> [[f64; 2]; 2] {
    ///         [[-9.0, 9.0], [-9.0, 9.0]]
    ///     }
    ///     fn analytic(&self) -> bool {
    ///         true
    ///     }
    /// }
    /// assert!(Normal.analytic());
    /// ```
    fn analytic(&self) -> bool {
        false
    }
    /// The pieces of the line x_axis = `at` within `range` (of the other state) on which p is
    /// smooth (C^∞ on each closed piece, its values at a piece's ends taken as the limits from
    /// inside) and outside which p is zero on the line, in order, into `out` (cleared first);
    /// `false` when the density cannot tell (then the caller integrates
    /// [`JointDensity::pdf_on_grid`] along the line by adaptive quadrature). The line
    /// integrals of Eqs. 23–28 take an [`PieceKind::Analytic`] piece by a fixed rule checked
    /// a posteriori ([`JointDensity::stated_accuracy`]) and bound a
    /// [`PieceKind::Transition`] by its maximum where that is negligible. The default: the
    /// whole range, analytic, when the density is [`analytic`](JointDensity::analytic);
    /// `false` otherwise.
    ///
    /// ```
    /// use fpsolve::density::{JointDensity, LinePiece, PieceKind};
    /// /// The uniform density on the unit square: analytic inside, zero outside.
    /// struct Square;
    /// impl JointDensity for Square {
    ///     fn pdf(&self, x: [f64; 2]) -> f64 {
    ///         if (0.0..1.0).contains(&x[0]) && (0.0..1.0).contains(&x[1]) { 1.0 } else { 0.0 }
    ///     }
    ///     fn extent(&self) -> [[f64; 2]; 2] {
    ///         [[0.0, 1.0], [0.0, 1.0]]
    ///     }
    ///     fn smooth_pieces(&self, _: usize, at: f64, r: [f64; 2], out: &mut Vec<LinePiece>) -> bool {
    ///         out.clear();
    ///         let range = [r[0].max(0.0), r[1].min(1.0)];
    ///         if (0.0..1.0).contains(&at) && range[0] < range[1] {
    ///             out.push(LinePiece { range, kind: PieceKind::Analytic });
    ///         }
    ///         true
    ///     }
    ///     fn pdf_on_piece(&self, _: usize, _: f64, _: &LinePiece, _: &[f64], out: &mut [f64]) {
    ///         out.fill(1.0); // the limit from inside, at the piece's ends too
    ///     }
    /// }
    /// let mut pieces = Vec::new();
    /// assert!(Square.smooth_pieces(0, 0.5, [-1.0, 0.5], &mut pieces));
    /// assert_eq!(pieces, [LinePiece { range: [0.0, 0.5], kind: PieceKind::Analytic }]);
    /// ```
    fn smooth_pieces(
        &self,
        axis: usize,
        at: f64,
        range: [f64; 2],
        out: &mut Vec<LinePiece>,
    ) -> bool {
        let _ = (axis, at);
        out.clear();
        let analytic = self.analytic();
        if analytic {
            out.push(LinePiece {
                range,
                kind: PieceKind::Analytic,
            });
        }
        analytic
    }
    /// p on the line x_axis = `at` at the points `t` of the other state, all in `piece` (one
    /// of [`JointDensity::smooth_pieces`]), into `out`: the density's smooth form on that
    /// piece, equal to [`JointDensity::pdf`] inside it (up to rounding) and its limit from
    /// inside at the piece's ends. The default is [`JointDensity::pdf_on_grid`] on the line.
    ///
    /// # Panics
    /// The default panics if `out.len()` differs from `t.len()`.
    ///
    /// ```
    /// use fpsolve::density::{JointDensity, LinePiece, PieceKind};
    /// struct Normal;
    /// impl JointDensity for Normal {
    ///     fn pdf(&self, x: [f64; 2]) -> f64 {
    ///         (-(x[0] * x[0] + x[1] * x[1]) / 2.0).exp() / (2.0 * std::f64::consts::PI)
    ///     }
    ///     fn extent(&self) -> [[f64; 2]; 2] {
    ///         [[-9.0, 9.0], [-9.0, 9.0]]
    ///     }
    /// }
    /// let piece = LinePiece { range: [-9.0, 9.0], kind: PieceKind::Analytic };
    /// let mut out = [0.0; 2];
    /// Normal.pdf_on_piece(1, 0.5, &piece, &[0.0, 1.0], &mut out);
    /// assert_eq!(out[1], Normal.pdf([1.0, 0.5]));
    /// ```
    fn pdf_on_piece(&self, axis: usize, at: f64, piece: &LinePiece, t: &[f64], out: &mut [f64]) {
        let _ = piece;
        if axis == 0 {
            self.pdf_on_grid(&[at], t, out);
        } else {
            self.pdf_on_grid(t, &[at], out);
        }
    }
    /// The relative accuracy the density states for its own values (for a normalised
    /// density, its normalising constant's): the fixed rules that integrate it along
    /// [`JointDensity::smooth_pieces`] are accepted when their a-posteriori check is within a
    /// tenth of this (never tighter than 1e−10), so that a marginal or moment is as accurate
    /// as the density claims to be and no more is paid for. The default, 1e−9, gives the
    /// 1e−10 of the adaptive quadrature.
    ///
    /// ```
    /// use fpsolve::density::JointDensity;
    /// struct Normal;
    /// impl JointDensity for Normal {
    ///     fn pdf(&self, x: [f64; 2]) -> f64 {
    ///         (-(x[0] * x[0] + x[1] * x[1]) / 2.0).exp() / (2.0 * std::f64::consts::PI)
    ///     }
    ///     fn extent(&self) -> [[f64; 2]; 2] {
    ///         [[-9.0, 9.0], [-9.0, 9.0]]
    ///     }
    /// }
    /// assert_eq!(Normal.stated_accuracy(), 1e-9);
    /// ```
    fn stated_accuracy(&self) -> f64 {
        1e-9
    }
}
