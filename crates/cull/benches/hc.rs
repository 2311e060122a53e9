//! HC traversal on the CPU with fake testers (no GPU): the cost of the traversal itself per
//! frame of a 2M-triangle plant, from the root and from the previous frame's visible set; and
//! the CPU pyramid HC builds from the depth it reads back.
//! Run: `cargo bench -p osw-cull --bench hc`.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use osw_cull::{AllVisible, View, Visibility, VisibilityTester, hardware_cull, hardware_cull_from};
use osw_scene::build::{BuildOptions, node_table};
use osw_scene::generators::{GenKind, generate};
use osw_scene::{Camera, NodeId};

/// Every other box visible: a deterministic stand-in for occlusion.
struct Alternate;

impl VisibilityTester for Alternate {
    type Error = std::convert::Infallible;

    fn test(&mut self, _: &View, ids: &[NodeId], out: &mut Vec<Visibility>) -> Result<(), Self::Error> {
        out.extend(ids.iter().map(|id| Visibility { visible: id % 2 == 0 || *id < 64, pixels: None }));
        Ok(())
    }
}

fn bench(c: &mut Criterion) {
    let nodes = &node_table(generate(GenKind::Plant, 2_000_000, 1).objects, &BuildOptions::default()).expect("scene");
    let root = nodes[0].aabb();
    let eye = root.center().as_dvec3() + DVec3::new(0.0, 0.0, -0.3 * root.extent().z as f64);
    let view = View::new(&Camera::look_along(eye, DVec3::Z, 60.0), DVec3::ZERO, 1024, 1024, 0.01);
    let mut pvs = Vec::new();
    let stats = hardware_cull(nodes, &view, 1.0, &mut Alternate, &mut pvs).unwrap();
    println!("hc: {} nodes, {} boxes tested in {} levels, PVS {}", nodes.len(), stats.tests, stats.levels, pvs.len());
    let mut g = c.benchmark_group("hc traversal");
    for tau in [0.0, 5.0] {
        g.bench_function(format!("levels, frustum only, tau {tau}"), |b| {
            b.iter(|| {
                pvs.clear();
                hardware_cull(nodes, &view, tau, &mut AllVisible, &mut pvs).unwrap()
            })
        });
        g.bench_function(format!("levels, every other box, tau {tau}"), |b| {
            b.iter(|| {
                pvs.clear();
                hardware_cull(nodes, &view, tau, &mut Alternate, &mut pvs).unwrap()
            })
        });
        let mut previous = Vec::new();
        hardware_cull(nodes, &view, tau, &mut Alternate, &mut previous).unwrap();
        g.bench_function(format!("from V(i-1), every other box, tau {tau}"), |b| {
            b.iter(|| {
                pvs.clear();
                hardware_cull_from(nodes, &view, tau, &previous, &mut Alternate, &mut pvs).unwrap()
            })
        });
    }
    g.finish();
}

/// HC's CPU farthest-depth pyramid of a 1024x1024 depth buffer (built every HC frame).
fn pyramid(c: &mut Criterion) {
    let depth: Vec<f32> = (0..1024 * 1024u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 8) as f32 / 16_777_216.0).collect();
    c.bench_function("hc pyramid 1024x1024", |b| b.iter(|| osw_cull::hzb::Pyramid::new(1024, 1024, depth.clone())));
}

criterion_group!(benches, bench, pyramid);
criterion_main!(benches);
