//! The grid's box given by hand (`--domain`, [`GridSolver::domain`]): refused before any work
//! when it is not a box or does not fit the model's walls (exit 2, a message naming the flag),
//! and, when it cuts the density, flagged with the mass at its edges, which the error
//! estimate then counts.

mod common;

use std::path::Path;

use common::refused;
use fpsolve::grid::{Domain, GridSolver};
use fpsolve::model::load_model;

const LINEAR: &str = "models/linear.sde";
const WALL: &str = "models/vibro_impact_duffing.sde";
const STRIP: &str = "models/vibro_impact_strip.sde";

#[test]
fn a_box_that_is_not_one_is_refused_before_any_work() {
    for (tag, domain, msg) in [
        (
            "dom-order",
            "x=3:1,v=-4:4",
            "lower end must be below the upper end",
        ),
        (
            "dom-equal",
            "x=1:1,v=-4:4",
            "lower end must be below the upper end",
        ),
        ("dom-inf", "x=-inf:3,v=-4:4", "finite"),
        ("dom-nan", "x=NaN:3,v=-4:4", "finite"),
        ("dom-v-zero", "x=-3:3,v=1:4", "hold 0 inside"),
        ("dom-name", "q=-3:3,v=-4:4", "`q`"),
        ("dom-twice", "x=-3:3,x=-4:4", "`x`"),
        ("dom-syntax", "x=-3..3", "is not x=LO:HI,v=LO:HI"),
    ] {
        refused(
            tag,
            &["solve", LINEAR, "--method", "grid", "--domain", domain],
            &["--domain", msg],
        );
    }
    // The model's own names are accepted (and checked) as well as x and v.
    refused(
        "dom-own-names",
        &[
            "solve",
            LINEAR,
            "--method",
            "grid",
            "--domain",
            "z=2:1,v=-4:4",
        ],
        &["--domain", "lower end must be below the upper end"],
    );
    refused(
        "dom-no-grid",
        &[
            "solve",
            LINEAR,
            "--method",
            "epc",
            "--domain",
            "x=-3:3,v=-4:4",
        ],
        &["--domain", "grid solver is not among the methods"],
    );
}

#[test]
fn a_box_that_does_not_end_on_its_wall_is_refused() {
    // The wall at y = 0 bounds the state from below: the box's lower end must be the wall.
    refused(
        "dom-wall-below",
        &[
            "solve",
            WALL,
            "--method",
            "grid",
            "--domain",
            "y=-1:8,ydot=-14:14",
        ],
        &["--domain", "lower end -1", "the wall at 0"],
    );
    refused(
        "dom-wall-above",
        &[
            "solve",
            WALL,
            "--method",
            "grid",
            "--domain",
            "y=0.5:8,ydot=-14:14",
        ],
        &["--domain", "lower end 0.5", "the wall at 0"],
    );
    // A strip's ends may lie inside it, not beyond a wall.
    refused(
        "dom-strip-beyond",
        &[
            "solve",
            STRIP,
            "--method",
            "grid",
            "--domain",
            "y=-1:1.5,ydot=-9:9",
        ],
        &["--domain", "upper end 1.5", "not go beyond"],
    );
    // The main job checks it as `solve` does.
    refused(
        "dom-wall-job",
        &[WALL, "--domain", "y=-1:8,ydot=-14:14"],
        &["--domain", "the wall at 0"],
    );
}

/// A box cut by hand through the density is flagged (edge density and mass), and its
/// estimate grows by at least that mass; the automatic box is not flagged.
#[test]
fn a_box_cut_through_the_density_is_flagged_and_its_estimate_grows() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(LINEAR);
    let bound = load_model(&path).unwrap().bind(&[]).unwrap();
    let sized = GridSolver::new(&bound).cells(80, 120).solve().unwrap();
    assert!(!sized.report.edges.cuts_density, "{:?}", sized.report.edges);
    assert!(!sized.report.domain_given);
    // The exact position marginal is N(0, 5): a box at x = ±4 (1.8 sd) cuts it deep.
    let cut = Domain {
        x: [-4.0, 4.0],
        v: sized.report.domain.v,
    };
    let sol = GridSolver::new(&bound)
        .cells(80, 120)
        .domain(cut)
        .solve()
        .unwrap();
    let edges = sol.report.edges;
    assert!(sol.report.domain_given);
    assert!(edges.cuts_density, "{edges:?}");
    assert!(edges.relative_density[0] > 0.1 && edges.relative_density[1] > 0.1);
    assert!(edges.mass[0] > 1e-3 && edges.mass[1] > 1e-3, "{edges:?}");
    let (e_sized, e_cut) = (
        sized.report.discretisation_estimate.unwrap(),
        sol.report.discretisation_estimate.unwrap(),
    );
    let beyond: f64 = edges.beyond.iter().sum();
    assert!(beyond > edges.total_mass(), "{edges:?}");
    assert!(e_cut.x >= 2.0 * beyond && e_cut.v >= 2.0 * beyond);
    assert!(e_cut.x > 2.0 * e_sized.x, "{} vs {}", e_cut.x, e_sized.x);
    // And it covers the true error: the written position curve against N(0, 5), with the
    // exact mass beyond ±4 that the box leaves out.
    let exact = |x: f64| (-x * x / 10.0).exp() / (10.0 * std::f64::consts::PI).sqrt();
    let m = sol.marginal(0);
    let inside: f64 = m
        .centres
        .iter()
        .zip(&m.density)
        .map(|(x, p)| (p - exact(*x)).abs())
        .sum::<f64>()
        * m.width;
    let outside = 2.0 * 0.036_819; // P(|N(0, 5)| > 4)
    let l1 = inside + outside;
    assert!(l1 <= e_cut.x, "L1 {l1:.3e} > estimate {:.3e}", e_cut.x);
    assert!(sol.report.to_string().contains("cuts the density"));
}
