//! Geometry residency: a mesh's vertices are copied into one vertex arena the first time a
//! node that uses it is drawn, straight from the mapped scene file, and dropped
//! least-recently-used first when the arena passes the budget. A mesh stored once in the file
//! (every use of an instanced part names the same block) is stored once here too: its uses
//! differ only in their rows of the pass's use table ([`crate::uses`]). Geometry never drawn is
//! never read from the file or uploaded.
//!
//! Normals and texture coordinates lie in arenas of their own, beside the vertex arena (the
//! same vertex at the same index), filled only by a renderer that shades: OR's and HC's depth
//! and item passes read positions alone, and upload nothing else.
//!
//! One arena, so that a pass is one draw call over all its nodes: a draw call costs lavapipe
//! more than most nodes' triangles do (docs/measurements/2026-12-01-scene-and-renderer.md).
//! The indices stay in the file and are gathered per pass (see `Renderer::draw`).

use crate::device::Gpu;
use crate::ranges::FreeRanges;
use bytemuck::{Pod, Zeroable};
use osw_scene::NodeId;
use osw_scene::block::Geometry;
use std::collections::HashMap;

/// A vertex in the arena (`Vertex` in shaders/draw.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ArenaVertex {
    /// In the mesh's frame: scene-local, or an instanced part's own.
    pub position: [f32; 3],
    /// The model's colour, or alpha 0 for the object's hashed colour.
    pub color: [u8; 4],
}

const _: () = assert!(std::mem::size_of::<ArenaVertex>() == 16);

const VERTEX_BYTES: u64 = std::mem::size_of::<ArenaVertex>() as u64;
/// A vertex's normal in the normal arena (octahedral, see [`osw_scene::normal`]).
const NORMAL_BYTES: u64 = 4;
/// A vertex's texture coordinates and texture in the texcoord arena.
const TEXCOORD_BYTES: u64 = std::mem::size_of::<osw_scene::texture::Texcoord>() as u64;

/// Smallest arena, vertices.
const MIN_CAPACITY: u32 = 1 << 16;

struct Resident {
    /// First vertex in the arena.
    base: u32,
    vertices: u32,
    /// Bytes uploaded: its vertices, and its normals where the renderer shades.
    uploaded: u64,
    last_used: u64,
}

/// Upload and eviction counts since creation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ResidencyStats {
    pub uploads: u64,
    pub upload_bytes: u64,
    pub evictions: u64,
    /// Distinct LOD nodes ever drawn, and the bytes of the distinct geometry blocks (vertices
    /// and indices) they read from the file: the rest of the file was never read.
    pub distinct: u64,
    pub distinct_bytes: u64,
    /// The vertex bytes of the nodes whose first draw found their mesh on the GPU already,
    /// uploaded for another of its uses: what storing each use on its own would have added.
    pub shared_bytes: u64,
}

#[derive(Debug, thiserror::Error)]
pub enum ResidencyError {
    #[error("one frame's geometry needs more than the largest GPU buffer ({0} bytes)")]
    TooLarge(u64),
}

pub struct Residency {
    /// Resident meshes by where their geometry block lies in the scene's blob: every use of a
    /// mesh stored once has its own block record, all at the same place.
    map: HashMap<u64, Resident>,
    /// Per node id: drawn at least once.
    ever: Vec<bool>,
    /// Blocks ever read from the file.
    read: std::collections::HashSet<u64>,
    arena: Option<wgpu::Buffer>,
    /// A normal per arena vertex, where the renderer shades.
    normals: Option<wgpu::Buffer>,
    /// Texture coordinates per arena vertex, likewise.
    texcoords: Option<wgpu::Buffer>,
    shade: bool,
    /// Arena size in vertices, and its free ranges.
    capacity: u32,
    free: FreeRanges,
    budget: u64,
    bytes: u64,
    frame: u64,
    pub stats: ResidencyStats,
    /// Largest arena, bytes: the device's largest buffer, or less.
    max_arena_bytes: u64,
}

impl Residency {
    /// `shade`: normals are uploaded too ([`Residency::normals`]).
    pub fn new(budget: u64, max_arena_bytes: u64, shade: bool) -> Residency {
        Residency {
            map: HashMap::new(),
            ever: Vec::new(),
            read: Default::default(),
            arena: None,
            normals: None,
            texcoords: None,
            shade,
            capacity: 0,
            free: FreeRanges::default(),
            budget,
            bytes: 0,
            frame: 0,
            stats: ResidencyStats::default(),
            max_arena_bytes,
        }
    }

