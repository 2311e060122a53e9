//! Scene file header and tables. Random bytes rarely get past the two hashes, so the target
//! first recomputes them over whatever tables the header points at: the fuzzer then explores
//! the layout and node checks behind them. A file `validate` accepts must be safe to use: the
//! HC traversal (everything visible, at tau 0 and at a large tau) walks it without a panic and
//! draws only LOD nodes.

use bytemuck::pod_read_unaligned;
use osw_cull::hc::frustum_cull;
use osw_cull::view::View;
use osw_scene::Camera;
use osw_scene::format::{
    BLOCK_BYTES, BlockRecord, Header, IMAGE_BYTES, INSTANCE_BYTES, ImageRecord, InstanceRecord, NODE_BYTES, NodeKind, NodeRecord,
    TEXTURE_BYTES, Tables, TextureRecord,
};
use osw_scene::format::{content_hash, header_hash};
use std::path::Path;

/// Recomputes the header's content and header hashes in place, where the tables fit.
pub(crate) fn rehash(bytes: &mut [u8]) {
    let hs = std::mem::size_of::<Header>();
    let Some(head) = bytes.get(..hs) else { return };
    let mut h: Header = pod_read_unaligned(head);
    let table = |off: u64, count: u32, size: u64| {
        let end = off.checked_add(count as u64 * size)?;
        bytes.get(off as usize..usize::try_from(end).ok()?)
    };
    let n = table(h.nodes_offset, h.node_count, NODE_BYTES);
    let b = table(h.blocks_offset, h.block_count, BLOCK_BYTES);
    let i = table(h.instances_offset, h.instance_count, INSTANCE_BYTES);
    let m = table(h.images_offset, h.image_count, IMAGE_BYTES);
    let t = h.images_offset.checked_add(h.image_count as u64 * IMAGE_BYTES).and_then(|at| table(at, h.texture_count, TEXTURE_BYTES));
    if let (Some(n), Some(b), Some(i), Some(m), Some(t)) = (n, b, i, m, t) {
        let nodes: Vec<NodeRecord> = bytemuck::pod_collect_to_vec(n);
        let blocks: Vec<BlockRecord> = bytemuck::pod_collect_to_vec(b);
        let instances: Vec<InstanceRecord> = bytemuck::pod_collect_to_vec(i);
        let images: Vec<ImageRecord> = bytemuck::pod_collect_to_vec(m);
        let textures: Vec<TextureRecord> = bytemuck::pod_collect_to_vec(t);
        h.content_hash =
            content_hash(&h, &Tables { nodes: &nodes, blocks: &blocks, instances: &instances, images: &images, textures: &textures });
    }
    h.header_hash = header_hash(&h);
    bytes[..hs].copy_from_slice(bytemuck::bytes_of(&h));
}

pub fn run(data: &[u8]) {
    let mut bytes = data.to_vec();
    rehash(&mut bytes);
    let Ok(h) = osw_scene::file::validate(Path::new("fuzz.osw"), &bytes) else { return };
    let nodes: Vec<NodeRecord> =
        bytemuck::pod_collect_to_vec(&bytes[h.nodes_offset as usize..][..h.node_count as usize * osw_scene::format::NODE_BYTES as usize]);
    let cam = Camera::look_along([0.0, 0.0, 5.0].into(), [0.0, 0.0, -1.0].into(), 60.0);
    let view = View::new(&cam, glam::DVec3::from_array(h.origin), 64, 64, 0.01);
    for tau in [0.0, 1e6] {
        let mut pvs = Vec::new();
        frustum_cull(&nodes, &view, tau, &mut pvs);
        assert!(pvs.iter().all(|&id| nodes[id as usize].kind() == NodeKind::Lod), "HC drew a non-LOD node");
    }
}
