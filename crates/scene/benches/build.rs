//! Scene build throughput (input triangles per second, end to end but for the generator) and
//! the time to open a built scene file. Run: `cargo bench -p osw-scene --bench build`.
//! Target: at least 1,000,000 input triangles per second for the plant scene on a
//! 2-core machine; Peng 2014 and Yoon 2003 report about 5,000 per second for their preprocessing.

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use osw_scene::build::{BuildOptions, build_scene};
use osw_scene::generators::{GenKind, generate};

const TRIANGLES: u64 = 2_000_000;

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut g = c.benchmark_group("build");
    g.sample_size(10);
    for kind in [GenKind::Plant, GenKind::City, GenKind::Teapots] {
        let objects = generate(kind, TRIANGLES, 1).objects;
        let tris: u64 = objects.iter().map(|o| o.mesh.triangle_count() as u64).sum();
        g.throughput(Throughput::Elements(tris));
        let out = dir.path().join(format!("{kind:?}.osw"));
        g.bench_function(format!("{kind:?} {tris} triangles"), |b| {
            b.iter_batched(
                || objects.clone(),
                |objects| {
                    build_scene(objects, "bench", Vec::new(), &BuildOptions::default(), &out, std::time::Instant::now(), &())
                        .expect("build")
                },
                BatchSize::LargeInput,
            )
        });
    }
    g.finish();
    let file = dir.path().join("Plant.osw");
    c.bench_function("open plant scene file", |b| b.iter(|| osw_scene::SceneFile::open(&file).expect("open")));
}

criterion_group!(benches, bench);
criterion_main!(benches);
