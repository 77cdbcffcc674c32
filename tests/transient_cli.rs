//! `fpsolve transient`: a small run on the linear oscillator from a Gaussian `--initial`
//! writes its files with the exact law's moments; every bad flag is refused before any work
//! (exit 2, no output directory).

mod common;
mod transient_exact;

use std::path::Path;

use common::{fpsolve, fresh_path, json, names};
use transient_exact::lyapunov;

fn linear() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("models/linear.sde")
        .display()
        .to_string()
}

/// 64x64 cells of 0.25 on [-8, 8]², from N((1, 0), 0.25 I) to t = 2: the moments file
/// holds the states and the observables (`y = z`, `ydot = v`), its variances those of the
/// Lyapunov equation within 1 %, and the summary the run's counts with the provenance.
#[test]
fn a_small_run_writes_moments_pdfs_and_summary() {
    let out = fresh_path("transient_cli");
    let o = fpsolve(&[
        "transient",
        &linear(),
        "--times",
        "0:2:5",
        "--cells",
        "64,64",
        "--domain",
        "z=-8:8,v=-8:8",
        "--tol",
        "1e-3",
        "--initial",
        "gaussian mean z = 1, v = 0 cov 0.25, 0, 0, 0.25",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    let files = names(&out);
    for f in [
        "moments_vs_t.csv",
        "pdf_v_t.csv",
        "pdf_z_t.csv",
        "summary.json",
    ] {
        assert!(files.iter().any(|n| n == f), "{f} not in {files:?}");
    }
    let moments = std::fs::read_to_string(out.join("moments_vs_t.csv")).unwrap();
    let mut lines = moments.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header[..4], ["t", "z_mean", "z_variance", "z_kurtosis"]);
    assert!(header.contains(&"ydot_variance"), "{header:?}");
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|u| u.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 5);
    let times: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let exact = lyapunov(
        0.1,
        1.0,
        |_| 1.0,
        [1.0, 0.0],
        [[0.25, 0.0], [0.0, 0.25]],
        &times,
    );
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    for (r, (m, cov)) in rows.iter().zip(&exact) {
        let (zv, vv) = (r[col("z_variance")], r[col("v_variance")]);
        eprintln!(
            "t={}: var z {zv:.5} (exact {:.5}), v {vv:.5} ({:.5}), mean z {:.5} ({:.5})",
            r[0],
            cov[0][0],
            cov[1][1],
            r[col("z_mean")],
            m[0]
        );
        assert!((zv / cov[0][0] - 1.0).abs() < 1e-2, "{r:?} {cov:?}");
        assert!((vv / cov[1][1] - 1.0).abs() < 1e-2, "{r:?} {cov:?}");
        assert!((r[col("z_mean")] - m[0]).abs() < 1e-2);
        // The observable y = z by the midpoint rule: the same up to the grouping term h²/12.
        assert!((r[col("y_variance")] - zv - 0.25 * 0.25 / 12.0).abs() < 1e-3);
    }
    let pdf = std::fs::read_to_string(out.join("pdf_z_t.csv")).unwrap();
    assert!(pdf.starts_with("t,x,grid\n"));
    assert_eq!(pdf.lines().count(), 1 + 5 * 64);
    let s = json(&out.join("summary.json"));
    assert_eq!(s["method"], "grid");
    assert_eq!(s["grid"]["cells"][0], 64);
    assert!(s["grid"]["factorizations"].as_u64().unwrap() >= 1);
    assert_eq!(s["grid"]["time_dependent"], false);
    assert_eq!(s["outputs"].as_array().unwrap().len(), 5);
    assert!(s["provenance"]["model"]["text"]
        .as_str()
        .unwrap()
        .contains("model linear"));
    let _ = std::fs::remove_dir_all(&out);
}

