//! The power plant: a building of several floors on a grid of bays. Each bay holds equipment of
//! very different sizes (tanks, boilers with tube banks, pumps and valves, pipe runs with
//! elbows), floors are slabs on I-beam columns, walkways with railings run along bay rows and
//! the outside walls have doors. The stand-in for the 13M-triangle power plant of the occlusion
//! switch, CHC and Yoon 2003: deep occlusion between floors and equipment, objects from 10 to 10^4 triangles.
//!
//! A plant above [`BUILDING_TRIANGLES`] is a site of buildings side by side with roads between
//! them, as real sites grow (more units, not denser ones), each building like a smaller plant.
//! The site streams a batch of bays at a time ([`Site`] is a [`Source`]), so a plant of any
//! size is generated in the memory of one batch.
//!
//! The instanced plant ([`Site::instanced`], `--gen plant --instanced`) is built as real plants
//! are drawn, from a catalogue: each bay is one of a few thousand bay designs (its equipment
//! finely tessellated, as a vendor's part is), turned by a multiple of 90 degrees, and every
//! object of it a use of the design's mesh. The catalogue's meshes are 2.5% of the triangles;
//! the floors and walls are each building's own.

use super::shapes::{add_box, cylinder, lathe, rounded, tube};
use super::triangles_of;
use crate::mesh::{Mesh, Object};
use crate::source::Source;
use glam::{DAffine3, DMat3, DVec3, Vec3};
use rand::RngExt;
use rayon::prelude::*;

/// Bay size (m) and floor height (m).
pub const BAY: f32 = 12.0;
pub const FLOOR: f32 = 6.0;
pub const FLOORS: u32 = 3;
const SLAB: f32 = 0.3;
const WALL: f32 = 0.4;
/// Most triangles of one building; a larger plant has more buildings.
pub const BUILDING_TRIANGLES: u64 = 100_000_000;
/// The road between two buildings (m).
const ROAD: f32 = 2.0 * BAY;
/// Bays generated at once (about a million triangles).
const BATCH_BAYS: u64 = 512;
/// The instanced plant: how much finer its parts are tessellated (round segments times this),
/// and the share of its triangles that its catalogue of bay designs holds.
const CATALOGUE_DETAIL: u32 = 12;
const CATALOGUE_SHARE: f64 = 0.025;

/// The whole plant in memory.
pub fn generate(triangles: u64, seed: u64) -> Vec<Object> {
    let mut site = Site::new(triangles, seed);
    std::iter::from_fn(|| site.next_batch()).flatten().collect()
}

/// A plant as a stream of batches: each building's bays, then its floors and walls.
pub struct Site {
    seed: u64,
    /// Bays across (x) and deep (z) of every building, and their corners.
    nx: u64,
    nz: u64,
    corners: Vec<Vec3>,
    triangles: u64,
    /// The next building and the next bay in it.
    building: usize,
    bay: u64,
    catalogue: Option<Catalogue>,
}

/// The bay designs of the instanced plant, and which of them the stream has given already
/// (a later use of a design's mesh comes without it; see [`Object::prototype`]).
struct Catalogue {
    designs: u64,
    /// Per design: its objects once given, 0 before.
    given: Vec<u8>,
}

impl Site {
    pub fn new(triangles: u64, seed: u64) -> Site {
        Site::sized(triangles, seed, BUILDING_TRIANGLES, 1, 1_000_000..1_000_016)
    }

    /// The instanced plant of about `triangles` triangles as drawn (its bays' uses of the
    /// catalogue counted each time).
    pub fn instanced(triangles: u64, seed: u64) -> Site {
        // Sized by the designs the site will use (all of them while they are few), so that a
        // small plant of few designs meets its budget too.
        let designs = |site: &Site| ((site.bays() * site.corners.len() as u64) as f64 * CATALOGUE_SHARE).ceil() as u64;
        let first = Site::sized(triangles, design_seed(seed), BUILDING_TRIANGLES, CATALOGUE_DETAIL, 0..16);
        let sample = 0..designs(&first).min(16);
        let mut site = Site::sized(triangles, design_seed(seed), BUILDING_TRIANGLES, CATALOGUE_DETAIL, sample);
        site.seed = seed;
        let designs = designs(&site);
        site.catalogue = Some(Catalogue { designs, given: vec![0; designs as usize] });
        site
    }

