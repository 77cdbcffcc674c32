//! First passage on the grid (issue 35): the backward and forward solves agree, the
//! lightly damped linear oscillator of the issue against an independent Monte Carlo with an
//! exact transition, and the model language's `safe` line.

use fpsolve::grid::{DecayOutcome, GridPassage, PassageSolution};
use fpsolve::model::{load_model, Override};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

fn linear(c: f64, safe: &str) -> (fpsolve::model::Model, Vec<Override>) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    let model = load_model(&path).unwrap().with_safe(safe).unwrap();
    (model, vec![Override::number("c", c)])
}

fn passage(c: f64, safe: &str, cells: [usize; 2], times: Vec<f64>) -> PassageSolution {
    let (model, set) = linear(c, safe);
    let bound = model.bind(&set).unwrap();
    let s = model.safe().unwrap().bind(&bound).unwrap();
    GridPassage::new(&bound, &s)
        .cells(cells[0], cells[1])
        .times(times)
        .tolerance(1e-5)
        .run()
        .unwrap()
}

/// The forward run with killing and the backward solve use one matrix and its transpose, so
/// ∫₀^H R dt plus the tail beyond H equals the start cell's mean time; the tail is below
/// R(H)·(mean time) for a decay at least as fast as the exponential of that mean.
#[test]
fn forward_reliability_integrates_to_the_backward_mean() {
    let (c, safe) = (1.0, "abs(z) < 1.2");
    let mean = passage(c, safe, [60, 80], vec![]).mean_from_start_cell;
    let horizon = 12.0 * mean;
    let times: Vec<f64> = (0..=600).map(|k| horizon * k as f64 / 600.0).collect();
    let p = passage(c, safe, [60, 80], times);
    let tail = p.reliability.last().unwrap() * mean;
    let gap = (p.integral_of_reliability - p.mean_from_start_cell).abs();
    println!(
        "mean {mean:.6}, ∫R {:.6}, R(H) {:.2e}, gap {gap:.2e}",
        p.integral_of_reliability,
        p.reliability.last().unwrap()
    );
    assert!(gap < tail + 2e-3 * mean, "gap {gap:e}, tail {tail:e}");
    // R falls from 1; the third-order scheme is not positivity-preserving, so from a point
    // start in one cell R rose by 1.4e-3 and its density dipped to -6.4e-3 (c = 1, 60x80).
    assert!((p.reliability[0] - 1.0).abs() < 1e-12);
    let rise = p
        .reliability
        .windows(2)
        .fold(0.0f64, |m, w| m.max(w[1] - w[0]));
    let dip = p.pdf.iter().fold(0.0f64, |m, f| m.max(-f));
    println!("largest rise of R {rise:.2e}, largest negative density {dip:.2e}");
    assert!(rise < 3e-3 && dip < 1.5e-2, "rise {rise:e}, dip {dip:e}");
    assert!(p.second_at_start > p.mean_at_start.powi(2));
}

/// The mean times' estimated errors (from the solve on half the cells) cover their distance
/// to a solve on four times the cells per axis.
#[test]
fn the_estimate_covers_the_mean_times_error() {
    let (c, safe) = (1.0, "abs(z) < 1.2");
    let coarse = passage(c, safe, [60, 80], vec![]);
    let fine = passage(c, safe, [240, 320], vec![]);
    let e = coarse
        .errors
        .as_ref()
        .expect("the estimate is on by default");
    let pairs = [
        (coarse.mean_at_start, fine.mean_at_start, e.mean_at_start),
        (
            coarse.mean_stationary,
            fine.mean_stationary,
            e.mean_stationary,
        ),
        (
            coarse.second_at_start,
            fine.second_at_start,
            e.second_at_start,
        ),
    ];
    for (a, b, stated) in pairs {
        println!(
            "60x80 {a:.6}, 240x320 {b:.6}: error {:.2e}, stated {stated:.2e}",
            (a - b).abs()
        );
        assert!((a - b).abs() <= stated, "{a} vs {b}: stated {stated}");
    }
    assert_eq!(coarse.report.estimate_cells, Some([30, 40]));
}

