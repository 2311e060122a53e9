//! Geometry residency: a LOD node's vertex and index buffers are made the first time it is
//! drawn, straight from the mapped scene file, and dropped least-recently-used first when the
//! total passes the budget. Geometry never drawn is never read from the file or uploaded.

use crate::device::Gpu;
use osw_scene::file::Indices;
use osw_scene::{NodeId, SceneError, SceneFile};
use std::collections::HashMap;
use wgpu::util::DeviceExt;

pub struct Resident {
    pub vertices: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    pub format: wgpu::IndexFormat,
    pub index_count: u32,
    bytes: u64,
    last_used: u64,
}

/// Upload and eviction counts since creation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ResidencyStats {
    pub uploads: u64,
    pub upload_bytes: u64,
    pub evictions: u64,
    /// Distinct LOD nodes ever uploaded, and their bytes: the rest of the file was never read.
    pub distinct: u64,
    pub distinct_bytes: u64,
}

pub struct Residency {
    map: HashMap<NodeId, Resident>,
    /// Per node id: uploaded at least once.
    ever: Vec<bool>,
    budget: u64,
    bytes: u64,
    frame: u64,
    pub stats: ResidencyStats,
}

impl Residency {
    pub fn new(budget: u64) -> Residency {
        Residency { map: HashMap::new(), ever: Vec::new(), budget, bytes: 0, frame: 0, stats: ResidencyStats::default() }
    }

    /// Bytes resident now.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// Starts a new use epoch: nodes used in the current epoch are never evicted.
    pub fn next_epoch(&mut self) {
        self.frame += 1;
    }

    /// Makes `id` resident (uploading it if needed) and marks it used in this epoch.
    pub fn ensure(&mut self, gpu: &Gpu, scene: &SceneFile, id: NodeId) -> Result<(), SceneError> {
        if let Some(r) = self.map.get_mut(&id) {
            r.last_used = self.frame;
            return Ok(());
        }
        let g = scene.geometry(id)?;
        let usage = wgpu::BufferUsages::VERTEX;
        let vertices = gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("lod vertices"),
            contents: bytemuck::cast_slice(g.positions),
            usage,
        });
        let indices = gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("lod indices"),
            contents: g.indices.bytes(),
            usage: wgpu::BufferUsages::INDEX,
        });
        let format = match g.indices {
            Indices::U16(_) => wgpu::IndexFormat::Uint16,
            Indices::U32(_) => wgpu::IndexFormat::Uint32,
        };
        let bytes = vertices.size() + indices.size();
        self.bytes += bytes;
        self.stats.uploads += 1;
        self.stats.upload_bytes += bytes;
        if self.ever.len() <= id as usize {
            self.ever.resize(id as usize + 1, false);
        }
        if !std::mem::replace(&mut self.ever[id as usize], true) {
            self.stats.distinct += 1;
            self.stats.distinct_bytes += bytes;
        }
        self.map.insert(id, Resident { vertices, indices, format, index_count: g.indices.len() as u32, bytes, last_used: self.frame });
        Ok(())
    }

    /// The buffers of a node made resident by [`Residency::ensure`].
    pub fn get(&self, id: NodeId) -> &Resident {
        &self.map[&id]
    }

    /// Drops least-recently-used nodes not used in this epoch until under budget.
    pub fn trim(&mut self) {
        if self.bytes <= self.budget {
            return;
        }
        let mut old: Vec<(u64, NodeId)> =
            self.map.iter().filter(|(_, r)| r.last_used < self.frame).map(|(&id, r)| (r.last_used, id)).collect();
        old.sort_unstable();
        for (_, id) in old {
            if self.bytes <= self.budget {
                break;
            }
            let r = self.map.remove(&id).expect("listed above");
            self.bytes -= r.bytes;
            self.stats.evictions += 1;
        }
    }
}