    /// A site whose buildings hold at most `building` triangles each, bays tessellated `detail`
    /// times finer than the plant's, sized by the bays of ids `sample`.
    fn sized(triangles: u64, seed: u64, building: u64, detail: u32, sample: std::ops::Range<u64>) -> Site {
        // Measure the average bay on a sample, then lay out as many bays as the budget pays for.
        let n = (sample.end - sample.start).max(1);
        let sample: u64 =
            sample.map(|i| triangles_of(&bay(Vec3::ZERO, i, seed, Vec3::ZERO, Vec3::splat(BAY * 100.0), detail))).sum::<u64>() / n;
        // Buildings (each about twice as wide as deep) on a full grid about as wide as it is
        // deep: no empty lot, so a walk through the site walks through buildings.
        let at_least = triangles.div_ceil(building).max(1);
        let columns = ((at_least as f64 / 2.0).sqrt().ceil() as u64).max(1);
        let buildings = columns * at_least.div_ceil(columns);
        let bays = (triangles / buildings * 95 / 100 / (sample + 60)).max(1);
        let per_floor = bays.div_ceil(FLOORS as u64);
        let nz = ((per_floor as f64 / 2.0).sqrt().ceil() as u64).max(1);
        let nx = per_floor.div_ceil(nz);
        let size = Vec3::new(nx as f32 * BAY, 0.0, nz as f32 * BAY);
        let corners = (0..buildings)
            .map(|k| Vec3::new((k % columns) as f32 * (size.x + ROAD), 0.0, (k / columns) as f32 * (size.z + ROAD)))
            .collect();
        Site { seed, nx, nz, corners, triangles, building: 0, bay: 0, catalogue: None }
    }

    fn size(&self) -> Vec3 {
        Vec3::new(self.nx as f32 * BAY, 0.0, self.nz as f32 * BAY)
    }

    fn bays(&self) -> u64 {
        self.nx * self.nz * FLOORS as u64
    }
}

impl Source for Site {
    fn world_bounds(&self) -> crate::place::Bounds {
        let size = self.size();
        let last = self.corners.iter().fold(Vec3::ZERO, |m, c| m.max(*c));
        let min = Vec3::new(-WALL, 0.0, -WALL);
        let max = last + Vec3::new(size.x + WALL, FLOORS as f32 * FLOOR, size.z + WALL);
        crate::place::Bounds::world(min.as_dvec3(), max.as_dvec3())
    }

    fn triangles_hint(&self) -> u64 {
        self.triangles
    }

    fn next_batch(&mut self) -> Option<Vec<Object>> {
        let corner = *self.corners.get(self.building)?;
        let (nx, nz, size, seed) = (self.nx, self.nz, self.size(), self.seed);
        // Bay ids and the walls' stream differ per building; building 0 is the plant of old.
        let first_id = self.building as u64 * (1 << 32);
        let walls_stream = u64::MAX - self.building as u64;
        if self.bay < self.bays() {
            let bays = self.bay..(self.bay + BATCH_BAYS).min(self.bays());
            self.bay = bays.end;
            let origin = |b: u64| corner + Vec3::new((b % nx) as f32 * BAY, (b / (nx * nz)) as f32 * FLOOR, ((b / nx) % nz) as f32 * BAY);
            if let Some(c) = &mut self.catalogue {
                return Some(c.bays(bays.map(|b| (origin(b), first_id + b)).collect(), seed));
            }
            return Some(bays.into_par_iter().flat_map_iter(|b| bay(origin(b), first_id + b, seed, corner, size, 1)).collect());
        }
        let mut objects: Vec<Object> = (0..FLOORS)
            .map(|f| Object::new(format!("structure floor {f}{}", suffix(self.building)), structure(corner, size, f, nx, nz)))
            .collect();
        objects.extend(walls(corner, size, nx, nz, seed, walls_stream, self.building));
        self.building += 1;
        self.bay = 0;
        Some(objects)
    }
}

