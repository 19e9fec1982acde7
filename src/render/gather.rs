//! The final gather (Besuievsky & Martín §6.1): a view-independent solution made into an
//! image, pixel by pixel.
//!
//! Per pixel, `samples` jittered-stratified primary rays (antialiasing) go through the
//! shared [`Tracer`]: glazing on the way multiplies them by τ(θ), and the first pane they
//! meet adds its mirror image with R(θ). Where a ray ends on an opaque surface, the
//! radiance is ρ/π × E + Ke with E made of three parts:
//! - **sun:** one shadow ray towards the sun's true direction, τ(θ) through glazing (the
//!   paper's "direct sun by one shadow ray per pixel");
//! - **sky** (and ground glow) and **interreflection:** cosine-distributed gather rays
//!   (the cosine is the per-pixel importance): a ray that leaves the scene reads the sky's
//!   radiance in its direction (binned to 0.7°, evaluated once per frame), one that meets a
//!   surface reads B/π of the mesh row it meets, with the sensors' rule for the first
//!   pane's mirror image. The gathered part is then re-estimated from nearby pixels on the
//!   same plane and material, over a window that grows until the stated error is small
//!   ([`RenderOptions::filter_radius`], [`super::denoise`]).
//!
//! Why the sky is gathered and not read from the elements, as the paper's §6.1 does: the
//! elements hold the direct sky as an average over each element, and on the sample
//! office's floor beside the window those averages differed from point values (the
//! sensors' own rays) by up to 25 % at 0.1 m pixels, far beyond their discretisation
//! estimate; gathered with the same rays as the interreflection, the sky's part agrees
//! with the sensors within the stated errors (test
//! `render::the_irradiance_image_agrees_with_sensors_within_the_stated_errors`).
//!
//! A ray leaving the scene shows the sky's radiance (ground glow below the horizon) and the
//! sun's disc. Everything that depends only on the camera and the geometry (the primary
//! hits, the gather rays' rows and weights) is a [`ViewGeometry`], built once and applied
//! to every step of a sequence ([`ViewGeometry::frame`]). Rays come from a counter-based
//! generator keyed by pixel, so images do not depend on the thread count.

use super::denoise::{filter, PixelOut};
use super::image::{Image, Quantity};
use crate::math::rng::{mix64, uniform};
use crate::photometry::{grey, ChannelValues, Rgb};
use crate::radiosity::{Mesh, Transport, TransportState};
use crate::scene::view::View;
use crate::sky::Sky;
use crate::trace::{barycentric, cosine_direction, End, Outcome, Tracer};
use glam::DVec3;
use rayon::prelude::*;
use record::FlatSample;
use std::f64::consts::PI;

#[path = "gather_record.rs"]
mod record;

/// Angular radius of the sun's disc, radians (0.533° across, Radiance's `gensky` sun).
pub const SUN_RADIUS_RAD: f64 = 0.533 / 2.0 * PI / 180.0;

/// What to render and how finely.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Pixels across.
    pub width: usize,
    /// Pixels down.
    pub height: usize,
    /// Primary rays per pixel (rounded up to a square: stratified n × n jitter).
    pub samples: u32,
    /// Interreflection gather rays per pixel, shared among its samples (0: no gather).
    pub gather_rays: u32,
    /// Radiance seen, or irradiance on the surfaces seen (`-i`).
    pub quantity: Quantity,
    /// Largest half-width (pixels) of the window over which the gathered interreflection
    /// is re-estimated from pixels on the same plane and material (0: none; the window
    /// starts at 2 and grows while the pixel's stated error is above 1 % of its value).
    pub filter_radius: usize,
    /// Seed of the ray generator.
    pub seed: u64,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 512,
            height: 512,
            samples: 4,
            gather_rays: 64,
            quantity: Quantity::Radiance,
            filter_radius: 8,
            seed: 0x5eed_0015,
        }
    }
}

/// One step's view-independent solution, as the gather reads it.
#[derive(Clone, Copy)]
pub struct Solution<'a> {
    /// The sky (its radiance for rays that leave; its sun for shadow rays and the disc).
    pub sky: &'a Sky,
    /// The interreflection operator and its solved state (`None`: black scene).
    pub transport: Option<(&'a Transport, &'a TransportState)>,
    /// The solve's relative iteration error (adds that fraction of the gathered light to
    /// the stated error).
    pub iteration_error: f64,
}

