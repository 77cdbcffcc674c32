//! An EPC solution as a joint density: its tensor-grid evaluation, and the smooth pieces of
//! its lines inside a ridge.

use std::cell::Cell;

use crate::density::{JointDensity, LinePiece, PieceKind};
use crate::epc::{EpcSolution, Stretch};

impl JointDensity for EpcSolution {
    fn pdf(&self, x: [f64; 2]) -> f64 {
        EpcSolution::pdf(self, x[0], x[1])
    }

    /// Bit for bit `pdf` at each point, with the powers shared along rows and columns.
    fn pdf_on_grid(&self, x1: &[f64], x2: &[f64], out: &mut [f64]) {
        EpcSolution::pdf_on_grid(self, x1, x2, out);
    }

    /// C·exp(Q) on the plane. Inside a ridge the density is cut off to the region (a mask of
    /// grid cells, and a C^∞ cutoff of Q across the last e-fold above the floor): not
    /// analytic, so its lines are split into [`JointDensity::smooth_pieces`] instead.
    fn analytic(&self) -> bool {
        EpcSolution::on_plane(self)
    }

    /// The whole range on the plane; inside a ridge the runs of the region's masked cells on
    /// the line, split where the cutoff starts to rise: analytic pieces where the density is
    /// C·exp(Q), transitions (at most C·exp(floor + 1)) where it is C·exp(Q)·cutoff(Q).
    fn smooth_pieces(
        &self,
        axis: usize,
        at: f64,
        range: [f64; 2],
        out: &mut Vec<LinePiece>,
    ) -> bool {
        thread_local! {
            // A line's stretches, kept between calls (a line integral allocates nothing).
            static STRETCHES: Cell<Vec<([f64; 2], Stretch)>> = const { Cell::new(Vec::new()) };
        }
        let mut stretches = STRETCHES.take();
        EpcSolution::smooth_pieces(self, axis, at, range, &mut stretches);
        let max = self.transition_max();
        out.clear();
        out.extend(stretches.iter().map(|&(range, kind)| LinePiece {
            range,
            kind: match kind {
                Stretch::Core => PieceKind::Analytic,
                Stretch::Transition => PieceKind::Transition { max },
            },
        }));
        STRETCHES.set(stretches);
        true
    }

    /// C·exp(Q) times the piece's cutoff (1 on the plane), Q restricted to the line once.
    fn pdf_on_piece(&self, axis: usize, at: f64, piece: &LinePiece, t: &[f64], out: &mut [f64]) {
        let kind = match piece.kind {
            PieceKind::Analytic => Stretch::Core,
            PieceKind::Transition { .. } => Stretch::Transition,
        };
        EpcSolution::pdf_on_piece(self, axis, at, kind, t, out);
    }

    /// The normalisation's [`stated_accuracy`](crate::epc::NormalisationReport::stated_accuracy):
    /// 1e−9 on the plane, e^−(d−1) inside a ridge of depth d (when that is larger).
    fn stated_accuracy(&self) -> f64 {
        self.normalisation.stated_accuracy()
    }

    /// The normalisation grid, which reaches e^−40 of the peak (or the ridge region).
    fn extent(&self) -> [[f64; 2]; 2] {
        EpcSolution::extent(self)
    }
}
