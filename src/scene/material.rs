//! Materials from MTL: diffuse reflectance `Kd`, glazing transmittance `Tf` with the angular
//! fall-off of a single clear pane (Radiance `glass`, n = 1.52), emitted radiance `Ke`.
//! PLACEHOLDER bodies to be implemented.

use crate::photometry::Rgb;

/// A surface material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name as in the MTL file.
    pub name: String,
    /// Diffuse reflectance per channel, [0, 1).
    pub kd: Rgb,
    /// Normal-incidence transmittance per channel; all zero for opaque materials.
    pub tf: Rgb,
    /// Emitted radiance, W·sr⁻¹·m⁻² per channel, from the front face.
    pub ke: Rgb,
}

impl Material {
    /// True when the material is glazing (any `Tf` channel > 0).
    pub fn is_glazing(&self) -> bool {
        self.tf.max_element() > 0.0
    }
    /// True when the material emits light.
    pub fn is_emitter(&self) -> bool {
        self.ke.max_element() > 0.0
    }
    /// Diffuse reflectance used by the radiosity solver: `Kd` for opaque materials, zero
    /// for glazing (its specular reflection is not modelled).
    pub fn reflectance(&self) -> Rgb {
        if self.is_glazing() {
            Rgb::ZERO
        } else {
            self.kd
        }
    }
    /// Transmittance (per channel, 0..1) at incidence with `|cos θ| = cos_incidence`
    /// (either side of the pane); zero for opaque materials.
    pub fn transmittance(&self, cos_incidence: f64) -> Rgb {
        let _ = cos_incidence;
        todo!()
    }
}
