//! Yoon 2003's second environment (sec. 6.2, fig. 6): an isosurface, one object of millions of
//! triangles with a high depth complexity (that paper's came from a turbulence simulation).
//! Here the zero set of a few octaves of seeded gradient noise in a cube: a sponge of tunnels
//! and blobs, layer behind layer from any side. It is extracted by surface nets (one vertex per
//! grid cell the surface crosses, at the mean of its edge crossings; one quad per grid edge the
//! surface crosses, joining the four cells around it), and the field is outside on the cube's
//! faces, so the surface is closed and every triangle faces out of the solid.

use super::rng;
use crate::mesh::{Mesh, Object};
use glam::DVec3;
use rand::RngExt;

/// The cube's side (m); it stands on the ground, centred on the origin in x and z.
const SIDE: f64 = 64.0;
/// Features across the cube in the first octave, and octaves, each twice as fine at half the
/// amplitude.
const FREQUENCY: f64 = 4.0;
const OCTAVES: u32 = 3;
/// Grid cells a side of the coarse extraction that sizes the real one.
const PROBE: usize = 64;

pub fn generate(triangles: u64, seed: u64) -> Vec<Object> {
    let noise = Noise::new(seed);
    // Surface nets make triangles in proportion to the surface's area in cells: the square of
    // the grid's resolution, once it resolves the finest octave: sized from a coarse grid,
    // then once more from the first try.
    let resize =
        |cells: usize, made: usize| (cells as f64 * (triangles as f64 / made.max(1) as f64).sqrt()).round().clamp(8.0, 4096.0) as usize;
    let cells = resize(PROBE, surface_nets(&noise, PROBE).triangle_count());
    let mut mesh = surface_nets(&noise, cells);
    if (mesh.triangle_count() as f64 / triangles as f64 - 1.0).abs() > 0.1 {
        mesh = surface_nets(&noise, resize(cells, mesh.triangle_count()));
    }
    vec![Object::new("isosurface", without_cavities(mesh))]
}

/// `mesh` less its cavities: a pocket of outside enclosed by the solid is a part wound inwards
/// (negative volume). Nothing outside the solid sees it, and without it every part is closed
/// and wound outwards, which the build checks before it lets back faces be culled
/// (crate::cluster::Parts).
fn without_cavities(mut mesh: Mesh) -> Mesh {
    let parts = crate::cluster::Parts::of(&mesh);
    let mut kept = Vec::with_capacity(mesh.indices.len());
    kept.extend(mesh.indices.chunks_exact(3).filter(|t| parts.closed_box(t).is_some()).flatten());
    mesh.indices = kept;
    mesh
}

/// The field at `p` in the unit cube: negative inside the solid.
fn field(noise: &Noise, p: DVec3) -> f64 {
    let (mut sum, mut amplitude, mut frequency) = (0.0, 1.0, FREQUENCY);
    for _ in 0..OCTAVES {
        sum += amplitude * noise.at(p * frequency);
        (amplitude, frequency) = (amplitude * 0.5, frequency * 2.0);
    }
    sum
}

