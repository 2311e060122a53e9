//! Where a person can stand in a scene, for walks (see [`crate::path_gen`]): a grid over the
//! ground plane whose cells hold one or more floors, so that a walk goes up stairs and through
//! the storeys of a building, through the rooms of a game level and between a plant's units.
//!
//! A floor is the height of an opaque surface facing up (or down: imported models are wound
//! either way) at a cell's centre, or the scene's lowest point, which every cell has (the ground
//! of a model without one). Floors closer than [`MERGE`] are one floor, the higher (a slab's top
//! over its bottom). A floor is blocked when an opaque triangle whose xz bounds cover the cell
//! (conservative) reaches into the slab from [`SLAB_LOW`] to [`SLAB_HIGH`] above it; it is
//! roofed when an opaque surface lies above that slab at the cell's centre. Translucent
//! surfaces (glass, a building's room volumes) neither carry nor block: a person walks through
//! a room's volume and looks through its windows.
//!
//! A walker steps between 4-neighbouring cells onto the floor nearest its own within [`CLIMB`]
//! (a stair's riser), and keeps a clearance from blocked floors, measured in cells over the
//! floors it could walk.

use crate::file::SceneFile;
use crate::format::NodeKind;
use crate::progress::Progress;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};

/// Eye height above a floor, and the slab [low, high] above it in which geometry blocks a
/// walker (below: kerbs and stair steps; above: doorways' lintels and overhead pipes).
pub const EYE: f32 = 1.7;
pub const SLAB_LOW: f32 = 0.4;
pub const SLAB_HIGH: f32 = 1.9;
/// Floors closer than this in one cell are one.
pub const MERGE: f32 = 0.5;
/// Most a walker climbs or descends from one cell to the next.
pub const CLIMB: f32 = 0.45;
/// A surface is a floor when its normal is within about 45 degrees of vertical.
const FLAT: f32 = 0.7;

/// A grid over the ground plane: `nx` by `nz` square cells from `min`.
pub struct Grid {
    pub min: Vec3,
    pub cell_size: f32,
    pub nx: usize,
    pub nz: usize,
}

