//! Camera paths through a built scene: `walk` at eye height through free space (stays out of
//! walls), `orbit` around the scene looking at its centre, `flyover` above it looking ahead and
//! down. Deterministic for a seed.
//!
//! Walk: the full-detail triangles that cross the eye-height slab are rasterised into a grid
//! over the ground plane (conservatively, by their xz bounds); blocked cells are dilated by the
//! clearance; the walk chains shortest grid paths between random cells of the largest free
//! region, resampled to a constant speed and smoothed where smoothing stays in free cells.

use crate::camera::Camera;
use crate::file::{SceneError, SceneFile};
use crate::format::NodeKind;
use glam::{DVec3, Vec3};
use rand::RngExt;
use std::collections::VecDeque;

/// Kinds of path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PathKind {
    Walk,
    Orbit,
    Flyover,
}

impl std::str::FromStr for PathKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "walk" => Ok(PathKind::Walk),
            "orbit" => Ok(PathKind::Orbit),
            "flyover" => Ok(PathKind::Flyover),
            _ => Err(format!("unknown path kind {s:?}: expected walk, orbit or flyover")),
        }
    }
}

/// Settings of a path.
#[derive(Clone, Debug)]
pub struct PathOptions {
    pub kind: PathKind,
    pub frames: u32,
    pub seed: u64,
    pub fovy_deg: f64,
    /// Walk speed, world units per frame.
    pub speed: f64,
}

impl Default for PathOptions {
    fn default() -> Self {
        PathOptions { kind: PathKind::Walk, frames: 300, seed: 1, fovy_deg: 60.0, speed: 0.25 }
    }
}

/// Eye height above the lowest point of the scene, and the slab [low, high] above it in which
/// geometry blocks a walker (below: kerbs and floor slabs; above: overhead pipes).
const EYE: f32 = 1.7;
const SLAB_LOW: f32 = 0.4;
const SLAB_HIGH: f32 = 2.4;
/// Closest a walking camera comes to blocking geometry.
pub const CLEARANCE: f32 = 0.6;

/// Makes a path through `scene`.
pub fn generate(scene: &SceneFile, o: &PathOptions) -> Result<Vec<Camera>, String> {
    if o.frames == 0 {
        return Err("a path needs at least one frame".into());
    }
    let root = scene.node(scene.root()).aabb();
    let (c, e) = (root.center().as_dvec3(), root.extent().as_dvec3());
    let diag = e.length().max(1e-6);
    let origin = scene.origin();
    let n = o.frames as usize;
    let cams: Vec<Camera> = match o.kind {
        PathKind::Orbit => (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                let r = 0.5 * e.x.max(e.z) + 0.4 * diag;
                let eye = c + DVec3::new(r * a.cos(), 0.35 * diag, r * a.sin());
                Camera::look_along(origin + eye, c - eye, o.fovy_deg)
            })
            .collect(),
        PathKind::Flyover => (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                let at = |a: f64| c + DVec3::new(0.35 * e.x * a.cos(), 0.5 * e.y + 0.08 * diag, 0.35 * e.z * (2.0 * a).sin());
                let (eye, ahead) = (at(a), at(a + 0.05));
                let target = ahead + (ahead - eye).normalize_or(DVec3::X) * 0.1 * diag - DVec3::Y * 0.06 * diag;
                Camera::look_along(origin + eye, target - eye, o.fovy_deg)
            })
            .collect(),
        PathKind::Walk => walk(scene, o)?,
    };
    cams.into_iter().map(Camera::validated).collect()
}

/// A grid over the scene's ground plane.
struct Grid {
    min: Vec3,
    cell: f32,
    nx: usize,
    nz: usize,
    blocked: Vec<bool>,
}

impl Grid {
    fn index(&self, p: Vec3) -> Option<usize> {
        let (x, z) = ((p.x - self.min.x) / self.cell, (p.z - self.min.z) / self.cell);
        (x >= 0.0 && z >= 0.0 && (x as usize) < self.nx && (z as usize) < self.nz).then(|| z as usize * self.nx + x as usize)
    }

    fn center(&self, i: usize) -> Vec3 {
        self.min + Vec3::new(((i % self.nx) as f32 + 0.5) * self.cell, 0.0, ((i / self.nx) as f32 + 0.5) * self.cell)
    }