/// Where one primary sample (or its mirror image in glazing) ended.
#[derive(Clone, Copy, Debug)]
enum Kind {
    /// Left the scene along `dir` with transmission `tau`.
    Sky { dir: DVec3, tau: [f32; 3] },
    /// An opaque front face.
    Surface(Surface),
    /// A back face (black), absorbed in glazing, or outside a fisheye's circle.
    Black,
}

#[derive(Clone, Copy, Debug)]
struct Surface {
    tri: u32,
    point: DVec3,
    /// Transmission from the eye (×R for a mirror image).
    tau: [f32; 3],
    /// Its gather rays: `entries[start..start + len]`.
    start: u32,
    len: u32,
}

/// One part of a pixel: a primary sample, or its mirror image, of antialiasing sample `aa`.
#[derive(Clone, Copy, Debug)]
struct Sample {
    aa: u32,
    kind: Kind,
}

const TAG_OFFSETS: u32 = crate::cache::FIRST_USER_TAG;
const TAG_AA: u32 = TAG_OFFSETS + 1;
const TAG_SAMPLES: u32 = TAG_OFFSETS + 2;
const TAG_ENTRIES: u32 = TAG_OFFSETS + 3;
const TAG_RAYS: u32 = TAG_OFFSETS + 4;

/// Everything about a camera that does not change from step to step: each pixel's
/// samples, where they end, and their gather rays' mesh rows and weights.
pub struct ViewGeometry {
    opts: RenderOptions,
    /// Per pixel, its samples: `samples[offsets[p]..offsets[p + 1]]`.
    offsets: Vec<u32>,
    samples: Vec<Sample>,
    /// Per pixel, how many antialiasing samples it has (0: outside the image's circle).
    aa_count: Vec<u32>,
    /// Gather entries' mesh rows (or sky bins, [`SKY_BIN`]).
    rows: Vec<u32>,
    /// Gather entries' irradiance weights of their radiosity (τ / rays): one value each
    /// while all are grey.
    weights: ChannelValues,
    /// Rays traced to build it.
    pub rays: u64,
}

fn f32s(v: Rgb) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

fn rgb(v: [f32; 3]) -> Rgb {
    Rgb::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]))
}

fn isqrt_ceil(n: u32) -> u32 {
    (f64::from(n.max(1))).sqrt().ceil() as u32
}

impl ViewGeometry {
    /// Traces the camera `view` (in the scene frame) through `tracer`, with gather rays
    /// onto `mesh` (the operator's; `None`: no interreflection to gather).
    pub fn new(
        tracer: &Tracer,
        view: &View,
        mesh: Option<&Mesh>,
        opts: &RenderOptions,
    ) -> ViewGeometry {
        let (w, h) = (opts.width, opts.height);
        let per_pixel: Vec<PixelGeometry> = (0..w * h)
            .into_par_iter()
            .map(|p| pixel_geometry(tracer, view, mesh, opts, p))
            .collect();
        let mut g = ViewGeometry {
            opts: *opts,
            offsets: Vec::with_capacity(w * h + 1),
            samples: Vec::new(),
            aa_count: Vec::with_capacity(w * h),
            rows: Vec::new(),
            weights: ChannelValues::default(),
            rays: 0,
        };
        g.offsets.push(0);
        for (mut samples, entries, aa, rays) in per_pixel {
            let base = g.rows.len() as u32;
            for s in &mut samples {
                if let Kind::Surface(f) = &mut s.kind {
                    f.start += base;
                }
            }
            g.samples.extend(samples);
            for (row, wt) in entries {
                g.rows.push(row);
                g.weights.push(wt);
            }
            g.offsets.push(g.samples.len() as u32);
            g.aa_count.push(aa);
            g.rays += rays;
        }
        g
    }

    /// The geometry as a cache record under `key`.
    pub fn encode(&self, key: &crate::cache::RecordKey) -> Vec<u8> {
        use crate::cache::Section;
        let flat: Vec<FlatSample> = self.samples.iter().map(FlatSample::of).collect();
        let rays = [self.rays as f64];
        crate::cache::encode(
            key,
            &[
                Section::u32s(TAG_OFFSETS, &self.offsets),
                Section::u32s(TAG_AA, &self.aa_count),
                Section::of(TAG_SAMPLES, &flat),
                Section::u32s(TAG_ENTRIES, &self.rows),
                Section::of(TAG_ENTRIES + 16, self.weights.as_slice()),
                Section::f64s(TAG_RAYS, &rays),
            ],
        )
    }

