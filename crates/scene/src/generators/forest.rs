//! The forest of Bartz 1999 (sec. 4.1.3, table 1): leafy trees in front of a castle, the hard
//! case for occlusion culling. A crown is thousands of small leaf triangles with gaps between
//! them: no leaf hides much, only many crowns together hide what is behind them (porous
//! occluders), so a conservative method finds little hidden and adaptive culling (eq. 1) has
//! room to trade error for time. Paper 003 had 12 trees of 28,500 polygons before a Castel del
//! Monte of 110,981; here a quarter of the budget is the castle (an octagonal ring of walls
//! with eight towers and battlements, as that castle is), the rest trees of 28,500 triangles.

use super::rng;
use super::shapes::{add_box, cylinder, grid_plane, lathe};
use crate::mesh::{Mesh, Object};
use glam::{Quat, Vec3};
use rand::RngExt;
use std::f32::consts::TAU;

/// Triangles of one tree, as in Bartz 1999.
const TREE_TRIANGLES: u64 = 28_500;
/// Distance between tree slots (m); trees stand jittered in them, crowns touching.
const SPACING: f32 = 10.0;
/// The castle's radius (m), to the middle of its walls.
const CASTLE: f32 = 28.0;

pub fn generate(triangles: u64, seed: u64) -> Vec<Object> {
    let mut r = rng(seed, 0);
    let castle_budget = triangles / 4;
    let trees = ((triangles - castle_budget) / TREE_TRIANGLES).max(1);
    let per_tree = (triangles - castle_budget) / trees;
    // Trees in rows in front of the castle (towards -z), the walk's side.
    let columns = ((trees as f64 * 2.0).sqrt().ceil() as u64).max(1);
    let rows = trees.div_ceil(columns);
    let front = -(CASTLE + 12.0);
    let mut objects = Vec::new();
    for k in 0..trees {
        let (i, j) = ((k % columns) as f32, (k / columns) as f32);
        let jitter = Vec3::new(r.random_range(-1.5..1.5), 0.0, r.random_range(-1.5..1.5));
        let base = Vec3::new((i - (columns as f32 - 1.0) / 2.0) * SPACING, 0.0, front - j * SPACING) + jitter;
        objects.push(Object::new(format!("tree {k}"), tree(base, per_tree, &mut r)));
    }
    objects.push(Object::new("castle", castle(castle_budget)));
    // Ground under the castle and the forest, out to where the walk may go.
    let half = (columns as f32 * SPACING / 2.0 + 10.0).max(CASTLE + 20.0);
    let mut ground = Mesh::default();
    grid_plane(&mut ground, Vec3::new(-half, 0.0, front - rows as f32 * SPACING - 20.0), Vec3::new(half, 0.0, CASTLE + 20.0), 16, 16);
    objects.push(Object::new("ground", ground));
    objects
}

/// A tree at `base` of about `budget` triangles: a trunk, a few boughs and a crown of single
/// leaf triangles (seen from both sides, as the renderer draws them) in an ellipsoid.
fn tree(base: Vec3, budget: u64, r: &mut rand_pcg::Pcg64Mcg) -> Mesh {
    let mut m = Mesh::default();
    let height = r.random_range(13.0..17.0);
    let crown = Vec3::new(r.random_range(4.5..5.5), r.random_range(4.5..6.0), r.random_range(4.5..5.5));
    let centre = base + Vec3::Y * (height - crown.y);
    cylinder(&mut m, base, base + Vec3::Y * (height - crown.y * 0.5), r.random_range(0.18..0.3), 12);
    for b in 0..5 {
        let a = TAU * (b as f32 + r.random::<f32>()) / 5.0;
        let from = base + Vec3::Y * (height - crown.y * 1.3);
        cylinder(&mut m, from, centre + Vec3::new(a.cos() * crown.x * 0.7, r.random_range(-0.5..1.0), a.sin() * crown.z * 0.7), 0.07, 6);
    }
    let leaves = budget.saturating_sub(m.triangle_count() as u64);
    for _ in 0..leaves {
        // A point in the ellipsoid, denser towards its skin, as foliage is.
        let d = loop {
            let p = Vec3::new(r.random_range(-1.0..1.0), r.random_range(-1.0..1.0), r.random_range(-1.0..1.0));
            if p.length_squared() <= 1.0 && p.length_squared() > 0.15 {
                break p;
            }
        };
        let at = centre + d * crown;
        let q = Quat::from_euler(glam::EulerRot::YXZ, r.random_range(0.0..TAU), r.random_range(0.0..TAU), r.random_range(0.0..TAU));
        let size = r.random_range(0.15..0.3);
        let first = m.positions.len() as u32;
        for c in [Vec3::new(0.0, 0.0, 0.0), Vec3::new(size, 0.0, size * 0.3), Vec3::new(size * 0.3, 0.0, size)] {
            m.positions.push((at + q * c).to_array());
        }
        m.indices.extend([first, first + 1, first + 2]);
    }
    m
}

