//! The bundled font. Figures are drawn with plotters' `ab_glyph` text renderer from a font
//! compiled into the binary, so rendering needs no system font library or font files at run
//! time (CI machines and containers often have none). Licence: `fonts/LICENSE`.

use std::sync::OnceLock;

use plotters::style::{FontDesc, FontStyle, IntoFont};

/// DejaVu Sans, unmodified.
static DEJAVU_SANS: &[u8] = include_bytes!("fonts/DejaVuSans.ttf");

/// The family name the font is registered under. The generic CSS name means SVG viewers that
/// lack DejaVu Sans fall back to a similar sans-serif face instead of a serif default.
pub(super) const FAMILY: &str = "sans-serif";

/// Registers the bundled font with plotters (once per process); `false` if the font data is
/// unreadable, which would be a build defect, not a user error.
pub(super) fn register() -> bool {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FAMILY, FontStyle::Normal, DEJAVU_SANS).is_ok()
    })
}

/// The font at `size` pixels times the supersampling factor `k`.
pub(super) fn font_of(size: u32, k: u32) -> FontDesc<'static> {
    (FAMILY, size * k).into_font()
}
