//! HC box tests per second on this machine's adapter (lavapipe here): one batch of every BVH
//! box of a 2M-triangle plant, against the depth of a frame's occluders, with each test.
//! Run: `cargo bench -p osw-gpu --bench boxtests` (needs a Vulkan driver).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use osw_gpu::draw::{Load, Pass};
use osw_gpu::renderer::{BoxTest, RenderOptions, Renderer, Sampling};
use osw_scene::Camera;

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("plant.osw");
    let scene = osw_scene::generators::build_generated(osw_scene::generators::GenKind::Plant, 2_000_000, 1, &path).expect("scene");
    let gpu = match osw_gpu::Gpu::new(None) {
        Ok(g) => g,
        Err(e) => {
            eprintln!("boxtests: skipped: {e}");
            return;
        }
    };
    let mut r = Renderer::new(gpu, &scene, 1024, 1024, RenderOptions::default()).expect("renderer");
    let root = scene.node(0).aabb();
    let eye = root.center().as_dvec3() + DVec3::new(0.0, 1.7 - root.center().y as f64, -0.3 * root.extent().z as f64);
    let view = r.view(&Camera::look_along(eye, DVec3::Z, 60.0), 0.0);
    // Occluders: every leaf's coarsest level in the frustum.
    let occluders: Vec<u32> =
        (0..scene.bvh_count()).map(|i| scene.node(i)).filter(|n| n.child_count == 0).map(|n| n.first_lod + n.lod_count - 1).collect();
    r.draw(&scene, &view, &occluders, Pass::Depth, Load::Clear).expect("occluders");
    r.build_pyramid();
    let ids: Vec<u32> = (0..scene.bvh_count()).collect();
    let boxes: Vec<osw_scene::Aabb> = ids.iter().map(|&i| scene.node(i).aabb()).collect();
    let mut g = c.benchmark_group("hc box tests");
    g.sample_size(10);
    g.throughput(Throughput::Elements(boxes.len() as u64));
    for test in [BoxTest::Pyramid, BoxTest::Exact, BoxTest::Queries] {
        let mut out = Vec::with_capacity(boxes.len());
        g.bench_function(format!("{test:?}, {} boxes", boxes.len()), |b| {
            b.iter(|| {
                out.clear();
                r.test_boxes(&view, boxes.iter().copied(), test, Sampling::EVERY_LINE, &mut out).expect("test")
            })
        });
    }
    // The hybrid's first test: the depth read back, the CPU pyramid, the boxes on the CPU.
    let nodes = scene.nodes();
    g.bench_function(format!("CPU pyramid with read-back, {} boxes", boxes.len()), |b| {
        b.iter(|| {
            let pyramid = osw_cull::hzb::Pyramid::new(1024, 1024, r.read_depth().expect("depth"));
            let mut out = Vec::with_capacity(boxes.len());
            osw_cull::VisibilityTester::test(
                &mut osw_cull::hzb::HzbTester { nodes, pyramid: &pyramid, read: osw_cull::hzb::Read::at(3) },
                &view,
                &ids,
                &mut out,
            );
            out
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
