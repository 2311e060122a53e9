//! Camera paths through a built scene: `walk` at eye height through free space (stays out of
//! walls), `orbit` around the scene looking at its centre, `flyover` above it looking ahead and
//! down. Deterministic for a seed.
//!
//! Walk: at eye height over the scene's floors ([`crate::nav`]), keeping a clearance from
//! blocked floors; the walk chains cheapest paths (dearer near obstacles) between random
//! floors of one connected region (inside, see `walk_region`, from a floor under its roof),
//! resampled to a constant speed and smoothed where smoothing stays over free floors. It
//! climbs stairs, goes through doorways and storeys, and through translucent room volumes.

use crate::camera::Camera;
use crate::file::SceneFile;
use crate::nav::{EYE, Floors};
use glam::{DVec3, Vec3};
use rand::RngExt;
use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};

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

/// Closest a walking camera comes to blocking geometry (in cells of the floor grid, at least
/// this): a doorway of 0.9 m lets a walker through.
pub const CLEARANCE: f32 = 0.2;

/// Why no path could be made.
#[derive(Debug, thiserror::Error)]
pub enum PathGenError {
    #[error("a path needs at least one frame")]
    NoFrames,
    #[error("no free space to walk in at eye height ({floors} floors in {cells} cells of {cell_size} m, all blocked or too narrow)")]
    NowhereToWalk { floors: usize, cells: usize, cell_size: f32 },
    #[error(transparent)]
    Floors(#[from] crate::nav::NavError),
    #[error(transparent)]
    Camera(#[from] crate::camera::CameraError),
}

/// Makes a path through `scene`.
pub fn generate(scene: &SceneFile, o: &PathOptions, progress: &dyn crate::progress::Progress) -> Result<Vec<Camera>, PathGenError> {
    if o.frames == 0 {
        return Err(PathGenError::NoFrames);
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
        PathKind::Walk => walk(scene, o, progress)?,
    };
    Ok(cams.into_iter().map(Camera::validated).collect::<Result<_, _>>()?)
}

/// Cheapest paths from floor `from` over free floors; returns parent links (u32::MAX =
/// unreached). A step onto a floor closer than `roomy` cells to a blocked one costs up to four
/// times a step in the open, so that a walk keeps to the middle of streets, aisles and rooms
/// (shortest grid paths hug the obstacles) and still goes through a doorway.
fn paths_from(floors: &Floors, free: &[bool], clearance: &[u32], roomy: u32, from: usize) -> Vec<u32> {
    let cost = |j: usize| 16 + 48 * (roomy - clearance[j].min(roomy)) / roomy.max(1);
    let mut parent = vec![u32::MAX; free.len()];
    let mut best = vec![u32::MAX; free.len()];
    parent[from] = from as u32;
    best[from] = 0;
    let mut heap = BinaryHeap::from([Reverse((0u32, from))]);
    while let Some(Reverse((c, i))) = heap.pop() {
        if c > best[i] {
            continue;
        }
        for j in floors.neighbours(i).filter(|&j| free[j]) {
            let cj = c + cost(j);
            if cj < best[j] {
                (best[j], parent[j]) = (cj, i as u32);
                heap.push(Reverse((cj, j)));
            }
        }
    }
    parent
}

/// The floors of the region of connected `free` floors to walk in, in index order: the lowest
/// region mostly under a roof (inside a building or a level rather than around it: its ground
/// floor, where a person comes in) of at least an eighth of the largest region (not the gap
/// under an overhang), else the largest; and whether it is the region under a roof. When the
/// largest region stands on the floor every cell has at the scene's lowest point, the regions
/// on the scene's surfaces are chosen from, where one is as large as a room: a model with
/// ground of its own (a circuit's terrain, a level's floors) is walked on it, not under it.
fn walk_region(floors: &Floors, free: &[bool]) -> (Vec<usize>, bool) {
    let mut region = vec![u32::MAX; free.len()];
    let mut regions = Vec::new();
    for s in 0..free.len() {
        if !free[s] || region[s] != u32::MAX {
            continue;
        }
        region[s] = s as u32;
        let mut r = Region { first: s, size: 0, roofed: 0, surface: 0, low: f32::INFINITY };
        let mut q = VecDeque::from([s]);
        while let Some(i) = q.pop_front() {
            r.size += 1;
            r.roofed += usize::from(floors.roofed[i]);
            r.surface += usize::from(floors.surface[i]);
            r.low = r.low.min(floors.height[i]);
            for j in floors.neighbours(i) {
                if free[j] && region[j] == u32::MAX {
                    region[j] = s as u32;
                    q.push_back(j);
                }
            }
        }
        regions.push(r);
    }
    // Where the largest region stands on the lowest point rather than on surfaces, the regions
    // on surfaces at least as large as a room, if any.
    let on_surface = |r: &Region| r.surface * 2 >= r.size;
    let area = |r: &Region| r.size as f32 * floors.grid.cell_size * floors.grid.cell_size;
    let mut candidates: Vec<&Region> = regions.iter().collect();
    if regions.iter().max_by_key(|r| r.size).is_some_and(|r| !on_surface(r))
        && regions.iter().any(|r| on_surface(r) && area(r) >= ROOM_AREA)
    {
        candidates.retain(|r| on_surface(r) && area(r) >= ROOM_AREA);
    }
    let largest = candidates.iter().map(|r| r.size).max().unwrap_or(0);
    let inside = candidates.iter().filter(|r| r.size * 8 >= largest && r.roofed * 2 >= r.size).min_by(|a, b| a.low.total_cmp(&b.low));
    let Some(chosen) = inside.or_else(|| candidates.iter().max_by_key(|r| r.size)) else { return (Vec::new(), false) };
    ((0..free.len()).filter(|&i| region[i] as usize == chosen.first).collect(), inside.is_some())
}

/// A region of connected free floors: its first floor, how many floors it has, how many of
/// them are roofed and carried by a surface, and its lowest height.
struct Region {
    first: usize,
    size: usize,
    roofed: usize,
    surface: usize,
    low: f32,
}

/// Smallest area (m²) of connected surfaces that a walk prefers to the scene's lowest point:
/// a room's (a table top is not ground).
const ROOM_AREA: f32 = 100.0;

/// Clearance below which a step costs more (see `paths_from`).
const ROOMY: f32 = 2.0;

fn walk(scene: &SceneFile, o: &PathOptions, progress: &dyn crate::progress::Progress) -> Result<Vec<Camera>, PathGenError> {
    let floors = Floors::of(scene, progress)?;
    let cells = |c: f32| (c / floors.grid.cell_size).ceil() as u32;
    let clearance = floors.clearance(cells(ROOMY));
    let free: Vec<bool> = clearance.iter().map(|&d| d > cells(CLEARANCE)).collect();
    let (region, inside) = walk_region(&floors, &free);
    if region.len() < 2 {
        return Err(PathGenError::NowhereToWalk {
            floors: floors.len(),
            cells: floors.grid.nx * floors.grid.nz,
            cell_size: floors.grid.cell_size,
        });
    }
    let mut rng = crate::generators::rng(o.seed, 0x9a7);
    // Inside (a region mostly under a roof), a walk starts under the roof, where a person comes
    // in: a building's ground floors reach out of its doors onto the ground around it. Any
    // other region starts anywhere: a forest's canopies roof some of its ground, and a walk
    // begun under one at the forest's edge looks out of it.
    let roofed: Vec<usize> = if inside { region.iter().copied().filter(|&i| floors.roofed[i]).collect() } else { Vec::new() };
    let starts = if roofed.is_empty() { &region } else { &roofed };
    let mut at = starts[rng.random_range(0..starts.len())];
    let mut route = vec![floors.point(at)];
    let need = o.speed * (o.frames as f64 + 64.0);
    let mut length = 0.0f64;
    for _ in 0..10_000 {
        if length >= need {
            break;
        }
        // The farthest of a few random goals: long legs, few turns.
        let parent = paths_from(&floors, &free, &clearance, cells(ROOMY), at);
        let goal = (0..8)
            .map(|_| region[rng.random_range(0..region.len())])
            .max_by(|&a, &b| floors.point(a).distance(floors.point(at)).total_cmp(&floors.point(b).distance(floors.point(at))))
            .expect("8 goals");
        let mut leg = vec![goal];
        while *leg.last().expect("non-empty") != at {
            leg.push(parent[*leg.last().expect("non-empty")] as usize);
        }
        for &c in leg.iter().rev().skip(1) {
            length += floors.point(c).distance(*route.last().expect("start")) as f64;
            route.push(floors.point(c));
        }
        at = goal;
    }
    // Resample to the walking speed, then smooth corners (and stairs) where the smoothed point
    // stays over a free floor.
    let samples = resample(&route, o.speed as f32, o.frames as usize + 32);
    let w = 12;
    let smooth: Vec<Vec3> = (0..samples.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(w), (i + w + 1).min(samples.len()));
            let avg = samples[a..b].iter().copied().sum::<Vec3>() / (b - a) as f32;
            match floors.floor_at(avg).filter(|&k| free[k]) {
                Some(k) => avg.with_y(floors.height[k]),
                None => samples[i],
            }
        })
        .collect();
    let eye = |p: Vec3| p + Vec3::Y * EYE;
    let origin = scene.origin();
    Ok((0..o.frames as usize)
        .map(|i| {
            let p = eye(smooth[i]);
            let ahead = eye(smooth[(i + 16).min(smooth.len() - 1)]);
            let dir =
                if ahead.distance(p) > 1e-3 { ahead - p } else { smooth[i.min(smooth.len() - 2) + 1] - smooth[i.min(smooth.len() - 2)] };
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