/// The field's zero set on a grid of `n` cells a side, the grid's outer points set outside.
fn surface_nets(noise: &Noise, n: usize) -> Mesh {
    let side = n + 1;
    let point = |i: usize, j: usize, k: usize| DVec3::new(i as f64, j as f64, k as f64) / n as f64;
    let slice = |k: usize| -> Vec<f64> {
        let mut s = Vec::with_capacity(side * side);
        for j in 0..side {
            for i in 0..side {
                let outer = [i, j, k].iter().any(|&c| c == 0 || c == n);
                s.push(if outer { 1.0 } else { field(noise, point(i, j, k)) });
            }
        }
        s
    };
    let mut mesh = Mesh::default();
    // Field slices k and k + 1; the vertex of each cell of layers k - 1 and k (u32::MAX: none).
    let (mut below, mut above) = (slice(0), slice(1));
    let (mut previous, mut layer) = (vec![u32::MAX; n * n], vec![u32::MAX; n * n]);
    for k in 0..n {
        if k > 0 {
            below = std::mem::replace(&mut above, slice(k + 1));
            std::mem::swap(&mut previous, &mut layer);
        }
        let value = |i: usize, j: usize, dz: usize| if dz == 0 { below[j * side + i] } else { above[j * side + i] };
        for j in 0..n {
            for i in 0..n {
                layer[j * n + i] = cell_vertex(&mut mesh, [i, j, k], n, &|di, dj, dk| value(i + di, j + dj, dk));
            }
        }
        // Quads around the edges whose four cells now have their vertices: along z in layer
        // k, along x and y in the plane of slice k (cells of layers k - 1 and k). The cells
        // around an edge are g - a e_u - b e_v (u, v the next axes after the edge's, cyclic);
        // in the order (0,0), (1,0), (1,1), (0,1) the quad's normal is +e_edge, kept when the
        // field rises along the edge (the outside is ahead) and reversed otherwise.
        let cell = |i: usize, j: usize, dk: usize| if dk == 0 { layer[j * n + i] } else { previous[j * n + i] };
        for j in 1..n {
            for i in 1..n {
                let around = [cell(i, j, 0), cell(i - 1, j, 0), cell(i - 1, j - 1, 0), cell(i, j - 1, 0)];
                quad(&mut mesh, around, value(i, j, 0), value(i, j, 1));
            }
        }
        if k == 0 {
            continue;
        }
        for j in 1..n {
            for i in 0..n {
                // Along x: u = y, v = z.
                let around = [cell(i, j, 0), cell(i, j - 1, 0), cell(i, j - 1, 1), cell(i, j, 1)];
                quad(&mut mesh, around, value(i, j, 0), value(i + 1, j, 0));
            }
        }
        for j in 0..n {
            for i in 1..n {
                // Along y: u = z, v = x.
                let around = [cell(i, j, 0), cell(i, j, 1), cell(i - 1, j, 1), cell(i - 1, j, 0)];
                quad(&mut mesh, around, value(i, j, 0), value(i, j + 1, 0));
            }
        }
    }
    mesh
}

/// The vertex of cell `c` (its minimum corner) if the surface crosses it: the mean of the
/// crossings on its 12 edges, `value(di, dj, dk)` the field at its corners.
fn cell_vertex(mesh: &mut Mesh, c: [usize; 3], n: usize, value: &dyn Fn(usize, usize, usize) -> f64) -> u32 {
    let corner = |k: usize| [k & 1, (k >> 1) & 1, k >> 2];
    let (mut sum, mut crossings) = (DVec3::ZERO, 0);
    for a in 0..8 {
        for axis in 0..3 {
            let ca = corner(a);
            if ca[axis] == 1 {
                continue;
            }
            let mut cb = ca;
            cb[axis] = 1;
            let (fa, fb) = (value(ca[0], ca[1], ca[2]), value(cb[0], cb[1], cb[2]));
            if (fa < 0.0) != (fb < 0.0) {
                let t = fa / (fa - fb);
                let pa = DVec3::new(ca[0] as f64, ca[1] as f64, ca[2] as f64);
                sum += pa + DVec3::from(std::array::from_fn(|k| if k == axis { t } else { 0.0 }));
                crossings += 1;
            }
        }
    }
    if crossings == 0 {
        return u32::MAX;
    }
    let unit = (DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) + sum / crossings as f64) / n as f64;
    let p = DVec3::new((unit.x - 0.5) * SIDE, unit.y * SIDE, (unit.z - 0.5) * SIDE);
    mesh.positions.push(p.as_vec3().to_array());
    mesh.positions.len() as u32 - 1
}

/// Two triangles joining the cells `around` an edge whose field goes from `from` to `to`, if
/// the surface crosses it (see [`surface_nets`] for the order).
fn quad(mesh: &mut Mesh, around: [u32; 4], from: f64, to: f64) {
    if (from < 0.0) == (to < 0.0) {
        return;
    }
    let [a, b, c, d] = if from < 0.0 { around } else { [around[0], around[3], around[2], around[1]] };
    mesh.indices.extend([a, b, c, a, c, d]);
}

