//! Protocol throughput: id coding and whole delta frames, ids per second, and bytes per id.
//! Run: `cargo bench -p osw-wire --bench ids`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use osw_wire::messages::{Delta, IdList, Message};
use osw_wire::{decode_frame, encode_frame};

/// A visible-set-like id list: `n` ids with gaps drawn from a skewed distribution (many
/// neighbours, some far jumps), deterministic.
fn ids(n: usize) -> Vec<u32> {
    let mut x = 0x9e3779b9u32;
    let mut id = 0u32;
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            id += 1 + if x.is_multiple_of(4) { x % 2000 } else { x % 16 };
            id
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let v = ids(10_000);
    let list = IdList::from_ids(&v);
    println!("ids: {} ids → {} bytes ({:.2} bytes/id)", v.len(), list.0.len(), list.0.len() as f64 / v.len() as f64);
    let mut g = c.benchmark_group("wire");
    g.throughput(Throughput::Elements(v.len() as u64));
    g.bench_function("encode 10k ids", |b| b.iter(|| IdList::from_ids(std::hint::black_box(&v))));
    g.bench_function("decode 10k ids", |b| b.iter(|| list.ids(u32::MAX).expect("valid")));
    let msg = Message::Delta(Delta { frame: 1, added: list.clone(), removed: IdList::from_ids(&v[..100]) });
    let mut frame = Vec::new();
    encode_frame(&msg, &mut frame).expect("a delta fits a frame");
    g.bench_function("encode delta frame", |b| {
        b.iter(|| {
            let mut out = Vec::with_capacity(frame.len());
            encode_frame(std::hint::black_box(&msg), &mut out).expect("a delta fits a frame");
            out
        })
    });
    g.bench_function("decode delta frame", |b| b.iter(|| decode_frame(std::hint::black_box(&frame)).expect("valid")));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