/// The paper's case 1 in its own coordinates (a reflecting wall at y = 0, safe y < 3) and in
/// its Zhuravlev form (a pass-through barrier at z = 0, safe |z| < 3) is one first-passage
/// problem: the two grids agree to within their stated errors and to 0.2 %. (Before the
/// Zhuravlev form's bounds were put on faces its set ended at |z| = 2.989 at every count of
/// cells and its mean time was 1.2 % short: 29.85 against 30.21 at 100×200.)
#[test]
fn the_paper_case_is_one_problem_in_both_coordinates() {
    let run = |file: &str, safe: &str| {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models")
            .join(file);
        let model = load_model(&path).unwrap().with_safe(safe).unwrap();
        let bound = model.bind(&[]).unwrap();
        let s = model.safe().unwrap().bind(&bound).unwrap();
        GridPassage::new(&bound, &s)
            .cells(100, 200)
            .start([1e-6, 0.0])
            .run()
            .unwrap()
    };
    let own = run("vibro_impact_duffing.sde", "y < 3");
    let zhuravlev = run("vibro_duffing.sde", "abs(z) < 3");
    let (a, b) = (own.mean_at_start, zhuravlev.mean_at_start);
    let stated = own.errors.as_ref().unwrap().mean_at_start
        + zhuravlev.errors.as_ref().unwrap().mean_at_start;
    println!("own {a:.5}, Zhuravlev {b:.5}, stated {stated:.3e}");
    assert!((a - b).abs() <= stated, "{a} vs {b}: stated {stated}");
    assert!((a / b - 1.0).abs() < 2e-3, "{a} vs {b}");
    let (a, b) = (own.mean_stationary, zhuravlev.mean_stationary);
    assert!((a / b - 1.0).abs() < 2e-3, "stationary start: {a} vs {b}");
}

/// The slowest decay of the killed generator: the forward and backward iterations find one
/// λ, the mean passage time from the quasi-stationary law is 1/λ (exponential passage from
/// it), and the stepped R(t) at late times is A e^{−λt}, each to the accuracy of the
/// time-stepping (1e-5 per unit time); the quasi-stationary marginals have unit mass.
#[test]
fn late_reliability_is_the_slowest_decay() {
    let (c, safe) = (1.0, "abs(z) < 1.2");
    let mean = passage(c, safe, [60, 80], vec![]).mean_from_start_cell;
    let horizon = 8.0 * mean;
    let times: Vec<f64> = (0..=400).map(|k| horizon * k as f64 / 400.0).collect();
    let p = passage(c, safe, [60, 80], times.clone());
    let DecayOutcome::Found(d) = &p.decay else {
        panic!("{:?}", p.decay)
    };
    println!("{d:?}; mean time {mean:.6}");
    assert!((d.rate - d.rate_backward).abs() < 1e-9 * d.rate, "{d:?}");
    assert!(
        (d.mean_from_quasi_stationary * d.rate - 1.0).abs() < 1e-6,
        "{d:?}"
    );
    // From a point at rest R(t) is the exponential only after the start's transients; from
    // four mean times on they have decayed far below the stepping's error.
    for (t, r) in times
        .iter()
        .zip(&p.reliability)
        .filter(|(t, _)| **t >= 4.0 * mean)
    {
        let tail = d.amplitude * (-d.rate * t).exp();
        assert!(
            (r / tail - 1.0).abs() < 2e-3,
            "t {t}: R {r:e}, A e^-lt {tail:e}"
        );
    }
    let [qx, qv] = p.quasi_stationary.as_ref().unwrap();
    for q in [qx, qv] {
        let mass: f64 = q.density.iter().sum::<f64>() * q.width;
        assert!((mass - 1.0).abs() < 1e-12, "{mass}");
    }
}