/// A model whose noise is modulated in time (x' = v, v' = −0.5v − x + 4(e^{−t/2} − e^{−t})·ξ)
/// runs on both methods from N(0, 0.09 I): the Monte Carlo ensemble's means and variances
/// agree with the grid's (its distance in standard errors, `grid_vs_mc_in_se`, within 4,
/// once the grid's own estimated error is allowed for) and both with the Lyapunov
/// equation's variances. Measured (seed 2): within 2.2 standard errors.
#[test]
fn a_time_dependent_model_runs_on_both_methods_and_they_agree() {
    let modulated = fresh_path("transient_cli_modulated_both.sde");
    std::fs::write(
        &modulated,
        "model m\nstate z, v\ndrift z: v\ndrift v: -0.5*v - z\nnoise xi: intensity 1\n\
         diffusion v: 4*(exp(-0.5*t) - exp(-t))*xi\n",
    )
    .unwrap();
    let out = fresh_path("transient_cli_time_dependent");
    let o = fpsolve(&[
        "transient",
        modulated.to_str().unwrap(),
        "--times",
        "0:4:5",
        "--cells",
        "64,64",
        "--domain",
        "z=-5:5,v=-5:5",
        "--tol",
        "1e-3",
        "--initial",
        "gaussian mean z = 0, v = 0 cov 0.09, 0, 0, 0.09",
        "--method",
        "grid,mc",
        "--trajectories",
        "20000",
        "--seed",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    let s = json(&out.join("summary.json"));
    assert_eq!(s["grid"]["time_dependent"], true);
    assert_eq!(s["mc"]["settings"]["scheme"], "mechanical-strang");
    let moments = std::fs::read_to_string(out.join("moments_vs_t.csv")).unwrap();
    let mut lines = moments.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|u| u.parse().unwrap()).collect())
        .collect();
    let times: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let env2 = |t: f64| (4.0 * ((-0.5 * t).exp() - (-t).exp())).powi(2);
    let exact = lyapunov(0.5, 1.0, env2, [0.0; 2], [[0.09, 0.0], [0.0, 0.09]], &times);
    for (r, (_, cov)) in rows.iter().zip(&exact) {
        for (axis, q) in ["z", "v"].iter().enumerate() {
            for what in ["mean", "variance"] {
                let grid = r[col(&format!("{q}_{what}"))];
                let err = r[col(&format!("{q}_{what}_err"))].abs();
                let mc = r[col(&format!("{q}_{what}_mc"))];
                let se = r[col(&format!("{q}_{what}_mc_se"))];
                eprintln!(
                    "t = {}: {q} {what} grid {grid:.5} (±{err:.1e}), mc {mc:.5} ± {se:.1e}: \
                     {:+.1} se",
                    r[0],
                    (mc - grid) / se
                );
                assert!(
                    (mc - grid).abs() <= 4.0 * se + err,
                    "t = {} {q} {what}",
                    r[0]
                );
            }
            let (mc, se) = (
                r[col(&format!("{q}_variance_mc"))],
                r[col(&format!("{q}_variance_mc_se"))],
            );
            assert!((mc - cov[axis][axis]).abs() <= 4.0 * se, "t = {} {q}", r[0]);
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// Bad flags: exit 2 with the reason, nothing written.
#[test]
fn bad_flags_are_refused_before_any_work() {
    let model = linear();
    let modulated = fresh_path("transient_cli_modulated.sde");
    std::fs::write(
        &modulated,
        "model m\nstate z, v\ndrift z: v\ndrift v: -0.5*v - z\nnoise xi: intensity 1\n\
         diffusion v: 4*(exp(-0.5*t) - exp(-t))*xi\n",
    )
    .unwrap();
    let cases: [(&[&str], &str); 7] = [
        (
            &["--times", "0:1:3", "--method", "mc"],
            "required for Monte Carlo alone",
        ),
        (&["--times", "0:1:3", "--method", "epc"], "expected `grid`"),
        (&["--times", "1:0:3"], "--times"),
        (&["--times", "0:1:3", "--tol", "0"], "--tol"),
        (&["--times", "0:1:3", "--cells", "41,40"], "--cells"),
        (
            &["--times", "0:1:3", "--initial", "point q = 1, v = 0"],
            "`q` is not a state",
        ),
        (
            &["--times", "0:1:3", "--domain", "z=3:1,v=-1:1"],
            "--domain",
        ),
    ];
    for (args, what) in cases {
        let out = fresh_path("transient_cli_refused");
        let mut all = vec!["transient", &model];
        all.extend_from_slice(args);
        all.extend_from_slice(&["--out", out.to_str().unwrap()]);
        let o = fpsolve(&all);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(what), "{args:?}: `{what}` not in {stderr}");
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    }
    let o = fpsolve(&["transient", modulated.to_str().unwrap(), "--times", "0:1:3"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--domain: required"), "{stderr}");
}

/// The Zhuravlev form at rest: Monte Carlo's sampled noise sgn(z)·ξ vanishes there, so every
/// trajectory stays while the grid's density spreads. The run writes everything and exits 1
/// naming the cause and the fix; started beside rest it is sound.
#[test]
fn a_monte_carlo_ensemble_stuck_at_its_start_is_flagged() {
    // At rest in the Zhuravlev form the drift and noise vanish: refused before any work.
    let vibro = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    let out = fresh_path("transient_cli_held");
    let o = fpsolve(&[
        "transient",
        vibro.to_str().unwrap(),
        "--times",
        "0:1:2",
        "--method",
        "grid,mc",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("every path would stay at its start"),
        "{stderr}"
    );
    assert!(!out.exists());
    // Where the coefficients depend on t the check cannot decide: the run flags it after.
    let model = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/models/zhuravlev_timed.sde")
        .display()
        .to_string();
    let run = |initial: &[&str]| {
        let out = fresh_path("transient_cli_stuck");
        let mut args = vec![
            "transient",
            &model,
            "--times",
            "0:1:2",
            "--cells",
            "30,60",
            "--domain",
            "z=-8:8,v=-8:8",
            "--method",
            "grid,mc",
            "--trajectories",
            "640",
        ];
        args.extend_from_slice(initial);
        args.extend_from_slice(&["--out", out.to_str().unwrap()]);
        (fpsolve(&args), out)
    };
    let (o, out) = run(&[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("still at its start"), "{stderr}");
    assert!(out.join("moments_vs_t.csv").is_file());
    let (o, _) = run(&["--initial", "point z = 1e-6, v = 0"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// `--period` with `--method grid,mc` on the forced linear oscillator (c = 0.2, k = 1,
/// A = cos(0.8 t), intensity 0.2, as tests/transient_periodic.rs): both periodic states at
/// four phases, Monte Carlo's columns beside the grid's in both files, the discarded and
/// recorded periods in `summary.json`, and the grid's distance from Monte Carlo
/// (`grid_vs_mc_in_se`) within 4 standard errors in every mean and variance; the
/// Monte Carlo means and variances within 4 of the exact ones. A bad period with Monte Carlo
/// alone is refused before any work.
#[test]
fn a_periodic_state_runs_on_both_methods_and_they_agree() {
    let forced = fresh_path("transient_cli_forced.sde");
    std::fs::write(
        &forced,
        "model forced\nparam c = 0.2, k = 1, A = 1, w = 0.8\nstate z, v\ndrift z: v\n\
         drift v: -c*v - k*z + A*cos(w*t)\nnoise xi: intensity 0.2\ndiffusion v: xi\n",
    )
    .unwrap();
    let period = 2.0 * std::f64::consts::PI / 0.8;
    let p = format!("{period}");
    let times = format!("0:{}:4", 0.75 * period);
    let out = fresh_path("transient_cli_periodic_both");
    let base = [
        "transient",
        forced.to_str().unwrap(),
        "--period",
        &p,
        "--times",
        &times,
        "--cells",
        "64,64",
        "--domain",
        "z=-7:7,v=-7:7",
    ];
    let mut args = base.to_vec();
    args.extend_from_slice(&[
        "--method",
        "grid,mc",
        "--trajectories",
        "4096",
        "--dt",
        "0.02",
        "--seed",
        "3",
        "--out",
        out.to_str().unwrap(),
    ]);
    let o = fpsolve(&args);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    let s = json(&out.join("summary.json"));
    assert_eq!(s["periodic"]["outcome"]["stop"], "converged");
    let mc = &s["mc_periodic"];
    let discarded = mc["discarded_periods"].as_u64().unwrap();
    assert!(discarded >= 1, "{mc}");
    assert_eq!(mc["recorded_periods"], 8);
    let outputs = s["outputs"].as_array().unwrap();
    assert_eq!(outputs.len(), 4);
    for o in outputs {
        for d in o["grid_vs_mc_in_se"].as_array().unwrap() {
            for what in ["mean", "variance"] {
                let z = d[what].as_f64().unwrap();
                eprintln!(
                    "phase {}: {} {what} grid - mc = {z:+.2} se; pdf worst {}",
                    o["t"], d["state"], d["pdf_worst"]
                );
                assert!(
                    z.abs() <= 4.0,
                    "phase {} {} {what}: {z}",
                    o["t"],
                    d["state"]
                );
            }
        }
    }
    let moments = std::fs::read_to_string(out.join("moments_vs_t.csv")).unwrap();
    let mut lines = moments.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (c, k, w) = (0.2, 1.0, 0.8);
    let den: f64 = (k - w * w) * (k - w * w) + (c * w) * (c * w);
    for l in lines {
        let r: Vec<f64> = l.split(',').map(|u| u.parse().unwrap()).collect();
        let t = r[0];
        let exact = ((k - w * w) * (w * t).cos() + c * w * (w * t).sin()) / den;
        let (mean, se) = (r[col("z_mean_mc")], r[col("z_mean_mc_se")]);
        assert!(
            (mean - exact).abs() <= 4.0 * se,
            "phase {t}: {mean} ± {se} vs {exact}"
        );
        let (var, se) = (r[col("z_variance_mc")], r[col("z_variance_mc_se")]);
        assert!(
            (var - 0.5).abs() <= 4.0 * se,
            "phase {t}: {var} ± {se} vs 0.5"
        );
    }
    let pdf = std::fs::read_to_string(out.join("pdf_z_t.csv")).unwrap();
    assert!(pdf.starts_with("t,x,grid,mc,mc_se\n"), "{}", &pdf[..40]);
    let _ = std::fs::remove_dir_all(&out);
    // Monte Carlo alone checks the period before any work, as the grid does.
    let refused = fresh_path("transient_cli_periodic_refused");
    let mut args = base.to_vec();
    args[3] = "7";
    args.extend_from_slice(&["--method", "mc", "--out", refused.to_str().unwrap()]);
    let o = fpsolve(&args);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("not periodic with period 7"), "{stderr}");
    assert!(!refused.exists());
}

/// The grid and Monte Carlo side by side are judged: the Duffing oscillator from (1, 0) at
/// 60x120 cells against 20 000 trajectories agrees at dt 0.01 (no warning), and Monte Carlo
/// at dt 0.5 (its velocity variance 5.23 at t = 20 against the grid's 4.56 ± 0.02) is named
/// in a warning per state, the run still writing everything (exit 0).
#[test]
fn the_grid_and_monte_carlo_apart_are_warned_about() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/duffing.sde");
    let run = |dt: &str| {
        let out = fresh_path(&format!("transient_disagree_{dt}"));
        let o = fpsolve(&[
            "transient",
            model,
            "--initial",
            "point z = 1, v = 0",
            "--times",
            "0:20:11",
            "--cells",
            "60,120",
            "--method",
            "grid,mc",
            "--trajectories",
            "20000",
            "--dt",
            dt,
            "--out",
            out.to_str().unwrap(),
        ]);
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        assert_eq!(o.status.code(), Some(0), "{text}");
        assert!(out.join("moments_vs_t.csv").exists());
        text
    };
    let fine = run("0.01");
    assert!(!fine.contains("Monte Carlo's"), "{fine}");
    let coarse = run("0.5");
    assert!(
        coarse.contains("warning: the grid's variance of v at t = 20 is")
            && coarse.contains("further apart than 3 standard errors plus the grid's"),
        "{coarse}"
    );
}
