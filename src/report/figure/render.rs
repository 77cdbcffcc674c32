//! Rendering a figure to PNG (supersampled) and SVG and writing both atomically.

use plotters::coord::Shift;
use plotters::prelude::*;

use std::path::PathBuf;

use super::error::FigureError;
use crate::report::{OutputDir, ReportError};

/// Supersampling factor of PNG output. plotters' bitmap backend draws lines without
/// antialiasing; drawing at this multiple of the size and averaging blocks of pixels gives
/// smooth curves and text at about the cost of one more render.
const SUPERSAMPLE: u32 = 2;

/// The two files a figure was written to.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FigureFiles {
    /// The raster image.
    pub png: PathBuf,
    /// The vector image.
    pub svg: PathBuf,
}

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
    let rgb = downsample(&big, w, h, k as usize);
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

/// The rounded mean of each `k`×`k` block of the supersampled RGB image `big` (`w·k` wide,
/// `h·k` high): the `w`×`h` image. Each band of `k` lines is first summed byte by byte down
/// its columns (a loop the compiler vectorises), then across each block: no division and no
/// bounds check per byte (the per-byte indexed loop was a tenth of the main job's time).
fn downsample(big: &[u8], w: usize, h: usize, k: usize) -> Vec<u8> {
    let block = (k * k) as u32;
    let big_row = w * k * 3;
    debug_assert_eq!(big.len(), big_row * h * k);
    let mut rgb = vec![0u8; w * h * 3];
    let mut columns = vec![0u32; big_row];
    for (out_row, band) in rgb
        .chunks_exact_mut(w * 3)
        .zip(big.chunks_exact(big_row * k))
    {
        columns.fill(0);
        for line in band.chunks_exact(big_row) {
            for (sum, &byte) in columns.iter_mut().zip(line) {
                *sum += u32::from(byte);
            }
        }
        for (out, sums) in out_row.chunks_exact_mut(3).zip(columns.chunks_exact(3 * k)) {
            for (c, value) in out.iter_mut().enumerate() {
                let sum: u32 = sums.iter().skip(c).step_by(3).sum();
                // Rounded mean of the block, which fits in a byte.
                *value = ((sum + block / 2) / block) as u8;
            }
        }
    }
    rgb
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

#[cfg(test)]
mod tests {
    use super::downsample;

    #[test]
    fn downsampling_takes_the_rounded_mean_of_each_block() {
        // A 3×2 image supersampled by 2 (6×4 RGB), every byte a different value.
        let (w, h, k) = (3, 2, 2);
        let big: Vec<u8> = (0..w * k * h * k * 3)
            .map(|i| (i * 37 % 256) as u8)
            .collect();
        let rgb = downsample(&big, w, h, k);
        assert_eq!(rgb.len(), w * h * 3);
        for row in 0..h {
            for col in 0..w {
                for c in 0..3 {
                    let mut sum = 0usize;
                    for dy in 0..k {
                        for dx in 0..k {
                            let (y, x) = (row * k + dy, col * k + dx);
                            sum += usize::from(big[(y * w * k + x) * 3 + c]);
                        }
                    }
                    assert_eq!(rgb[(row * w + col) * 3 + c], ((sum + 2) / 4) as u8);
                }
            }
        }
        // A half-way mean rounds up: (0 + 0 + 1 + 1) / 4 = 0.5 → 1.
        let big = [0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1];
        assert_eq!(downsample(&big, 1, 1, 2), vec![1, 1, 1]);
    }
}
