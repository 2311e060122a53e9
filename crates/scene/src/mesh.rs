//! Indexed triangle meshes, and the clean-up every input goes through before the build.
//!
//! An input object's positions are f32 in its own frame, placed in the world by an f64 affine
//! transform (a glTF node's world matrix, a PLY or OBJ file's anchor, a generator's offset);
//! [`crate::place`] moves every object into scene-local f32 around one f64 origin, which the
//! scene file stores. Degenerate triangles
//! (two equal indices or zero area) are dropped and counted; non-finite positions and
//! out-of-range indices are errors, because guessing would change what the user sees.

use crate::aabb::Aabb;
use glam::Vec3;

/// An indexed triangle list: `indices.len()` is a multiple of 3, every index < `positions.len()`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<[f32; 3]>,
    pub indices: Vec<u32>,
    /// The model's colour per vertex, RGBA8 as displayed (sRGB), or empty when the model gives
    /// none. Alpha is 255 for an opaque colour, [`CUT_OUT`] for a cut-out's, 1 to 253 for a
    /// translucent one (its coverage, see [`alpha`]), and 0 for [`NO_COLOR`] (a vertex of a
    /// mesh merged with an uncoloured one), which is drawn opaque in the object's hashed colour.
    pub colors: Vec<[u8; 4]>,
    /// A unit normal per vertex, octahedral ([`crate::normal`]), or empty when the mesh has
    /// none; [`crate::normal::NO_NORMAL`] at a vertex of a mesh merged with one without.
    pub normals: Vec<crate::normal::Normal>,
    /// Per vertex, true where its surface is single-sided (glTF `doubleSided` false): never
    /// drawn from behind. Empty when every surface is double-sided (OBJ, PLY, generators). A
    /// triangle is single-sided when its three corners are ([`Mesh::is_single_sided`]).
    pub single_sided: Vec<bool>,
    /// Where each vertex samples its surface's texture, or empty when no surface has one;
    /// [`crate::texture::Texcoord::NONE`] at a vertex of a mesh merged with one without.
    pub texcoords: Vec<crate::texture::Texcoord>,
}

/// A vertex without a colour from the model, in a mesh whose other vertices have one.
pub const NO_COLOR: [u8; 4] = [0; 4];

/// The alpha byte of a cut-out (glTF alphaMode MASK): opaque where drawn, but holed where its
/// texture's alpha falls below the cutoff, which the display tests per pixel. It is never an
/// occluder (nothing it hides is known to be hidden).
pub const CUT_OUT: u8 = 254;

/// The alpha byte of a colour of coverage `a` (0 to 1): 255 when opaque, else 1 to 253, so that
/// a fully transparent surface stays a translucent one and never reads as [`NO_COLOR`], and a
/// nearly opaque one never as a [`CUT_OUT`].
pub fn alpha(a: f32) -> u8 {
    let a = (a.clamp(0.0, 1.0) * 255.0).round() as u8;
    if a == 255 { 255 } else { a.clamp(1, CUT_OUT - 1) }
}

/// How a triangle is drawn, by its corners' alphas: the first that one corner asks for, of
/// translucent, cut-out and opaque (a simplified level may join such a vertex to an opaque one).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Layer {
    /// Drawn and an occluder.
    Opaque,
    /// Drawn opaque, never an occluder ([`CUT_OUT`]).
    CutOut,
    /// Drawn blended after everything opaque, never an occluder.
    Translucent,
}

pub fn layer(colors: &[[u8; 4]], t: &[u32]) -> Layer {
    let corner = |v: &u32| match colors[*v as usize][3] {
        1..CUT_OUT => Layer::Translucent,
        CUT_OUT => Layer::CutOut,
        _ => Layer::Opaque,
    };
    if colors.is_empty() { Layer::Opaque } else { t.iter().map(corner).max().unwrap_or(Layer::Opaque) }
}

/// Whether a triangle with these vertex colours is translucent (see [`Layer`]).
pub fn is_translucent(colors: &[[u8; 4]], t: &[u32]) -> bool {
    layer(colors, t) == Layer::Translucent
}