impl Catalogue {
    /// The bays at `bays` (corner, id): each a design and a quarter turn drawn from its id, its
    /// objects uses of the design's meshes; a design's meshes come with its first use only.
    fn bays(&mut self, bays: Vec<(Vec3, u64)>, seed: u64) -> Vec<Object> {
        let picks: Vec<(Vec3, u64, u32)> = bays
            .into_iter()
            .map(|(o, id)| {
                let mut r = super::rng(seed, id ^ 0xC47A_1064);
                (o, r.random_range(0..self.designs), r.random_range(0..4u32))
            })
            .collect();
        let mut new: Vec<u64> = picks.iter().map(|p| p.1).filter(|&d| self.given[d as usize] == 0).collect();
        new.sort_unstable();
        new.dedup();
        // A design is a bay at the origin; its pipes may reach one bay beyond it.
        let reach = (Vec3::splat(-BAY), Vec3::splat(3.0 * BAY));
        let meshes: rustc_hash::FxHashMap<u64, Vec<Object>> =
            new.into_par_iter().map(|d| (d, bay(Vec3::ZERO, d, design_seed(seed), reach.0, reach.1, CATALOGUE_DETAIL))).collect();
        for (&d, objects) in &meshes {
            self.given[d as usize] = objects.len() as u8;
        }
        let mut out = Vec::new();
        for (o, design, turn) in picks {
            let placement = quarter_turn(o, turn);
            let given = meshes.get(&design);
            // Objects of a design are the same whichever bay draws it: a design's k-th object
            // is prototype (design, k).
            for k in 0..self.given[design as usize] as usize {
                let mesh = given.map_or_else(Mesh::default, |g| g[k].mesh.clone());
                let name = given.map_or_else(|| format!("part {k} of design {design}"), |g| format!("{} of design {design}", g[k].name));
                let prototype = u32::try_from(design * MAX_DESIGN_OBJECTS + k as u64).expect("designs fit in u32 ids");
                out.push(Object { prototype: Some(prototype), ..Object::placed(name, mesh, DVec3::ZERO, placement) });
            }
        }
        out
    }
}

/// The seed of the catalogue's designs: design `d` is the bay of id `d` under it.
fn design_seed(seed: u64) -> u64 {
    seed ^ 0xDE51_6A5E
}

/// Most objects of one bay (a bay has at most 5 pumps, 3 pipes, a tank or boiler and a walkway).
const MAX_DESIGN_OBJECTS: u64 = 16;

/// Turns a bay about its centre by `turn` quarter turns and moves it to `o`, exactly (the
/// rotation's entries are 0 and ±1).
fn quarter_turn(o: Vec3, turn: u32) -> DAffine3 {
    let (c, s) = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][turn as usize % 4];
    let m = DMat3::from_cols(DVec3::new(c, 0.0, -s), DVec3::Y, DVec3::new(s, 0.0, c));
    let centre = DVec3::new(BAY as f64 / 2.0, 0.0, BAY as f64 / 2.0);
    DAffine3 { matrix3: m, translation: o.as_dvec3() + centre - m * centre }
}

/// Names of a building's own objects: building 0 as the plant always named them.
fn suffix(building: usize) -> String {
    if building == 0 { String::new() } else { format!(" building {building}") }
}

