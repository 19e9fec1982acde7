//! How a [`super::ViewGeometry`]'s samples are stored in a cache record: plain old data.

use super::{Kind, Sample, Surface};
use glam::DVec3;

/// A [`Sample`] as stored in a cache record (plain old data, no padding).
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub(super) struct FlatSample {
    /// Surface point, or sky direction.
    point: [f64; 3],
    tau: [f32; 3],
    /// 0 black, 1 sky, 2 surface.
    kind: u32,
    aa: u32,
    tri: u32,
    start: u32,
    len: u32,
}

impl FlatSample {
    pub(super) fn of(s: &Sample) -> FlatSample {
        let mut f = FlatSample {
            aa: s.aa,
            ..FlatSample::default()
        };
        match s.kind {
            Kind::Black => {}
            Kind::Sky { dir, tau } => {
                f.kind = 1;
                f.point = dir.to_array();
                f.tau = tau;
            }
            Kind::Surface(x) => {
                f.kind = 2;
                f.point = x.point.to_array();
                f.tau = x.tau;
                (f.tri, f.start, f.len) = (x.tri, x.start, x.len);
            }
        }
        f
    }

    pub(super) fn sample(&self) -> Option<Sample> {
        let kind = match self.kind {
            0 => Kind::Black,
            1 => Kind::Sky {
                dir: DVec3::from_array(self.point),
                tau: self.tau,
            },
            2 => Kind::Surface(Surface {
                tri: self.tri,
                point: DVec3::from_array(self.point),
                tau: self.tau,
                start: self.start,
                len: self.len,
            }),
            _ => return None,
        };
        Some(Sample { aa: self.aa, kind })
    }
}
