//! The report stage end to end: files in an output directory, CSV round trip, JSON refusal of
//! NaN, and figures rendered with the bundled font.
//!
//! Set `FPSOLVE_FIGURE_DIR` to keep the rendered figures for a look.

use std::path::{Path, PathBuf};

use approx::assert_relative_eq;
use fpsolve::report::{
    write_json, Curve, FigureError, LineFigure, OutputDir, PdfFigure, PdfTable, Points, ReportError,
};

/// A scratch directory, removed on drop unless figures are to be kept.
struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Self {
        let path =
            std::env::temp_dir().join(format!("fpsolve-report-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&path);
        Self(path)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn names_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Stationary density of dx = y dt, dy = (-c y - x - mu x^3) dt + sqrt(2 pi K) dW, marginal in x:
/// p(x) ∝ exp(-(c / (pi K)) (x^2/2 + mu x^4/4)), normalised by the trapezoidal rule.
fn duffing_pdf(x: &[f64], c: f64, k: f64, mu: f64) -> Vec<f64> {
    let beta = c / (std::f64::consts::PI * k);
    let unnorm: Vec<f64> = x
        .iter()
        .map(|&v| (-beta * (0.5 * v * v + 0.25 * mu * v.powi(4))).exp())
        .collect();
    let h = x[1] - x[0];
    let area: f64 = unnorm.windows(2).map(|w| 0.5 * h * (w[0] + w[1])).sum();
    unnorm.iter().map(|p| p / area).collect()
}

fn grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}

fn comparison_figure() -> PdfFigure {
    let x = grid(-3.5, 3.5, 281);
    let exact = duffing_pdf(&x, 0.1, 0.05, 1.0);
    // A Gaussian with the wrong variance and a slightly perturbed quartic stand in for
    // closure solutions of increasing degree.
    let gauss = duffing_pdf(&x, 0.1, 0.05, 0.0);
    let quartic = duffing_pdf(&x, 0.1, 0.05, 0.9);
    let bins = grid(-3.0, 3.0, 41);
    let bin_pdf = duffing_pdf(&bins, 0.1, 0.05, 1.0);
    // Deterministic "sampling noise" of relative size 1/sqrt(counts) for 1e6 samples.
    let stderr: Vec<f64> = bin_pdf.iter().map(|p| (p / (1e6 * 0.15)).sqrt()).collect();
    let mc: Vec<f64> = bin_pdf
        .iter()
        .zip(&stderr)
        .enumerate()
        .map(|(i, (p, s))| {
            let value = p + s * ((i as f64 * 1.7).sin());
            if *p < 1e-7 {
                0.0 // an empty tail bin
            } else {
                value
            }
        })
        .collect();
    PdfFigure {
        title: "Duffing oscillator: PDF of displacement".into(),
        subtitle: String::new(),
        variable_label: "x₁".into(),
        curves: vec![
            Curve {
                label: "exact".into(),
                x: x.clone(),
                y: exact,
            },
            Curve {
                label: "EPC n=2".into(),
                x: x.clone(),
                y: gauss,
            },
            Curve {
                label: "EPC n=4".into(),
                x,
                y: quartic,
            },
        ],
        points: Some(Points {
            label: "Monte Carlo".into(),
            x: bins,
            y: mc,
            stderr,
        }),
    }
}

fn keep_or_scratch(tag: &str) -> (OutputDir, Option<Scratch>) {
    match std::env::var_os("FPSOLVE_FIGURE_DIR") {
        Some(dir) => (OutputDir::create(dir).unwrap(), None),
        None => {
            let scratch = Scratch::new(tag);
            (OutputDir::create(&scratch.0).unwrap(), Some(scratch))
        }
    }
}

const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];

/// Decodes a PNG and counts dark pixels in the rows `rows` (to see that text was drawn).
fn dark_pixels(png_bytes: &[u8], rows: std::ops::Range<u32>) -> (u32, u32, usize) {
    let decoder = png::Decoder::new(png_bytes);
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let width = info.width as usize;
    let dark = rows
        .flat_map(|r| (0..width).map(move |c| (r as usize * width + c) * 3))
        .filter(|&i| buf[i] < 100 && buf[i + 1] < 100 && buf[i + 2] < 100)
        .count();
    (info.width, info.height, dark)
}

#[test]
fn atomic_write_replaces_and_leaves_no_temporaries() {
    let scratch = Scratch::new("atomic");
    let dir = OutputDir::create(scratch.0.join("nested").join("run")).unwrap();
    let first = vec![b'a'; 64 * 1024];
    dir.write_atomic("pdf_y.csv", &first).unwrap();
    dir.write_atomic("pdf_y.csv", b"y,mc\n0,1\n").unwrap();
    dir.write_atomic("summary.json", b"{}\n").unwrap();
    assert_eq!(
        std::fs::read(dir.path().join("pdf_y.csv")).unwrap(),
        b"y,mc\n0,1\n"
    );
    assert_eq!(names_in(dir.path()), vec!["pdf_y.csv", "summary.json"]);
}

#[test]
fn csv_round_trip_through_a_file() {
    let scratch = Scratch::new("csv");
    let dir = OutputDir::create(&scratch.0).unwrap();
    let x = grid(0.0, 4.0, 101);
    let epc = duffing_pdf(&x, 0.1, 0.05, 1.0);
    let mut mc = epc.iter().map(|p| p * 1.01).collect::<Vec<_>>();
    mc[100] = f64::NAN;
    let table = PdfTable {
        variable: "y".into(),
        x,
        columns: vec![
            ("epc_n4".into(), epc),
            ("mc".into(), mc),
            ("mc_stderr".into(), vec![1e-3; 101]),
        ],
    };
    let path = table.write_csv(&dir, "pdf_y.csv").unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.starts_with("y,epc_n4,mc,mc_stderr\n0,"));
    assert_eq!(text.lines().count(), 102);
    assert!(text.lines().last().unwrap().starts_with("4,") && text.contains(",,0.001\n"));

    let back = PdfTable::read_csv(&path).unwrap();
    assert_eq!(back.variable, "y");
    assert_eq!(back.x, table.x);
    assert_eq!(back.columns[0], table.columns[0]);
    assert!(back.columns[1].1[100].is_nan());
    assert_eq!(back.columns[1].1[..100], table.columns[1].1[..100]);
    assert_relative_eq!(back.columns[2].1[7], 1e-3);

    match PdfTable::read_csv(dir.path().join("missing.csv")) {
        Err(ReportError::Io { path, .. }) => assert_eq!(path, dir.path().join("missing.csv")),
        other => panic!("expected Io, got {other:?}"),
    }
}