    fn neighbours(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        let (x, z) = (i % self.nx, i / self.nx);
        [(x > 0).then(|| i - 1), (x + 1 < self.nx).then(|| i + 1), (z > 0).then(|| i - self.nx), (z + 1 < self.nz).then(|| i + self.nx)]
            .into_iter()
            .flatten()
    }
}

/// Rasterises blocking geometry at eye height into a grid.
fn blocked_grid(scene: &SceneFile) -> Result<(Grid, f32), SceneError> {
    let root = scene.node(scene.root()).aabb();
    let floor = root.min.y;
    // At most 4096 cells a side (16M cells); at least 0.2 m so a small scene is not over-resolved.
    let cell = (root.extent().x.max(root.extent().z) / 4096.0).max(0.2);
    let (nx, nz) = (((root.extent().x / cell) as usize + 1).max(1), ((root.extent().z / cell) as usize + 1).max(1));
    let mut g = Grid { min: root.min, cell, nx, nz, blocked: vec![false; nx * nz] };
    let (lo, hi) = (floor + SLAB_LOW, floor + SLAB_HIGH);
    for id in 0..scene.bvh_count() {
        let n = scene.node(id);
        if n.kind() != NodeKind::Leaf || n.bbox_max[1] < lo || n.bbox_min[1] > hi {
            continue;
        }
        let geo = scene.geometry(n.first_lod)?;
        for t in 0..geo.indices.len() / 3 {
            let p = [0, 1, 2].map(|k| Vec3::from_array(geo.positions[geo.indices.get(t * 3 + k) as usize]));
            let (tmin, tmax) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
            if tmax.y < lo || tmin.y > hi {
                continue;
            }
            let to = |v: f32, m: f32, n: usize| (((v - m) / cell) as usize).min(n - 1);
            for z in to(tmin.z, g.min.z, nz)..=to(tmax.z, g.min.z, nz) {
                for x in to(tmin.x, g.min.x, nx)..=to(tmax.x, g.min.x, nx) {
                    g.blocked[z * nx + x] = true;
                }
            }
        }
    }
    Ok((g, floor))
}

/// Cells within `r` cells of a blocked cell (a square neighbourhood: conservative).
fn dilated(g: &Grid, r: usize) -> Vec<bool> {
    let mut rows = vec![false; g.blocked.len()];
    for z in 0..g.nz {
        for x in 0..g.nx {
            if g.blocked[z * g.nx + x] {
                for xx in x.saturating_sub(r)..(x + r + 1).min(g.nx) {
                    rows[z * g.nx + xx] = true;
                }
            }
        }
    }
    let mut out = vec![false; g.blocked.len()];
    for z in 0..g.nz {
        for x in 0..g.nx {
            if rows[z * g.nx + x] {
                for zz in z.saturating_sub(r)..(z + r + 1).min(g.nz) {
                    out[zz * g.nx + x] = true;
                }
            }
        }
    }
    out
}

/// Breadth-first search from `from` over free cells; returns parent links (u32::MAX = unreached).
fn bfs(g: &Grid, free: &[bool], from: usize) -> Vec<u32> {
    let mut parent = vec![u32::MAX; free.len()];
    parent[from] = from as u32;
    let mut q = VecDeque::from([from]);
    while let Some(i) = q.pop_front() {
        for j in g.neighbours(i) {
            if free[j] && parent[j] == u32::MAX {
                parent[j] = i as u32;
                q.push_back(j);
            }
        }
    }
    parent
}

/// The cells of the largest 4-connected region of `free` cells, in index order.
fn largest_region(grid: &Grid, free: &[bool]) -> Vec<usize> {
    let mut region = vec![u32::MAX; free.len()];
    let mut best = (0usize, usize::MAX);
    for s in 0..free.len() {
        if !free[s] || region[s] != u32::MAX {
            continue;
        }
        region[s] = s as u32;
        let (mut q, mut size) = (VecDeque::from([s]), 0);
        while let Some(i) = q.pop_front() {
            size += 1;
            for j in grid.neighbours(i) {
                if free[j] && region[j] == u32::MAX {
                    region[j] = s as u32;
                    q.push_back(j);
                }
            }
        }
        if size > best.0 {
            best = (size, s);
        }
    }
    (0..free.len()).filter(|&i| region[i] as usize == best.1).collect()
}

