//! A pass's gather on the CPU: the cluster tests and the triangle tests of every object of a
//! 200K-triangle plant, seen from inside it (triangles of every size on screen, most of them
//! covering no pixel centre, as in a walk through the large plants) and from far, and of a
//! 1M-triangle isosurface from its orbit (one smooth surface, triangles of a few pixels).
//! Run: `cargo bench -p osw-cull --bench gather`.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use osw_cull::View;
use osw_cull::cluster::{ClusterStats, ClusterTests, Out, gather};
use osw_scene::Camera;
use osw_scene::generators::{GenKind, generate};

type Meshes = Vec<(Vec<[f32; 3]>, Vec<u32>, Vec<osw_scene::format::ClusterRecord>)>;

fn clustered(kind: GenKind, triangles: u64) -> (Meshes, osw_scene::aabb::Aabb) {
    let meshes: Meshes = generate(kind, triangles, 1)
        .objects
        .into_iter()
        .map(|o| {
            let osw_scene::cluster::Clustered { indices, clusters, .. } = osw_scene::cluster::clusterize(&o.mesh, None);
            (o.mesh.positions, indices, clusters)
        })
        .collect();
    let bounds = osw_scene::aabb::Aabb::from_points(meshes.iter().flat_map(|m| m.0.iter()));
    (meshes, bounds)
}

fn bench(c: &mut Criterion) {
    let tests = ClusterTests { occlusion: false, ..ClusterTests::ALL };
    let (plant, plant_bounds) = clustered(GenKind::Plant, 200_000);
    let (iso, iso_bounds) = clustered(GenKind::Isosurface, 1_000_000);
    let (pc, pe) = (plant_bounds.center().as_dvec3(), plant_bounds.extent().as_dvec3());
    let (ic, ie) = (iso_bounds.center().as_dvec3(), iso_bounds.extent().as_dvec3());
    // From inside the plant, and from far enough that most triangles cover no pixel centre;
    // the isosurface from as far as its orbit (`osw path --kind orbit`).
    for (name, meshes, eye, centre) in [
        ("inside", &plant, pc + DVec3::new(0.0, 1.0 - 0.5 * pe.y, -0.45 * pe.z), pc),
        ("far", &plant, pc + DVec3::new(0.3, 0.5, -1.0) * pe.length(), pc),
        ("the isosurface's orbit", &iso, ic + DVec3::new(0.69, 0.35, 0.0) * ie.length(), ic),
    ] {
        let view = View::new(&Camera::look_at(eye, centre, 60.0), DVec3::ZERO, 1024, 1024, 0.01);
        let (mut out, mut s) = (Vec::new(), ClusterStats::default());
        for m in meshes {
            gather(&view, tests, &m.0, &m.1, &m.2, &[], &mut Out { indices: &mut out, base: 0, stats: &mut s });
        }
        println!(
            "gather from {name}: {} clusters, {} triangles kept, {} facing away, {} covering no pixel",
            s.clusters,
            out.len() / 3,
            s.backface_culled,
            s.small_culled
        );
        c.bench_function(&format!("gather from {name}, every test but occlusion"), |b| {
            b.iter(|| {
                out.clear();
                for m in meshes {
                    gather(&view, tests, &m.0, &m.1, &m.2, &[], &mut Out { indices: &mut out, base: 0, stats: &mut s });
                }
                out.len()
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
