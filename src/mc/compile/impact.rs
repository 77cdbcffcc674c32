//! Impacts as events: barriers on one state (one, or two bounding a strip), and the jump map
//! applied where a step meets one.
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
//!
//! Between two walls (a strip, both laws reflecting) a fast trajectory may hit both walls,
//! even several times, within one flight: the flight is continued from each impact with the
//! remaining time until it is used up, each impact located exactly, at most
//! [`MAX_FLIGHT_EVENTS`] per flight (every one counted). A flight that needs more spends the
//! rest of its time on the wall it last hit (its speed is then beyond any the model can
//! reach: the strip's width crossed that many times in one sub-step).

use crate::mc::compile::eval::{BatchKernel, NO_TIME};
use crate::mc::compile::lanes::LaneOp;
use crate::mc::compile::tally::ImpactSink;
use crate::symbolic::Expr;

/// Impacts one free flight between two walls may have before its remaining time is spent on
/// the wall (see the module's documentation).
pub(crate) const MAX_FLIGHT_EVENTS: usize = 64;

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
    /// The map as an expression (for the run's settings).
    pub(crate) expr: Expr,
    /// The side (±1) trajectories start on.
    pub(crate) side: f64,
    /// Whether the law keeps the state on its side (a wall) or lets it pass through.
    pub(crate) crossing: Crossing,
}

/// What an impact does to the side of the barrier a trajectory is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Crossing {
    /// A reflecting wall (a law with a `domain`): the state lives on one side, always.
    Reflects,
    /// A pass-through law (the Zhuravlev form, Eq. 6): after the jump the trajectory moves on
    /// to whichever side the barrier state's motion takes it.
    PassesThrough,
}

impl Barrier {
    /// The value of `other` after an impact at the state `(x, v)` (on the barrier).
    pub(crate) fn jump(&self, x: f64, v: f64) -> f64 {
        let mut out = [0.0];
        self.map.eval_point(NO_TIME, x, v, &mut out);
        out[0]
    }

    /// `r` when the compiled map is the law `v → r·v` of the jumping state, a product the
    /// tape rounds once (`r·v`, `v·r`, a negation of either, or `v` itself): `r·v` is then
    /// the map's value bit for bit, which lets the mechanical kernel resolve impacts in
    /// vector form. `None` for any other map.
    pub(crate) fn gain(&self) -> Option<f64> {
        let program = self.map.program();
        let ops = program.ops();
        let other = u32::try_from(self.other).ok()?;
        // ±1 when op `i` is ±v.
        let unit = |i: u32| -> Option<f64> {
            match ops.get(i as usize)? {
                LaneOp::Var(j) if *j == other => Some(1.0),
                LaneOp::Neg(a) => match ops.get(*a as usize)? {
                    LaneOp::Var(j) if *j == other => Some(-1.0),
                    _ => None,
                },
                _ => None,
            }
        };
        let constant = |i: u32| match ops.get(i as usize)? {
            LaneOp::Const(c) => Some(*c),
            _ => None,
        };
        // (±v)·c = ±(v·c) = (±c)·v exactly: rounding to nearest is symmetric.
        let gain = |i: u32| -> Option<f64> {
            match *ops.get(i as usize)? {
                LaneOp::MulC(a, c) => Some(unit(a)? * c),
                LaneOp::Mul(a, b) => match (unit(a), unit(b)) {
                    (Some(s), None) => Some(s * constant(b)?),
                    (None, Some(s)) => Some(s * constant(a)?),
                    _ => None,
                },
                _ => unit(i),
            }
        };
        let &[out] = program.outputs() else {
            return None;
        };
        match ops.get(out as usize)? {
            LaneOp::Neg(a) => gain(*a).map(|r| -r),
            _ => gain(out),
        }
    }