/// Why [`Floors::of`] found no floors: a block of the scene that cannot be read, or a Ctrl-C.
#[derive(Debug, thiserror::Error)]
pub enum NavError {
    #[error(transparent)]
    Scene(#[from] crate::SceneError),
    #[error("stopped (Ctrl-C) before the walk was made")]
    Cancelled,
}

/// The floors of a scene on a grid. A floor is a node: `height[i]` in cell `cell[i]`.
pub struct Floors {
    pub grid: Grid,
    /// Per cell, its floors `start[c]..start[c + 1]`, lowest first.
    start: Vec<u32>,
    pub cell: Vec<u32>,
    pub height: Vec<f32>,
    pub blocked: Vec<bool>,
    pub roofed: Vec<bool>,
    /// Whether a surface of the scene carries the floor: false for a cell's lowest floor at
    /// the scene's lowest point where nothing lies (the ground the model stands on, when it
    /// has none of its own; under a model's own ground, nobody walks).
    pub surface: Vec<bool>,
}

impl Floors {
    /// The floors of `scene`'s full-detail opaque triangles, read twice (stages `floors` and
    /// `blocked` of `progress`, counted in leaves); an error names a bad block or a Ctrl-C.
    pub fn of(scene: &SceneFile, progress: &dyn Progress) -> Result<Floors, NavError> {
        let root = scene.node(scene.root()).aabb();
        // At most 4096 cells a side (16M cells); at least 0.2 m so a small scene is not over-resolved.
        let cell_size = (root.extent().x.max(root.extent().z) / 4096.0).max(0.2);
        let (nx, nz) = (((root.extent().x / cell_size) as usize + 1).max(1), ((root.extent().z / cell_size) as usize + 1).max(1));
        let grid = Grid { min: root.min, cell_size, nx, nz };
        let leaves: Vec<u32> = (0..scene.bvh_count()).filter(|&id| scene.node(id).kind() == NodeKind::Leaf).collect();
        progress.stage("floors", leaves.len() as u64);
        let mut found: Vec<(u32, f32)> = leaves_in_parallel(scene, &leaves, progress, |p, found: &mut Vec<(u32, f32)>| {
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            if n.y.abs() >= FLAT * n.length() {
                grid.for_each_centre_in(p, |c, h| found.push((c as u32, h)));
            }
        })?
        .concat();
        let mut f = Floors {
            grid,
            start: Vec::new(),
            cell: Vec::new(),
            height: Vec::new(),
            blocked: Vec::new(),
            roofed: Vec::new(),
            surface: Vec::new(),
        };
        found.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let mut next = found.iter().peekable();
        for c in 0..nx * nz {
            f.start.push(f.height.len() as u32);
            let first = f.height.len();
            f.cell.push(c as u32);
            f.height.push(root.min.y);
            f.surface.push(false);
            while let Some(&(_, h)) = next.next_if(|(k, _)| *k as usize == c) {
                if h - f.height[f.height.len() - 1] < MERGE {
                    *f.height.last_mut().expect("a floor") = h.max(f.height[f.height.len() - 1]);
                    *f.surface.last_mut().expect("a floor") = true;
                } else {
                    f.cell.push(c as u32);
                    f.height.push(h);
                    f.surface.push(true);
                }
            }
            debug_assert!(f.height.len() > first);
        }
        f.start.push(f.height.len() as u32);
        // Marked from every thread at once: a floor is blocked (roofed) when any triangle
        // blocks (roofs) it, whichever thread sees it first.
        let blocked: Vec<AtomicBool> = (0..f.height.len()).map(|_| AtomicBool::new(false)).collect();
        let roofed: Vec<AtomicBool> = (0..f.height.len()).map(|_| AtomicBool::new(false)).collect();
        let Floors { grid, start, height, .. } = &f;
        progress.stage("blocked", leaves.len() as u64);
        leaves_in_parallel(scene, &leaves, progress, |p, _: &mut ()| {
            let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
            let reaches = |i: usize, (y0, y1): (f32, f32)| y1 >= height[i] + SLAB_LOW && y0 <= height[i] + SLAB_HIGH;
            let cells = grid.cells_under(lo, hi);
            for (c, corner) in grid.each(cells) {
                let floors = start[c] as usize..start[c + 1] as usize;
                if !floors.clone().any(|i| !blocked[i].load(Ordering::Relaxed) && reaches(i, (lo.y, hi.y))) {
                    continue;
                }
                // A triangle over several cells, within each cell's column (a roof sloping over
                // a whole storey, or a rafter's side, blocks only where it comes down).
                let ys = match cells.is_one() {
                    true => (lo.y, hi.y),
                    // Within the triangle's own heights: a clipped corner may round past them.
                    false => match heights_in(p, corner, corner + grid.cell_size) {
                        Some((y0, y1)) => (y0.max(lo.y), y1.min(hi.y)),
                        None => continue,
                    },
                };
                for i in floors.filter(|&i| reaches(i, ys)) {
                    blocked[i].store(true, Ordering::Relaxed);
                }
            }
            if lo.y > root.min.y + SLAB_HIGH {
                grid.for_each_centre_in(p, |c, y| {
                    let floors = start[c] as usize..start[c + 1] as usize;
                    for (flag, &h) in roofed[floors.clone()].iter().zip(&height[floors]) {
                        if y > h + SLAB_HIGH {
                            flag.store(true, Ordering::Relaxed);
                        }
                    }
                });
            }
        })?;
        f.blocked = blocked.into_iter().map(AtomicBool::into_inner).collect();
        f.roofed = roofed.into_iter().map(AtomicBool::into_inner).collect();
        Ok(f)
    }

    pub fn len(&self) -> usize {
        self.height.len()
    }

    pub fn is_empty(&self) -> bool {
        self.height.is_empty()
    }

    /// Floors of cell `c`.
    pub fn floors_of(&self, c: usize) -> std::ops::Range<usize> {
        self.start[c] as usize..self.start[c + 1] as usize
    }

    /// Where a walker stands on floor `i`.
    pub fn point(&self, i: usize) -> Vec3 {
        let c = self.grid.centre(self.cell[i] as usize);
        Vec3::new(c.x, self.height[i], c.y)
    }

    /// The floor nearest `p` within CLIMB in the cell under it.
    pub fn floor_at(&self, p: Vec3) -> Option<usize> {
        let g = &self.grid;
        let (x, z) = ((p.x - g.min.x) / g.cell_size, (p.z - g.min.z) / g.cell_size);
        let inside = x >= 0.0 && z >= 0.0 && (x as usize) < g.nx && (z as usize) < g.nz;
        inside.then(|| self.nearest(z as usize * g.nx + x as usize, p.y)).flatten()
    }

