//! The settings' checks in their order, and the tables' shapes.

use super::*;
use crate::model::{load_model, parse_model};

fn linear() -> BoundModel {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    load_model(&path).unwrap().bind(&[]).unwrap()
}

fn small(methods: Methods) -> TransientSettings {
    let mut s = TransientSettings::new(vec![0.0, 0.5, 1.0]);
    s.methods = methods;
    s.cells = [32, 32];
    s.domain = Some(Domain {
        x: [-8.0, 8.0],
        v: [-8.0, 8.0],
    });
    s.mc.trajectories = 256;
    s
}

#[test]
fn methods_read_as_the_command_line_writes_them() {
    let read = |s: &str| s.parse::<Methods>();
    assert_eq!(read("grid"), Ok(Methods::Grid));
    assert_eq!(read(" mc "), Ok(Methods::Mc));
    assert_eq!(read("mc,grid"), Ok(Methods::GridAndMc));
    assert_eq!(read("grid,epc"), Err(MethodError("epc".into())));
    assert_eq!(read(""), Err(MethodError(String::new())));
}

/// Two bad settings at once: the first check in the documented order is the one reported.
#[test]
fn the_first_failing_check_is_reported() {
    let bound = linear();
    let mut s = small(Methods::Grid);
    (s.cells, s.tolerance) = ([31, 32], Some(2.0));
    let e = s.clone().check(&bound).unwrap_err();
    assert!(matches!(e, TransientSetupError::Cells(_)) && e.setting() == Some("cells"));
    s.cells = [32, 32];
    assert!(matches!(
        s.clone().check(&bound),
        Err(TransientSetupError::Tolerance(t)) if t == 2.0
    ));
    let mut s = small(Methods::Mc);
    s.domain = None;
    assert!(matches!(
        s.clone().check(&bound),
        Err(TransientSetupError::McWithoutBox)
    ));
    s.methods = Methods::GridAndMc;
    s.mc.dt = -1.0;
    let e = s.check(&bound).unwrap_err();
    assert!(matches!(e, TransientSetupError::Mc(_)) && e.setting().is_none());
}

#[test]
fn a_time_dependent_model_needs_a_box_before_anything_else() {
    let model = parse_model(
        "model m\nstate z, v\ndrift z: v\ndrift v: -0.5*v - z\nnoise xi: intensity 1\n\
         diffusion v: 4*(exp(-0.5*t) - exp(-t))*xi\n",
        None,
    )
    .unwrap();
    let bound = model.bind(&[]).unwrap();
    let mut s = small(Methods::Grid);
    (s.domain, s.tolerance) = (None, Some(0.0));
    let e = s.check(&bound).unwrap_err();
    assert_eq!(
        e.to_string(),
        "required for a model whose coefficients depend on the time (the automatic box is \
         sized from a stationary law), e.g. z=-5:5,v=-5:5"
    );
}

/// Both methods on the grid's box: the moments' columns name every quantity, the PDFs' rows
/// are the cells at each time, and Monte Carlo's bins are the grid's cells.
#[test]
fn the_tables_hold_every_quantity_and_cell() {
    let bound = linear();
    let checked = small(Methods::GridAndMc).check(&bound).unwrap();
    assert_eq!(checked.settings().tolerance, Some(1e-4));
    let run = checked.run(&bound).unwrap();
    let moments = run.moments(&bound);
    assert_eq!(
        moments.names[..4],
        ["t", "z_mean", "z_variance", "z_kurtosis"]
    );
    for name in ["y_variance_err", "ydot_kurtosis", "v_kurtosis_mc_se"] {
        assert!(moments.column(name).is_some(), "{name}");
    }
    // The grid's 4 quantities × 6 (with errors), the MC's 2 states × 6, and t.
    assert_eq!(moments.names.len(), 1 + 4 * 6 + 2 * 6);
    assert_eq!(moments.column("t"), Some(&[0.0, 0.5, 1.0][..]));
    let pdf = run.pdf(1);
    assert_eq!(pdf.names, ["t", "x", "grid", "mc", "mc_se"]);
    assert!(pdf.values.iter().all(|c| c.len() == 3 * 32));
    let x = pdf.column("x").unwrap();
    assert_eq!(x[..32], x[32..64]);
    assert_eq!(pdf.csv().lines().count(), 1 + 3 * 32);
    assert!(run.warnings(&bound).iter().all(|w| !w.flags()));
}

/// A period with Monte Carlo alone: the period checked before any work (its value the
/// `period` setting, a period the force does not have naming the coefficient), then the
/// periodic state at the phases with Monte Carlo's report and no grid.
#[test]
fn a_period_runs_on_monte_carlo_alone() {
    let bound = parse_model(
        "model f\nstate x, v\ndrift x: v\ndrift v: -0.5*v - x + cos(t)\n\
         noise xi: intensity 0.5\ndiffusion v: xi\n",
        None,
    )
    .unwrap()
    .bind(&[])
    .unwrap();
    let period = 2.0 * std::f64::consts::PI;
    let mut s = small(Methods::Mc);
    s.times = vec![0.0, 0.5 * period];
    s.period = Some(-1.0);
    let e = s.clone().check(&bound).unwrap_err();
    assert_eq!(e.setting(), Some("period"), "{e}");
    s.period = Some(3.0);
    let e = s.clone().check(&bound).unwrap_err();
    assert!(
        matches!(
            &e,
            TransientSetupError::Mc(McTransientError::Period(PeriodError::NotPeriodic { .. }))
        ),
        "{e}"
    );
    s.period = Some(period);
    let run = s.check(&bound).unwrap().run(&bound).unwrap();
    assert!(run.grid.is_none() && run.periodic.is_none());
    assert_eq!(run.times(), vec![0.0, 0.5 * period]);
    let report = run.mc_periodic.expect("Monte Carlo's periodic report");
    assert!(report.discarded_periods >= 1 && report.recorded_periods == 8);
    // In resonance the response is 2 sin t: the velocity's mean 2 cos t is 2 at phase 0
    // and −2 half a period later.
    let mean = |k: usize| run.mc.as_ref().unwrap().snapshots[k].moments[1].mean;
    for (k, exact) in [(0, 2.0), (1, -2.0)] {
        let m = mean(k);
        assert!(
            (m.value - exact).abs() < 5.0 * m.stderr + 0.02,
            "{k}: {m:?}"
        );
    }
}