/// The equipment of one bay with its corner at `o`, in a building from `corner` and `size`
/// (x, z) across; `id` seeds it, round parts have `detail` times the plant's segments.
fn bay(o: Vec3, id: u64, seed: u64, corner: Vec3, size: Vec3, detail: u32) -> Vec<Object> {
    let d = detail;
    let mut r = super::rng(seed, id);
    let mut out = Vec::new();
    let floor_y = o.y + SLAB;
    let inner = |r: &mut rand_pcg::Pcg64Mcg, margin: f32| {
        o + Vec3::new(r.random_range(margin..BAY - margin), SLAB, r.random_range(margin..BAY - margin))
    };
    let mut push = |name: &str, mesh: Mesh| out.push(Object::new(format!("{name} {id}"), mesh));
    let roll: f32 = r.random();
    if roll < 0.3 {
        // A vertical tank with a domed head.
        let rad = r.random_range(1.2..4.0);
        let h = r.random_range(2.5..FLOOR - SLAB - rad * 0.45 - 0.2);
        let c = inner(&mut r, rad + 0.3);
        let mut prof = vec![(0.0, 0.0), (rad, 0.0), (rad, h)];
        prof.extend((1..=8).map(|i| {
            let a = std::f32::consts::FRAC_PI_2 * i as f32 / 8.0;
            // Exact 0 at the pole: cos(pi/2) in f32 is not 0.
            (if i == 8 { 0.0 } else { rad * a.cos() }, h + rad * 0.45 * a.sin())
        }));
        let mut m = Mesh::default();
        lathe(&mut m, c, &prof, 48 * d);
        // Legs and a nozzle.
        cylinder(&mut m, c + Vec3::new(rad, h * 0.7, 0.0), c + Vec3::new(rad + 0.6, h * 0.7, 0.0), 0.15, 12 * d);
        push("tank", m);
    } else if roll < 0.45 {
        // A boiler: a casing, a bank of vertical tubes in front and a steam drum on top.
        let mut m = Mesh::default();
        let lo = o + Vec3::new(2.0, SLAB, 3.0);
        let hi = lo + Vec3::new(r.random_range(5.0..8.0), FLOOR - SLAB - 1.5, r.random_range(4.0..6.5));
        add_box(&mut m, lo, hi);
        let tubes = r.random_range(8..24);
        for k in 0..tubes {
            let x = lo.x + (hi.x - lo.x) * (k as f32 + 0.5) / tubes as f32;
            cylinder(&mut m, Vec3::new(x, lo.y, lo.z - 0.3), Vec3::new(x, hi.y, lo.z - 0.3), 0.12, 10 * d);
        }
        cylinder(&mut m, Vec3::new(lo.x, hi.y + 0.6, (lo.z + hi.z) / 2.0), Vec3::new(hi.x, hi.y + 0.6, (lo.z + hi.z) / 2.0), 0.6, 24 * d);
        push("boiler", m);
    } else if roll < 0.7 {
        // Pumps with motors and valves: small objects.
        for _ in 0..r.random_range(2..6) {
            let p = inner(&mut r, 1.5);
            let mut m = Mesh::default();
            add_box(&mut m, p, p + Vec3::new(1.2, 0.4, 0.8));
            cylinder(&mut m, p + Vec3::new(0.2, 0.75, 0.4), p + Vec3::new(1.0, 0.75, 0.4), 0.32, 16 * d);
            cylinder(&mut m, p + Vec3::new(0.6, 1.05, 0.4), p + Vec3::new(0.6, 1.6, 0.4), 0.06, 8 * d);
            let wheel: Vec<Vec3> = (0..=16)
                .map(|k| {
                    p + Vec3::new(0.6, 1.6, 0.4)
                        + 0.25
                            * Vec3::new((k as f32 * std::f32::consts::FRAC_PI_8).cos(), 0.0, (k as f32 * std::f32::consts::FRAC_PI_8).sin())
                })
                .collect();
            tube(&mut m, &wheel, 0.03, 6 * d, false);
            push("pump", m);
        }
    }
    // Pipe runs: most bays start one or more, crossing into neighbouring bays, with elbows
    // down to the floor or up to the ceiling. Radii from 5 cm to 50 cm.
    for _ in 0..r.random_range(0..4) {
        let rad = 0.05 * 10f32.powf(r.random::<f32>());
        let y = floor_y + r.random_range(3.0..FLOOR - SLAB - 0.6);
        let start = Vec3::new(o.x + r.random_range(0.5..BAY - 0.5), y, o.z + r.random_range(0.5..BAY - 0.5));
        let dir = if r.random::<bool>() { Vec3::X } else { Vec3::Z };
        let len = BAY * r.random_range(0.5..3.0);
        let mut corners = vec![start.with_y(floor_y + 0.3), start, start + dir * len * 0.5];
        let side = if dir == Vec3::X { Vec3::Z } else { Vec3::X };
        corners.push(corners[2] + side * r.random_range(1.0..4.0));
        corners.push(corners[3] + dir * len * 0.5);
        if r.random::<bool>() {
            let last = corners[4];
            corners.push(last.with_y(floor_y + 0.3));
        }
        // Pipes stay inside the building's walls.
        for c in &mut corners {
            (c.x, c.z) = (c.x.clamp(corner.x + 0.5, corner.x + size.x - 0.5), c.z.clamp(corner.z + 0.5, corner.z + size.z - 0.5));
        }
        let seg = (8.0 + rad * 30.0) as u32 * d;
        let mut m = Mesh::default();
        tube(&mut m, &rounded(&corners, rad * 3.0, 6), rad, seg, true);
        push("pipe", m);
    }
    // A walkway with railings along the bay's north edge, 2.8 m up (not on every bay).
    if r.random::<f32>() < 0.35 {
        let y = floor_y + 2.8;
        let (a, b) = (o + Vec3::new(0.0, y - o.y, 0.4), o + Vec3::new(BAY, y - o.y, 1.6));
        let mut m = Mesh::default();
        add_box(&mut m, a, b.with_y(y + 0.08));
        for k in 0..=8 {
            let x = a.x + BAY * k as f32 / 8.0;
            add_box(&mut m, Vec3::new(x, y, b.z - 0.05), Vec3::new(x + 0.06, y + 1.1, b.z));
        }
        cylinder(&mut m, Vec3::new(a.x, y + 1.1, b.z - 0.02), Vec3::new(b.x, y + 1.1, b.z - 0.02), 0.03, 6 * d);
        cylinder(&mut m, Vec3::new(a.x, y + 0.55, b.z - 0.02), Vec3::new(b.x, y + 0.55, b.z - 0.02), 0.03, 6 * d);
        push("walkway", m);
    }
    out
}

