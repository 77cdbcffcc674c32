use super::axes::decade_label;
use super::*;
use approx::assert_relative_eq;

#[test]
fn runs_are_cut_at_the_floor_and_at_gaps() {
    let x = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
    let y = [1e-10, 1e-2, 1.0, f64::NAN, 1.0, 0.5, 0.0];
    let runs = visible_runs(&x, &y, 1e-3);
    assert_eq!(runs.len(), 2);
    // Entering: the crossing lies on the segment (0, 1e-10)–(1, 1e-2) where y = 1e-3.
    let t = (1e-3 - 1e-10) / (1e-2 - 1e-10);
    assert_relative_eq!(runs[0][0].0, t, max_relative = 1e-12);
    assert_relative_eq!(runs[0][0].1, 1e-3);
    assert_eq!(&runs[0][1..], &[(1.0, 1e-2), (2.0, 1.0)]);
    // Leaving through zero: cut where the segment (5, 0.5)–(6, 0) meets 1e-3.
    let last = *runs[1].last().unwrap();
    assert_relative_eq!(
        last.0,
        5.0 + (1e-3 - 0.5) / (0.0 - 0.5),
        max_relative = 1e-12
    );
    assert_relative_eq!(last.1, 1e-3);
    assert_eq!(runs[1].len(), 3);
    // Without a floor only the NaN splits.
    let all = visible_runs(&x, &y, f64::NEG_INFINITY);
    assert_eq!(all.iter().map(Vec::len).collect::<Vec<_>>(), vec![3, 3]);
}

#[test]
fn decade_labels() {
    assert_eq!(decade_label(1e-8), "10⁻⁸");
    assert_eq!(decade_label(1.0), "10⁰");
    assert_eq!(decade_label(10.0), "10¹");
    assert_eq!(decade_label(1e-12), "10⁻¹²");
    assert_eq!(decade_label(2e-3), "2e-3");
}

#[test]
fn invalid_data_is_refused_before_drawing() {
    let mut fig = PdfFigure {
        title: "t".into(),
        subtitle: String::new(),
        variable_label: "y".into(),
        curves: vec![Curve {
            label: "a".into(),
            x: vec![0.0, 1.0],
            y: vec![1.0],
        }],
        points: None,
    };
    assert!(matches!(
        fig.render_svg(),
        Err(FigureError::LengthMismatch { field: "y", .. })
    ));
    fig.curves[0].y = vec![1.0, f64::INFINITY];
    assert!(matches!(
        fig.render_svg(),
        Err(FigureError::BadValue { index: 1, .. })
    ));
    fig.curves[0].y = vec![0.0, -1.0];
    assert_eq!(fig.render_svg(), Err(FigureError::NoPositiveValues));
    fig.curves[0].y = vec![f64::NAN, f64::NAN];
    assert_eq!(fig.render_svg(), Err(FigureError::NoData));
    fig.curves[0].y = vec![0.5, 0.5];
    fig.points = Some(Points {
        label: "mc".into(),
        x: vec![0.5],
        y: vec![0.4],
        stderr: vec![-0.1],
    });
    assert!(matches!(
        fig.render_svg(),
        Err(FigureError::BadValue {
            field: "stderr",
            ..
        })
    ));
    fig.points = None;
    fig.curves[0].x[0] = f64::NAN;
    assert!(matches!(
        fig.render_svg(),
        Err(FigureError::NonFiniteX { index: 0, .. })
    ));
}

/// Renders on another thread and gives up after `seconds` (a hang is a failure, not a stuck
/// test run).
fn rendered_within<T: Send + 'static>(
    seconds: u64,
    render: impl FnOnce() -> T + Send + 'static,
) -> T {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || tx.send(render()));
    rx.recv_timeout(std::time::Duration::from_secs(seconds))
        .expect("the figure was not drawn or refused in time (an endless tick search)")
}

#[test]
fn an_axis_wider_than_the_largest_float_is_refused_not_looped() {
    let line = |x: Vec<f64>, y: Vec<f64>| LineFigure {
        title: "t".into(),
        x_label: "eps".into(),
        y_label: "mean".into(),
        series: vec![Curve {
            label: "a".into(),
            x,
            y,
        }],
    };
    let wide_x = line(vec![-1e308, 0.0, 1e308], vec![1.0, 2.0, 3.0]);
    assert!(matches!(
        rendered_within(20, move || wide_x.render_svg()),
        Err(FigureError::Span { axis: "x", .. })
    ));
    let wide_y = line(vec![0.0, 1.0], vec![-1e308, 1e308]);
    assert!(matches!(
        rendered_within(20, move || wide_y.render_png()),
        Err(FigureError::Span { axis: "y", .. })
    ));
    // Wide but finite spans are drawn.
    let wide = line(vec![-1e307, 1e307], vec![-1e307, 1e307]);
    assert!(rendered_within(60, move || wide.render_svg()).is_ok());
}