/// One step of the exact transition of x' = v, v' = −c v − x + ξ (2πK = 1): mean map e^{Ah}
/// and the covariance ∫₀^h e^{As} B Bᵀ e^{Aᵀs} ds, both by many RK4 substeps of their ODEs.
fn exact_step(c: f64, h: f64) -> ([[f64; 2]; 2], [[f64; 3]; 1]) {
    let a = [[0.0, 1.0], [-1.0, -c]];
    let mul = |m: [[f64; 2]; 2], n: [[f64; 2]; 2]| {
        let mut o = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                o[i][j] = m[i][0] * n[0][j] + m[i][1] * n[1][j];
            }
        }
        o
    };
    let tr = |m: [[f64; 2]; 2]| [[m[0][0], m[1][0]], [m[0][1], m[1][1]]];
    let add = |m: [[f64; 2]; 2], n: [[f64; 2]; 2], s: f64| {
        [
            [m[0][0] + s * n[0][0], m[0][1] + s * n[0][1]],
            [m[1][0] + s * n[1][0], m[1][1] + s * n[1][1]],
        ]
    };
    // Φ' = AΦ; P' = AP + PAᵀ + BBᵀ with BBᵀ = diag(0, 1).
    let f_phi = |p: [[f64; 2]; 2]| mul(a, p);
    let f_p = |p: [[f64; 2]; 2]| {
        let q = add(mul(a, p), mul(p, tr(a)), 1.0);
        add(q, [[0.0, 0.0], [0.0, 1.0]], 1.0)
    };
    let rk4 = |y: [[f64; 2]; 2], f: &dyn Fn([[f64; 2]; 2]) -> [[f64; 2]; 2], d: f64| {
        let k1 = f(y);
        let k2 = f(add(y, k1, d / 2.0));
        let k3 = f(add(y, k2, d / 2.0));
        let k4 = f(add(y, k3, d));
        let s = add(add(k1, k4, 1.0), add(k2, k3, 1.0), 2.0);
        add(y, s, d / 6.0)
    };
    let (mut phi, mut p) = ([[1.0, 0.0], [0.0, 1.0]], [[0.0; 2]; 2]);
    let sub = 1000;
    for _ in 0..sub {
        phi = rk4(phi, &f_phi, h / sub as f64);
        p = rk4(p, &f_p, h / sub as f64);
    }
    // Cholesky of P: l11, l21, l22.
    let l11 = p[0][0].sqrt();
    let l21 = p[1][0] / l11;
    let l22 = (p[1][1] - l21 * l21).sqrt();
    (phi, [[l11, l21, l22]])
}

