//! Energy and comfort export (`surfaces.csv`): per OBJ group (the material name where the
//! OBJ has no groups) and timestep, the mean incident irradiance over the group's area and,
//! for groups holding glazing, the solar power transmitted through it.
//!
//! Units: solar irradiance in W/m² and power in W. The sky model is photometric (its RGB
//! irradiance is illuminance / 179, Radiance's convention), so each step's values are
//! scaled by the weather record's global horizontal irradiance (DNI·sin(alt) + DHI) over
//! the model sky's own (the luminance-weighted RGB of every source above the horizon):
//! an unobstructed horizontal surface reads exactly the file's global horizontal
//! irradiance, and the spectral difference between sun and sky light is not modelled. Incident = direct (sun, sky, ground glow) + interreflected, both on the
//! interreflection mesh (area-averaged rows). Transmitted: direct light of each source
//! through τ(θ) of the pane at that source's incidence angle, interreflected light through
//! the pane's hemispherical (diffuse) transmittance.

use crate::photometry::{Rgb, LUMINANCE_WEIGHTS};
use crate::radiosity::{Transport, TransportState};
use crate::scene::Scene;
use crate::sources::Source;
use glam::DVec3;

/// Row → group map of an operator's mesh, with what glazing rows need.
#[derive(Clone, Debug)]
pub struct SurfaceMap {
    /// Group of each row.
    group: Vec<u32>,
    /// Unit normal of each row.
    normal: Vec<DVec3>,
    /// Material of each glazing row, or `None`.
    glazing: Vec<Option<u32>>,
    /// Hemispherical (cosine-weighted) transmittance per material (zero when opaque).
    tau_diffuse: Vec<Rgb>,
    /// Area of each group on the mesh, m².
    area: Vec<f64>,
    /// Whether each group holds glazing.
    has_glazing: Vec<bool>,
    /// Group names (the scene's).
    names: Vec<String>,
}

/// Hemispherical transmittance 2∫τ(θ) cosθ sinθ dθ of `m` (midpoint rule, 512 steps).
fn diffuse_transmittance(m: &crate::scene::Material) -> Rgb {
    let n = 512;
    let mut sum = Rgb::ZERO;
    for i in 0..n {
        // u = cos²θ is uniform under the cosine-weighted measure: τ averaged over u.
        let u = (i as f64 + 0.5) / n as f64;
        sum += m.transmittance(u.sqrt());
    }
    sum / n as f64
}

impl SurfaceMap {
    /// The map of `op`'s mesh rows onto `scene`'s groups.
    pub fn new(scene: &Scene, op: &Transport) -> SurfaceMap {
        let rows = op.rows();
        let mut map = SurfaceMap {
            group: Vec::with_capacity(rows),
            normal: Vec::with_capacity(rows),
            glazing: Vec::with_capacity(rows),
            tau_diffuse: scene.materials.iter().map(diffuse_transmittance).collect(),
            area: vec![0.0; scene.groups.len()],
            has_glazing: vec![false; scene.groups.len()],
            names: scene.groups.clone(),
        };
        for (r, &e) in op.mesh.elements.iter().enumerate() {
            let tri = &scene.triangles[op.mesh.hierarchy.elements[e as usize].key.tri as usize];
            let g = tri.group as usize;
            map.group.push(tri.group);
            map.normal.push(tri.normal());
            let glass = scene.materials[tri.material as usize].is_glazing();
            map.glazing.push(glass.then_some(tri.material));
            map.area[g] += op.mesh.area[r];
            map.has_glazing[g] |= glass;
        }
        map
    }

    /// The CSV header: `time`, then per group `<group>:irradiance_w_m2` and, for groups
    /// with glazing, `<group>:transmitted_w` (commas in names become `_`).
    pub fn header(&self) -> String {
        let mut h = String::from("time");
        for (g, name) in self.names.iter().enumerate() {
            if self.area[g] <= 0.0 {
                continue;
            }
            let name = name.replace([',', '\n', '\r'], "_");
            h.push_str(&format!(",{name}:irradiance_w_m2"));
            if self.has_glazing[g] {
                h.push_str(&format!(",{name}:transmitted_w"));
            }
        }
        h.push('\n');
        h
    }

    /// Number of value columns of [`SurfaceMap::header`].
    pub fn columns(&self) -> usize {
        (0..self.names.len())
            .filter(|&g| self.area[g] > 0.0)
            .map(|g| 1 + usize::from(self.has_glazing[g]))
            .sum()
    }

    /// Direct light transmitted by each glazing row (RGB W/m² of the row), accumulated over
    /// sources: `weights` is one source's mesh irradiance per unit normal irradiance.
    pub fn add_transmitted(
        &self,
        out: &mut [Rgb],
        src: &Source,
        weights: &[(u32, Rgb)],
        scene: &Scene,
    ) {
        for &(r, w) in weights {
            if let Some(m) = self.glazing[r as usize] {
                let cos = self.normal[r as usize].dot(src.direction).abs();
                out[r as usize] +=
                    src.normal_irradiance * w * scene.materials[m as usize].transmittance(cos);
            }
        }
    }

    /// Solar over model global horizontal irradiance for one step (1 when the model sky is
    /// dark): `dni`, `dhi` from the weather record (W/m²), `sun_sin_alt` of the true sun.
    pub fn solar_scale(sources: &[Source], dni: f64, dhi: f64, sun_sin_alt: f64) -> f64 {
        let model: f64 = sources
            .iter()
            .map(|s| s.normal_irradiance.dot(LUMINANCE_WEIGHTS) * s.direction.z.max(0.0))
            .sum();
        let file = dni * sun_sin_alt.max(0.0) + dhi;
        if model > 0.0 {
            file / model
        } else {
            1.0
        }
    }

    /// One timestep's row: per group the area-mean incident irradiance, and transmitted
    /// power for glazing groups, in the order of [`SurfaceMap::header`].
    pub fn values(
        &self,
        op: &Transport,
        state: Option<&TransportState>,
        direct: &[Rgb],
        transmitted_direct: &[Rgb],
        scale: f64,
    ) -> Vec<f64> {
        let grey = |v: Rgb| v.dot(LUMINANCE_WEIGHTS);
        let groups = self.names.len();
        let mut inc = vec![0.0; groups];
        let mut trans = vec![0.0; groups];
        for r in 0..op.rows() {
            let g = self.group[r] as usize;
            let a = op.mesh.area[r];
            let ind = state.map_or(Rgb::ZERO, |s| op.indirect_irradiance(s, r));
            inc[g] += a * grey(direct[r] + ind);
            if let Some(m) = self.glazing[r] {
                trans[g] += a * grey(transmitted_direct[r] + ind * self.tau_diffuse[m as usize]);
            }
        }
        let mut out = Vec::with_capacity(self.columns());
        for g in 0..groups {
            if self.area[g] <= 0.0 {
                continue;
            }
            out.push(scale * inc[g] / self.area[g]);
            if self.has_glazing[g] {
                out.push(scale * trans[g]);
            }
        }
        out
    }
}
