//! Rendering a figure to PNG (supersampled) and SVG and writing both atomically.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{FigureError, FigureFiles};
use super::{OutputDir, ReportError};

/// Supersampling factor of PNG output. plotters' bitmap backend draws lines without
/// antialiasing; drawing at this multiple of the size and averaging blocks of pixels gives
/// smooth curves and text at about the cost of one more render.
const SUPERSAMPLE: u32 = 2;

pub(super) fn render_png(
    size: (u32, u32),
    draw: impl FnOnce(DrawingArea<BitMapBackend<'_>, Shift>, u32) -> Result<(), FigureError>,
) -> Result<Vec<u8>, FigureError> {
    let k = SUPERSAMPLE;
    let (w, h) = (size.0 as usize, size.1 as usize);
    let big_w = w * k as usize;
    let mut big = vec![0u8; big_w * h * k as usize * 3];
    draw(
        BitMapBackend::with_buffer(&mut big, (size.0 * k, size.1 * k)).into_drawing_area(),
        k,
    )?;
    let block = (k * k) as usize;
    let mut rgb = vec![0u8; w * h * 3];
    for (i, pixel) in rgb.chunks_exact_mut(3).enumerate() {
        let (row, col) = (i / w, i % w);
        for (c, out) in pixel.iter_mut().enumerate() {
            let mut sum = 0usize;
            for dy in 0..k as usize {
                let line = (row * k as usize + dy) * big_w;
                for dx in 0..k as usize {
                    sum += usize::from(big[(line + col * k as usize + dx) * 3 + c]);
                }
            }
            // Rounded mean of the block, which fits in a byte.
            *out = ((sum + block / 2) / block) as u8;
        }
    }
    let mut png_bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut png_bytes, size.0, size.1);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let encode = |e: png::EncodingError| FigureError::Encoding(e.to_string());
    let mut writer = encoder.write_header().map_err(encode)?;
    writer.write_image_data(&rgb).map_err(encode)?;
    writer.finish().map_err(encode)?;
    Ok(png_bytes)
}

pub(super) fn render_svg(
    size: (u32, u32),
    draw: impl FnOnce(DrawingArea<SVGBackend<'_>, Shift>, u32) -> Result<(), FigureError>,
) -> Result<String, FigureError> {
    // plotters writes integer pixel coordinates; drawing at twice the size under a viewBox
    // keeps half-pixel detail, so steep tails and dashes do not look stepped when zoomed.
    let k = SUPERSAMPLE;
    let mut svg = String::new();
    draw(
        SVGBackend::with_string(&mut svg, (size.0 * k, size.1 * k)).into_drawing_area(),
        k,
    )?;
    let drawn = format!(r#"<svg width="{}" height="{}" "#, size.0 * k, size.1 * k);
    if !svg.starts_with(&drawn) {
        return Err(FigureError::Drawing(
            "unexpected SVG header from plotters".into(),
        ));
    }
    Ok(svg.replacen(
        &drawn,
        &format!(r#"<svg width="{}" height="{}" "#, size.0, size.1),
        1,
    ))
}

pub(super) fn write_both(
    dir: &OutputDir,
    stem: &str,
    png: impl FnOnce() -> Result<Vec<u8>, FigureError> + Send,
    svg: impl FnOnce() -> Result<String, FigureError> + Send,
) -> Result<FigureFiles, ReportError> {
    let png_name = format!("{stem}.png");
    let svg_name = format!("{stem}.svg");
    let png_path = dir.file_path(&png_name)?;
    let svg_path = dir.file_path(&svg_name)?;
    // The two renderings are independent: side by side.
    let (png_bytes, svg_text) = rayon::join(png, svg);
    let png_bytes = png_bytes.map_err(|source| ReportError::Figure {
        path: png_path,
        source,
    })?;
    let svg_text = svg_text.map_err(|source| ReportError::Figure {
        path: svg_path,
        source,
    })?;
    Ok(FigureFiles {
        png: dir.write_atomic(&png_name, &png_bytes)?,
        svg: dir.write_atomic(&svg_name, svg_text.as_bytes())?,
    })
}
