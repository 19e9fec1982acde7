//! Heap-encoded quadtree paths, shared by the sky's direction keys and the element keys:
//! 1 is a root, child k (0..4) of path p is 4p + k, so a path is an exact, hashable address.

/// The path of a root.
pub const ROOT: u64 = 1;

/// Deepest level a path can hold (2 bits per level in 64 bits, one sentinel bit).
pub const MAX_DEPTH: u32 = 31;

/// Depth of `path` (0 for a root).
pub fn depth(path: u64) -> u32 {
    (63 - path.leading_zeros()) / 2
}

/// Path of child `k` (0..4) of `path`.
pub fn child(path: u64, k: u8) -> u64 {
    path * 4 + k as u64
}

/// Path of the parent, or `None` for a root.
pub fn parent(path: u64) -> Option<u64> {
    (path > ROOT).then_some(path / 4)
}

/// Follows `path` from `root`, applying `split` at each level and taking the child the path
/// names.
pub fn descend<T>(root: T, path: u64, split: impl Fn(&T) -> [T; 4]) -> T {
    let mut t = root;
    for level in (0..depth(path)).rev() {
        let [a, b, c, d] = split(&t);
        t = match (path >> (2 * level)) & 3 {
            0 => a,
            1 => b,
            2 => c,
            _ => d,
        };
    }
    t
}

/// The inherent quadtree methods (`root`, `depth`, `child`, `parent`) of a key type made
/// of a root index field and a heap-encoded `path` field: written once for the element
/// keys and the sky-node keys.
#[macro_export]
macro_rules! quadtree_key {
    ($key:ident, $root:ident: $root_ty:ty) => {
        impl $key {
            /// The root (an input triangle, or a base face) `root` itself.
            pub fn root($root: $root_ty) -> Self {
                $key {
                    $root,
                    path: $crate::math::quadtree::ROOT,
                }
            }
            /// Subdivision depth (0 for a root).
            pub fn depth(&self) -> u32 {
                $crate::math::quadtree::depth(self.path)
            }
            /// Child `k` (0..4), in the split order of the key's geometry.
            pub fn child(&self, k: u8) -> Self {
                $key {
                    $root: self.$root,
                    path: $crate::math::quadtree::child(self.path, k),
                }
            }
            /// Parent, or `None` at the root.
            pub fn parent(&self) -> Option<Self> {
                $crate::math::quadtree::parent(self.path).map(|path| $key {
                    $root: self.$root,
                    path,
                })
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn paths_round_trip() {
        let p = child(child(child(ROOT, 3), 0), 2);
        assert_eq!(depth(p), 3);
        assert_eq!(parent(parent(parent(p).unwrap()).unwrap()), Some(ROOT));
        assert_eq!(parent(ROOT), None);
        // Descending over integers records the digits in order.
        let digits = descend(0u64, p, |&t| [t * 4, t * 4 + 1, t * 4 + 2, t * 4 + 3]);
        assert_eq!(digits, 3 * 16 + 2); // digits 3, 0, 2 in base 4
    }
}
