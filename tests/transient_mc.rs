//! The Monte Carlo transient against the exact law: the linear oscillator from rest under
//! white noise (x' = v, v' = −0.1 v − x + ξ, intensity 1) has Gaussian marginals whose
//! variances solve the Lyapunov equation. 16 384 trajectories, dt = 0.01: each variance
//! within 4.5 standard errors plus its time-step bias estimate.

mod transient_exact;

use std::path::Path;

use fpsolve::mc::McTransient;
use fpsolve::model::{load_model, InitialState};
use transient_exact::lyapunov;

#[test]
fn linear_oscillator_from_rest_matches_the_lyapunov_variances() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    let model = load_model(&path).unwrap().bind(&[]).unwrap();
    let times = vec![0.0, 1.0, 3.0, 6.0];
    let h = McTransient::new(&model)
        .initial(InitialState::Rest)
        .times(times.clone())
        .trajectories(16_384)
        .dt(0.01)
        .seed(7)
        .run()
        .unwrap();
    let exact = lyapunov(0.1, 1.0, |_| 1.0, [0.0, 0.0], [[0.0; 2]; 2], &times);
    for (s, (_, cov)) in h.snapshots.iter().zip(&exact) {
        for (axis, m) in s.moments.iter().enumerate() {
            let want = cov[axis][axis];
            let bias = m.bias.map_or(0.0, |b| b[1].value.abs() + b[1].stderr);
            let off = (m.variance.value - want).abs();
            eprintln!(
                "t = {}: var[{axis}] {:.5} ± {:.1e} (bias {bias:.1e}), exact {want:.5}",
                s.t, m.variance.value, m.variance.stderr
            );
            assert!(
                off <= 4.5 * m.variance.stderr + bias + 1e-12,
                "t = {} axis {axis}",
                s.t
            );
            assert!(
                m.mean.value.abs() <= 4.5 * m.mean.stderr + 1e-12,
                "t = {}",
                s.t
            );
        }
        assert_eq!(s.blown_up, 0);
    }
}
