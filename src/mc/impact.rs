//! Impacts as events: a barrier on one state, and the jump map applied where a step meets it.
//!
//! Each trajectory remembers the side of the barrier it is on. A move "meets" the barrier
//! when it ends strictly on the other side, or lands exactly on the barrier from off it;
//! a trajectory sitting exactly on the barrier may leave towards its own side freely. After
//! the jump the side is set by the direction the trajectory moves in: for the Zhuravlev map
//! (`v → r·v`, paper's Eq. 6) it passes through to the other side, for a reflecting law
//! (`v → −r·v`, Eq. 2) it stays. Within one free flight a trajectory starts its remaining
//! motion at the barrier and moves away from it, so it meets the barrier at most once per
//! flight: a chattering trajectory costs at most one event per sub-step, and one that has
//! lost all its velocity waits on the barrier until the force or the noise carries it away.

use super::eval::BatchKernel;

/// A compiled impact law.
pub(crate) struct Barrier {
    /// Index of the state that meets the barrier.
    pub(crate) state: usize,
    /// Where the barrier is.
    pub(crate) at: f64,
    /// Index of the state that jumps.
    pub(crate) other: usize,
    /// The post-impact value of `other`, an expression of the states.
    pub(crate) map: Box<dyn BatchKernel>,
}

impl Barrier {
    /// The value of `other` after an impact at the state `(x, v)` (on the barrier).
    pub(crate) fn jump(&self, x: f64, v: f64) -> f64 {
        let mut out = [0.0];
        self.map.eval_point(x, v, &mut out);
        out[0]
    }

    /// The side (±1) a trajectory starting at `s` on the barrier state is on.
    pub(crate) fn initial_side(&self, s: f64) -> f64 {
        if s >= self.at {
            1.0
        } else {
            -1.0
        }
    }
}

/// Whether the move `s0 → s1` of the barrier state, on side `side`, meets the barrier at `b`.
#[inline(always)]
pub(crate) fn meets(b: f64, side: f64, s0: f64, s1: f64) -> bool {
    let d0 = (s0 - b) * side;
    let d1 = (s1 - b) * side;
    d1 < 0.0 || (d1 == 0.0 && d0 > 0.0)
}

/// Free flight `x ← x + v·τ` of a batch, with impacts located exactly (the motion is
/// linear within the flight) for the mechanical form, where the barrier is on `x` and the
/// jump acts on `v`.
///
/// `scratch` holds the new positions; `impacts[i]` counts lane i's events.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn free_flight(
    x: &mut Vec<f64>,
    v: &mut [f64],
    side: &mut [f64],
    impacts: &mut [u64],
    tau: f64,
    barrier: Option<&Barrier>,
    scratch: &mut Vec<f64>,
) {
    let n = x.len();
    let Some(bar) = barrier else {
        for (x, v) in x.iter_mut().zip(v.iter()) {
            *x += *v * tau;
        }
        return;
    };
    let b = bar.at;
    scratch.resize(n, 0.0);
    let xn = &mut scratch[..n];
    let mut any = false;
    for i in 0..n {
        xn[i] = x[i] + v[i] * tau;
        any |= meets(b, side[i], x[i], xn[i]);
    }
    if any {
        for i in 0..n {
            if meets(b, side[i], x[i], xn[i]) {
                // The flight is linear, so the crossing time is exact.
                let t_hit = ((b - x[i]) / v[i]).clamp(0.0, tau);
                let v_new = bar.jump(b, v[i]);
                if v_new * side[i] < 0.0 {
                    side[i] = -side[i];
                }
                v[i] = v_new;
                xn[i] = b + v_new * (tau - t_hit);
                impacts[i] += 1;
            }
        }
    }
    std::mem::swap(x, scratch);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::eval::compile;
    use crate::symbolic::Expr;

    fn barrier(map: Expr) -> Barrier {
        Barrier {
            state: 0,
            at: 0.0,
            other: 1,
            map: compile(&[map], ["z", "v"]).unwrap(),
        }
    }

    #[test]
    fn zhuravlev_map_passes_through_with_reduced_speed() {
        let bar = barrier(Expr::num(0.5) * Expr::sym("v"));
        let (mut x, mut v, mut side, mut k) = (vec![0.1], vec![-1.0], vec![1.0], vec![0]);
        let mut s = Vec::new();
        free_flight(&mut x, &mut v, &mut side, &mut k, 0.3, Some(&bar), &mut s);
        // 0.1 to reach the barrier, then 0.2 at speed −0.5.
        assert!((x[0] + 0.1).abs() < 1e-15);
        assert_eq!((v[0], side[0], k[0]), (-0.5, -1.0, 1));
        // Moving on, away from the barrier: no more events.
        free_flight(&mut x, &mut v, &mut side, &mut k, 0.3, Some(&bar), &mut s);
        assert_eq!(k[0], 1);
    }

    #[test]
    fn reflecting_map_stays_on_its_side() {
        let bar = barrier(Expr::num(-0.8) * Expr::sym("v"));
        let (mut x, mut v, mut side, mut k) = (vec![0.1], vec![-1.0], vec![1.0], vec![0]);
        let mut s = Vec::new();
        free_flight(&mut x, &mut v, &mut side, &mut k, 0.3, Some(&bar), &mut s);
        assert!((x[0] - 0.16).abs() < 1e-15);
        assert_eq!((v[0], side[0], k[0]), (0.8, 1.0, 1));
    }

    #[test]
    fn a_trajectory_resting_on_the_barrier_leaves_freely_towards_its_side() {
        let bar = barrier(Expr::num(0.0) * Expr::sym("v"));
        let (mut x, mut v, mut side, mut k) = (vec![0.1], vec![-1.0], vec![1.0], vec![0]);
        let mut s = Vec::new();
        free_flight(&mut x, &mut v, &mut side, &mut k, 0.3, Some(&bar), &mut s);
        assert_eq!((x[0], v[0], k[0]), (0.0, 0.0, 1));
        v[0] = 0.5;
        free_flight(&mut x, &mut v, &mut side, &mut k, 0.2, Some(&bar), &mut s);
        assert_eq!((x[0], k[0]), (0.1, 1));
        // Pushed into the barrier again: a new impact, which stops it again.
        v[0] = -2.0;
        free_flight(&mut x, &mut v, &mut side, &mut k, 0.2, Some(&bar), &mut s);
        assert_eq!((x[0], v[0], k[0]), (0.0, 0.0, 2));
    }
}
