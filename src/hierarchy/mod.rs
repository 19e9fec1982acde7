//! L3 the patch hierarchy: every input triangle is the root of a quadtree of elements made
//! by 4-way midpoint subdivision. An element is addressed by an exact key (triangle, path),
//! so refinements found for different sources (and cached) merge into one hierarchy.

use crate::math::quadtree;
use crate::scene::{Scene, Triangle};
use glam::DVec3;
use std::collections::HashMap;

/// Exact address of an element: input triangle and heap-encoded quadtree path (1 = the
/// triangle itself, child k of p is 4p + k, children in [`split`] order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ElementKey {
    /// Index of the input triangle.
    pub tri: u32,
    /// Heap-encoded path.
    pub path: u64,
}

/// Deepest subdivision representable by a path.
pub const MAX_DEPTH: u32 = quadtree::MAX_DEPTH - 1;

crate::quadtree_key!(ElementKey, tri: u32);

impl ElementKey {
    /// Vertices of the element (scene frame), from the root triangle's vertices.
    pub fn vertices(&self, root: [DVec3; 3]) -> [DVec3; 3] {
        quadtree::descend(root, self.path, |t| split(*t))
    }
}

/// 4-way midpoint split: corners at v0, v1, v2, then the middle triangle (same orientation).
pub fn split(v: [DVec3; 3]) -> [[DVec3; 3]; 4] {
    let m01 = (v[0] + v[1]) * 0.5;
    let m12 = (v[1] + v[2]) * 0.5;
    let m20 = (v[2] + v[0]) * 0.5;
    [
        [v[0], m01, m20],
        [m01, v[1], m12],
        [m20, m12, v[2]],
        [m01, m12, m20],
    ]
}

/// Picks the child (split order) containing the point with barycentrics `b` and rewrites
/// `b` to the child's barycentrics (see [`split`]).
pub fn child_of(b: &mut [f64; 3]) -> u8 {
    let [b0, b1, b2] = *b;
    let (k, nb) = if b0 >= 0.5 {
        (0, [2.0 * b0 - 1.0, 2.0 * b1, 2.0 * b2])
    } else if b1 >= 0.5 {
        (1, [2.0 * b0, 2.0 * b1 - 1.0, 2.0 * b2])
    } else if b2 >= 0.5 {
        (2, [2.0 * b0, 2.0 * b1, 2.0 * b2 - 1.0])
    } else {
        (3, [1.0 - 2.0 * b2, 1.0 - 2.0 * b0, 1.0 - 2.0 * b1])
    };
    *b = nb.map(|x| x.clamp(0.0, 1.0));
    k
}

/// One element of the arena.
#[derive(Clone, Debug)]
pub struct Element {
    /// Its key.
    pub key: ElementKey,
    /// Vertices, scene frame (m).
    pub vertices: [DVec3; 3],
    /// Area, m².
    pub area: f64,
    /// Index of the parent element.
    pub parent: Option<u32>,
    /// Index of the first of four consecutive children, if split.
    pub first_child: Option<u32>,
}

/// The union of refinements: an arena of elements, roots first (index = triangle index).
#[derive(Clone, Debug, Default)]
pub struct Hierarchy {
    /// All elements; `elements[t]` is the root of triangle `t`.
    pub elements: Vec<Element>,
    index: HashMap<ElementKey, u32, ahash::RandomState>,
}

impl Hierarchy {
    /// The unrefined hierarchy: one element per input triangle.
    pub fn new(scene: &Scene) -> Hierarchy {
        Hierarchy::of_roots(&scene.triangles)
    }

    /// The unrefined hierarchy of the triangles `roots`, in order.
    fn of_roots(roots: &[Triangle]) -> Hierarchy {
        let elements: Vec<Element> = roots
            .iter()
            .enumerate()
            .map(|(i, t)| Element {
                key: ElementKey::root(i as u32),
                vertices: t.v,
                area: t.area(),
                parent: None,
                first_child: None,
            })
            .collect();
        let index = elements
            .iter()
            .enumerate()
            .map(|(i, e)| (e.key, i as u32))
            .collect();
        Hierarchy { elements, index }
    }