fn normal(rng: &mut Xoshiro256PlusPlus) -> f64 {
    // Box–Muller, one of the pair.
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Monte Carlo of the first exit from |x| < u from rest, on the exact Gaussian transition
/// over steps of h; between two steps the path is the cubic Hermite interpolant of (x, v) at
/// both ends (x is C¹), whose maximum of |x| decides a crossing inside the step, located by
/// bisection. Returns (mean, its standard error, E[T²]).
fn monte_carlo(c: f64, u: f64, h: f64, paths: usize, seed: u64) -> (f64, f64, f64) {
    let (phi, [[l11, l21, l22]]) = exact_step(c, h);
    let (mut s1, mut s2) = (0.0, 0.0);
    for path in 0..paths {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(
            seed ^ (path as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
        );
        let (mut x, mut v, mut t) = (0.0f64, 0.0f64, 0.0f64);
        loop {
            let (z1, z2) = (normal(&mut rng), normal(&mut rng));
            let xn = phi[0][0] * x + phi[0][1] * v + l11 * z1;
            let vn = phi[1][0] * x + phi[1][1] * v + l21 * z1 + l22 * z2;
            let herm = |s: f64| {
                let (s2, s3) = (s * s, s * s * s);
                (2.0 * s3 - 3.0 * s2 + 1.0) * x
                    + (s3 - 2.0 * s2 + s) * h * v
                    + (-2.0 * s3 + 3.0 * s2) * xn
                    + (s3 - s2) * h * vn
            };
            let out = |s: f64| herm(s).abs() >= u;
            // The first sample (of 16) of the interpolant outside, then bisection.
            if let Some(k) = (1..=16).find(|k| out(*k as f64 / 16.0)) {
                let (mut a, mut b) = ((k - 1) as f64 / 16.0, k as f64 / 16.0);
                for _ in 0..40 {
                    let m = 0.5 * (a + b);
                    if out(m) {
                        b = m;
                    } else {
                        a = m;
                    }
                }
                let tau = t + b * h;
                s1 += tau;
                s2 += tau * tau;
                break;
            }
            x = xn;
            v = vn;
            t += h;
        }
    }
    let n = paths as f64;
    let mean = s1 / n;
    let var = s2 / n - mean * mean;
    (mean, (var / n).sqrt(), s2 / n)
}

/// The case: ζ = 0.05 (c = 0.1, k = 1), barrier |x| = 2.5σ with σ² = πK/(ck) = 5,
/// start at rest. The grid at two resolutions beside a Monte Carlo of 1e5 paths on the exact
/// transition: the finer grid within 3 standard errors plus its stated error.
#[test]
#[ignore = "about a minute: cargo test --release --test passage -- --ignored"]
fn lightly_damped_oscillator_against_monte_carlo() {
    let c = 0.1;
    let u = 2.5 * 5f64.sqrt();
    let safe = format!("abs(z) < {u}");
    let coarse = passage(c, &safe, [100, 200], vec![]);
    let fine = passage(c, &safe, [200, 400], vec![]);
    let (mc, se, mc2) = monte_carlo(c, u, 0.05, 100_000, 35);
    println!(
        "grid 100x200: T {:.4}, T2 {:.2}; 200x400: T {:.4}, T2 {:.2}, stationary-start T {:.4}; \
         MC 1e5: T {mc:.4} ± {se:.4}, T2 {mc2:.2}",
        coarse.mean_at_start,
        coarse.second_at_start,
        fine.mean_at_start,
        fine.second_at_start,
        fine.mean_stationary
    );
    // Within 3 standard errors plus the grid's own stated error (no allowance beyond: an
    // independent Monte Carlo of 1.6e6 paths gives 175.10 ± 0.13, the grid 175.24 at 400×800).
    let stated = fine.errors.as_ref().unwrap().mean_at_start;
    assert!(
        (fine.mean_at_start - mc).abs() < 3.0 * se + stated,
        "grid {} ± {stated} vs MC {mc} ± {se}",
        fine.mean_at_start
    );
}

/// A strongly damped case (c = 1) small enough to run always: grid at 80x160 against 2e4
/// Monte Carlo paths within 4 standard errors plus 2 %.
#[test]
fn damped_oscillator_against_monte_carlo() {
    let (c, u) = (1.0, 1.2);
    let g = passage(c, &format!("abs(z) < {u}"), [80, 160], vec![]);
    let (mc, se, _) = monte_carlo(c, u, 0.02, 20_000, 7);
    println!("grid T {:.4} vs MC {mc:.4} ± {se:.4}", g.mean_at_start);
    assert!((g.mean_at_start - mc).abs() < 4.0 * se + 0.02 * mc);
}

/// A `safe` line may name observables (their definitions are substituted) and parameters.
#[test]
fn the_safe_line_reads_observables_and_parameters() {
    let text = "model m\nparam c = 0.1, e0 = 3\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
                noise xi: intensity 1\ndiffusion v: xi\nobserve energy = v^2/2 + z^2/2\n\
                safe energy < e0\n";
    let model = fpsolve::model::parse_model(text, None).unwrap();
    let bound = model.bind(&[]).unwrap();
    let safe = model.safe().unwrap().bind(&bound).unwrap();
    assert_eq!(safe.upper, Some(3.0));
    assert_eq!(safe.quantity_at([1.0, 2.0]), 2.5);
    assert!(safe.contains([1.0, 2.0]) && !safe.contains([2.0, 2.0]));
    // `--safe` replaces it; its errors point into the flag's text.
    let err = model.with_safe("-1 < z < 2 +").unwrap_err();
    assert_eq!(err.line(), Some(1));
    assert!(err.to_string().contains("--safe"), "{err}");
    let empty = model.with_safe("2 < z < 1").unwrap();
    assert!(empty.safe().unwrap().bind(&bound).is_err());
}

fn fpsolve(args: &[&str]) -> (Option<i32>, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(args)
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stderr).into_owned() + &String::from_utf8_lossy(&out.stdout);
    (out.status.code(), text)
}

/// `fpsolve reliability` refuses a start outside the set and a model without one (exit 2),
/// under its former name `passage` too, and writes R(t) from 1 down with the mean in
/// summary.json, into out/<model>_reliability by default.
#[test]
fn the_reliability_command_checks_then_writes() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    for command in ["reliability", "passage"] {
        let (code, text) = fpsolve(&[command, model, "--safe", "abs(z) < 2", "--start", "3,0"]);
        assert_eq!(code, Some(2), "{text}");
        assert!(text.contains("not inside the safe set"), "{text}");
        let (code, text) = fpsolve(&[command, model]);
        assert_eq!(code, Some(2), "{text}");
        assert!(text.contains("no safe set"), "{text}");
        let (code, text) = fpsolve(&[command, model, "--safe", "abs(w) < 2"]);
        assert_eq!(code, Some(2), "{text}");
        assert!(text.contains("--safe:1:5"), "{text}");
    }
    let cwd = std::env::temp_dir().join(format!("fpsolve_reliability_{}", std::process::id()));
    std::fs::create_dir_all(&cwd).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args([
            "reliability",
            model,
            "--safe",
            "abs(z) < 2",
            "--cells",
            "40,40",
            "--times",
            "0:20:5",
            "--method",
            "grid",
            "--quiet",
        ])
        .current_dir(&cwd)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let dir = cwd.join("out/linear_reliability");
    let csv = std::fs::read_to_string(dir.join("reliability.csv")).unwrap();
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 5);
    assert_eq!(rows[0][1], 1.0);
    assert!(rows[4][1] < rows[1][1]);
    assert!(!dir.join("passage.csv").exists() && !dir.join("first_passage_pdf.csv").exists());
    let summary = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    assert!(summary.contains("\"mean_at_start\""), "{summary}");
    assert!(!summary.contains("\"unwritten\""), "{summary}");
    for stem in ["reliability", "first_passage_pdf"] {
        for ext in ["png", "svg"] {
            let size = std::fs::metadata(dir.join(format!("{stem}.{ext}")))
                .unwrap()
                .len();
            assert!(size > 1000, "{stem}.{ext}: {size} bytes");
        }
    }
    std::fs::remove_dir_all(&cwd).unwrap();
}