/// One input object: a named mesh and where it stands in the world. Objects are what chunks are
/// cut from; each keeps its index so that renderers can colour by object.
#[derive(Clone, Debug, Default)]
pub struct Object {
    pub name: String,
    pub mesh: Mesh,
    /// Object frame → world, in f64: world coordinates of a real model (site coordinates of a
    /// plant or a city, 1e6-1e9 units out) do not fit f32, so they are composed and kept in
    /// f64 until the scene's origin is chosen. At the model's own scale: its whole units of
    /// translation are in `anchor`. The identity once placed.
    pub placement: glam::DAffine3,
    /// Whole units added after `placement`: world = anchor + placement · p. Kept apart so that
    /// nothing is composed at a large magnitude (see [`crate::place`]). Zero once placed.
    pub anchor: glam::DVec3,
    /// The input's mesh this object is a use of, where the input names one (a glTF mesh):
    /// objects of one prototype have the same mesh. A use after the first may come with an
    /// empty mesh (a generator's catalogue part): the build takes the one given first.
    pub prototype: Option<u32>,
}

impl Object {
    /// An object whose mesh is already in world coordinates.
    pub fn new(name: impl Into<String>, mesh: Mesh) -> Object {
        Object::placed(name, mesh, glam::DVec3::ZERO, glam::DAffine3::IDENTITY)
    }

    /// An object at `anchor + placement · p`; `anchor` whole units.
    pub fn placed(name: impl Into<String>, mesh: Mesh, anchor: glam::DVec3, placement: glam::DAffine3) -> Object {
        Object { name: name.into(), mesh, placement, anchor, prototype: None }
    }

    /// World position of vertex `p` of the mesh, in f64.
    pub fn world(&self, p: [f32; 3]) -> glam::DVec3 {
        self.anchor + self.placement.transform_point3(glam::Vec3::from_array(p).as_dvec3())
    }
}

/// What is wrong with a mesh that cannot be cleaned up without guessing.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    #[error("index count {0} is not a multiple of 3")]
    RaggedIndices(usize),
    #[error("index {index} at position {at} is out of range (the mesh has {vertices} vertices)")]
    IndexOutOfRange { at: usize, index: u32, vertices: usize },
    #[error("vertex {vertex} has a non-finite position {pos:?}")]
    NonFinite { vertex: usize, pos: [f32; 3] },
    #[error("{colors} colours for {vertices} vertices")]
    Colors { colors: usize, vertices: usize },
    #[error("{normals} normals for {vertices} vertices")]
    Normals { normals: usize, vertices: usize },
    #[error("{flags} single-sided flags for {vertices} vertices")]
    Sides { flags: usize, vertices: usize },
    #[error("{texcoords} texture coordinates for {vertices} vertices")]
    Texcoords { texcoords: usize, vertices: usize },
}

/// Counts of what [`Mesh::clean`] removed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CleanStats {
    pub degenerate_triangles: u64,
    pub unused_vertices: u64,
}

impl CleanStats {
    pub fn add(&mut self, o: CleanStats) {
        self.degenerate_triangles += o.degenerate_triangles;
        self.unused_vertices += o.unused_vertices;
    }
}

