//! The geometry a sky cut reads at each node of the fixed quadtree (its vertices, centre
//! and solid angle, its children's centres and solid angles), computed once per process.
//! Every step's cut visits the same nodes and only their radiance changes, and this
//! arithmetic (square roots and arc tangents) was half of a cut: about a fifth of a warm
//! annual run. The values are the same bits [`NodeGeometry::of`] gives, from the same
//! splits [`SkyNodeKey::vertices`] repeats.

use super::SkyNodeKey;
use crate::math::spherical_triangle;
use glam::DVec3;
use std::sync::OnceLock;

/// Deepest level kept: `default`'s deepest split. All eight faces to depth 5 are 10 920
/// nodes, 2.5 MB; to depth 6 they would be 10 MB for `high` alone. Deeper nodes are
/// computed where they are visited.
pub(super) const MEMO_DEPTH: u32 = 5;

/// What a cut reads of one node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct NodeGeometry {
    /// Unit vertices of the spherical triangle.
    pub vertices: [DVec3; 3],
    /// Unit centre direction ([`spherical_triangle::centre`]).
    pub centre: DVec3,
    /// Solid angle, sr.
    pub solid_angle: f64,
    /// Centres of the four children (split order), lifted just above the horizon for sky
    /// nodes, where the sky is sampled.
    pub child_centres: [DVec3; 4],
    /// Solid angles of the four children, sr.
    pub child_solid_angles: [f64; 4],
}

impl NodeGeometry {
    /// The geometry of node `key` with vertices `v`.
    pub fn of(key: SkyNodeKey, v: [DVec3; 3]) -> NodeGeometry {
        let kids = spherical_triangle::split(v[0], v[1], v[2]);
        let lift = |d: DVec3| {
            if key.is_sky() && d.z < 1e-6 {
                DVec3::new(d.x, d.y, 1e-6).normalize()
            } else {
                d
            }
        };
        NodeGeometry {
            vertices: v,
            centre: spherical_triangle::centre(v[0], v[1], v[2]),
            solid_angle: spherical_triangle::solid_angle(v[0], v[1], v[2]),
            child_centres: kids.map(|k| lift(spherical_triangle::centre(k[0], k[1], k[2]))),
            child_solid_angles: kids.map(|k| spherical_triangle::solid_angle(k[0], k[1], k[2])),
        }
    }
}

/// Nodes above [`MEMO_DEPTH`] in one face.
const PER_FACE: usize = ((1usize << (2 * (MEMO_DEPTH + 1))) - 1) / 3;

/// Index of `key` in the memo: face, then depth, then path within the depth.
fn index(key: SkyNodeKey) -> usize {
    let d = key.depth();
    let first = 1u64 << (2 * d);
    let above = ((1usize << (2 * d)) - 1) / 3;
    key.base as usize * PER_FACE + above + (key.path - first) as usize
}

fn memo() -> &'static [NodeGeometry] {
    static MEMO: OnceLock<Vec<NodeGeometry>> = OnceLock::new();
    MEMO.get_or_init(|| {
        let blank = NodeGeometry::of(SkyNodeKey::root(0), SkyNodeKey::root(0).vertices());
        let mut all = vec![blank; 8 * PER_FACE];
        let mut stack: Vec<(SkyNodeKey, [DVec3; 3])> = (0..8u8)
            .map(|b| (SkyNodeKey::root(b), SkyNodeKey::root(b).vertices()))
            .collect();
        while let Some((key, v)) = stack.pop() {
            all[index(key)] = NodeGeometry::of(key, v);
            if key.depth() < MEMO_DEPTH {
                let kids = spherical_triangle::split(v[0], v[1], v[2]);
                for k in 0..4u8 {
                    stack.push((key.child(k), kids[k as usize]));
                }
            }
        }
        all
    })
}

/// The geometry of `key`, whose vertices are `v`: from the memo down to [`MEMO_DEPTH`],
/// computed below it.
pub(super) fn geometry(key: SkyNodeKey, v: &[DVec3; 3]) -> NodeGeometry {
    if key.depth() <= MEMO_DEPTH {
        memo()[index(key)]
    } else {
        NodeGeometry::of(key, *v)
    }
}

/// The geometry of `key`: from the memo down to [`MEMO_DEPTH`] (no splits from the root),
/// computed from [`SkyNodeKey::vertices`] below it; the same bits either way.
pub(super) fn of_key(key: SkyNodeKey) -> NodeGeometry {
    if key.depth() <= MEMO_DEPTH {
        memo()[index(key)]
    } else {
        NodeGeometry::of(key, key.vertices())
    }
}

/// The vertices of child `k` of `key` (vertices `v`), the same bits as splitting `v`.
pub(super) fn child_vertices(key: SkyNodeKey, v: &[DVec3; 3], k: u8) -> [DVec3; 3] {
    let c = key.child(k);
    if c.depth() <= MEMO_DEPTH {
        memo()[index(c)].vertices
    } else {
        spherical_triangle::split(v[0], v[1], v[2])[k as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn remembered_geometry_is_the_computed_geometry_to_the_bit() {
        // Every node of two faces (a sky and a ground one) to the memo's depth, and one
        // below it: the memo must be the arithmetic, not an approximation of it.
        for base in [1u8, 6] {
            let mut stack = vec![SkyNodeKey::root(base)];
            while let Some(key) = stack.pop() {
                let v = key.vertices();
                assert_eq!(geometry(key, &v), NodeGeometry::of(key, v), "{key:?}");
                assert_eq!(of_key(key), NodeGeometry::of(key, v), "{key:?}");
                for k in 0..4u8 {
                    let c = key.child(k);
                    assert_eq!(child_vertices(key, &v, k), c.vertices(), "{c:?}");
                    if c.depth() <= MEMO_DEPTH + 1 {
                        stack.push(c);
                    }
                }
            }
        }
    }

    #[test]
    fn indices_are_distinct_and_dense() {
        let mut seen = vec![false; 8 * PER_FACE];
        for base in 0..8u8 {
            let mut stack = vec![SkyNodeKey::root(base)];
            while let Some(key) = stack.pop() {
                let i = index(key);
                assert!(!seen[i], "{key:?}");
                seen[i] = true;
                if key.depth() < MEMO_DEPTH {
                    stack.extend((0..4u8).map(|k| key.child(k)));
                }
            }
        }
        assert!(seen.iter().all(|&s| s));
    }
}
