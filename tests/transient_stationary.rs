//! The transient's long-time limit is the stationary solver's answer: on the same cells and
//! box both solve G p = 0 in the limit, and both read the moments of the same interpolant of
//! the cell averages. Vibro-impact case 1 (`models/vibro_duffing.sde`: a barrier at z = 0,
//! impulsive damping, parametric noise) from rest, on coarse cells so that it is cheap.

use std::path::Path;

use fpsolve::grid::{GridSolver, GridTransient, Initial};
use fpsolve::model::load_model;
use fpsolve::observe::{moments, ObservableMap};
use fpsolve::symbolic::Expr;

/// Measured at 40x80 from rest to t = 400 (tolerance 1e-6): the transient's variances of z
/// and v equal the stationary solver's within 1e-6 relative (the time-stepping error left
/// after 400 time units of decay at rate about c = 0.1); the difference of the two
/// estimators this replaced (Sheppard-corrected cell sums against the interpolant) was
/// h²/4, 2e-2 here.
#[test]
fn vibro_impact_long_time_limit_is_the_stationary_answer() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    let model = load_model(&path).unwrap().bind(&[]).unwrap();
    let (nx, nv) = (40, 80);
    let stationary = GridSolver::new(&model)
        .cells(nx, nv)
        .estimate(false)
        .solve()
        .unwrap();
    let history = GridTransient::new(&model)
        .cells(nx, nv)
        .domain(stationary.domain())
        .initial(Initial::Rest)
        .tolerance(1e-6)
        .times(vec![400.0])
        .run()
        .unwrap();
    let s = &history.snapshots[0];
    let states = ["z".into(), "v".into()];
    for (axis, name) in ["z", "v"].iter().enumerate() {
        let map = ObservableMap::classify(&Expr::sym(name), &states);
        let want = moments(&stationary, &map).moments;
        let got = s.moments[axis];
        eprintln!(
            "{name}: transient mean {:+.8} var {:.8} kurt {:.6}; stationary mean {:+.8} \
             var {:.8} kurt {:.6}",
            got.mean, got.variance, got.kurtosis, want.mean, want.variance, want.kurtosis
        );
        assert!((got.variance / want.variance - 1.0).abs() < 1e-5, "{name}");
        assert!((got.kurtosis / want.kurtosis - 1.0).abs() < 1e-5, "{name}");
        assert!((got.mean - want.mean).abs() < 1e-5 * want.variance.sqrt(), "{name}");
    }
    eprintln!("{:?}", history.report);
}
