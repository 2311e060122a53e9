//! A pass's use table: one entry per node drawn, naming the node (its object's colour, its item
//! id), where its mesh lies in the vertex arena and, for a use of a mesh stored once, the
//! instance's placement made camera-relative. The vertex shader pulls its vertex through it:
//! a pass index is `slot << shift | vertex`, the node's slot in the table and the vertex within
//! its mesh, so one draw call covers every node while each mesh is stored once on the GPU
//! however many nodes use it.

use bytemuck::{Pod, Zeroable};
use osw_cull::View;
use osw_scene::format::NONE;
use osw_scene::{NodeId, SceneFile};

/// One node of a pass (`Use` in shaders/draw.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Use {
    pub node: u32,
    /// The node's mesh's first vertex in the arena.
    pub base: u32,
    /// 1 where `rows` place the mesh; 0 where its positions are scene-local already (then the
    /// shader adds the view's offset, exactly as for a mesh stored for one use).
    pub placed: u32,
    /// The node's object, whose hash colours it.
    pub object: u32,
    /// 1 where its mesh has normals in the normal arena; 0 where it is shaded flat (nothing of
    /// it is uploaded there).
    pub normals: u32,
    /// 1 where its mesh has texture coordinates in the texcoord arena; 0 where it samples no
    /// texture (nothing of it is uploaded there).
    pub textured: u32,
    pub pad: [u32; 2],
    /// The placement's three rows, linear part and translation ([`Rows`]).
    pub rows: [u32; 24],
}

const _: () = assert!(std::mem::size_of::<Use>() == 128);

/// How a pass's rows place a vertex (`place` in shaders/place64.wgsl and place32.wgsl).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rows {
    /// f64 rows, the scene-local point rounded to f32 and then made camera-relative: the
    /// arithmetic of `osw_scene::instance::Placement::point`, so that an instance draws exactly
    /// what its placed copy (`--instances expand`) and the CPU's cluster tests see.
    Exact,
    /// f32 rows, their translation less the eye taken in f64 first (adapters without 64-bit
    /// floats in shaders): within a rounding of the exact placement.
    Single,
}

impl Rows {
    /// The rows `gpu` can place with: exact where it has 64-bit floats in shaders.
    pub fn of(gpu: &crate::Gpu) -> Rows {
        if gpu.features.contains(wgpu::Features::SHADER_F64) { Rows::Exact } else { Rows::Single }
    }
}

#[derive(Debug, thiserror::Error)]
#[error("{0} nodes in one pass, more than its indices can name (at most {1} with meshes of {2} vertices)")]
pub struct TooManyNodes(pub usize, pub usize, pub u32);

pub struct Uses {
    pub rows: Rows,
    /// Bits of a pass index that name the vertex within its mesh.
    pub shift: u32,
    pub list: Vec<Use>,
    /// The largest mesh of the pass, vertices.
    vertices: u32,
    /// At most this many nodes in one pass, below what its indices can name.
    max_nodes: usize,
}

impl Uses {
    pub fn new(rows: Rows, max_nodes: usize) -> Uses {
        Uses { rows, shift: 0, list: Vec::new(), vertices: 0, max_nodes }
    }

    /// Starts a pass over `ids`: the shift that holds the largest of their meshes.
    pub fn begin(&mut self, scene: &SceneFile, ids: &[NodeId]) {
        self.list.clear();
        let vertices = |id: NodeId| scene.blocks().get(scene.node(id).block as usize).map_or(0, |b| b.vertex_count);
        self.vertices = ids.iter().map(|&id| vertices(id)).max().unwrap_or(0);
        self.shift = u32::BITS - self.vertices.saturating_sub(1).leading_zeros();
    }

    /// Adds LOD node `id`, its mesh at `base` in the arena, seen from `view`; returns what its
    /// mesh's vertex indices are offset by in the pass.
    pub fn push(&mut self, scene: &SceneFile, view: &View, id: NodeId, base: u32) -> Result<u32, TooManyNodes> {
        let slot = self.list.len();
        if (slot as u64) << self.shift > u32::MAX as u64 || slot >= self.max_nodes {
            return Err(TooManyNodes(slot + 1, slot, self.vertices));
        }
        let node = scene.node(id);
        let instance = node.instance;
        let (normals, textured) = (u32::from(scene.has_normals(id)), u32::from(scene.has_texcoords(id)));
        let mut u = Use { node: id, base, placed: 0, object: node.object, normals, textured, pad: [0; 2], rows: [0; 24] };
        if instance != NONE {
            let a = scene.instances()[instance as usize].affine();
            u.placed = 1;
            match self.rows {
                Rows::Exact => {
                    let rows: [f64; 12] = std::array::from_fn(|k| a.matrix3.row(k / 4).extend(a.translation[k / 4])[k % 4]);
                    u.rows = bytemuck::cast(rows);
                }
                Rows::Single => {
                    let t = a.translation - view.eye;
                    let rows: [f32; 12] = std::array::from_fn(|k| a.matrix3.row(k / 4).extend(t[k / 4])[k % 4] as f32);
                    u.rows[..12].copy_from_slice(&bytemuck::cast::<_, [u32; 12]>(rows));
                }
            }
        }
        self.list.push(u);
        Ok((slot as u32) << self.shift)
    }
}