#[test]
fn nan_in_json_is_an_error_naming_the_field() {
    #[derive(serde::Serialize)]
    struct Run {
        model: String,
        moments: Vec<Moment>,
    }
    #[derive(serde::Serialize)]
    struct Moment {
        order: u32,
        value: f64,
    }
    let scratch = Scratch::new("json");
    let dir = OutputDir::create(&scratch.0).unwrap();
    let mut run = Run {
        model: "duffing".into(),
        moments: vec![
            Moment {
                order: 2,
                value: 0.31,
            },
            Moment {
                order: 4,
                value: 0.22,
            },
        ],
    };
    let path = write_json(&dir, "summary.json", &run).unwrap();
    let back: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    assert_eq!(back["moments"][1]["value"].as_f64(), Some(0.22));

    run.moments[1].value = f64::NAN;
    let err = write_json(&dir, "summary.json", &run).unwrap_err();
    let message = err.to_string();
    match err {
        ReportError::NonFiniteJson { field, path, value } => {
            assert_eq!(field, "$.moments[1].value");
            assert_eq!(path, dir.path().join("summary.json"));
            assert!(value.is_nan());
        }
        other => panic!("expected NonFiniteJson, got {other:?}"),
    }
    assert!(message.contains("$.moments[1].value") && message.contains("summary.json"));
    // The earlier, valid file is untouched.
    let still: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(still["moments"][1]["value"].as_f64(), Some(0.22));
}

