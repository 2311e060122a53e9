//! Where a build's objects come from: a stream of batches, so that the build never holds more
//! of the model than one batch (see [`crate::build`]). Before the first batch a source gives
//! the world bounds of everything it will stream: the scene origin is their rounded centre
//! ([`crate::place`]), and every vertex goes to scene-local f32 as it arrives.

use crate::mesh::Object;
use crate::place::Bounds;
use glam::{DAffine3, DVec3};

/// A stream of objects in world coordinates.
pub trait Source: Send {
    /// Bounds of the world positions the stream will give (each object's placement applied).
    /// They may be larger than the true bounds: the origin only has to be a whole-unit point
    /// that moves with the model.
    fn world_bounds(&self) -> Bounds;
    /// About how many triangles the stream will give (for progress).
    fn triangles_hint(&self) -> u64;
    /// The next batch, None at the end. Batches come in the same order for the same input.
    fn next_batch(&mut self) -> Option<Vec<Object>>;
    /// The textures the objects' texture coordinates name, taken once the objects are.
    fn textures(&mut self) -> crate::texture::Textures {
        crate::texture::Textures::default()
    }
}

/// Triangles a batch aims at: large enough to keep both cores busy, small next to memory.
pub const BATCH_TRIANGLES: u64 = 1 << 20;

/// Objects already in memory (an imported file, a small generated scene), streamed in batches.
pub struct InMemory {
    objects: std::vec::IntoIter<Object>,
    textures: crate::texture::Textures,
    bounds: Bounds,
    triangles: u64,
}

impl InMemory {
    pub fn new(objects: Vec<Object>) -> InMemory {
        InMemory::textured(objects, crate::texture::Textures::default())
    }

    pub fn textured(objects: Vec<Object>, textures: crate::texture::Textures) -> InMemory {
        InMemory {
            bounds: crate::place::world_bounds(&objects),
            triangles: objects.iter().map(|o| o.mesh.triangle_count() as u64).sum(),
            objects: objects.into_iter(),
            textures,
        }
    }
}

impl Source for InMemory {
    fn textures(&mut self) -> crate::texture::Textures {
        std::mem::take(&mut self.textures)
    }

    fn world_bounds(&self) -> Bounds {
        self.bounds
    }

    fn triangles_hint(&self) -> u64 {
        self.triangles
    }

    fn next_batch(&mut self) -> Option<Vec<Object>> {
        let mut batch = Vec::new();
        let mut triangles = 0;
        while triangles < BATCH_TRIANGLES {
            let Some(o) = self.objects.next() else { break };
            triangles += o.mesh.triangle_count() as u64;
            batch.push(o);
        }
        (!batch.is_empty()).then_some(batch)
    }
}

/// Another source moved by `by` in the world (`osw build --offset`), in f64 like a model's own
/// coordinates: its whole units join each object's anchor, the rest its placement.
pub struct Shifted<S> {
    pub inner: S,
    pub by: DVec3,
}

impl<S: Source> Source for Shifted<S> {
    fn textures(&mut self) -> crate::texture::Textures {
        self.inner.textures()
    }

    fn world_bounds(&self) -> Bounds {
        let (whole, rest) = (self.by.round(), self.by - self.by.round());
        let b = self.inner.world_bounds();
        Bounds { anchor: b.anchor + whole, min: b.min + rest, max: b.max + rest }
    }

    fn triangles_hint(&self) -> u64 {
        self.inner.triangles_hint()
    }

    fn next_batch(&mut self) -> Option<Vec<Object>> {
        let (whole, rest) = (self.by.round(), DAffine3::from_translation(self.by - self.by.round()));
        let mut batch = self.inner.next_batch()?;
        batch.iter_mut().for_each(|o| (o.anchor, o.placement) = (o.anchor + whole, rest * o.placement));
        Some(batch)
    }
}

impl<S: Source + ?Sized> Source for Box<S> {
    fn textures(&mut self) -> crate::texture::Textures {
        (**self).textures()
    }

    fn world_bounds(&self) -> Bounds {
        (**self).world_bounds()
    }

    fn triangles_hint(&self) -> u64 {
        (**self).triangles_hint()
    }

    fn next_batch(&mut self) -> Option<Vec<Object>> {
        (**self).next_batch()
    }
}
