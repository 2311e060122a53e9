//! The city: a grid of blocks separated by streets, each block six lots with a building of
//! one to three stepped tiers, protruding window frames and roof equipment. Street-level views
//! see one street and its facades: high occlusion, as in CHC's city (CHC sec. 6.1).

use super::shapes::{add_box, cylinder, grid_plane};
use crate::mesh::{Mesh, Object};
use glam::Vec3;
use rand::RngExt;
use rayon::prelude::*;

/// Lot size (m): blocks are 2 by 3 lots.
const LOT: f32 = 24.0;
/// Street width (m), kerb to kerb.
const STREET: f32 = 14.0;
const LOTS_X: u32 = 2;
const LOTS_Z: u32 = 3;
/// Triangles of a building without windows, about: tiers and roof equipment.
const BUILDING_BASE: u64 = 100;
/// A window frame is a box.
const WINDOW_TRIANGLES: u64 = 12;

pub fn generate(triangles: u64, seed: u64) -> Vec<Object> {
    let buildings = (triangles / 1200).clamp(6, 60_000);
    let per_building = triangles * 97 / 100 / buildings;
    let windows = per_building.saturating_sub(BUILDING_BASE) / WINDOW_TRIANGLES;
    let blocks = buildings.div_ceil((LOTS_X * LOTS_Z) as u64);
    let gx = (blocks as f64).sqrt().ceil() as u64;
    let gz = blocks.div_ceil(gx);
    let block = Vec3::new(LOT * LOTS_X as f32, 0.0, LOT * LOTS_Z as f32);
    let pitch = block + Vec3::new(STREET, 0.0, STREET);
    let lot_origin = |b: u64| {
        let (bx, bz) = (b % gx, b / gx);
        Vec3::new(STREET + bx as f32 * pitch.x, 0.0, STREET + bz as f32 * pitch.z)
    };
    let mut objects: Vec<Object> = (0..buildings)
        .into_par_iter()
        .map(|i| {
            let b = i / (LOTS_X * LOTS_Z) as u64;
            let lot = (i % (LOTS_X * LOTS_Z) as u64) as u32;
            let min = lot_origin(b) + Vec3::new((lot % LOTS_X) as f32 * LOT, 0.0, (lot / LOTS_X) as f32 * LOT);
            Object::new(format!("building {i}"), building(min, windows, &mut super::rng(seed, i)))
        })
        .collect();
    // Ground: streets as one subdivided plane plus a raised kerb slab per block.
    let size = Vec3::new(STREET + gx as f32 * pitch.x, 0.0, STREET + gz as f32 * pitch.z);
    let mut ground = Mesh::default();
    grid_plane(&mut ground, Vec3::ZERO, size, (size.x / 8.0) as u32, (size.z / 8.0) as u32);
    for b in 0..blocks {
        add_box(&mut ground, lot_origin(b) - Vec3::new(1.0, 0.0, 1.0), lot_origin(b) + block + Vec3::new(1.0, 0.15, 1.0));
    }
    objects.push(Object::new("ground", ground));
    objects
}

/// A building in the lot at `min`, with about `windows` window frames on its lowest tier.
fn building(min: Vec3, windows: u64, rng: &mut impl RngExt) -> Mesh {
    let mut m = Mesh::default();
    let inset = |rng: &mut dyn FnMut() -> f32| rng() * 3.0 + 1.0;
    let mut r = || rng.random::<f32>();
    let lo = min + Vec3::new(inset(&mut r), 0.15, inset(&mut r));
    let hi_xz = min + Vec3::new(LOT - inset(&mut r), 0.0, LOT - inset(&mut r));
    // Most buildings are 4-12 storeys; one in ten is a tower.
    let height = if r() < 0.1 { 60.0 + r() * 60.0 } else { 12.0 + r() * 28.0 };
    let tiers = 1 + (r() * 3.0) as u32;
    let (mut tlo, mut thi) = (lo, Vec3::new(hi_xz.x, lo.y, hi_xz.z));
    let tier_h = height / tiers as f32;
    let ground_tier = (tlo, Vec3::new(thi.x, lo.y + tier_h, thi.z));
    for _ in 0..tiers {
        let top = thi.y + tier_h;
        add_box(&mut m, tlo, Vec3::new(thi.x, top, thi.z));
        let shrink = (thi - tlo) * (0.08 + 0.1 * r());
        tlo = Vec3::new(tlo.x + shrink.x, top, tlo.z + shrink.z);
        thi = Vec3::new(thi.x - shrink.x, top, thi.z - shrink.z);
    }
    // Roof equipment: small boxes and a water tank.
    let roof = |r: &mut dyn FnMut() -> f32| tlo + (thi - tlo) * Vec3::new(0.1 + 0.8 * r(), 0.0, 0.1 + 0.8 * r());
    for _ in 0..(r() * 4.0) as u32 {
        let p = roof(&mut r);
        add_box(&mut m, p, p + Vec3::new(1.5, 1.2, 1.0));
    }
    if r() < 0.5 {
        let p = roof(&mut r);
        cylinder(&mut m, p, p + Vec3::Y * 2.5, 1.2, 12);
    }
    window_frames(&mut m, ground_tier.0, ground_tier.1, windows);
    m
}

/// About `count` window frames spread over the four facades of the box `lo..hi`, each
/// facade's share proportional to its area.
fn window_frames(m: &mut Mesh, lo: Vec3, hi: Vec3, count: u64) {
    let e = hi - lo;
    let perimeter = 2.0 * (e.x + e.z);
    // (along-axis, width, fixed coordinate, outward sign)
    for (along_x, width, sign) in [(true, e.x, -1.0f32), (true, e.x, 1.0), (false, e.z, -1.0), (false, e.z, 1.0)] {
        let n = (count as f32 * width / perimeter).round().max(0.0);
        if n < 1.0 {
            continue;
        }
        let cols = ((n * width / e.y).sqrt().round() as u32).max(1);
        let rows = ((n / cols as f32).round() as u32).max(1);
        let (cw, ch) = (width / cols as f32, e.y / rows as f32);
        let (fw, fh, depth) = (cw * 0.5, ch * 0.5, 0.25);
        for row in 0..rows {
            for col in 0..cols {
                let a = col as f32 * cw + (cw - fw) * 0.5;
                let y = lo.y + row as f32 * ch + (ch - fh) * 0.5;
                let (p0, p1) = if along_x {
                    let z = if sign < 0.0 { lo.z - depth } else { hi.z };
                    (Vec3::new(lo.x + a, y, z), Vec3::new(lo.x + a + fw, y + fh, z + depth))
                } else {
                    let x = if sign < 0.0 { lo.x - depth } else { hi.x };
                    (Vec3::new(x, y, lo.z + a), Vec3::new(x + depth, y + fh, lo.z + a + fw))
                };
                add_box(m, p0, p1);
            }
        }
    }
}