    /// Index of the element with `key`, splitting ancestors as needed.
    pub fn insert(&mut self, key: ElementKey) -> u32 {
        if let Some(&i) = self.index.get(&key) {
            return i;
        }
        let parent = self.insert(key.parent().expect("roots exist from construction"));
        let first = self.elements.len() as u32;
        let pv = self.elements[parent as usize].vertices;
        for (k, v) in split(pv).into_iter().enumerate() {
            let ck = self.elements[parent as usize].key.child(k as u8);
            let area = 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length();
            self.elements.push(Element {
                key: ck,
                vertices: v,
                area,
                parent: Some(parent),
                first_child: None,
            });
            self.index.insert(ck, first + k as u32);
        }
        self.elements[parent as usize].first_child = Some(first);
        self.index[&key]
    }

    /// Index of `key` if present.
    pub fn get(&self, key: ElementKey) -> Option<u32> {
        self.index.get(&key).copied()
    }

    /// Indices of all leaves (elements without children), in arena order.
    pub fn leaves(&self) -> impl Iterator<Item = u32> + '_ {
        self.elements
            .iter()
            .enumerate()
            .filter(|(_, e)| e.first_child.is_none())
            .map(|(i, _)| i as u32)
    }

    /// Number of leaves.
    pub fn leaf_count(&self) -> usize {
        self.leaves().count()
    }
}

/// Leaves of the union of the refinements that make the elements `keys` exist, over
/// `triangles` roots: what [`Hierarchy::leaf_count`] gives after inserting them all, from
/// the set of split elements alone (every split adds three leaves), without the arena's
/// vertices. For a step whose element count is reported but whose elements nobody reads.
pub fn union_leaf_count(triangles: usize, keys: impl Iterator<Item = ElementKey>) -> usize {
    let mut u = LeafUnion::default();
    u.add(keys);
    u.leaf_count(triangles)
}

/// [`union_leaf_count`] fed a batch of keys at a time: a step that streams its
/// directions counts their elements without holding every direction's leaves.
#[derive(Default)]
pub struct LeafUnion {
    split: std::collections::HashSet<ElementKey, ahash::RandomState>,
}

impl LeafUnion {
    /// Adds the refinements that make the elements `keys` exist.
    pub fn add(&mut self, keys: impl Iterator<Item = ElementKey>) {
        for key in keys {
            let mut k = key;
            while let Some(p) = k.parent() {
                if !self.split.insert(p) {
                    break;
                }
                k = p;
            }
        }
    }

    /// Leaves of the union so far over `triangles` roots.
    pub fn leaf_count(&self, triangles: usize) -> usize {
        triangles + 3 * self.split.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_preserves_area_and_keys_address_children() {
        let v = [
            DVec3::ZERO,
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ];
        let kids = split(v);
        let area = |t: &[DVec3; 3]| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
        let sum: f64 = kids.iter().map(area).sum();
        assert!((sum - area(&v)).abs() < 1e-15);
        // Every child keeps the parent's orientation.
        let n = (v[1] - v[0]).cross(v[2] - v[0]);
        assert!(kids
            .iter()
            .all(|t| (t[1] - t[0]).cross(t[2] - t[0]).dot(n) > 0.0));
        let k = ElementKey::root(7).child(3).child(1);
        assert_eq!(k.depth(), 2);
        assert_eq!(k.vertices(v), split(split(v)[3])[1]);
        assert_eq!(k.parent().unwrap().parent().unwrap(), ElementKey::root(7));
    }

    #[test]
    fn the_union_leaf_count_equals_the_arena_s() {
        let t = Triangle {
            v: [DVec3::ZERO, DVec3::X, DVec3::Y],
            material: 0,
            group: 0,
        };
        let mut h = Hierarchy::of_roots(&[t; 3]);
        // Overlapping refinements: shared ancestors, a leaf that is another's ancestor,
        // a root never split.
        let keys = [
            ElementKey::root(0).child(3).child(1),
            ElementKey::root(0).child(3).child(2).child(0),
            ElementKey::root(0).child(3),
            ElementKey::root(1).child(0),
            ElementKey::root(1).child(0).child(0),
        ];
        for k in keys {
            h.insert(k);
        }
        assert_eq!(h.leaf_count(), 3 + 3 * 5);
        assert_eq!(union_leaf_count(3, keys.into_iter()), h.leaf_count());
        // Fed in two batches, in another order: the same union.
        let mut u = LeafUnion::default();
        u.add(keys[3..].iter().copied());
        u.add(keys[..3].iter().rev().copied());
        assert_eq!(u.leaf_count(3), h.leaf_count());
    }
}