#[test]
fn pdf_figure_renders_png_and_svg_with_the_bundled_font() {
    let (dir, _scratch) = keep_or_scratch("pdf-figure");
    let figure = comparison_figure();
    let files = figure.write(&dir, "pdf_x1").unwrap();

    let png_bytes = std::fs::read(&files.png).unwrap();
    assert_eq!(png_bytes[..8], PNG_SIGNATURE);
    // The title band holds text: dark glyph pixels can only come from the embedded font,
    // since plotters is built without any system font support.
    let (w, h, dark_title) = dark_pixels(&png_bytes, 0..30);
    assert_eq!((w, h), (1500, 620));
    assert!(dark_title > 300, "title has {dark_title} dark pixels");

    let svg = std::fs::read_to_string(&files.svg).unwrap();
    assert!(svg.starts_with(r#"<svg width="1500" height="620" viewBox="0 0 3000 1240""#));
    for label in [
        "Duffing oscillator: PDF of displacement",
        "linear scale",
        "log scale",
        "x₁",
        "probability density",
        "exact",
        "EPC n=2",
        "EPC n=4",
        "Monte Carlo",
        "10⁻",
    ] {
        assert!(svg.contains(label), "SVG lacks `{label}`");
    }
}

#[test]
fn pdf_figure_of_a_one_sided_density_without_points() {
    let (dir, _scratch) = keep_or_scratch("one-sided");
    // The displacement y = |x| of the impact oscillator: density 2 p(y) on y ≥ 0.
    let y = grid(0.0, 3.0, 151);
    let p: Vec<f64> = duffing_pdf(&grid(-3.0, 3.0, 301), 0.1, 0.05, 1.0)[150..]
        .iter()
        .map(|v| 2.0 * v)
        .collect();
    let mut with_gap: Vec<f64> = p.iter().map(|v| 0.8 * v).collect();
    with_gap[40..50].fill(f64::NAN);
    let figure = PdfFigure {
        title: "Vibro-impact oscillator: PDF of y = |x₁|".into(),
        subtitle: String::new(),
        variable_label: "y".into(),
        curves: vec![
            Curve {
                label: "EPC n=6".into(),
                x: y.clone(),
                y: p,
            },
            Curve {
                label: "with a gap".into(),
                x: y,
                y: with_gap,
            },
        ],
        points: None,
    };
    let files = figure.write(&dir, "pdf_y").unwrap();
    assert_eq!(std::fs::read(&files.png).unwrap()[..8], PNG_SIGNATURE);
    assert!(std::fs::read_to_string(&files.svg)
        .unwrap()
        .contains("with a gap"));
}

#[test]
fn line_figure_renders() {
    let (dir, _scratch) = keep_or_scratch("line");
    let k = grid(0.02, 0.2, 10);
    let figure = LineFigure {
        title: "Mean square displacement against noise intensity".into(),
        x_label: "K".into(),
        y_label: "E[x₁²]".into(),
        series: vec![
            Curve {
                label: "EPC n=4".into(),
                x: k.clone(),
                y: k.iter().map(|v| 1.9 * v.sqrt() - 0.1).collect(),
            },
            Curve {
                label: "Monte Carlo".into(),
                x: k.clone(),
                y: k.iter().map(|v| 1.92 * v.sqrt() - 0.1).collect(),
            },
            Curve {
                label: "Gaussian closure".into(),
                x: k.clone(),
                y: k.iter().map(|v| 2.2 * v).collect(),
            },
        ],
    };
    let files = figure.write(&dir, "msd_vs_k").unwrap();
    let png_bytes = std::fs::read(&files.png).unwrap();
    assert_eq!(png_bytes[..8], PNG_SIGNATURE);
    let (w, h, dark) = dark_pixels(&png_bytes, 0..40);
    assert_eq!((w, h), (900, 600));
    assert!(dark > 300, "title has {dark} dark pixels");
    let svg = std::fs::read_to_string(&files.svg).unwrap();
    for label in ["Mean square displacement", "E[x₁²]", "Gaussian closure"] {
        assert!(svg.contains(label), "SVG lacks `{label}`");
    }
    // plotters writes each text on a line of its own.
    assert!(svg.lines().any(|l| l == "K"), "SVG lacks the x label");
}

#[test]
fn figure_errors_name_the_file_and_write_nothing() {
    let scratch = Scratch::new("figure-error");
    let dir = OutputDir::create(&scratch.0).unwrap();
    let mut figure = comparison_figure();
    figure.points.as_mut().unwrap().stderr.pop();
    match figure.write(&dir, "bad") {
        Err(ReportError::Figure { path, source }) => {
            assert_eq!(path, dir.path().join("bad.png"));
            assert!(matches!(
                source,
                FigureError::LengthMismatch {
                    field: "stderr",
                    ..
                }
            ));
        }
        other => panic!("expected Figure error, got {other:?}"),
    }
    assert!(names_in(dir.path()).is_empty());
}
