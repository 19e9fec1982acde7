//! Text in pictures (falsecolor legends): DejaVu Sans, embedded in the program
//! (`assets/fonts/DejaVuSans.ttf`, Bitstream Vera licence with public-domain DejaVu
//! changes, `assets/fonts/DejaVuSans-LICENSE.txt`), rasterised with anti-aliasing by
//! `ab_glyph`.

use super::falsecolor::Rgba8;
use ab_glyph::{Font, FontRef, PxScale, ScaleFont};
use std::sync::OnceLock;

const DEJAVU_SANS: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

fn font() -> &'static FontRef<'static> {
    static FONT: OnceLock<FontRef<'static>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(DEJAVU_SANS).expect("the embedded font parses"))
}

/// Advance width of `text` at `size` pixels per em, in pixels (kerning included).
pub fn width(text: &str, size: f64) -> f64 {
    let f = font().as_scaled(PxScale::from(size as f32));
    let mut w = 0.0f32;
    let mut prev = None;
    for ch in text.chars() {
        let id = f.glyph_id(ch);
        if let Some(p) = prev {
            w += f.kern(p, id);
        }
        w += f.h_advance(id);
        prev = Some(id);
    }
    f64::from(w)
}

/// Draws `text` into `out` in colour `c`, `size` pixels per em, starting at `x` (pixels
/// from the left) with the middle of its digits' height at `y_centre` (pixels from the
/// top); coverage is blended into what is there, and glyphs are clipped to the picture.
pub fn draw(out: &mut Rgba8, x: f64, y_centre: f64, size: f64, text: &str, c: [u8; 3]) {
    let scale = PxScale::from(size as f32);
    let f = font().as_scaled(scale);
    // Digits and capitals stand on the baseline about 0.73 em tall in DejaVu Sans.
    let baseline = (y_centre + 0.365 * size) as f32;
    let mut pen = x as f32;
    let mut prev = None;
    for ch in text.chars() {
        let id = f.glyph_id(ch);
        if let Some(p) = prev {
            pen += f.kern(p, id);
        }
        let glyph = id.with_scale_and_position(scale, ab_glyph::point(pen, baseline));
        pen += f.h_advance(id);
        prev = Some(id);
        let Some(outline) = font().outline_glyph(glyph) else {
            continue;
        };
        let b = outline.px_bounds();
        outline.draw(|gx, gy, coverage| {
            out.blend(
                b.min.x as i64 + i64::from(gx),
                b.min.y as i64 + i64::from(gy),
                c,
                coverage,
            );
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glyphs_cover_where_text_is_drawn_and_nowhere_else() {
        let mut img = Rgba8::new(120, 40);
        draw(&mut img, 4.0, 20.0, 20.0, "812.5", [255, 255, 255]);
        let lit: Vec<(usize, usize)> = (0..40)
            .flat_map(|y| (0..120).map(move |x| (x, y)))
            .filter(|&(x, y)| img.pixel(x, y) != [0, 0, 0])
            .collect();
        // Five glyphs of about 0.73 × 0.5 em: a few hundred pixels touched, all within
        // the text's box (advance width across, the digits' height about the centre).
        assert!(lit.len() > 150, "{}", lit.len());
        let w = width("812.5", 20.0);
        assert!(w > 40.0 && w < 70.0, "{w}");
        for (x, y) in &lit {
            assert!(*x >= 4 && (*x as f64) <= 4.0 + w + 1.0, "x {x}");
            assert!((*y as f64 - 20.0).abs() <= 9.0, "y {y}");
        }
        // Fully covered pixels take the colour exactly.
        assert!(lit.iter().any(|&(x, y)| img.pixel(x, y) == [255, 255, 255]));
    }

    #[test]
    fn wider_text_is_wider() {
        assert!(width("1000", 12.0) > width("10", 12.0));
        assert!((width("10", 24.0) - 2.0 * width("10", 12.0)).abs() < 0.5);
    }
}