/// The files of a run, by name, but the run marker (the command line as typed) and
/// `summary.json` without what differs between two runs of one command line (its provenance,
/// the command, the wall times).
fn files_of(dir: &std::path::Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    let mut files = std::collections::BTreeMap::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name == fpsolve::report::MARKER {
            continue;
        }
        let mut bytes = std::fs::read(&path).unwrap();
        if name == "summary.json" {
            let mut json: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
            let map = json.as_object_mut().unwrap();
            map.remove("provenance");
            map.remove("command");
            if let Some(report) = map.get_mut("grid").and_then(|g| g.get_mut("report")) {
                report.as_object_mut().unwrap().remove("total_ms");
            }
            bytes = serde_json::to_vec(&json).unwrap();
        }
        files.insert(name, bytes);
    }
    files
}

/// Both methods: `reliability.csv`, Monte Carlo's histogram in `first_passage_pdf.csv`
/// (each bin's mass what R_mc loses over it), both figures; `fpsolve passage` writes the
/// same files, to the byte but for summary.json's provenance and command line.
#[test]
fn the_former_name_writes_the_same_files() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    let base = std::env::temp_dir().join(format!("fpsolve_alias_{}", std::process::id()));
    let mut runs = Vec::new();
    for command in ["reliability", "passage"] {
        let dir = base.join(command);
        let (code, text) = fpsolve(&[
            command,
            model,
            "--safe",
            "abs(z) < 1.2",
            "--set",
            "c=1",
            "--cells",
            "40,60",
            "--times",
            "0:6:7",
            "--paths",
            "512",
            "--dt",
            "0.02",
            "--out",
            dir.to_str().unwrap(),
            "--quiet",
        ]);
        assert_eq!(code, Some(0), "{command}: {text}");
        runs.push(files_of(&dir));
    }
    let names: Vec<&str> = runs[0].keys().map(String::as_str).collect();
    assert_eq!(
        names,
        [
            "first_passage_pdf.csv",
            "first_passage_pdf.png",
            "first_passage_pdf.svg",
            "quasi_stationary_v.csv",
            "quasi_stationary_z.csv",
            "reliability.csv",
            "reliability.png",
            "reliability.svg",
            "summary.json",
        ]
    );
    for (name, bytes) in &runs[0] {
        assert!(bytes.len() > 100, "{name}: {} bytes", bytes.len());
        assert!(
            runs[1][name] == *bytes,
            "{name} differs between the two names"
        );
    }
    let table = |name: &str| -> Vec<Vec<f64>> {
        String::from_utf8(runs[0][name].clone())
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .collect()
    };
    let pdf = String::from_utf8(runs[0]["first_passage_pdf.csv"].clone()).unwrap();
    assert!(
        pdf.starts_with("t_lo,t_hi,t_mid,pdf_mc,pdf_mc_se\n"),
        "{pdf}"
    );
    let (r, bins) = (table("reliability.csv"), table("first_passage_pdf.csv"));
    assert_eq!((r.len(), bins.len()), (7, 6));
    // Columns t,R_grid,pdf_grid,R_grid_err,R_mc,...: bin k spans rows k and k + 1.
    for (k, b) in bins.iter().enumerate() {
        assert_eq!((b[0], b[1]), (r[k][0], r[k + 1][0]));
        let lost = r[k][4] - r[k + 1][4];
        assert!((b[3] * (b[1] - b[0]) - lost).abs() < 1e-12, "bin {k}");
        assert!(b[4] >= 0.0);
    }
    std::fs::remove_dir_all(&base).unwrap();
}