/// Gradient noise (Perlin's improved noise) over a permutation of 0..256 made from the seed.
struct Noise {
    perm: [u8; 512],
}

impl Noise {
    fn new(seed: u64) -> Noise {
        let mut r = rng(seed, 4);
        let mut p: [u8; 256] = std::array::from_fn(|k| k as u8);
        for k in (1..256).rev() {
            p.swap(k, r.random_range(0..=k));
        }
        Noise { perm: std::array::from_fn(|k| p[k & 255]) }
    }

    fn at(&self, p: DVec3) -> f64 {
        let cell = p.floor();
        let [x, y, z] = (p - cell).to_array();
        let [i, j, k] = cell.to_array().map(|c| (c as i64 & 255) as usize);
        let h = |di: usize, dj: usize, dk: usize| self.perm[self.perm[self.perm[i + di] as usize + j + dj] as usize + k + dk];
        let g = |di: usize, dj: usize, dk: usize| grad(h(di, dj, dk), x - di as f64, y - dj as f64, z - dk as f64);
        let (u, v, w) = (fade(x), fade(y), fade(z));
        let lerp = |t: f64, a: f64, b: f64| a + t * (b - a);
        lerp(
            w,
            lerp(v, lerp(u, g(0, 0, 0), g(1, 0, 0)), lerp(u, g(0, 1, 0), g(1, 1, 0))),
            lerp(v, lerp(u, g(0, 0, 1), g(1, 0, 1)), lerp(u, g(0, 1, 1), g(1, 1, 1))),
        )
    }
}

fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// The dot product of (x, y, z) with one of 12 edge directions of a cube, picked by `h`.
fn grad(h: u8, x: f64, y: f64, z: f64) -> f64 {
    let h = h & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    #[test]
    fn the_surface_is_closed_and_faces_out_of_the_solid() {
        let m = surface_nets(&Noise::new(3), 64);
        assert!(m.triangle_count() > 1000, "{}", m.triangle_count());
        // Closed and consistently wound: every directed edge is matched by its reverse (twice
        // each where four quads meet at a saddle of the field).
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for t in m.indices.chunks_exact(3) {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *edges.entry((a, b)).or_default() += 1;
            }
        }
        for (&(a, b), &count) in &edges {
            assert_eq!(edges.get(&(b, a)), Some(&count), "edge {a}-{b}");
        }
        // Facing out of the solid: the volume the triangles enclose (each with the origin, signed
        // by its winding) is positive, and it is the solid's, as the grid's points inside count it.
        let volume: f64 = m
            .indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|k| DVec3::from(m.positions[k as usize].map(f64::from)));
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        let (noise, n) = (Noise::new(3), 96);
        let inside = (1..n)
            .flat_map(|k| (1..n).flat_map(move |j| (1..n).map(move |i| (i, j, k))))
            .filter(|&(i, j, k)| field(&noise, DVec3::new(i as f64, j as f64, k as f64) / n as f64) < 0.0);
        let grid = inside.count() as f64 / (n as f64).powi(3) * SIDE.powi(3);
        assert!((volume / grid - 1.0).abs() < 0.1, "enclosed {volume:.0} m³, the grid's points say {grid:.0}");
    }

    #[test]
    fn without_its_cavities_the_object_is_closed() {
        let m = generate(100_000, 1).remove(0).mesh;
        assert!(crate::cluster::Parts::of(&m).all_closed());
        // The cavities were there: the surface as extracted has parts wound inwards.
        assert!(!crate::cluster::Parts::of(&surface_nets(&Noise::new(1), 64)).all_closed());
    }

    #[test]
    fn the_budget_sizes_the_grid_and_the_seed_the_shape() {
        for budget in [20_000, 200_000] {
            let t = generate(budget, 1)[0].mesh.triangle_count() as f64;
            assert!((t / budget as f64 - 1.0).abs() < 0.2, "{t} triangles for {budget}");
        }
        let (a, b) = (generate(20_000, 1), generate(20_000, 2));
        assert_eq!(a[0].mesh.indices, generate(20_000, 1)[0].mesh.indices);
        assert_ne!(a[0].mesh.positions, b[0].mesh.positions);
    }
}