    /// The geometry of a cache record [`Self::encode`] wrote for `opts`, over a scene of
    /// `triangles` triangles and a mesh of `rows` rows; `None` when any part is missing,
    /// inconsistent or out of range (the record is then rebuilt, never trusted).
    pub fn decode(
        r: &crate::cache::MappedRecord,
        opts: &RenderOptions,
        triangles: usize,
        rows: usize,
    ) -> Option<ViewGeometry> {
        let n = opts.width * opts.height;
        let offsets = r.u32s(TAG_OFFSETS).ok()?.to_vec();
        let aa_count = r.u32s(TAG_AA).ok()?.to_vec();
        let flat = r.section::<FlatSample>(TAG_SAMPLES).ok()?;
        let rows_of = r.u32s(TAG_ENTRIES).ok()?;
        // One weight per entry when all are grey, else three.
        let weights = ChannelValues::from_raw(
            r.section::<f32>(TAG_ENTRIES + 16).ok()?.to_vec(),
            rows_of.len(),
        )?;
        let rays = *r.f64s(TAG_RAYS).ok()?.first()?;
        let ok = offsets.len() == n + 1
            && aa_count.len() == n
            && weights.as_slice().iter().all(|w| w.is_finite())
            && offsets.windows(2).all(|w| w[0] <= w[1])
            && offsets.last().copied() == Some(flat.len() as u32)
            && offsets.first() == Some(&0);
        if !ok {
            return None;
        }
        let samples: Option<Vec<Sample>> = flat.iter().map(FlatSample::sample).collect();
        let samples = samples?;
        let entries = rows_of.len();
        let in_range = samples.iter().all(|s| match s.kind {
            Kind::Surface(f) => {
                (f.start as usize + f.len as usize) <= entries && (f.tri as usize) < triangles
            }
            _ => true,
        }) && rows_of.iter().all(|&r| {
            r & SKY_BIN != 0 && ((r & !SKY_BIN) as usize) < SKY_BINS * SKY_BINS
                || (r as usize) < rows
        });
        if !in_range {
            return None;
        }
        Some(ViewGeometry {
            opts: *opts,
            offsets,
            samples,
            aa_count,
            rows: rows_of.to_vec(),
            weights,
            rays: rays as u64,
        })
    }

    /// Bytes the geometry holds (for reports and memory budgets).
    pub fn bytes(&self) -> usize {
        self.samples.len() * std::mem::size_of::<Sample>()
            + self.rows.len() * 4
            + self.weights.bytes() as usize
            + (self.offsets.len() + self.aa_count.len()) * 4
    }

