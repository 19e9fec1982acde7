//! The image every render step shares: linear RGB values and a per-pixel stated error,
//! plus where the image came from (written into file headers).

use crate::error::{Error, Result};
use crate::photometry::{grey, Rgb, EFFICACY_LM_PER_W};
use std::path::Path;

/// The most pixels daystep reads from one picture (Radiance RGBE or OpenEXR, each part of
/// an OpenEXR file): 2^28 (e.g. 16 384 × 16 384). A read [`Image`] holds 33 bytes a pixel
/// (RGB and stated error as f64, a validity flag), about 8.9 GB at the limit. A picture
/// declaring more is refused before anything is allocated ([`check_size`]); one within the
/// limit that this machine cannot hold is refused by fallible allocation
/// ([`Image::try_new`]), never by an abort.
pub const MAX_PIXELS: usize = 1 << 28;

/// The most channel values (pixels × channels) daystep reads from one picture or one part
/// of an OpenEXR file: [`MAX_PIXELS`] pixels of four channels (R, G, B and one more), so a
/// file of many channels cannot make the decoder hold more than four channels' worth.
pub const MAX_SAMPLES: usize = 4 * MAX_PIXELS;

/// Checks the size a picture declares, before anything is allocated for it: `width ×
/// height` pixels of `channels` values each (checked arithmetic, so sizes whose product
/// overflows are refused too), at most [`MAX_PIXELS`] pixels and [`MAX_SAMPLES`] values.
/// Returns the pixel count.
///
/// # Errors
/// [`Error::Input`] naming `path` and the declared size.
pub fn check_size(path: &Path, width: usize, height: usize, channels: usize) -> Result<usize> {
    let size = format!("{width} x {height}");
    let pixels = width.checked_mul(height).filter(|&n| n <= MAX_PIXELS);
    let Some(pixels) = pixels else {
        return Err(Error::input(
            path,
            None,
            Some(&size),
            format!("{size} pixels is more than daystep reads (2^28 pixels)"),
        ));
    };
    if pixels.checked_mul(channels).is_none_or(|n| n > MAX_SAMPLES) {
        return Err(Error::input(
            path,
            None,
            Some(&size),
            format!(
                "{size} pixels of {channels} channels is more than daystep reads \
                 (2^28 pixels of 4 channels)"
            ),
        ));
    }
    Ok(pixels)
}

/// `n` copies of `value` in a vector allocated fallibly; `None` when the allocator refuses.
pub(crate) fn try_filled<T: Clone>(n: usize, value: T) -> Option<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).ok()?;
    v.resize(n, value);
    Some(v)
}

/// The error for a picture of `width × height` pixels whose `bytes` this machine could not
/// allocate.
pub(crate) fn no_memory(path: &Path, width: usize, height: usize, bytes: usize) -> Error {
    let size = format!("{width} x {height}");
    Error::input(
        path,
        None,
        Some(&size),
        format!(
            "not enough memory to read {size} pixels ({:.1} GB); use a smaller picture",
            bytes as f64 / 1e9
        ),
    )
}

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

    /// [`Image::new`] for a picture read from `path`: the size is checked against
    /// [`MAX_PIXELS`] and the buffers are allocated fallibly, so a size this machine cannot
    /// hold is an error, not an abort.
    ///
    /// # Errors
    /// [`Error::Input`] naming `path` and the size when it is beyond [`MAX_PIXELS`] or the
    /// memory cannot be allocated.
    pub fn try_new(width: usize, height: usize, quantity: Quantity, path: &Path) -> Result<Image> {
        let n = check_size(path, width, height, 1)?;
        let bytes = n * (std::mem::size_of::<Rgb>() + std::mem::size_of::<f64>() + 1);
        let fail = || no_memory(path, width, height, bytes);
        Ok(Image {
            width,
            height,
            quantity,
            rgb: try_filled(n, Rgb::ZERO).ok_or_else(fail)?,
            err: try_filled(n, 0.0).ok_or_else(fail)?,
            valid: try_filled(n, true).ok_or_else(fail)?,
            provenance: Provenance::default(),
        })
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