    /// The arena, once anything is resident.
    pub fn arena(&self) -> Option<&wgpu::Buffer> {
        self.arena.as_ref()
    }

    /// The normal arena, once anything is resident in a renderer that shades.
    pub fn normals(&self) -> Option<&wgpu::Buffer> {
        self.normals.as_ref()
    }

    /// The texcoord arena, likewise.
    pub fn texcoords(&self) -> Option<&wgpu::Buffer> {
        self.texcoords.as_ref()
    }

    /// Bytes a resident vertex takes: its position and colour, and its normal and texture
    /// coordinates where shaded.
    fn vertex_bytes(&self) -> u64 {
        VERTEX_BYTES + if self.shade { NORMAL_BYTES + TEXCOORD_BYTES } else { 0 }
    }

    /// Starts a new use epoch: nodes used in the current epoch are never evicted.
    pub fn next_epoch(&mut self) {
        self.frame += 1;
    }

    /// The first vertex in the arena of LOD node `id`'s mesh, whose geometry block lies at
    /// `block` in the scene's blob, if it is resident, marking it used in this epoch.
    pub fn resident(&mut self, id: NodeId, block: u64) -> Option<u32> {
        let r = self.map.get_mut(&block)?;
        r.last_used = self.frame;
        let (base, bytes) = (r.base, r.uploaded);
        if self.first_draw(id) {
            self.stats.shared_bytes += bytes;
        }
        Some(base)
    }

    /// Uploads the mesh of `id` at `block`, not resident ([`Residency::resident`]), `g` its
    /// geometry as stored, and marks it used in this epoch; returns its first vertex in the
    /// arena.
    pub fn upload(&mut self, gpu: &Gpu, id: NodeId, block: u64, g: &Geometry) -> Result<u32, ResidencyError> {
        debug_assert!(!self.map.contains_key(&block), "uploaded once");
        let n = g.positions.len() as u32;
        let base = self.allocate(gpu, n)?;
        let color = |i: usize| g.colors.get(i).copied().unwrap_or(osw_scene::mesh::NO_COLOR);
        let vertices: Vec<ArenaVertex> =
            g.positions.iter().enumerate().map(|(i, &position)| ArenaVertex { position, color: color(i) }).collect();
        if let Some(arena) = &self.arena
            && n > 0
        {
            gpu.queue.write_buffer(arena, base as u64 * VERTEX_BYTES, bytemuck::cast_slice(&vertices));
        }
        // A mesh without normals leaves its range of the normal arena as it was: its uses say
        // so (crate::uses::Use::normals), and the shader reads none of it.
        let with_normals = self.shade && !g.normals.is_empty();
        if let Some(normals) = self.normals.as_ref().filter(|_| with_normals) {
            gpu.queue.write_buffer(normals, base as u64 * NORMAL_BYTES, bytemuck::cast_slice(&g.normals));
        }
        // Likewise texture coordinates (crate::uses::Use::textured).
        let with_texcoords = self.shade && !g.texcoords.is_empty();
        if let Some(texcoords) = self.texcoords.as_ref().filter(|_| with_texcoords) {
            gpu.queue.write_buffer(texcoords, base as u64 * TEXCOORD_BYTES, bytemuck::cast_slice(g.texcoords));
        }
        let attributes = if with_normals { NORMAL_BYTES } else { 0 } + if with_texcoords { TEXCOORD_BYTES } else { 0 };
        let uploaded = n as u64 * (VERTEX_BYTES + attributes);
        self.bytes += n as u64 * self.vertex_bytes();
        self.stats.uploads += 1;
        self.stats.upload_bytes += uploaded;
        self.first_draw(id);
        if self.read.insert(block) {
            let attributes = g.positions.len() as u64 * attributes;
            self.stats.distinct_bytes += g.positions.len() as u64 * 12 + attributes + g.indices.bytes().len() as u64;
        }
        self.map.insert(block, Resident { base, vertices: n, uploaded, last_used: self.frame });
        Ok(base)
    }

