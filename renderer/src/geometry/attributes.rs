//! Vertex attributes beyond a triangle's normals and first texture coordinates: the second
//! texture-coordinate set, COLOR_0 and tangents. Each is stored only for the triangles whose
//! material reads it, so a scene that uses none of them holds nothing more than before (the
//! per-triangle [`crate::geometry::scene::TriangleShading`] is unchanged).

use glam::{Vec2, Vec4};

/// A triangle's extra attributes at its three corners (world space for tangents), each
/// `None` where its primitive has none or its material does not read it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CornerExtras {
    /// The second texture-coordinate set ([`crate::geometry::material::Material::second_uv_set`]).
    pub uv2: Option<[Vec2; 3]>,
    /// COLOR_0, linear RGBA (RGB files read with alpha 1).
    pub color: Option<[Vec4; 3]>,
    /// Unit tangent (xyz) and the bitangent's sign (w = +-1): B = w (N x T).
    pub tangent: Option<[Vec4; 3]>,
}

impl CornerExtras {
    pub fn is_empty(&self) -> bool {
        self.uv2.is_none() && self.color.is_none() && self.tangent.is_none()
    }
}

/// Values for some of a list's items: per item a slot (or none), the values packed. Empty,
/// it holds nothing at all, whatever the list's length.
#[derive(Debug, Clone)]
pub struct Sparse<T> {
    /// Per item: its value's index, or [`Sparse::NONE`]; empty while no item has a value.
    slots: Vec<u32>,
    values: Vec<T>,
}

impl<T> Default for Sparse<T> {
    fn default() -> Self {
        Self { slots: Vec::new(), values: Vec::new() }
    }
}

impl<T: Copy> Sparse<T> {
    const NONE: u32 = u32::MAX;

    /// Appends item number `index` (items pushed in order, from 0) with `value`.
    pub fn push(&mut self, index: usize, value: Option<T>) {
        let Some(v) = value else { return };
        // The slots of the items before the first value are made only now.
        self.slots.resize(index, Self::NONE);
        self.slots.push(self.values.len() as u32);
        self.values.push(v);
    }

    /// Ends a list of `len` items (the slots of the last items without a value made), its
    /// storage cut to what it holds (pushes grew it by doubling).
    pub fn finish(&mut self, len: usize) {
        if !self.values.is_empty() {
            self.slots.resize(len, Self::NONE);
        }
        self.slots.shrink_to_fit();
        self.values.shrink_to_fit();
    }

    /// Item `index`'s value.
    #[inline]
    pub fn get(&self, index: usize) -> Option<T> {
        let slot = *self.slots.get(index)?;
        self.values.get(slot as usize).copied()
    }

    /// Whether no item has a value.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// The items reordered: item `i` of the result is item `order[i]` of this list. `order`
    /// may leave items out (triangles the build drops): their values stay, unreachable.
    pub fn reorder(&mut self, order: &[u32]) {
        if !self.slots.is_empty() {
            self.slots = order.iter().map(|&i| self.slots[i as usize]).collect();
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.slots.capacity() * 4 + self.values.capacity() * std::mem::size_of::<T>()
    }
}

/// The extra attributes of a scene's flattened triangles, in BVH order beside
/// `Scene::shading`.
#[derive(Debug, Clone, Default)]
pub struct TriangleExtras {
    pub uv2: Sparse<[Vec2; 3]>,
    pub color: Sparse<[Vec4; 3]>,
    pub tangent: Sparse<[Vec4; 3]>,
}

impl TriangleExtras {
    /// Appends triangle number `index`'s attributes.
    pub fn push(&mut self, index: usize, e: CornerExtras) {
        self.uv2.push(index, e.uv2);
        self.color.push(index, e.color);
        self.tangent.push(index, e.tangent);
    }

    /// Ends a list of `len` triangles.
    pub fn finish(&mut self, len: usize) {
        self.uv2.finish(len);
        self.color.finish(len);
        self.tangent.finish(len);
    }

    /// Triangle `index`'s attributes.
    #[inline]
    pub fn get(&self, index: usize) -> CornerExtras {
        CornerExtras {
            uv2: self.uv2.get(index),
            color: self.color.get(index),
            tangent: self.tangent.get(index),
        }
    }

    /// The triangles reordered as [`Sparse::reorder`] does.
    pub fn reorder(&mut self, order: &[u32]) {
        self.uv2.reorder(order);
        self.color.reorder(order);
        self.tangent.reorder(order);
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.uv2.bytes() + self.color.bytes() + self.tangent.bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sparse_lists_hold_only_what_was_given() {
        let mut s = Sparse::<u8>::default();
        for i in 0..1000 {
            s.push(i, None);
        }
        s.finish(1000);
        assert_eq!((s.bytes(), s.get(3), s.is_empty()), (0, None, true));
        let mut s = Sparse::<u8>::default();
        s.push(2, Some(7));
        s.push(5, Some(9));
        s.finish(8);
        let got: Vec<Option<u8>> = (0..9).map(|i| s.get(i)).collect();
        assert_eq!(got, [None, None, Some(7), None, None, Some(9), None, None, None]);
        s.reorder(&[5, 0, 2, 7, 1, 3, 4, 6]);
        let got: Vec<Option<u8>> = (0..8).map(|i| s.get(i)).collect();
        assert_eq!(got, [Some(9), None, Some(7), None, None, None, None, None]);
    }
}
