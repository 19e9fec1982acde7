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

/// RGB values of many entries (f32 per channel), stored as one value per entry while every
/// entry is grey (the same in R, G and B), else three: a grey scene's large arrays (its
/// interreflection operator, a render's gather weights) take a third of the memory.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ChannelValues {
    values: Vec<f32>,
    rgb: bool,
}

impl ChannelValues {
    /// Empty, with room for `entries` grey entries.
    pub fn with_capacity(entries: usize) -> ChannelValues {
        ChannelValues {
            values: Vec::with_capacity(entries),
            rgb: false,
        }
    }

    /// Appends one entry; the first coloured one turns every earlier value into three.
    pub fn push(&mut self, v: [f32; 3]) {
        if !self.rgb && (v[0] != v[1] || v[1] != v[2]) {
            self.values = self.values.iter().flat_map(|&g| [g; 3]).collect();
            self.rgb = true;
        }
        if self.rgb {
            self.values.extend_from_slice(&v);
        } else {
            self.values.push(v[0]);
        }
    }

    /// Entry `k` in R, G and B.
    #[inline]
    pub fn get(&self, k: usize) -> [f32; 3] {
        if self.rgb {
            [
                self.values[3 * k],
                self.values[3 * k + 1],
                self.values[3 * k + 2],
            ]
        } else {
            [self.values[k]; 3]
        }
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.values.len() / self.channels()
    }

    /// Whether there are no entries.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Whether every entry is grey (stored with one value each).
    pub fn is_grey(&self) -> bool {
        !self.rgb
    }

    /// Values stored per entry: 1 or 3.
    pub fn channels(&self) -> usize {
        if self.rgb {
            3
        } else {
            1
        }
    }

    /// The stored values, [`Self::channels`] per entry (for cache records).
    pub fn as_slice(&self) -> &[f32] {
        &self.values
    }

    /// Values of `entries` entries as [`Self::as_slice`] gave them: one per entry (grey) or
    /// three; `None` for any other length.
    pub fn from_raw(values: Vec<f32>, entries: usize) -> Option<ChannelValues> {
        let rgb = match values.len() {
            n if n == entries => false,
            n if n == 3 * entries => true,
            _ => return None,
        };
        Some(ChannelValues { values, rgb })
    }

    /// The stored values ([`Self::as_slice`]), given up.
    pub fn into_values(self) -> Vec<f32> {
        self.values
    }

    /// Frees the spare capacity of the growth by pushes.
    pub fn shrink_to_fit(&mut self) {
        self.values.shrink_to_fit();
    }

    /// Bytes of the stored values.
    pub fn bytes(&self) -> u64 {
        4 * self.values.len() as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grey_values_are_stored_once_until_a_coloured_one_comes() {
        let mut v = ChannelValues::default();
        v.push([0.5; 3]);
        v.push([0.25; 3]);
        assert!(v.is_grey());
        assert_eq!((v.as_slice(), v.len(), v.bytes()), (&[0.5, 0.25][..], 2, 8));
        v.push([0.1, 0.2, 0.3]);
        assert!(!v.is_grey());
        assert_eq!((v.len(), v.channels(), v.bytes()), (3, 3, 36));
        assert_eq!(
            (v.get(0), v.get(1), v.get(2)),
            ([0.5; 3], [0.25; 3], [0.1, 0.2, 0.3])
        );
        let back = ChannelValues::from_raw(v.as_slice().to_vec(), 3).unwrap();
        assert_eq!(back, v);
        assert!(ChannelValues::from_raw(vec![1.0; 5], 3).is_none());
        assert!(ChannelValues::from_raw(Vec::new(), 0).unwrap().is_grey());
    }

    #[test]
    fn white_weights_sum_to_one_and_round_trip() {
        assert!((LUMINANCE_WEIGHTS.element_sum() - 1.0).abs() < 1e-12);
        assert!((lux(from_lux(12345.0)) - 12345.0).abs() < 1e-9);
    }
}