    /// The image of one step's `solution`: the gather at the cached points. Traces one
    /// shadow ray per surface sample towards the sun (none without a sun).
    pub fn frame(&self, tracer: &Tracer, solution: &Solution) -> Image {
        let (w, h) = (self.opts.width, self.opts.height);
        let mut img = Image::new(w, h, self.opts.quantity);
        let sun = solution
            .sky
            .sun
            .filter(|s| s.normal_irradiance != Rgb::ZERO);
        let sun_disc = 2.0 * PI * (1.0 - SUN_RADIUS_RAD.cos());
        let irradiance = self.opts.quantity == Quantity::Irradiance;
        let parts = solution.transport.map_or(0, |(t, _)| t.parts());
        // π × the sky's radiance at each direction bin's centre: an escaped gather ray of
        // weight τ/m² adds τ π L / m² (cosine-distributed rays).
        let sky_bins: Vec<Rgb> = (0..SKY_BINS * SKY_BINS)
            .into_par_iter()
            .map(|b| solution.sky.radiance(bin_direction(b as u32)) * PI)
            .collect();
        let px: Vec<PixelOut> = (0..w * h)
            .into_par_iter()
            .map(|p| {
                let n_aa = self.aa_count[p];
                if n_aa == 0 {
                    return PixelOut::default();
                }
                let samples = &self.samples[self.offsets[p] as usize..self.offsets[p + 1] as usize];
                let mut per_aa = vec![Rgb::ZERO; n_aa as usize];
                let mut per_aa_ind = vec![Rgb::ZERO; n_aa as usize];
                let mut key = None;
                let mut per_part = vec![Rgb::ZERO; parts];
                let (mut disc, mut disc_abs, mut gathered) = (0.0, 0.0, Rgb::ZERO);
                for s in samples {
                    let v = match s.kind {
                        Kind::Black => Rgb::ZERO,
                        Kind::Sky { dir, tau } => {
                            if irradiance {
                                Rgb::ZERO
                            } else {
                                let mut l = solution.sky.radiance(dir);
                                if let Some(sun) = sun {
                                    if dir.dot(sun.direction) >= SUN_RADIUS_RAD.cos() {
                                        l += sun.normal_irradiance / sun_disc;
                                    }
                                }
                                rgb(tau) * l
                            }
                        }
                        Kind::Surface(f) => {
                            let n = tracer.normal(f.tri);
                            let m = tracer.material_of(f.tri);
                            // What turns the surface's irradiance into what the pixel shows.
                            let k = if irradiance {
                                Rgb::ONE
                            } else {
                                rgb(f.tau) * m.reflectance() / PI
                            };
                            let mut e = Rgb::ZERO;
                            if let Some(sun) = sun {
                                let c = n.dot(sun.direction);
                                if c > 0.0 {
                                    e += sun.normal_irradiance
                                        * tracer.transmission(f.point, sun.direction)
                                        * c;
                                }
                            }
                            let (mut fine, mut coarse, mut sky_e) =
                                (Rgb::ZERO, Rgb::ZERO, Rgb::ZERO);
                            for e in f.start as usize..(f.start + f.len) as usize {
                                let (row, wt) = (self.rows[e], rgb(self.weights.get(e)));
                                if row & SKY_BIN != 0 {
                                    sky_e += wt * sky_bins[(row & !SKY_BIN) as usize];
                                    continue;
                                }
                                let Some((t, st)) = solution.transport else {
                                    continue;
                                };
                                let r = row as usize;
                                fine += wt * t.radiosity(st, r);
                                coarse += wt * t.coarse_radiosity(st, r);
                                for (q, acc) in per_part.iter_mut().enumerate() {
                                    *acc += k * wt * t.part_radiosity(st, q, r);
                                }
                            }
                            e += fine + sky_e;
                            disc += grey(k * (fine - coarse));
                            disc_abs += grey(k * (fine - coarse)).abs();
                            gathered += k * fine;
                            per_aa_ind[s.aa as usize] += k * (fine + sky_e);
                            let pk = plane_key(tracer, f.tri, f.point);
                            key = match key {
                                None => Some(pk),
                                Some(q) if q == pk => Some(q),
                                _ => Some(0),
                            };
                            let own = if irradiance {
                                Rgb::ZERO
                            } else {
                                rgb(f.tau) * m.ke
                            };
                            k * e + own
                        }
                    };
                    if !matches!(s.kind, Kind::Surface(_)) {
                        key = Some(0);
                    }
                    per_aa[s.aa as usize] += v;
                }
                let n = f64::from(n_aa);
                let mean = per_aa.iter().fold(Rgb::ZERO, |a, x| a + *x) / n;
                let ind = per_aa_ind.iter().fold(Rgb::ZERO, |a, x| a + *x) / n;
                // Variance of the mean over antialiasing samples, of the direct and of the
                // gathered part apart: the filter below averages the gathered part only.
                let var_of = |v: &[Rgb], m: Rgb| {
                    if n_aa > 1 {
                        v.iter().map(|x| (grey(*x) - grey(m)).powi(2)).sum::<f64>() / (n - 1.0) / n
                    } else {
                        0.0
                    }
                };
                let direct: Vec<Rgb> = per_aa
                    .iter()
                    .zip(&per_aa_ind)
                    .map(|(a, b)| *a - *b)
                    .collect();
                let var_direct = var_of(&direct, mean - ind);
                let var_ind = var_of(&per_aa_ind, ind);
                let var_parts = if parts > 1 {
                    let pm = per_part.iter().fold(Rgb::ZERO, |a, x| a + *x) / parts as f64;
                    per_part
                        .iter()
                        .map(|x| (grey(*x) - grey(pm)).powi(2))
                        .sum::<f64>()
                        / (parts as f64 - 1.0)
                        / parts as f64
                        / (n * n)
                } else {
                    0.0
                };
                PixelOut {
                    direct: mean - ind,
                    ind,
                    var_direct: var_direct + var_parts,
                    var_ind,
                    disc: disc / n,
                    disc_abs: disc_abs / n,
                    iteration: solution.iteration_error * grey(gathered).abs() / n,
                    noise_known: n_aa > 1,
                    key: key.unwrap_or(0),
                    valid: true,
                }
            })
            .collect();
        let filtered = filter(&px, w, h, self.opts.filter_radius);
        for (i, (p, f)) in px.iter().zip(filtered).enumerate() {
            img.rgb[i] = f.value;
            img.err[i] = f.err;
            img.valid[i] = p.valid;
        }
        img
    }
}