/// Floor slabs (one box per bay) and I-beam columns at bay corners for floor `f` of the
/// building at `corner`.
fn structure(corner: Vec3, size: Vec3, f: u32, nx: u64, nz: u64) -> Mesh {
    let mut m = Mesh::default();
    let y = f as f32 * FLOOR;
    for i in 0..nx {
        for k in 0..nz {
            let lo = Vec3::new(i as f32 * BAY, y, k as f32 * BAY);
            add_box(&mut m, lo, lo + Vec3::new(BAY, SLAB, BAY));
        }
    }
    for i in 0..=nx {
        for k in 0..=nz {
            let c = Vec3::new((i as f32 * BAY).min(size.x - 0.2).max(0.2), y + SLAB, (k as f32 * BAY).min(size.z - 0.2).max(0.2));
            let top = y + FLOOR;
            add_box(&mut m, c + Vec3::new(-0.15, 0.0, -0.15), Vec3::new(c.x + 0.15, top, c.z - 0.12));
            add_box(&mut m, c + Vec3::new(-0.15, 0.0, 0.12), Vec3::new(c.x + 0.15, top, c.z + 0.15));
            add_box(&mut m, c + Vec3::new(-0.03, 0.0, -0.12), Vec3::new(c.x + 0.03, top, c.z + 0.12));
        }
    }
    moved(m, corner)
}

fn moved(mut m: Mesh, by: Vec3) -> Mesh {
    m.positions.iter_mut().for_each(|p| *p = (Vec3::from_array(*p) + by).to_array());
    m
}

/// Outside walls of the building at `corner`, one object per side and floor, with a door in
/// one bay in four; `stream` seeds them.
fn walls(corner: Vec3, size: Vec3, nx: u64, nz: u64, seed: u64, stream: u64, building: usize) -> Vec<Object> {
    let mut r = super::rng(seed, stream);
    let mut out = Vec::new();
    for f in 0..FLOORS {
        let y0 = f as f32 * FLOOR + SLAB;
        let y1 = (f + 1) as f32 * FLOOR;
        for (side, bays) in [(0, nx), (1, nx), (2, nz), (3, nz)] {
            let mut m = Mesh::default();
            for b in 0..bays {
                let (a, e) = (b as f32 * BAY, (b + 1) as f32 * BAY);
                let door = r.random::<f32>() < 0.25;
                let yb = if door { y0 + 3.0 } else { y0 };
                let (lo, hi) = match side {
                    0 => (Vec3::new(a, yb, -WALL), Vec3::new(e, y1, 0.0)),
                    1 => (Vec3::new(a, yb, size.z), Vec3::new(e, y1, size.z + WALL)),
                    2 => (Vec3::new(-WALL, yb, a), Vec3::new(0.0, y1, e)),
                    _ => (Vec3::new(size.x, yb, a), Vec3::new(size.x + WALL, y1, e)),
                };
                add_box(&mut m, lo, hi);
            }
            out.push(Object::new(format!("wall {side} floor {f}{}", suffix(building)), moved(m, corner)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::place::world_bounds;

    #[test]
    fn a_site_streams_buildings_side_by_side_within_its_bounds() {
        for (triangles, building) in [(60_000, BUILDING_TRIANGLES), (150_000, 40_000)] {
            let mut site = Site::sized(triangles, 7, building, 1, 1_000_000..1_000_016);
            let crate::place::Bounds { min, max, .. } = site.world_bounds();
            let batches: Vec<Vec<Object>> = std::iter::from_fn(|| site.next_batch()).collect();
            let objects: Vec<Object> = batches.into_iter().flatten().collect();
            let crate::place::Bounds { min: lo, max: hi, .. } = world_bounds(&objects);
            assert!(lo.cmpge(min).all() && hi.cmple(max).all(), "{lo}..{hi} outside {min}..{max}");
            // The declared bounds are tight: within a pipe's reach of the true ones.
            assert!((lo - min).max_element() < 1.0 && (max - hi).max_element() < 1.0, "{lo}..{hi} vs {min}..{max}");
            let walls = objects.iter().filter(|o| o.name.starts_with("wall 0 floor 0")).count() as u64;
            assert!(
                walls >= triangles.div_ceil(building) && walls <= triangles.div_ceil(building) + 2,
                "{walls} buildings for {building} triangles each"
            );
            let total = triangles_of(&objects) as f64;
            assert!((total / triangles as f64 - 1.0).abs() < 0.15, "{total} triangles for a budget of {triangles}");
        }
    }

    #[test]
    fn the_stream_is_the_same_for_the_same_seed() {
        let names = |seed| generate(50_000, seed).into_iter().map(|o| (o.name, o.mesh.positions.len())).collect::<Vec<_>>();
        assert_eq!(names(3), names(3));
        assert_ne!(names(3), names(4));
    }
}
