//! The image every render step shares: linear RGB values and a per-pixel stated error,
//! plus where the image came from (written into file headers).

use crate::photometry::{grey, Rgb, EFFICACY_LM_PER_W};

/// What an image's pixels hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Quantity {
    /// Radiance seen along the pixel's ray, RGB W·sr⁻¹·m⁻²; luminance = 179 × grey, cd/m².
    #[default]
    Radiance,
    /// Irradiance on the surface seen at the pixel, RGB W/m² (rtrace/rpict `-i`);
    /// illuminance = 179 × grey, lux.
    Irradiance,
}

impl Quantity {
    /// The photometric unit of 179 × grey(pixel): "cd/m2" or "lux".
    pub fn unit(self) -> &'static str {
        match self {
            Quantity::Radiance => "cd/m2",
            Quantity::Irradiance => "lux",
        }
    }
}

/// Where an image came from: written into EXR headers and preview pages.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Provenance {
    /// The command line that made it.
    pub command: String,
    /// The view, as Radiance view options (`-vtv -vp … -vd …`).
    pub view: String,
    /// The instant, local standard time of the site (ISO 8601), and UTC.
    pub time: String,
    /// The sky's description (e.g. `perez dni=700 dhi=100`).
    pub sky: String,
    /// daystep's version.
    pub software: String,
}

/// A linear image: `width × height` pixels, row-major from the top-left corner.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Image {
    /// Pixels across.
    pub width: usize,
    /// Pixels down.
    pub height: usize,
    /// What the pixels hold.
    pub quantity: Quantity,
    /// Per pixel: linear RGB (W·sr⁻¹·m⁻², or W/m² for [`Quantity::Irradiance`]).
    pub rgb: Vec<Rgb>,
    /// Per pixel: stated error of the pixel's grey value (same unit as `rgb`): the
    /// gather's noise plus the solution's noise and discretisation at that pixel.
    pub err: Vec<f64>,
    /// Per pixel: false where no ray was traced (outside a fisheye's circle).
    pub valid: Vec<bool>,
    /// Where the image came from.
    pub provenance: Provenance,
}

impl Image {
    /// A black image of `width × height` holding `quantity`, every pixel valid.
    pub fn new(width: usize, height: usize, quantity: Quantity) -> Image {
        let n = width * height;
        Image {
            width,
            height,
            quantity,
            rgb: vec![Rgb::ZERO; n],
            err: vec![0.0; n],
            valid: vec![true; n],
            provenance: Provenance::default(),
        }
    }

    /// Index of pixel (`x` from the left, `y` from the top).
    pub fn index(&self, x: usize, y: usize) -> usize {
        y * self.width + x
    }

    /// Photometric value of pixel `i`: luminance cd/m² (radiance images) or illuminance
    /// lux (irradiance images), 179 × grey.
    pub fn photometric(&self, i: usize) -> f64 {
        EFFICACY_LM_PER_W * grey(self.rgb[i])
    }
}