/// A key of the plane and material of triangle `tri` (never 0): pixels on one plane of one
/// material share their gathered light in the filter. The plane's offset is rounded to
/// 1 mm and its normal to 1e-4.
fn plane_key(tracer: &Tracer, tri: u32, point: DVec3) -> u64 {
    let n = tracer.normal(tri);
    let q = |x: f64, s: f64| (x * s).round() as i64 as u64;
    let m = tracer.material_of(tri) as *const _ as u64;
    let h = mix64(
        q(n.x, 1e4) ^ mix64(q(n.y, 1e4) ^ mix64(q(n.z, 1e4) ^ mix64(q(n.dot(point), 1e3) ^ m))),
    );
    h.max(1)
}

/// Marks a gather entry as an escaped ray's sky direction bin instead of a mesh row.
const SKY_BIN: u32 = 1 << 31;
/// Octahedral sky bins per side: 256 × 256 bins of about 0.7° over the sphere, fine for
/// sky radiance, which varies over tens of degrees (the sun's disc is a shadow ray).
const SKY_BINS: usize = 256;

/// The octahedral bin of unit direction `d`.
fn bin_of(d: DVec3) -> u32 {
    let l1 = d.x.abs() + d.y.abs() + d.z.abs();
    let (mut u, mut v) = (d.x / l1, d.y / l1);
    if d.z < 0.0 {
        (u, v) = ((1.0 - v.abs()) * u.signum(), (1.0 - u.abs()) * v.signum());
    }
    let n = SKY_BINS as f64;
    let i = (((u + 1.0) / 2.0 * n) as usize).min(SKY_BINS - 1);
    let j = (((v + 1.0) / 2.0 * n) as usize).min(SKY_BINS - 1);
    (j * SKY_BINS + i) as u32
}

/// The unit direction at the centre of octahedral bin `b`.
fn bin_direction(b: u32) -> DVec3 {
    let n = SKY_BINS as f64;
    let (i, j) = (
        (b as usize % SKY_BINS) as f64,
        (b as usize / SKY_BINS) as f64,
    );
    let (u, v) = ((i + 0.5) / n * 2.0 - 1.0, (j + 0.5) / n * 2.0 - 1.0);
    let z = 1.0 - u.abs() - v.abs();
    let (x, y) = if z < 0.0 {
        ((1.0 - v.abs()) * u.signum(), (1.0 - u.abs()) * v.signum())
    } else {
        (u, v)
    };
    DVec3::new(x, y, z).normalize()
}

/// One pixel's samples, its gather entries (offsets local to the pixel), its antialiasing
/// sample count and the rays traced.
type PixelGeometry = (Vec<Sample>, Vec<(u32, [f32; 3])>, u32, u64);