/// The castle: an octagonal ring of walls around a courtyard with an octagonal tower at each
/// corner and battlements, finer as the budget grows (towers' segments, merlons).
fn castle(budget: u64) -> Mesh {
    let mut m = Mesh::default();
    let (wall_h, tower_h, tower_r, thick) = (12.0, 15.0, 3.5, 3.0);
    let corner = |k: u32| {
        let a = TAU * (k as f32 + 0.5) / 8.0;
        Vec3::new(a.cos(), 0.0, a.sin()) * CASTLE
    };
    // Towers take about half the budget, battlements the rest: segments and merlons to match.
    let segments = ((budget / 2 / 8 / 4) as u32).clamp(8, 1024);
    for k in 0..8 {
        lathe(&mut m, corner(k), &[(0.0, 0.0), (tower_r, 0.0), (tower_r, tower_h), (0.0, tower_h)], segments);
    }
    let merlons_per_wall = ((budget.saturating_sub(m.triangle_count() as u64 + 8 * 12) / 8 / 12) as u32).max(4);
    for k in 0..8 {
        let (a, b) = (corner(k), corner((k + 1) % 8));
        let along = (b - a).normalize();
        let len = a.distance(b);
        // The wall as a box turned along its side: corners made from the rotated frame.
        let rot = Quat::from_rotation_arc(Vec3::X, along);
        let mut wall = Mesh::default();
        add_box(&mut wall, Vec3::new(0.0, 0.0, -thick / 2.0), Vec3::new(len, wall_h, thick / 2.0));
        for i in 0..merlons_per_wall {
            let x = len * (i as f32 + 0.25) / merlons_per_wall as f32;
            let w = len * 0.5 / merlons_per_wall as f32;
            add_box(&mut wall, Vec3::new(x, wall_h, thick / 2.0 - 0.6), Vec3::new(x + w, wall_h + 1.2, thick / 2.0));
        }
        let first = m.positions.len() as u32;
        m.positions.extend(wall.positions.iter().map(|p| (a + rot * Vec3::from_array(*p)).to_array()));
        m.indices.extend(wall.indices.iter().map(|i| i + first));
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_forest_meets_its_budget_with_trees_before_a_castle() {
        for budget in [150_000u64, 1_000_000] {
            let objects = generate(budget, 3);
            let total: u64 = objects.iter().map(|o| o.mesh.triangle_count() as u64).sum();
            assert!((total as f64 / budget as f64 - 1.0).abs() < 0.1, "{total} triangles for {budget}");
            let trees: Vec<&Object> = objects.iter().filter(|o| o.name.starts_with("tree")).collect();
            assert!(trees.len() as u64 >= budget * 3 / 4 / TREE_TRIANGLES);
            let castle = objects.iter().find(|o| o.name == "castle").expect("a castle");
            // Every tree stands in front of the castle (towards -z), none inside it.
            assert!(trees.iter().all(|t| t.mesh.bounds().max.z < castle.mesh.bounds().min.z));
        }
        let names = |seed| generate(100_000, seed).into_iter().map(|o| o.mesh.positions).collect::<Vec<_>>();
        assert_eq!(names(1), names(1));
        assert_ne!(names(1), names(2));
    }
}
