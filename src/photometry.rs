//! Radiance-compatible photometry: RGB radiometric quantities (W/m², W·sr⁻¹·m⁻²) and their
//! conversion to luminous ones with the fixed white efficacy 179 lm/W.

use glam::DVec3;

/// An RGB triple of radiometric values (irradiance W/m², radiance W·sr⁻¹·m⁻², or a
/// dimensionless factor such as reflectance), in Radiance's RGB primaries.
pub type Rgb = DVec3;

/// Radiance's white luminous efficacy, lm/W.
pub const EFFICACY_LM_PER_W: f64 = 179.0;

/// Radiance's luminance weights of its R, G, B primaries.
pub const LUMINANCE_WEIGHTS: Rgb = DVec3::new(0.265, 0.670, 0.065);

/// Luminance-weighted value of an RGB triple (same unit as the input).
pub fn grey(rgb: Rgb) -> f64 {
    rgb.dot(LUMINANCE_WEIGHTS)
}

/// Illuminance (lux) of an RGB irradiance (W/m²): 179 × (0.265 R + 0.670 G + 0.065 B).
pub fn lux(irradiance: Rgb) -> f64 {
    EFFICACY_LM_PER_W * grey(irradiance)
}

/// Uniform RGB irradiance (W/m²) whose illuminance is `lux`.
pub fn from_lux(lux: f64) -> Rgb {
    Rgb::splat(lux / EFFICACY_LM_PER_W)
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn white_weights_sum_to_one_and_round_trip() {
        assert!((LUMINANCE_WEIGHTS.element_sum() - 1.0).abs() < 1e-12);
        assert!((lux(from_lux(12345.0)) - 12345.0).abs() < 1e-9);
    }
}