    fn nearest(&self, c: usize, y: f32) -> Option<usize> {
        self.floors_of(c)
            .filter(|&i| (self.height[i] - y).abs() <= CLIMB)
            .min_by(|&a, &b| (self.height[a] - y).abs().total_cmp(&(self.height[b] - y).abs()))
    }

    /// The cells next to floor `i`'s, 4 (`diagonal` false) or 8 of them, each with the floor a
    /// walker steps onto from `i`, or None where there is none within CLIMB (a ledge).
    fn steps(&self, i: usize, diagonal: bool) -> impl Iterator<Item = Option<usize>> + '_ {
        let (c, nx, nz) = (self.cell[i] as usize, self.grid.nx, self.grid.nz);
        let (x, z) = ((c % nx) as i64, (c / nx) as i64);
        let around: &[(i64, i64)] = if diagonal {
            &[(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1)]
        } else {
            &[(-1, 0), (1, 0), (0, -1), (0, 1)]
        };
        around.iter().filter_map(move |&(dx, dz)| {
            let (x, z) = (x + dx, z + dz);
            let inside = x >= 0 && z >= 0 && (x as usize) < nx && (z as usize) < nz;
            inside.then(|| self.nearest(z as usize * nx + x as usize, self.height[i]))
        })
    }

    /// The floors a walker steps onto from floor `i` (4-neighbours).
    pub fn neighbours(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        self.steps(i, false).flatten()
    }

    /// Per floor, its distance in cells (8-neighbour steps over the floors) to the nearest
    /// blocked floor, up to `most` (more is `most + 1`). A ledge needs none: no step leads
    /// over it.
    pub fn clearance(&self, most: u32) -> Vec<u32> {
        let d0 = |blocked: &bool| if *blocked { 0 } else { most + 1 };
        let mut d: Vec<u32> = self.blocked.iter().map(d0).collect();
        let mut q: VecDeque<usize> = (0..self.len()).filter(|&i| self.blocked[i]).collect();
        while let Some(i) = q.pop_front() {
            if d[i] >= most {
                continue;
            }
            // Only to floors that step back onto this one: a floor buried in a stair's solid
            // keeps no clearance from the steps beside it.
            let back = |j: usize| self.nearest(self.cell[i] as usize, self.height[j]) == Some(i);
            for j in self.steps(i, true).flatten().filter(|&j| back(j)) {
                if d[j] > d[i] + 1 {
                    d[j] = d[i] + 1;
                    q.push_back(j);
                }
            }
        }
        d
    }
}

/// The cells `x0..=x1` by `z0..=z1` of a grid, as [`Grid::cells_under`] finds them.
#[derive(Clone, Copy)]
struct Cells {
    x0: usize,
    x1: usize,
    z0: usize,
    z1: usize,
}

impl Cells {
    fn is_one(&self) -> bool {
        self.x0 == self.x1 && self.z0 == self.z1
    }
}

impl Grid {
    /// The centre of cell `c`, in xz.
    pub fn centre(&self, c: usize) -> Vec2 {
        self.cell_min(c) + 0.5 * self.cell_size
    }

    /// The corner of cell `c` with the least x and z.
    pub fn cell_min(&self, c: usize) -> Vec2 {
        self.corner(c % self.nx, c / self.nx)
    }

    /// The corner with the least x and z of the cell in column `x`, row `z`.
    fn corner(&self, x: usize, z: usize) -> Vec2 {
        Vec2::new(self.min.x, self.min.z) + Vec2::new(x as f32, z as f32) * self.cell_size
    }

    /// The cells whose columns the box `lo..hi` overlaps or touches (in xz): a wall's face on
    /// the border of two cells blocks both.
    fn cells_under(&self, lo: Vec3, hi: Vec3) -> Cells {
        let eps = self.cell_size * 1e-3;
        let (lo, hi) = (lo - eps, hi + eps);
        let to = |v: f32, m: f32, n: usize| (((v - m) / self.cell_size).max(0.0) as usize).min(n - 1);
        let (x0, x1) = (to(lo.x, self.min.x, self.nx), to(hi.x, self.min.x, self.nx));
        let (z0, z1) = (to(lo.z, self.min.z, self.nz), to(hi.z, self.min.z, self.nz));
        Cells { x0, x1, z0, z1 }
    }