/// One pixel's samples, gather entries (pixel-local offsets), antialiasing count and rays.
fn pixel_geometry(
    tracer: &Tracer,
    view: &View,
    mesh: Option<&Mesh>,
    opts: &RenderOptions,
    p: usize,
) -> PixelGeometry {
    let (w, h) = (opts.width as f64, opts.height as f64);
    let (col, row) = ((p % opts.width) as f64, (p / opts.width) as f64);
    // Outside a fisheye's circle (judged at the pixel's centre): no pixel at all.
    if view.ray((col + 0.5) / w, 1.0 - (row + 0.5) / h).is_none() {
        return (Vec::new(), Vec::new(), 0, 0);
    }
    let m = isqrt_ceil(opts.samples);
    let stream = mix64(opts.seed ^ (p as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
    let gather_per = if opts.gather_rays > 0 {
        isqrt_ceil(opts.gather_rays.div_ceil(m * m))
    } else {
        0
    };
    let mut samples = Vec::new();
    let mut entries = Vec::new();
    let (mut aa, mut rays, mut counter) = (0u32, 0u64, 0u64);
    let mut next = || {
        counter += 1;
        uniform(opts.seed, stream, counter)
    };
    // The primary rays first: where they end decides the gather rays.
    let mut ends = Vec::new();
    for i in 0..m {
        for j in 0..m {
            let x = (col + (f64::from(i) + next()) / f64::from(m)) / w;
            let y = 1.0 - (row + (f64::from(j) + next()) / f64::from(m)) / h;
            let Some((o, d)) = view.ray(x, y) else {
                continue;
            };
            let out = tracer.trace(o, d, Rgb::ONE);
            rays += 1;
            ends.push((aa, out, d));
            if out.glazing_loss != Rgb::ZERO {
                if let Some(hit) = tracer.first_hit(o, d).filter(|h| h.glazing) {
                    if let Some(mo) = tracer.mirror(hit.tri, hit.point, -d, Rgb::ONE) {
                        let n = tracer.normal(hit.tri);
                        let c = (-d).dot(n);
                        ends.push((aa, mo, (n * (2.0 * c) + d).normalize()));
                        rays += 2;
                    }
                }
            }
            aa += 1;
        }
    }
    // A pixel whose samples do not all meet one plane (edges, glazing with its mirror
    // image) is left alone by the filter, so it gets twice the gather rays across, four
    // times the rays: its own noise is all the noise it has.
    let mut keys = ends.iter().map(|(_, out, _)| match out.end {
        End::Front { tri, point, .. } => plane_key(tracer, tri, point),
        _ => 0,
    });
    let first = keys.next().unwrap_or(0);
    let one_plane = first != 0 && keys.all(|k| k == first);
    let gather_per = if one_plane {
        gather_per
    } else {
        2 * gather_per
    };
    for (aa, out, dir) in ends {
        let kind = match out.end {
            End::Escaped => Kind::Sky {
                dir,
                tau: f32s(out.power),
            },
            End::Front { tri, point, .. } if out.power != Rgb::ZERO => {
                let start = entries.len() as u32;
                let n = tracer.normal(tri);
                rays += gather(tracer, mesh, point, n, gather_per, &mut next, &mut entries);
                Kind::Surface(Surface {
                    tri,
                    point,
                    tau: f32s(out.power),
                    start,
                    len: entries.len() as u32 - start,
                })
            }
            _ => Kind::Black,
        };
        samples.push(Sample { aa, kind });
    }
    (samples, entries, aa, rays)
}

/// `m × m` stratified cosine rays from `point` about `n`: each front face met adds its mesh
/// row with weight τ/m² (and the first pane's mirror image, as the sensors' gather does),
/// each ray that leaves the scene its sky direction bin.
/// Returns the rays traced.
fn gather(
    tracer: &Tracer,
    mesh: Option<&Mesh>,
    point: DVec3,
    n: DVec3,
    m: u32,
    next: &mut impl FnMut() -> f64,
    entries: &mut Vec<(u32, [f32; 3])>,
) -> u64 {
    let w = 1.0 / f64::from(m * m);
    let mut rays = 0;
    let add = |out: Outcome, entries: &mut Vec<(u32, [f32; 3])>| {
        if let (End::Front { tri, point, .. }, Some(mesh)) = (out.end, mesh) {
            let root = mesh.hierarchy.elements[tri as usize].vertices;
            let row = mesh.row_at(tri, barycentric(root, point));
            entries.push((row, f32s(out.power * w)));
        }
    };
    for i in 0..m {
        for j in 0..m {
            let u1 = (f64::from(i) + next()) / f64::from(m);
            let u2 = (f64::from(j) + next()) / f64::from(m);
            let (d, _) = cosine_direction(n, u1, u2);
            let out = tracer.trace(point, d, Rgb::ONE);
            rays += 1;
            let met_glazing = out.glazing_loss != Rgb::ZERO;
            if out.end == End::Escaped {
                entries.push((SKY_BIN | bin_of(d), f32s(out.power * w)));
            }
            add(out, entries);
            if let Some(h) = met_glazing.then(|| tracer.first_hit(point, d)).flatten() {
                if h.glazing {
                    if let Some(mo) = tracer.mirror(h.tri, h.point, -d, Rgb::ONE) {
                        add(mo, entries);
                        rays += 2;
                    }
                }
            }
        }
    }
    rays
}
