//! The teapots: thousands of dense teapots in a long, thin field with empty rows and holes that
//! one sees through to the far end, as in CHC's teapot scene (CHC sec. 6.1). Uses the real
//! Utah teapot when `scripts/fetch-meshes.sh` has put `teapot.ply` in the mesh cache, else a
//! procedural teapot (body, lid, spout, handle) tessellated to the budget.

use super::shapes::{grid_plane, lathe, rounded, tube};
use super::{Generated, rng};
use crate::mesh::{Mesh, Object};
use glam::{Affine3A, Quat, Vec3};
use rand::RngExt;
use std::path::PathBuf;

/// Teapot height (m): a little above eye height, so that a walk between them is occluded.
const HEIGHT: f32 = 2.5;
/// Distance between teapot slots (m): a teapot is up to ~5 m across with spout and handle,
/// so lanes of about 2 m stay open between them for a walk.
const SPACING: f32 = 7.0;
/// Slots across the field: long and thin.
const COLUMNS: u64 = 8;

/// Where fetched meshes live: `$OSW_MESH_CACHE`, else `$HOME/.cache/osw/meshes`.
pub fn mesh_cache() -> PathBuf {
    match std::env::var_os("OSW_MESH_CACHE") {
        Some(p) => PathBuf::from(p),
        None => PathBuf::from(std::env::var_os("HOME").unwrap_or_default()).join(".cache/osw/meshes"),
    }
}

pub fn generate(triangles: u64, seed: u64) -> Generated {
    generate_with(triangles, seed, &mesh_cache())
}

/// [`generate`] with the Utah teapot looked up in `cache` (tests pin it).
pub fn generate_with(triangles: u64, seed: u64, cache: &std::path::Path) -> Generated {
    let mut notes = Vec::new();
    let utah = cache.join("teapot.ply");
    let teapot = match crate::import::ply::read(&utah).map(|o| o.mesh.welded()) {
        Ok(m) if !m.is_empty() => {
            notes.push(format!("teapots: the Utah teapot from {}", utah.display()));
            normalised(m)
        }
        _ => {
            notes.push(format!("teapots: procedural teapot ({} not found; run scripts/fetch-meshes.sh)", utah.display()));
            // Aim for at least about 2,000 teapots.
            let per = (triangles / 2_000).clamp(200, 40_000);
            let probe = procedural(16).triangle_count() as f64;
            let seg = (16.0 * (per as f64 / probe).sqrt()).round().max(6.0) as u32;
            normalised(procedural(seg))
        }
    };
    let per = teapot.triangle_count() as u64;
    let count = (triangles * 98 / 100 / per).max(1);
    let mut r = rng(seed, 0);
    let mut objects = Vec::with_capacity(count as usize + 1);
    let mut slot = 0u64;
    while (objects.len() as u64) < count {
        let (col, row) = (slot % COLUMNS, slot / COLUMNS);
        slot += 1;
        // Every 9th row is empty and one slot in eight is a hole: lines of sight to far away.
        if row % 9 == 8 || r.random::<f32>() < 0.125 {
            continue;
        }
        let at = Vec3::new(col as f32 * SPACING + r.random_range(-0.8..0.8), 0.0, row as f32 * SPACING + r.random_range(-0.8..0.8));
        let rot = Quat::from_rotation_y(r.random_range(0.0..std::f32::consts::TAU));
        let s = r.random_range(0.8..1.25);
        let mut mesh = teapot.clone();
        mesh.transform(&Affine3A::from_scale_rotation_translation(Vec3::splat(s), rot, at));
        objects.push(Object::new(format!("teapot {}", objects.len()), mesh));
    }
    let rows = slot.div_ceil(COLUMNS) as f32;
    let mut ground = Mesh::default();
    let margin = SPACING;
    grid_plane(
        &mut ground,
        Vec3::new(-margin, 0.0, -margin),
        Vec3::new(COLUMNS as f32 * SPACING + margin, 0.0, rows * SPACING + margin),
        COLUMNS as u32 * 2,
        rows as u32 * 2,
    );
    objects.push(Object::new("ground", ground));
    Generated { objects, notes }
}

/// `m` scaled to HEIGHT, standing on y = 0, centred on the y axis. Any source orientation with
/// y up works (the npm teapot is y-up).
fn normalised(mut m: Mesh) -> Mesh {
    let b = m.bounds();
    let s = HEIGHT / b.extent().y.max(1e-6);
    let c = b.center();
    m.transform(&Affine3A::from_scale_rotation_translation(Vec3::splat(s), Quat::IDENTITY, -Vec3::new(c.x, b.min.y, c.z) * s));
    m
}

/// A teapot of unit-ish size with `seg` segments around: about 2.3 * seg^2 triangles.
fn procedural(seg: u32) -> Mesh {
    let rings = (seg / 2).max(3);
    let mut m = Mesh::default();
    // Body: a squat bulb, closed at the bottom.
    let body: Vec<(f32, f32)> = (0..=rings)
        .map(|i| {
            let t = i as f32 / rings as f32;
            let r = if i == 0 { 0.0 } else { 1.0 + 0.45 * (std::f32::consts::PI * (t * 0.9 + 0.05)).sin() - 0.3 * t };
            (r, 1.4 * t)
        })
        .collect();
    lathe(&mut m, Vec3::ZERO, &body, seg);
    // Lid: a dome with a knob, closed at the top.
    let top = body.last().expect("rings >= 3");
    let lid: Vec<(f32, f32)> = (0..=rings / 2)
        .map(|i| {
            let t = i as f32 / (rings / 2) as f32;
            ((top.0 * (1.0 - t * t)).max(0.0), top.1 + 0.35 * t)
        })
        .collect();
    lathe(&mut m, Vec3::ZERO, &lid, seg);
    // Spout and handle: tubes along curves.
    let spout = rounded(&[Vec3::new(1.1, 0.4, 0.0), Vec3::new(1.7, 0.6, 0.0), Vec3::new(2.1, 1.4, 0.0)], 0.5, rings);
    tube(&mut m, &spout, 0.16, seg / 2, true);
    let handle = rounded(
        &[Vec3::new(-1.2, 1.1, 0.0), Vec3::new(-1.9, 1.1, 0.0), Vec3::new(-1.9, 0.35, 0.0), Vec3::new(-1.25, 0.35, 0.0)],
        0.35,
        rings,
    );
    tube(&mut m, &handle, 0.09, seg / 2, true);
    m
}