    /// The side (±1) of a barrier at `at` holding the value `s` (+1 on the barrier).
    pub(crate) fn side_of(at: f64, s: f64) -> f64 {
        if s >= at {
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
/// linear within the flight) for the mechanical form, where the barriers are on `x` and the
/// jumps act on `v`: none, one, or two bounding a strip (lower first).
///
/// `scratch` holds the new positions; `impacts[i]` counts lane i's events.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn free_flight(
    x: &mut Vec<f64>,
    v: &mut [f64],
    side: &mut [f64],
    impacts: &mut ImpactSink<'_>,
    tau: f64,
    barriers: &[Barrier],
    scratch: &mut Vec<f64>,
) {
    let n = x.len();
    let bar = match barriers {
        [] => {
            for (x, v) in x.iter_mut().zip(v.iter()) {
                *x += *v * tau;
            }
            return;
        }
        [bar] => bar,
        [lo, hi, ..] => return strip_flight(x, v, impacts, tau, [lo, hi]),
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
        impacts_in_flight(x, xn, v, side, impacts, tau, bar);
    }
    std::mem::swap(x, scratch);
}

/// The impacts of a flight `x → xn = x + v·τ` at the one barrier `bar`: each lane that meets
/// it gets the jump at the exactly located crossing and the rest of its flight from there.
pub(crate) fn impacts_in_flight(
    x: &[f64],
    xn: &mut [f64],
    v: &mut [f64],
    side: &mut [f64],
    impacts: &mut ImpactSink<'_>,
    tau: f64,
    bar: &Barrier,
) {
    for i in 0..xn.len() {
        if meets(bar.at, side[i], x[i], xn[i]) {
            let before = v[i];
            impact_in_flight(x[i], &mut xn[i], &mut v[i], &mut side[i], tau, bar);
            impacts.hit(i, 0, before, v[i]);
        }
    }
}

/// The impact of one lane whose flight `x → xn = x + v·τ` meets `bar`: the jump at the
/// exactly located crossing (the flight is linear), the side after it, and the rest of the
/// flight from the barrier.
#[inline(never)]
pub(crate) fn impact_in_flight(
    x: f64,
    xn: &mut f64,
    v: &mut f64,
    side: &mut f64,
    tau: f64,
    bar: &Barrier,
) {
    let b = bar.at;
    let t_hit = ((b - x) / *v).clamp(0.0, tau);
    let v_new = bar.jump(b, *v);
    if v_new * *side < 0.0 {
        *side = -*side;
    }
    *v = v_new;
    *xn = b + v_new * (tau - t_hit);
}

/// Free flight between two reflecting walls `lo.at < hi.at`, the state inside: each lane's
/// flight is continued from every impact with its remaining time (see the module's
/// documentation).
#[inline(always)]
fn strip_flight(
    x: &mut [f64],
    v: &mut [f64],
    impacts: &mut ImpactSink<'_>,
    tau: f64,
    [lo, hi]: [&Barrier; 2],
) {
    let (a, b) = (lo.at, hi.at);
    for i in 0..x.len() {
        let end = x[i] + v[i] * tau;
        if a < end && end < b {
            x[i] = end;
            continue;
        }
        // Out of events, the rest of the flight is spent on the wall last hit.
        let (mut s, mut u, mut rest) = (x[i], v[i], tau);
        for _ in 0..MAX_FLIGHT_EVENTS {
            let end = s + u * rest;
            let (k, wall) = if meets(a, 1.0, s, end) {
                (0, lo)
            } else if meets(b, -1.0, s, end) {
                (1, hi)
            } else {
                s = end;
                break;
            };
            let t_hit = ((wall.at - s) / u).clamp(0.0, rest);
            let before = u;
            u = wall.jump(wall.at, u);
            s = wall.at;
            rest -= t_hit;
            impacts.hit(i, k, before, u);
        }
        x[i] = s;
        v[i] = u;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::compile::eval::compile;
    use crate::symbolic::Expr;

    fn barrier(map: Expr) -> Barrier {
        Barrier {
            state: 0,
            at: 0.0,
            other: 1,
            map: compile(std::slice::from_ref(&map), ["z", "v"]).unwrap(),
            expr: map,
            side: 1.0,
            crossing: Crossing::PassesThrough,
        }
    }

    fn wall(at: f64, r: f64, side: f64) -> Barrier {
        Barrier {
            at,
            side,
            crossing: Crossing::Reflects,
            ..barrier(Expr::num(-r) * Expr::sym("v"))
        }
    }

    /// A fast flight across a strip hits both walls, each impact exactly located, until the
    /// flight's time is used up.
    #[test]
    fn a_fast_flight_bounces_between_both_walls() {
        let walls = [wall(-0.5, 1.0, 1.0), wall(0.5, 0.5, -1.0)];
        let (mut x, mut v, mut side, mut k) = (vec![0.0], vec![10.0], vec![1.0], vec![0]);
        let mut s = Vec::new();
        // 0.05 to the upper wall, back at speed 5 for 0.2 to the lower wall, up at 5: 0.05 left.
        free_flight(
            &mut x,
            &mut v,
            &mut side,
            &mut ImpactSink::new(&mut k, None),
            0.3,
            &walls,
            &mut s,
        );
        assert_eq!((v[0], k[0]), (5.0, 2));
        assert!((x[0] - (-0.25)).abs() < 1e-14, "{}", x[0]);
        // A slow lane inside moves freely.
        let (mut x, mut v) = (vec![0.1], vec![-1.0]);
        free_flight(
            &mut x,
            &mut v,
            &mut side,
            &mut ImpactSink::new(&mut k, None),
            0.3,
            &walls,
            &mut s,
        );
        assert!((x[0] + 0.2).abs() < 1e-15);
        assert_eq!(k[0], 2);
    }

    /// With r = 1 and an absurd speed the events stop at the bound, counted, and the lane
    /// stays on a wall, never outside the strip.
    #[test]
    fn events_per_flight_are_bounded_and_counted() {
        let walls = [wall(0.0, 1.0, 1.0), wall(1.0, 1.0, -1.0)];
        let (mut x, mut v, mut side, mut k) = (vec![0.5], vec![1e6], vec![1.0], vec![0]);
        let mut s = Vec::new();
        free_flight(
            &mut x,
            &mut v,
            &mut side,
            &mut ImpactSink::new(&mut k, None),
            1.0,
            &walls,
            &mut s,
        );
        assert_eq!(k[0], MAX_FLIGHT_EVENTS as u64);
        assert!(x[0] == 0.0 || x[0] == 1.0);
        assert_eq!(v[0].abs(), 1e6);
    }

    #[test]
    fn zhuravlev_map_passes_through_with_reduced_speed() {
        let bar = barrier(Expr::num(0.5) * Expr::sym("v"));
        let (mut x, mut v, mut side, mut k) = (vec![0.1], vec![-1.0], vec![1.0], vec![0]);
        let mut s = Vec::new();
        free_flight(
            &mut x,
            &mut v,
            &mut side,
            &mut ImpactSink::new(&mut k, None),
            0.3,
            std::slice::from_ref(&bar),
            &mut s,
        );
        // 0.1 to reach the barrier, then 0.2 at speed −0.5.
        assert!((x[0] + 0.1).abs() < 1e-15);
        assert_eq!((v[0], side[0], k[0]), (-0.5, -1.0, 1));
        // Moving on, away from the barrier: no more events.
        free_flight(
            &mut x,
            &mut v,
            &mut side,
            &mut ImpactSink::new(&mut k, None),
            0.3,
            std::slice::from_ref(&bar),
            &mut s,
        );
        assert_eq!(k[0], 1);
    }

    #[test]
    fn reflecting_map_stays_on_its_side() {
        let bar = barrier(Expr::num(-0.8) * Expr::sym("v"));
        let (mut x, mut v, mut side, mut k) = (vec![0.1], vec![-1.0], vec![1.0], vec![0]);
        let mut s = Vec::new();
        free_flight(
            &mut x,
            &mut v,
            &mut side,
            &mut ImpactSink::new(&mut k, None),
            0.3,
            std::slice::from_ref(&bar),
            &mut s,
        );
        assert!((x[0] - 0.16).abs() < 1e-15);
        assert_eq!((v[0], side[0], k[0]), (0.8, 1.0, 1));
    }

    #[test]
    fn a_trajectory_resting_on_the_barrier_leaves_freely_towards_its_side() {
        let bar = barrier(Expr::num(0.0) * Expr::sym("v"));
        let (mut x, mut v, mut side, mut k) = (vec![0.1], vec![-1.0], vec![1.0], vec![0]);
        let mut s = Vec::new();
        free_flight(
            &mut x,
            &mut v,
            &mut side,
            &mut ImpactSink::new(&mut k, None),
            0.3,
            std::slice::from_ref(&bar),
            &mut s,
        );
        assert_eq!((x[0], v[0], k[0]), (0.0, 0.0, 1));
        v[0] = 0.5;
        free_flight(
            &mut x,
            &mut v,
            &mut side,
            &mut ImpactSink::new(&mut k, None),
            0.2,
            std::slice::from_ref(&bar),
            &mut s,
        );
        assert_eq!((x[0], k[0]), (0.1, 1));
        // Pushed into the barrier again: a new impact, which stops it again.
        v[0] = -2.0;
        free_flight(
            &mut x,
            &mut v,
            &mut side,
            &mut ImpactSink::new(&mut k, None),
            0.2,
            std::slice::from_ref(&bar),
            &mut s,
        );
        assert_eq!((x[0], v[0], k[0]), (0.0, 0.0, 2));
    }
}