/// A run without output times has nothing to draw: the figures are skipped with why, in
/// summary.json and on the console, and the run succeeds; Monte Carlo alone draws both.
#[test]
fn figures_that_cannot_be_drawn_are_skipped_with_a_warning() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    let base = std::env::temp_dir().join(format!("fpsolve_nofig_{}", std::process::id()));
    let dir = base.join("grid");
    let (code, text) = fpsolve(&[
        "reliability",
        model,
        "--safe",
        "abs(z) < 2",
        "--cells",
        "40,40",
        "--method",
        "grid",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{text}");
    assert!(
        text.contains("warning: reliability.png/.svg was not written: no output times"),
        "{text}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    let unwritten = summary["unwritten"].as_array().unwrap();
    assert_eq!(unwritten.len(), 2, "{summary}");
    assert_eq!(unwritten[1]["file"], "first_passage_pdf.png/.svg");
    assert!(!dir.join("reliability.png").exists());
    assert!(dir.join("reliability.csv").exists());
    let dir = base.join("mc");
    let (code, text) = fpsolve(&[
        "reliability",
        model,
        "--safe",
        "abs(z) < 1.2",
        "--set",
        "c=1",
        "--method",
        "mc",
        "--times",
        "0:10:6",
        "--paths",
        "256",
        "--dt",
        "0.02",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{text}");
    assert!(!text.contains("was not written"), "{text}");
    for file in [
        "reliability.png",
        "first_passage_pdf.svg",
        "first_passage_pdf.csv",
    ] {
        assert!(
            std::fs::metadata(dir.join(file)).unwrap().len() > 100,
            "{file}"
        );
    }
    std::fs::remove_dir_all(&base).unwrap();
}

/// fpsolve's own first-passage Monte Carlo (`McPassage`, the stationary kernel's steps with
/// the exit located in the step) against the independent exact-transition Monte Carlo above
/// and the grid, on the strongly damped case: the means within 4 combined standard errors
/// plus the estimated time-step bias, R(t) within its 95 % band (widened by the grid's
/// 2 %) at a few times, the seed reproducing the exit statistics bit for bit.
#[test]
fn passage_monte_carlo_agrees_with_the_exact_transition_and_the_grid() {
    let (c, u) = (1.0, 1.2);
    let (model, set) = linear(c, &format!("abs(z) < {u}"));
    let bound = model.bind(&set).unwrap();
    let safe = model.safe().unwrap().bind(&bound).unwrap();
    let times = vec![1.0, 3.0, 6.0, 10.0];
    let run = fpsolve::mc::McPassage::new(&bound, &safe)
        .paths(4096)
        .dt(0.02)
        .horizon(200.0)
        .times(times.clone())
        .seed(11);
    let r = run.run().unwrap();
    assert_eq!((r.censored, r.blowups), (0, 0));
    let m = r.mean.unwrap();
    let (exact, se, _) = monte_carlo(c, u, 0.02, 8_000, 7);
    let g = passage(c, &format!("abs(z) < {u}"), [80, 160], times.clone());
    println!(
        "McPassage T {:.4} ± {:.4} (bias {:.4} ± {:.4}), Var T {:.3} ± {:.3}; exact-transition MC \
         {exact:.4} ± {se:.4}; grid {:.4}",
        m.value,
        m.stderr,
        r.bias.value,
        r.bias.stderr,
        r.variance.unwrap().value,
        r.variance.unwrap().stderr,
        g.mean_at_start
    );
    let tol = 4.0 * m.stderr.hypot(se) + r.bias.value.abs() + 2.0 * r.bias.stderr;
    assert!((m.value - exact).abs() < tol, "{} vs {exact}", m.value);
    assert!((m.value - g.mean_at_start).abs() < 4.0 * m.stderr + 0.02 * g.mean_at_start);
    for (k, t) in times.iter().enumerate() {
        let (lo, hi, grid) = (r.reliability_lo[k], r.reliability_hi[k], g.reliability[k]);
        println!(
            "t {t}: MC R {:.4} [{lo:.4}, {hi:.4}], grid {grid:.4}",
            r.reliability[k]
        );
        assert!(lo - 0.02 <= grid && grid <= hi + 0.02, "t {t}: grid {grid}");
    }
    let again = run.run().unwrap();
    assert_eq!(again.mean, r.mean);
    assert_eq!(again.reliability, r.reliability);
}

/// The Monte Carlo paths carry the time: under the force cos(t) from rest (noise of
/// intensity 1e-12, so every path is the deterministic one) z(t) = 1 − cos t leaves
/// |z| < 1.5 at t = 2π/3, where a force frozen at t = 0 would give √3. Measured: 2.094403
/// at dt = 0.01 (2π/3 = 2.094395), bias estimate −2.2e−5.
#[test]
fn passage_monte_carlo_follows_a_time_dependent_force() {
    let model = fpsolve::model::parse_model(
        "model forced\nstate z, v\ndrift z: v\ndrift v: cos(t)\nnoise xi: intensity 1e-12\n\
         diffusion v: xi\nsafe abs(z) < 1.5\n",
        None,
    )
    .unwrap();
    let bound = model.bind(&[]).unwrap();
    let safe = model.safe().unwrap().bind(&bound).unwrap();
    let r = fpsolve::mc::McPassage::new(&bound, &safe)
        .paths(256)
        .dt(0.01)
        .horizon(5.0)
        .run()
        .unwrap();
    let m = r.mean.unwrap();
    let exact = 2.0 * std::f64::consts::PI / 3.0;
    println!(
        "T {:.6} ± {:.1e}, bias {:.1e}; exact {exact:.6}",
        m.value, m.stderr, r.bias.value
    );
    assert!((m.value - exact).abs() < 1e-4, "{} vs {exact}", m.value);
}

/// Censored paths: the mean is not reported, only its lower bound, and R at the horizon is
/// the censored fraction.
#[test]
fn passage_monte_carlo_flags_censoring() {
    let (model, set) = linear(1.0, "abs(z) < 1");
    let bound = model.bind(&set).unwrap();
    let safe = model.safe().unwrap().bind(&bound).unwrap();
    let r = fpsolve::mc::McPassage::new(&bound, &safe)
        .paths(256)
        .dt(0.02)
        .horizon(3.0)
        .times(vec![3.0])
        .run()
        .unwrap();
    println!(
        "censored {} of {}, min(T, 3) {:.4}",
        r.censored, r.paths, r.mean_lower_bound.value
    );
    assert!(r.censored > 0 && r.censored < r.paths);
    assert!(r.mean.is_none() && r.variance.is_none());
    assert_eq!(r.reliability[0], r.censored_fraction);
    assert!(r.mean_lower_bound.value < 3.0);
}

/// `--method mc`'s flags are checked before any work (exit 2, naming the flag); a run of both
/// methods writes the Monte Carlo's columns beside the grid's and the distance in standard
/// errors.
#[test]
fn the_reliability_command_runs_monte_carlo_beside_the_grid() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    let base = [
        "reliability",
        model,
        "--safe",
        "abs(z) < 1.2",
        "--set",
        "c=1",
    ];
    for (flags, says) in [
        (&["--paths", "1"][..], "--paths"),
        (&["--dt=-1"][..], "--dt"),
        (&["--horizon", "nan"][..], "--horizon"),
        (&["--seed", "x"][..], "--seed"),
        (&["--method", "mc"][..], "--horizon"),
        (&["--method", "grid,pde"][..], "--method"),
    ] {
        let args: Vec<&str> = base.iter().chain(flags).copied().collect();
        let (code, text) = fpsolve(&args);
        assert_eq!(code, Some(2), "{flags:?}: {text}");
        assert!(text.contains(says), "{flags:?}: {text}");
    }
    let dir = std::env::temp_dir().join(format!("fpsolve_passage_mc_{}", std::process::id()));
    let out = dir.to_str().unwrap();
    let args: Vec<&str> = base
        .iter()
        .chain(&[
            "--cells",
            "40,60",
            "--times",
            "0:6:4",
            "--paths",
            "512",
            "--dt",
            "0.02",
            "--horizon",
            "100",
            "--out",
            out,
            "--quiet",
        ])
        .copied()
        .collect();
    let (code, text) = fpsolve(&args);
    assert_eq!(code, Some(0), "{text}");
    let csv = std::fs::read_to_string(dir.join("reliability.csv")).unwrap();
    assert!(
        csv.starts_with("t,R_grid,pdf_grid,R_grid_err,R_mc,R_mc_lo95,R_mc_hi95\n"),
        "{csv}"
    );
    assert_eq!(csv.lines().count(), 5);
    let summary = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    // The provenance block opens it, as every result file (issue 37).
    assert!(
        summary.trim_start().starts_with("{\n  \"provenance\": {"),
        "{summary}"
    );
    for key in [
        "\"schema_version\"",
        "\"created\"",
        "\"threads\"",
        "\"text\"",
    ] {
        assert!(summary.contains(key), "{key}: {summary}");
    }
    for key in [
        "\"mc\"",
        "\"censored_fraction\"",
        "\"grid_vs_mc_se\"",
        "\"bias\"",
    ] {
        assert!(summary.contains(key), "{key}: {summary}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