/// Clearances tried before CLEARANCE, widest first: a walk keeps to the middle of streets and
/// aisles when they are wide enough, instead of brushing the walls (shortest grid paths hug
/// the obstacles).
const ROOMY: [f32; 2] = [2.0, 1.2];

fn walk(scene: &SceneFile, o: &PathOptions) -> Result<Vec<Camera>, String> {
    let (grid, floor) = blocked_grid(scene).map_err(|e| e.to_string())?;
    let free_at = |c: f32| -> Vec<bool> { dilated(&grid, (c / grid.cell).ceil() as usize).iter().map(|b| !b).collect() };
    let mut free = free_at(CLEARANCE);
    let mut cells = largest_region(&grid, &free);
    if cells.len() < 2 {
        return Err(format!("no free space to walk in at eye height ({} cells of {} m, all blocked)", free.len(), grid.cell));
    }
    // A wider clearance is used when its largest region still covers half the area the
    // minimum clearance leaves (a narrow margin around a scene must not win over its inside).
    for c in ROOMY {
        let f = free_at(c);
        let r = largest_region(&grid, &f);
        if r.len() * 2 >= cells.len() {
            (free, cells) = (f, r);
            break;
        }
    }
    let mut rng = crate::generators::rng(o.seed, 0x9a7);
    let mut at = cells[rng.random_range(0..cells.len())];
    let mut route = vec![grid.center(at)];
    let need = o.speed * (o.frames as f64 + 64.0);
    let mut length = 0.0f64;
    for _ in 0..10_000 {
        if length >= need {
            break;
        }
        // The farthest of a few random goals: long legs, few turns.
        let parent = bfs(&grid, &free, at);
        let goal = (0..8)
            .map(|_| cells[rng.random_range(0..cells.len())])
            .max_by(|&a, &b| grid.center(a).distance(grid.center(at)).total_cmp(&grid.center(b).distance(grid.center(at))))
            .expect("8 goals");
        let mut leg = vec![goal];
        while *leg.last().expect("non-empty") != at {
            leg.push(parent[*leg.last().expect("non-empty")] as usize);
        }
        for &c in leg.iter().rev().skip(1) {
            length += grid.center(c).distance(*route.last().expect("start")) as f64;
            route.push(grid.center(c));
        }
        at = goal;
    }
    // Resample to the walking speed, then smooth corners where the smoothed point stays free.
    let samples = resample(&route, o.speed as f32, o.frames as usize + 32);
    let w = 12;
    let smooth: Vec<Vec3> = (0..samples.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(w), (i + w + 1).min(samples.len()));
            let avg = samples[a..b].iter().copied().sum::<Vec3>() / (b - a) as f32;
            if grid.index(avg).is_some_and(|k| free[k]) { avg } else { samples[i] }
        })
        .collect();
    let eye_y = floor + EYE;
    let origin = scene.origin();
    Ok((0..o.frames as usize)
        .map(|i| {
            let p = smooth[i].with_y(eye_y);
            let ahead = smooth[(i + 16).min(smooth.len() - 1)].with_y(eye_y);
            let dir = if ahead.distance(p) > 1e-3 {
                ahead - p
            } else {
                smooth[i.min(smooth.len() - 2) + 1].with_y(eye_y) - smooth[i.min(smooth.len() - 2)].with_y(eye_y)
            };
            Camera::look_along(origin + p.as_dvec3(), dir.as_dvec3().normalize_or(DVec3::X), o.fovy_deg)
        })
        .collect())
}

/// Points every `step` along the polyline `route`, `count` of them (the last point repeats if
/// the route is short).
fn resample(route: &[Vec3], step: f32, count: usize) -> Vec<Vec3> {
    let mut out = Vec::with_capacity(count);
    let (mut seg, mut t) = (0usize, 0.0f32);
    while out.len() < count {
        if seg + 1 >= route.len() {
            out.push(*route.last().expect("non-empty route"));
            continue;
        }
        let (a, b) = (route[seg], route[seg + 1]);
        let len = a.distance(b);
        if t <= len {
            out.push(a + (b - a) * (t / len.max(1e-9)));
            t += step;
        } else {
            t -= len;
            seg += 1;
        }
    }
    out
}
