//! A short fuzz run in every test run: each target on its seeds (real files osw writes) and on
//! deterministic mutations of them (bit flips, byte changes, cuts, splices), tens of thousands
//! of inputs in all. The long runs are `scripts/fuzz.sh` (cargo fuzz, libFuzzer).

use osw_fuzz::TARGETS;
use std::path::Path;

/// xorshift64: deterministic mutations.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

fn mutate(rng: &mut Rng, seed: &[u8], other: &[u8]) -> Vec<u8> {
    let mut v = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        match rng.below(6) {
            0 if !v.is_empty() => {
                let i = rng.below(v.len());
                v[i] ^= 1 << rng.below(8);
            }
            1 if !v.is_empty() => {
                let i = rng.below(v.len());
                v[i] = [0, 1, 0x7f, 0x80, 0xff, b',', b'\n', b'='][rng.below(8)];
            }
            2 => v.truncate(rng.below(v.len() + 1)),
            3 if !other.is_empty() => {
                let at = rng.below(v.len() + 1);
                let from = rng.below(other.len());
                let piece = &other[from..(from + 1 + rng.below(32)).min(other.len())];
                v.splice(at..at, piece.iter().copied());
            }
            4 if v.len() > 4 => {
                // Overwrite four bytes with an extreme little-endian number.
                let i = rng.below(v.len() - 4);
                let x = [0u32, 1, u32::MAX, 0x8000_0000, 255, 256][rng.below(6)];
                v[i..i + 4].copy_from_slice(&x.to_le_bytes());
            }
            _ => v.push(rng.next() as u8),
        }
    }
    v
}

fn seeds(target: &str) -> Vec<Vec<u8>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("libfuzzer/seeds").join(target);
    let mut v: Vec<Vec<u8>> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| std::fs::read(e.unwrap().path()).unwrap())
        .collect();
    v.push(Vec::new());
    v
}

#[test]
fn every_target_survives_its_seeds_and_their_mutations() {
    for (name, run) in TARGETS {
        let seeds = seeds(name);
        assert!(seeds.len() > 1, "{name}: no seeds");
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        for s in &seeds {
            run(s);
        }
        for k in 0..20_000 {
            let (a, b) = (&seeds[k % seeds.len()], &seeds[rng.below(seeds.len())]);
            let input = mutate(&mut rng, a, b);
            run(&input);
        }
    }
}

/// The seeds are real inputs, accepted by their decoders: the fuzzer starts past the checks.
#[test]
fn every_seed_is_accepted_by_its_decoder() {
    let nonempty = |t: &str| seeds(t).into_iter().filter(|s| !s.is_empty()).collect::<Vec<_>>();
    for s in nonempty("wire_frame") {
        assert!(matches!(osw_wire::decode_frame(&s), Ok(Some(_))), "{s:?}");
    }
    for s in nonempty("scene_tables").into_iter().chain(nonempty("texture_table")) {
        osw_scene::file::validate(Path::new("seed.osw"), &s).unwrap();
    }
    let textured = |s: &Vec<u8>| osw_scene::file::validate(Path::new("seed.osw"), s).is_ok_and(|h| h.texture_count > 0);
    assert!(nonempty("texture_table").iter().all(textured), "a texture_table seed without textures");
    for s in nonempty("path_csv") {
        osw_scene::path::parse_csv(std::str::from_utf8(&s).unwrap(), "seed.csv").unwrap();
    }
    for s in nonempty("config") {
        osw_wire::config::Config::parse(std::str::from_utf8(&s).unwrap()).unwrap();
    }
    let none = Path::new("/nonexistent");
    for s in nonempty("gltf_import") {
        assert!(!osw_scene::import::gltf::parse(&s, none).unwrap().objects.is_empty());
    }
    for s in nonempty("obj_import") {
        assert!(!osw_scene::import::obj::parse(&mut std::io::Cursor::new(&s), none).unwrap().objects.is_empty());
    }
    for s in nonempty("ply_import") {
        assert!(!osw_scene::import::ply::parse(&s).unwrap().mesh.is_empty());
    }
}