impl Mesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(&self.positions)
    }

    pub fn vertex(&self, i: u32) -> Vec3 {
        Vec3::from_array(self.positions[i as usize])
    }

    /// Checks the contract of [`Mesh`] and that every position is finite.
    pub fn validate(&self) -> Result<(), MeshError> {
        if !self.indices.len().is_multiple_of(3) {
            return Err(MeshError::RaggedIndices(self.indices.len()));
        }
        if let Some((vertex, p)) = self.positions.iter().enumerate().find(|(_, p)| !p.iter().all(|c| c.is_finite())) {
            return Err(MeshError::NonFinite { vertex, pos: *p });
        }
        let n = self.positions.len();
        if let Some((at, &index)) = self.indices.iter().enumerate().find(|(_, i)| **i as usize >= n) {
            return Err(MeshError::IndexOutOfRange { at, index, vertices: n });
        }
        if !self.colors.is_empty() && self.colors.len() != n {
            return Err(MeshError::Colors { colors: self.colors.len(), vertices: n });
        }
        if !self.normals.is_empty() && self.normals.len() != n {
            return Err(MeshError::Normals { normals: self.normals.len(), vertices: n });
        }
        if !self.single_sided.is_empty() && self.single_sided.len() != n {
            return Err(MeshError::Sides { flags: self.single_sided.len(), vertices: n });
        }
        if !self.texcoords.is_empty() && self.texcoords.len() != n {
            return Err(MeshError::Texcoords { texcoords: self.texcoords.len(), vertices: n });
        }
        Ok(())
    }

    /// Validates, then drops degenerate triangles (repeated index or zero area) and vertices no
    /// triangle uses. The result may be empty.
    pub fn clean(mut self) -> Result<(Mesh, CleanStats), MeshError> {
        self.validate()?;
        let mut stats = CleanStats::default();
        let mut kept = Vec::with_capacity(self.indices.len());
        for t in self.indices.chunks_exact(3) {
            let (a, b, c) = (self.vertex(t[0]), self.vertex(t[1]), self.vertex(t[2]));
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || (b - a).cross(c - a).length_squared() == 0.0 {
                stats.degenerate_triangles += 1;
            } else {
                kept.extend_from_slice(t);
            }
        }
        self.indices = kept;
        let before = self.positions.len();
        let compact = self.compacted();
        stats.unused_vertices = (before - compact.positions.len()) as u64;
        Ok((compact, stats))
    }

    /// A copy holding only the vertices the indices use, in first-use order.
    pub fn compacted(&self) -> Mesh {
        self.sub_mesh(&self.indices)
    }

    /// The mesh made of `indices` into this mesh's vertices, with only the used vertices (and
    /// their colours and normals), in first-use order.
    pub fn sub_mesh(&self, indices: &[u32]) -> Mesh {
        // A hash map, not one slot per vertex: a large object's hierarchy leaves in tens of
        // thousands of small pieces, and a map over all its vertices each time cost more than
        // the rest of its build.
        let mut map = rustc_hash::FxHashMap::with_capacity_and_hasher(indices.len().min(self.positions.len()), Default::default());
        let mut out = Mesh { indices: Vec::with_capacity(indices.len()), ..Mesh::default() };
        for &i in indices {
            let slot = *map.entry(i).or_insert_with(|| {
                out.positions.push(self.positions[i as usize]);
                if let Some(c) = self.colors.get(i as usize) {
                    out.colors.push(*c);
                }
                if let Some(n) = self.normals.get(i as usize) {
                    out.normals.push(*n);
                }
                if let Some(&s) = self.single_sided.get(i as usize) {
                    out.single_sided.push(s);
                }
                if let Some(&t) = self.texcoords.get(i as usize) {
                    out.texcoords.push(t);
                }
                out.positions.len() as u32 - 1
            });
            out.indices.push(slot);
        }
        out
    }

    /// Appends `o`, offsetting its indices. When only one of the two has colours (normals), the
    /// other's vertices get [`NO_COLOR`] ([`crate::normal::NO_NORMAL`]).
    pub fn append(&mut self, o: &Mesh) {
        let (before, base) = (self.positions.len(), self.positions.len() as u32);
        self.positions.extend_from_slice(&o.positions);
        self.indices.extend(o.indices.iter().map(|i| i + base));
        append_attribute(&mut self.colors, &o.colors, before, self.positions.len(), NO_COLOR);
        append_attribute(&mut self.normals, &o.normals, before, self.positions.len(), crate::normal::NO_NORMAL);
        append_attribute(&mut self.single_sided, &o.single_sided, before, self.positions.len(), false);
        append_attribute(&mut self.texcoords, &o.texcoords, before, self.positions.len(), crate::texture::Texcoord::NONE);
    }

    /// Whether triangle `t` is single-sided: all its corners are (see [`Mesh::single_sided`]).
    pub fn is_single_sided(&self, t: &[u32]) -> bool {
        !self.single_sided.is_empty() && t.iter().all(|&v| self.single_sided[v as usize])
    }

    /// Gives every vertex the colour `c`; an alpha of 0 is made 1 (see [`alpha`]).
    pub fn paint(&mut self, c: [u8; 4]) {
        self.colors = vec![[c[0], c[1], c[2], c[3].max(1)]; self.positions.len()];
    }

    /// Triangles with a translucent corner (see [`is_translucent`]).
    pub fn translucent_triangles(&self) -> usize {
        self.indices.chunks_exact(3).filter(|t| is_translucent(&self.colors, t)).count()
    }

    /// Triangles of the cut-out layer (see [`Layer`]).
    pub fn cut_out_triangles(&self) -> usize {
        self.indices.chunks_exact(3).filter(|t| layer(&self.colors, t) == Layer::CutOut).count()
    }

    /// Adds a triangle by its three corners (no welding).
    pub fn push_triangle(&mut self, a: Vec3, b: Vec3, c: Vec3) {
        let base = self.positions.len() as u32;
        self.positions.extend([a.to_array(), b.to_array(), c.to_array()]);
        self.indices.extend([base, base + 1, base + 2]);
    }

    /// Applies an affine transform to every position, and its normal matrix to every normal.
    pub fn transform(&mut self, m: &glam::Affine3A) {
        for p in &mut self.positions {
            *p = m.transform_point3(Vec3::from_array(*p)).to_array();
        }
        crate::normal::transform(&mut self.normals, glam::Mat3::from(m.matrix3).as_dmat3());
    }

    /// Merges vertices with bit-identical positions, colours, normals, sides and texture
    /// coordinates (meshoptimizer's remap), so that the simplifier sees a connected surface in
    /// inputs that repeat corners per triangle.
    pub fn welded(&self) -> Mesh {
        let keys: Vec<[u32; 9]> = (0..self.positions.len())
            .map(|i| {
                let p = self.positions[i].map(f32::to_bits);
                let c = self.colors.get(i).map_or(0, |c| u32::from_le_bytes(*c));
                let n = self.normals.get(i).copied().unwrap_or(0);
                let t = self.texcoords.get(i).copied().unwrap_or(crate::texture::Texcoord::NONE);
                let s = u32::from(self.single_sided.get(i).copied().unwrap_or(false));
                [p[0], p[1], p[2], c, n, s, t.uv[0].to_bits(), t.uv[1].to_bits(), t.texture]
            })
            .collect();
        let (unique, remap) = meshopt::generate_vertex_remap(&keys, Some(&self.indices));
        fn remapped<T: Copy + Default>(v: &[T], unique: usize, remap: &[u32]) -> Vec<T> {
            if v.is_empty() { Vec::new() } else { meshopt::remap_vertex_buffer(v, unique, remap) }
        }
        Mesh {
            colors: remapped(&self.colors, unique, &remap),
            normals: remapped(&self.normals, unique, &remap),
            single_sided: remapped(&self.single_sided, unique, &remap),
            texcoords: remapped(&self.texcoords, unique, &remap),
            positions: meshopt::remap_vertex_buffer(&self.positions, unique, &remap),
            indices: meshopt::remap_index_buffer(Some(&self.indices), self.indices.len(), &remap),
        }
    }
}