    /// Each of `cells` as (cell, its corner with the least x and z), found without dividing
    /// by the grid's width: a walk visits the cells of every triangle of the scene, up to
    /// twice.
    fn each(&self, cells: Cells) -> impl Iterator<Item = (usize, Vec2)> + '_ {
        (cells.z0..=cells.z1).flat_map(move |z| (cells.x0..=cells.x1).map(move |x| (z * self.nx + x, self.corner(x, z))))
    }

    /// Calls `f(cell, height)` for every cell whose centre lies in triangle `p` seen from
    /// above, with the triangle's height there.
    fn for_each_centre_in(&self, p: [Vec3; 3], mut f: impl FnMut(usize, f32)) {
        let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
        let q = p.map(|v| Vec2::new(v.x, v.z));
        let area = (q[1] - q[0]).perp_dot(q[2] - q[0]);
        if area == 0.0 {
            return;
        }
        for (c, corner) in self.each(self.cells_under(lo, hi)) {
            let centre = corner + 0.5 * self.cell_size;
            // Barycentric coordinates of the centre.
            let w1 = (centre - q[0]).perp_dot(q[2] - q[0]) / area;
            let w2 = (q[1] - q[0]).perp_dot(centre - q[0]) / area;
            let w0 = 1.0 - w1 - w2;
            if w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 {
                f(c, w0 * p[0].y + w1 * p[1].y + w2 * p[2].y);
            }
        }
    }
}

/// The heights of triangle `p` within the column over the xz rectangle `lo..hi` (None when it
/// misses it): the triangle clipped to the column (Sutherland-Hodgman).
fn heights_in(p: [Vec3; 3], lo: Vec2, hi: Vec2) -> Option<(f32, f32)> {
    // On the stack, as this runs for every cell a large triangle covers. A triangle clipped by
    // four planes keeps at most seven corners; each plane at most doubles them whatever
    // rounding does (3 * 2^4).
    let (mut poly, mut n) = ([Vec3::ZERO; 48], 3);
    poly[..3].copy_from_slice(&p);
    let mut next = [Vec3::ZERO; 48];
    // Each side of the column as (axis, bound, keep the side above it).
    for (axis, bound, above) in [(0, lo.x, true), (0, hi.x, false), (2, lo.y, true), (2, hi.y, false)] {
        let inside = |v: &Vec3| if above { v[axis] >= bound } else { v[axis] <= bound };
        let mut m = 0;
        for k in 0..n {
            let (a, b) = (poly[k], poly[(k + 1) % n]);
            if inside(&a) {
                next[m] = a;
                m += 1;
            }
            if inside(&a) != inside(&b) {
                next[m] = a.lerp(b, (bound - a[axis]) / (b[axis] - a[axis]));
                m += 1;
            }
        }
        (poly, n) = (next, m);
        if n == 0 {
            return None;
        }
    }
    Some(poly[..n].iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), v| (l.min(v.y), h.max(v.y))))
}

/// Calls `f` with the corners of every opaque triangle of `leaves` at full detail, the leaves
/// spread over threads (a billion triangles are read twice to find floors): the calls on one
/// run of leaves share one `T`, and the `T`s come back in the leaves' order.
fn leaves_in_parallel<T: Default + Send>(
    scene: &SceneFile,
    leaves: &[u32],
    progress: &dyn Progress,
    f: impl Fn([Vec3; 3], &mut T) + Sync,
) -> Result<Vec<T>, NavError> {
    leaves
        .par_iter()
        .try_fold(T::default, |mut acc, &id| {
            progress.advance(1);
            if progress.cancelled() {
                return Err(NavError::Cancelled);
            }
            let lod = scene.node(id).first_lod;
            let g = scene.stored_geometry(lod)?;
            // Only an instance's corners are placed: its clusters' cuts and opacity are its
            // mesh's, and a floor is found whichever way it is wound (placing the clusters too
            // was a fifth of the walk's time on the 1B instanced plant).
            let placed = scene.placement(lod).map(|p| p.points(&g.positions));
            let positions = placed.as_deref().unwrap_or(&g.positions);
            // A cut node also holds simplified groups: only the original triangles count.
            let original = (0..g.opaque).filter(|&k| g.cut(k).lo.error == 0.0);
            for c in original.map(|k| &g.clusters[k]) {
                for t in (c.first_index..c.first_index + c.index_count).step_by(3) {
                    f([0, 1, 2].map(|k| Vec3::from_array(positions[g.indices.get(t as usize + k) as usize])), &mut acc);
                }
            }
            Ok(acc)
        })
        .collect()
}
