//! The kernel's own tests: every vector width gives the same bits, and the vector impacts
//! are `impact_in_flight`'s.

use super::*;
use crate::mc::compile::eval::compile;
use crate::mc::compile::mech_form::tests::{plan, plan_named};
use crate::mc::compile::mech_form::MechForm;
use crate::mc::compile::scheme::{Dynamics, Plan};
use crate::mc::compile::tally::ImpactSink;
use crate::mc::kernel::rng::{stream_state, IncrementStream, Increments};
use crate::symbolic::Expr;

/// A batch's columns as the kernel takes them, and their rows.
#[derive(Clone, Debug, PartialEq)]
struct Batch {
    x: Vec<u64>,
    v: Vec<u64>,
    side: Vec<u64>,
    impacts: Vec<u64>,
    rng: [Vec<u64>; 4],
    draws: Vec<u64>,
    field: u8,
    rows: [Vec<u64>; 2],
}

fn form_of(p: &Plan) -> &MechForm {
    match &p.dynamics {
        Dynamics::Mechanical { form: Some(f), .. } => f,
        _ => panic!("not on the fast path"),
    }
}

/// The bits of `s`, every NaN as one: which of two NaN operands an operation returns is
/// not fixed (the compiler may swap the operands of a sum or product), and a NaN lane has
/// blown up whatever its bits.
fn bits_of(s: f64) -> u64 {
    if s.is_nan() {
        f64::NAN.to_bits()
    } else {
        s.to_bits()
    }
}