/// `to` after appending `from`'s attribute to a mesh of `before` vertices, now `after`: empty
/// while neither has it, else one per vertex, `none` where only the other had it.
fn append_attribute<T: Copy>(to: &mut Vec<T>, from: &[T], before: usize, after: usize, none: T) {
    if to.is_empty() && from.is_empty() {
        return;
    }
    to.resize(before, none);
    to.extend_from_slice(from);
    to.resize(after, none);
}

/// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection 5.1.5).
pub fn closest_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Mesh {
        Mesh {
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
            indices: vec![0, 1, 2, 0, 2, 3],
            ..Mesh::default()
        }
    }

    #[test]
    fn clean_drops_degenerates_and_unused_vertices() {
        let mut m = quad();
        m.positions.push([5.0, 5.0, 5.0]); // unused
        m.positions.push([2.0, 0.0, 0.0]); // collinear with 0 and 1
        m.indices.extend([0, 0, 1]); // repeated index
        m.indices.extend([0, 1, 5]); // zero area
        let (c, stats) = m.clean().unwrap();
        assert_eq!(c, quad());
        assert_eq!(stats, CleanStats { degenerate_triangles: 2, unused_vertices: 2 });
    }

    #[test]
    fn validate_names_what_is_wrong() {
        let mut m = quad();
        m.indices[4] = 9;
        assert_eq!(m.validate(), Err(MeshError::IndexOutOfRange { at: 4, index: 9, vertices: 4 }));
        let mut m = quad();
        m.positions[2][1] = f32::NAN;
        assert!(matches!(m.validate(), Err(MeshError::NonFinite { vertex: 2, .. })));
        let mut m = quad();
        m.indices.pop();
        assert_eq!(m.validate(), Err(MeshError::RaggedIndices(5)));
    }

    #[test]
    fn colours_follow_their_vertices_through_append_clean_and_weld() {
        let mut red = quad();
        red.paint([255, 0, 0, 255]);
        let mut m = quad();
        m.append(&red);
        assert_eq!(m.colors.len(), 8);
        assert_eq!(&m.colors[..4], &[NO_COLOR; 4]);
        assert_eq!(&m.colors[4..], &[[255, 0, 0, 255]; 4]);
        m.validate().unwrap();
        // Drop the uncoloured quad's triangles: the red vertices remain, with their colour.
        m.indices.drain(..6);
        let (c, _) = m.clone().clean().unwrap();
        assert_eq!(c.colors, vec![[255, 0, 0, 255]; 4]);
        // Same positions, different colours: not merged.
        let mut both = quad();
        both.append(&red);
        assert_eq!(both.welded().positions.len(), 8);
        m.colors.pop();
        assert_eq!(m.validate(), Err(MeshError::Colors { colors: 7, vertices: 8 }));
        // Normals the same way: the quad without them gets NO_NORMAL, and they split a weld.
        let mut bent = quad();
        bent.normals = vec![7; 4];
        let mut m = quad();
        m.append(&bent);
        assert_eq!(m.normals, [[crate::normal::NO_NORMAL; 4], [7; 4]].concat());
        assert_eq!(m.welded().positions.len(), 8);
        m.normals.pop();
        assert_eq!(m.validate(), Err(MeshError::Normals { normals: 7, vertices: 8 }));
    }

    #[test]
    fn a_triangle_is_translucent_when_a_corner_is() {
        assert_eq!([alpha(0.0), alpha(0.12), alpha(0.99), alpha(0.997), alpha(0.999), alpha(2.0)], [1, 31, 252, 253, 255, 255]);
        let mut m = quad();
        assert_eq!(m.translucent_triangles(), 0, "no colours: opaque");
        m.paint([9, 9, 9, 255]);
        assert_eq!(m.translucent_triangles(), 0);
        m.colors[m.indices[0] as usize] = NO_COLOR;
        assert_eq!(m.translucent_triangles(), 0, "no colour is opaque");
        m.colors[m.indices[0] as usize][3] = CUT_OUT;
        let shared = m.indices[3..].contains(&m.indices[0]);
        assert_eq!((m.translucent_triangles(), m.cut_out_triangles()), (0, 1 + usize::from(shared)));
        m.colors[m.indices[0] as usize][3] = alpha(0.5);
        assert_eq!((m.translucent_triangles(), m.cut_out_triangles()), (1 + usize::from(shared), 0));
        // A translucent corner wins over a cut-out one.
        m.colors[m.indices[1] as usize][3] = CUT_OUT;
        assert_eq!(layer(&m.colors, &m.indices[..3]), Layer::Translucent);
    }

    #[test]
    fn weld_merges_repeated_corners() {
        let mut soup = Mesh::default();
        soup.push_triangle(Vec3::ZERO, Vec3::X, Vec3::Y);
        soup.push_triangle(Vec3::X, Vec3::ONE, Vec3::Y);
        let w = soup.welded();
        assert_eq!(w.positions.len(), 4);
        assert_eq!(w.triangle_count(), 2);
    }
}