    /// Counts node `id` drawn; true the first time.
    fn first_draw(&mut self, id: NodeId) -> bool {
        if self.ever.len() <= id as usize {
            self.ever.resize(id as usize + 1, false);
        }
        let first = !std::mem::replace(&mut self.ever[id as usize], true);
        self.stats.distinct += first as u64;
        first
    }

    /// Room for `n` vertices: a free range; else, over the budget, the least recently used
    /// nodes not used in this epoch make room; else the arena grows.
    fn allocate(&mut self, gpu: &Gpu, n: u32) -> Result<u32, ResidencyError> {
        if n == 0 {
            return Ok(0);
        }
        if let Some(at) = self.free.take(n) {
            return Ok(at);
        }
        let over_budget = (self.capacity as u64 + n as u64) * self.vertex_bytes() > self.budget;
        if over_budget && let Some(at) = self.evict_for(n) {
            return Ok(at);
        }
        match self.grow(gpu, n) {
            Ok(()) => Ok(self.free.take(n).expect("the arena grew by at least n")),
            // At the largest arena: what this epoch does not use makes room, if it can.
            Err(e) => self.evict_for(n).ok_or(e),
        }
    }

    /// Doubles the arena and the attribute arenas (at least by `n` vertices), copying what
    /// they hold.
    fn grow(&mut self, gpu: &Gpu, n: u32) -> Result<(), ResidencyError> {
        let limits = gpu.device.limits();
        let max = limits.max_buffer_size.min(limits.max_storage_buffer_binding_size).min(self.max_arena_bytes) / VERTEX_BYTES;
        let want = (self.capacity as u64 * 2).max(self.capacity as u64 + n as u64).max(MIN_CAPACITY as u64);
        let capacity = want.min(max).min(u32::MAX as u64);
        if capacity < self.capacity as u64 + n as u64 {
            return Err(ResidencyError::TooLarge(max * VERTEX_BYTES));
        }
        self.arena = Some(grown(gpu, self.arena.take(), "vertex arena", capacity * VERTEX_BYTES));
        if self.shade {
            self.normals = Some(grown(gpu, self.normals.take(), "normal arena", capacity * NORMAL_BYTES));
            self.texcoords = Some(grown(gpu, self.texcoords.take(), "texcoord arena", capacity * TEXCOORD_BYTES));
        }
        self.free.give(self.capacity, capacity as u32 - self.capacity);
        self.capacity = capacity as u32;
        Ok(())
    }

    /// Evicts least recently used meshes not used in this epoch until `n` vertices fit, and
    /// then on until an eighth of the arena is freed: finding the oldest sorts every resident
    /// node, which a pass that fills the arena block by block must not do for each block.
    fn evict_for(&mut self, n: u32) -> Option<u32> {
        let (mut freed, enough) = (0u64, (self.capacity / 8).max(n) as u64);
        for block in self.unused_oldest_first() {
            freed += self.map[&block].vertices as u64;
            self.evict(block);
            if freed >= enough && self.free.fits(n) {
                break;
            }
        }
        self.free.take(n)
    }

    fn unused_oldest_first(&self) -> Vec<u64> {
        let mut old: Vec<(u64, u64)> =
            self.map.iter().filter(|(_, r)| r.last_used < self.frame).map(|(&block, r)| (r.last_used, block)).collect();
        old.sort_unstable();
        old.into_iter().map(|(_, block)| block).collect()
    }

    fn evict(&mut self, block: u64) {
        let r = self.map.remove(&block).expect("resident");
        self.free.give(r.base, r.vertices);
        self.bytes -= r.vertices as u64 * self.vertex_bytes();
        self.stats.evictions += 1;
    }

    /// Drops least-recently-used meshes not used in this epoch until under budget.
    pub fn trim(&mut self) {
        if self.bytes <= self.budget {
            return;
        }
        for block in self.unused_oldest_first() {
            if self.bytes <= self.budget {
                break;
            }
            self.evict(block);
        }
    }
}

/// A storage buffer of `size` bytes holding what `old` held.
fn grown(gpu: &Gpu, old: Option<wgpu::Buffer>, label: &str, size: u64) -> wgpu::Buffer {
    let new = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    if let Some(old) = old {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(&old, 0, &new, 0, Some(old.size()));
        gpu.queue.submit([enc.finish()]);
    }
    new
}