/// Uniform numbers in [0, 1) from a xorshift64 generator started at `seed` (test data).
pub(crate) fn uniforms(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `lanes` lanes from states spread over [−2, 2] (each on its side of the barrier), run
/// with `simd` through 7 calls of `samples` × `steps` steps (10, not a multiple of 3, so
/// that calls start at every field of a draw), every state as bits.
fn run(plan: &Plan, bar: Option<&Barrier>, simd: Simd, lanes: usize) -> Batch {
    let (samples, steps, h) = (2, 5, 0.02);
    let mut uniform = uniforms(0x9E37_79B9_7F4A_7C15);
    let side0 = bar.map_or(1.0, |b| b.side);
    let mut x: Vec<f64> = (0..lanes).map(|_| side0 * 2.0 * uniform()).collect();
    let mut v: Vec<f64> = (0..lanes).map(|_| 4.0 * uniform() - 2.0).collect();
    // Lanes on the barrier, at rest or leaving, and a blown-up one.
    x[1] = 0.0;
    v[1] = 0.0;
    x[2] = 0.0;
    v[2] = side0;
    x[3] = f64::NAN;
    let mut side = vec![side0; lanes];
    let mut impacts = vec![0; lanes];
    let mut words: [Vec<u64>; 4] = std::array::from_fn(|_| vec![0; lanes]);
    for i in 0..lanes {
        let s = stream_state(5, i as u64);
        for j in 0..4 {
            words[j][i] = s[j];
        }
    }
    let mut inc = IncrementStream::new(Increments::ThreePoint, lanes);
    let tp = inc.three_point_mut().unwrap();
    let mut rows = [
        vec![0.0; lanes * samples as usize],
        vec![0.0; lanes * samples as usize],
    ];
    let mut out_rows = [vec![], vec![]];
    for _call in 0..7 {
        let [r0, r1, r2, r3] = &mut words;
        let [rx, rv] = &mut rows;
        let c = Columns {
            x: &mut x,
            v: &mut v,
            side: &mut side,
            impacts: ImpactSink::new(&mut impacts, None),
            rng: [r0, r1, r2, r3],
            draws: &mut *tp.draws,
            rows: Some(Rows {
                x: rx,
                v: rv,
                stride: lanes,
            }),
        };
        advance(
            Coefs::new(form_of(plan), h, tp.a),
            bar,
            c,
            &mut *tp.field,
            samples,
            steps,
            h,
            simd,
        );
        for (o, r) in out_rows.iter_mut().zip(&rows) {
            o.extend(r.iter().map(|&s| bits_of(s)));
        }
    }
    let bits = |s: &[f64]| s.iter().map(|&s| bits_of(s)).collect::<Vec<_>>();
    Batch {
        x: bits(&x),
        v: bits(&v),
        side: bits(&side),
        impacts,
        rng: words,
        draws: tp.draws.to_vec(),
        field: *tp.field,
        rows: out_rows,
    }
}

/// The barrier of `plan` with the map `map` of (z, v) instead of its own.
fn with_map(plan: &Plan, map: Expr) -> Barrier {
    let b = &plan.barriers[0];
    Barrier {
        state: b.state,
        at: b.at,
        other: b.other,
        map: compile(std::slice::from_ref(&map), ["z", "v"]).unwrap(),
        expr: map,
        side: b.side,
        crossing: b.crossing,
    }
}

/// Scalar lanes, single vectors and groups of every width available give the same bits
/// (states, sides, impacts, generators, pending increments and rows), with the law `r·v`
/// resolved in vector form, with a law that is not (lane by lane), and without a barrier;
/// 150 lanes cover whole groups, single vectors and leftover lanes of every width.
#[test]
fn every_vector_width_gives_the_same_bits() {
    for name in [
        "vibro_impact_duffing",
        "vibro_duffing",
        "van_der_pol",
        "parametric",
        "energy_damping",
        "rayleigh_impact",
    ] {
        let p = plan_named(name).unwrap();
        let nonlinear = p.barriers.first().map(|_| {
            let v = Expr::sym("v");
            with_map(
                &p,
                Expr::num(-0.6) * v.clone() + Expr::num(0.01) * v.clone() * v,
            )
        });
        let bars: Vec<Option<&Barrier>> = match (&p.barriers.first(), &nonlinear) {
            (Some(b), Some(n)) => vec![Some(b), Some(n), None],
            _ => vec![None],
        };
        for bar in bars {
            let want = run(&p, bar, Simd::Baseline, 150);
            if bar.is_some() {
                assert!(want.impacts.iter().sum::<u64>() > 20, "{name}: few impacts");
            }
            for simd in Simd::available() {
                let got = run(&p, bar, simd, 150);
                assert!(
                    got == want,
                    "{name}, {simd:?}, gain {:?}",
                    bar.map(|b| b.gain())
                );
            }
        }
    }
}

/// The vector impact of a law `r·v` is `impact_in_flight`'s, bit for bit, at crossings,
/// landings on the barrier, starts on it, and both kinds of law.
#[test]
fn vector_impacts_are_impact_in_flight() {
    let p = plan("vibro_impact_duffing").unwrap();
    for map in ["0.7*v", "-0.8*v", "v*0.3", "-(0.9*v)"] {
        let expr: Expr = crate::model::parse_expr(map).unwrap();
        let bar = with_map(&p, expr);
        let r = bar.gain().expect("a law r·v");
        let jump = Jump {
            bar: &bar,
            gain: Some(r),
        };
        let tau = 0.01;
        for (x0, v) in [
            (0.003, -0.7),
            (0.007, -0.7),
            (1e-9, -3.1),
            (0.0, -1.0),
            (-0.004, 0.9),
            (0.0, 0.0),
        ] {
            let side = if x0 < 0.0 { -1.0f64 } else { 1.0 };
            let xn = x0 + v * tau;
            let hit = crate::mc::compile::impact::meets(bar.at, side, x0, xn);
            let (mut wx, mut wv, mut ws) = (xn, v, side);
            if hit {
                impact_in_flight(x0, &mut wx, &mut wv, &mut ws, tau, &bar);
            }
            let (mut fx, mut fv, mut fs, mut count) = ([xn], [v], [side.and(-0.0)], [0]);
            impacts::<f64, 1>(&mut Flight {
                jump: &jump,
                x0: &[x0],
                x: &mut fx,
                v: &mut fv,
                side: &mut fs,
                impacts: &mut ImpactSink::new(&mut count, None),
                tau,
                near: 1,
            });
            let got = (fx[0].to_bits(), fv[0].to_bits(), fs[0].or(1.0), count[0]);
            assert_eq!(
                got,
                (wx.to_bits(), wv.to_bits(), ws, u64::from(hit)),
                "{map} {x0} {v}"
            );
        }
    }
}
