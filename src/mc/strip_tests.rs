//! Two walls bounding a strip, set in code on a barrier-free oscillator so that one model
//! serves every strip and restitution these tests try (a model file states a strip too): every
//! sample inside, impacts at both walls, and with elastic walls the exact density of a
//! Caughey–Ma oscillator restricted to the strip, within the run's error bars.

use super::reference::{bin_errors, CaugheyMa};
use super::{BarrierLayout, Grid, McConfig, McError, McResult, Simulation};
use crate::dynamics::{Barrier, BarrierKind};
use crate::grid::BarrierSide;

pub(crate) const OSCILLATOR: CaugheyMa = CaugheyMa {
    c: 0.2,
    a: 0.5,
    k: 1.0,
    mu: 0.5,
    s: 0.4,
};

/// Reflecting walls `v -> -r v` at `lo` (state above) and `hi` (state below).
pub(crate) fn strip(lo: f64, hi: f64, r: f64) -> Vec<Barrier> {
    vec![
        Barrier::restitution(lo, BarrierSide::Above, r),
        Barrier::restitution(hi, BarrierSide::Below, r),
    ]
}

/// A Monte Carlo run of the oscillator between the walls, histograms of z and v on `bins`.
pub(crate) fn run_strip(
    [lo, hi]: [f64; 2],
    r: f64,
    bins: [usize; 2],
    trajectories: u64,
    samples: u64,
) -> Result<McResult, McError> {
    let model = OSCILLATOR.model().bind(&[]).unwrap();
    let config = McConfig {
        trajectories,
        samples,
        seed: 7,
        grids: vec![
            ("z".into(), Grid::new(lo, hi, bins[0]).unwrap()),
            ("v".into(), Grid::new(-3.5, 3.5, bins[1]).unwrap()),
        ],
        ..McConfig::default()
    };
    Simulation::with_impacts(&model, &config, strip(lo, hi, r))?.run()
}

#[test]
fn elastic_strip_restricts_the_caughey_ma_density() {
    let (lo, hi) = (-0.6, 0.8);
    let res = run_strip([lo, hi], 1.0, [28, 28], 2048, 1000).unwrap();
    // The walls are hit often (0.37 impacts per unit time and trajectory, measured).
    let rate = res.impacts.as_ref().unwrap().rate.value;
    assert!(rate > 0.2, "impact rate {rate}");
    assert_eq!(res.settings.barriers.len(), 2);
    for (axis, name) in [(0, "z"), (1, "v")] {
        let q = res.quantity(name).unwrap();
        if axis == 0 {
            assert!(q.min >= lo && q.max <= hi, "z in [{}, {}]", q.min, q.max);
            assert_eq!(q.underflow + q.overflow, 0);
        }
        let g = q.grid;
        let edges: Vec<f64> = (0..=g.bins).map(|j| g.lo + j as f64 * g.width()).collect();
        let exact = OSCILLATOR.bin_masses(axis, &edges, [lo, hi]);
        let top = exact.iter().cloned().fold(0.0, f64::max);
        let mut worst = 0.0f64;
        for j in (0..g.bins).filter(|&j| exact[j] > 1e-3 * top) {
            worst = worst.max(((q.density[j] - exact[j] / g.width()) / q.stderr[j]).abs());
        }
        let (l1, log) = bin_errors(&exact, &q.density, g.width(), 1e-3);
        let noise: f64 = q.stderr.iter().sum::<f64>() * g.width();
        println!(
            "strip {name}: L1 {l1:.2e} (noise {noise:.1e}), max|log10| {log:.2e}, worst {worst:.1} se, impact rate {rate:.3}"
        );
        assert!(worst < 5.0, "{name}: {worst:.1} standard errors");
    }
}

#[test]
fn walls_that_do_not_bound_a_strip_are_refused() {
    let model = OSCILLATOR.model().bind(&[]).unwrap();
    let config = McConfig::default();
    let mut swapped = strip(-0.5, 0.5, 1.0);
    swapped[0].kind = BarrierKind::Reflecting(BarrierSide::Below);
    swapped[1].kind = BarrierKind::Reflecting(BarrierSide::Above);
    let err = Simulation::with_impacts(&model, &config, swapped)
        .err()
        .unwrap();
    assert!(matches!(
        err,
        McError::Barriers {
            layout: BarrierLayout::NotAStrip { .. }
        }
    ));
    let mut three = strip(-0.5, 0.5, 1.0);
    three.push(three[0].clone());
    let err = Simulation::with_impacts(&model, &config, three)
        .err()
        .unwrap();
    assert!(matches!(
        err,
        McError::Barriers {
            layout: BarrierLayout::TooMany { count: 3 }
        }
    ));
}
