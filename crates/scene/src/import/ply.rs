//! PLY reader (ASCII, binary little- and big-endian): the `vertex` element's x, y, z (float or
//! double: survey and scan tools write large coordinates as double, which are kept in f64 up to
//! the scene's origin, see [`crate::place`]) and the `face` element's vertex index list;
//! polygons are fanned into triangles; the vertices' `red`, `green`, `blue` and `alpha` (bytes,
//! or floats from 0 to 1) are their colours, an alpha below 1 translucent; every other element
//! and property is skipped.

use super::{ImportError, ParseError};
use crate::mesh::{Mesh, Object};
use std::path::Path;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Result<Scalar, ParseError> {
        Ok(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return Err(ParseError::new(format!("bad type {s}"))),
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

/// A property: a scalar, or a list with a count type and an item type.
#[derive(Clone, Debug)]
struct Property {
    name: String,
    list: Option<Scalar>,
    ty: Scalar,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

/// A source of values: ASCII tokens or bytes of either order.
enum Body<'a> {
    Ascii(std::str::SplitAsciiWhitespace<'a>),
    Binary { bytes: &'a [u8], big_endian: bool },
}

impl Body<'_> {
    fn value(&mut self, ty: Scalar) -> Result<f64, ParseError> {
        match self {
            Body::Ascii(tokens) => {
                let t = tokens.next().ok_or_else(|| ParseError::new("unexpected end of data"))?;
                t.parse::<f64>().map_err(|e| ParseError::caused(format!("bad number {t:?}"), e))
            }
            Body::Binary { bytes, big_endian } => {
                let n = ty.size();
                if bytes.len() < n {
                    return Err(ParseError::new("unexpected end of data (file truncated?)"));
                }
                let (v, rest) = bytes.split_at(n);
                *bytes = rest;
                // Little-endian in the low bytes of a u64 of the value's width.
                let mut b = [0u8; 8];
                b[..n].copy_from_slice(v);
                if *big_endian {
                    b[..n].reverse();
                }
                let u = u64::from_le_bytes(b);
                Ok(match ty {
                    Scalar::I8 => u as u8 as i8 as f64,
                    Scalar::U8 => u as u8 as f64,
                    Scalar::I16 => u as u16 as i16 as f64,
                    Scalar::U16 => u as u16 as f64,
                    Scalar::I32 => u as u32 as i32 as f64,
                    Scalar::U32 => u as u32 as f64,
                    Scalar::F32 => f32::from_bits(u as u32) as f64,
                    Scalar::F64 => f64::from_bits(u),
                })
            }
        }
    }
}

/// Reads the PLY file at `path` as one object named after the file.
pub fn read(path: &Path) -> Result<Object, ImportError> {
    let bytes = std::fs::read(path).map_err(ImportError::io(path))?;
    let mut o = parse(&bytes).map_err(ImportError::malformed(path))?;
    o.name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    Ok(o)
}

/// Parses PLY bytes into an unnamed object. Errors say what is wrong; the mesh is not cleaned
/// up.
pub fn parse(bytes: &[u8]) -> Result<Object, ParseError> {
    let (elements, src) = header(bytes)?;
    read_body(&elements, src, bytes.len())
}

/// The elements the header of `bytes` declares, and the source of their values after it.
fn header(bytes: &[u8]) -> Result<(Vec<Element>, Body<'_>), ParseError> {
    let end = find(bytes, b"end_header").ok_or_else(|| ParseError::new("no end_header line: not a PLY file, or truncated"))?;
    let head = std::str::from_utf8(&bytes[..end]).map_err(|e| ParseError::caused("header is not text", e))?;
    let mut body = &bytes[end + b"end_header".len()..];
    body = match body {
        [b'\r', b'\n', rest @ ..] | [b'\n', rest @ ..] => rest,
        _ => body,
    };
    let mut lines = head.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with("comment") && !l.starts_with("obj_info"));
    if lines.next() != Some("ply") {
        return Err(ParseError::new("does not start with \"ply\""));
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for line in lines {
        let w: Vec<&str> = line.split_ascii_whitespace().collect();
        match w.as_slice() {
            ["format", f @ ("ascii" | "binary_little_endian" | "binary_big_endian"), _] => format = Some(*f),
            ["format", f, _] => {
                return Err(ParseError::new(format!("unsupported format {f} (ascii, binary_little_endian and binary_big_endian are)")));
            }
            ["element", name, count] => {
                let count = count.parse::<usize>().map_err(|e| ParseError::caused(format!("bad element count {count:?}"), e))?;
                elements.push(Element { name: name.to_string(), count, props: Vec::new() });
            }
            ["property", "list", c, t, name] => {
                let property = Property { name: name.to_string(), list: Some(Scalar::parse(c)?), ty: Scalar::parse(t)? };
                elements.last_mut().ok_or_else(|| ParseError::new("property before any element"))?.props.push(property);
            }
            ["property", t, name] => {
                let property = Property { name: name.to_string(), list: None, ty: Scalar::parse(t)? };
                elements.last_mut().ok_or_else(|| ParseError::new("property before any element"))?.props.push(property);
            }
            _ => return Err(ParseError::new(format!("bad header line {line:?}"))),
        }
    }
    let src = match format.ok_or_else(|| ParseError::new("no format line"))? {
        "ascii" => {
            let text = std::str::from_utf8(body).map_err(|e| ParseError::caused("ASCII body is not text", e))?;
            Body::Ascii(text.split_ascii_whitespace())
        }
        f => Body::Binary { bytes: body, big_endian: f == "binary_big_endian" },
    };
    Ok((elements, src))
}

/// Reads the values of `elements` from `src` into an unnamed object: the vertices' positions
/// and colours, the faces fanned into triangles. `bytes`, the file's length, bounds what a
/// lying vertex count reserves.
fn read_body(elements: &[Element], mut src: Body<'_>, bytes: usize) -> Result<Object, ParseError> {
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut indices: Vec<u32> = Vec::new();
    let mut colors: Vec<[u8; 4]> = Vec::new();
    let mut normals: Vec<crate::normal::Normal> = Vec::new();
    for el in elements {
        let xyz = ["x", "y", "z"].map(|a| el.props.iter().position(|p| p.name == a && p.list.is_none()));
        let rgb = ["red", "green", "blue", "alpha"].map(|a| el.props.iter().position(|p| p.name == a && p.list.is_none()));
        let has_rgb = el.name == "vertex" && rgb[..3].iter().all(Option::is_some);
        let nxyz = ["nx", "ny", "nz"].map(|a| el.props.iter().position(|p| p.name == a && p.list.is_none()));
        let has_normal = el.name == "vertex" && nxyz.iter().all(Option::is_some);
        let faces = el.props.iter().position(|p| (p.name == "vertex_indices" || p.name == "vertex_index") && p.list.is_some());
        if el.name == "vertex" && xyz.iter().any(Option::is_none) {
            return Err(ParseError::new("vertex element without x, y, z"));
        }
        // Guard the reservation against a lying count.
        if el.name == "vertex" {
            positions.reserve(el.count.min(bytes / 12 + 1));
        }
        for i in 0..el.count {
            let mut p = [0f64; 3];
            let mut c = [0u8, 0, 0, 255];
            let mut n = glam::Vec3::ZERO;
            for (k, prop) in el.props.iter().enumerate() {
                let at = |e: ParseError| e.at(format!("element {} {i}, property {}", el.name, prop.name));
                match prop.list {
                    None => {
                        let v = src.value(prop.ty).map_err(at)?;
                        if let Some(axis) = xyz.iter().position(|&a| a == Some(k)) {
                            p[axis] = v;
                        } else if let Some(axis) = nxyz.iter().position(|&a| a == Some(k)) {
                            n[axis] = v as f32;
                        } else if let Some(ch) = rgb.iter().position(|&a| a == Some(k)) {
                            let unit = matches!(prop.ty, Scalar::F32 | Scalar::F64);
                            let v = if unit { v } else { v / 255.0 };
                            c[ch] = if ch == 3 { crate::mesh::alpha(v as f32) } else { (v * 255.0).round().clamp(0.0, 255.0) as u8 };
                        }
                    }
                    Some(count_ty) => {
                        let n = src.value(count_ty).map_err(at)?;
                        if !(0.0..=1e6).contains(&n) {
                            return Err(at(ParseError::new(format!("bad list length {n}"))));
                        }
                        let items = (0..n as usize).map(|_| src.value(prop.ty)).collect::<Result<Vec<f64>, ParseError>>().map_err(at)?;
                        if el.name == "face" && faces == Some(k) {
                            if items.iter().any(|&v| v < 0.0 || v > u32::MAX as f64 || v.fract() != 0.0) {
                                return Err(at(ParseError::new(format!("bad vertex index in {items:?}"))));
                            }
                            for j in 1..items.len().saturating_sub(1) {
                                indices.extend([items[0] as u32, items[j] as u32, items[j + 1] as u32]);
                            }
                        }
                    }
                }
            }
            if el.name == "vertex" {
                positions.push(p);
                if has_rgb {
                    colors.push(c);
                }
                if has_normal {
                    normals.push(crate::normal::given(n));
                }
            }
        }
    }
    let anchor = crate::place::anchor(positions.iter().map(|p| glam::DVec3::from_array(*p)));
    let mesh = Mesh { positions: crate::place::relative(&positions, anchor), indices, colors, normals, ..Mesh::default() };
    Ok(Object::placed("", mesh, anchor, glam::DAffine3::IDENTITY))
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

#[cfg(test)]
mod tests {
    use super::*;

    const ASCII: &str = "ply\nformat ascii 1.0\ncomment x\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 1\n1 0 0 1\n1 1 0 1\n0 1 0 1\n4 0 1 2 3\n";

    fn binary() -> Vec<u8> {
        let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
        for v in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            v.iter().for_each(|c| b.extend(c.to_le_bytes()));
        }
        b.push(3);
        [0i32, 1, 2].iter().for_each(|i| b.extend(i.to_le_bytes()));
        b
    }

    /// The triangle at `corners` as binary big-endian PLY with double coordinates, with a
    /// 16-bit face count and an unsigned index list as some scanners write it.
    fn big_endian_double(corners: [[f64; 3]; 3]) -> Vec<u8> {
        let mut b = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\nproperty uchar green\nproperty float blue\nelement face 1\nproperty list ushort uint vertex_indices\nend_header\n".to_vec();
        for v in corners {
            v.iter().for_each(|c| b.extend(c.to_be_bytes()));
            b.extend([200, 100]);
            b.extend((50f32 / 255.0).to_be_bytes());
        }
        b.extend(3u16.to_be_bytes());
        [0u32, 1, 2].iter().for_each(|i| b.extend(i.to_be_bytes()));
        b
    }

    /// World positions of a parsed object (its placement applied in f64).
    fn world(o: &Object) -> Vec<[f64; 3]> {
        o.mesh.positions.iter().map(|p| o.world(*p).to_array()).collect()
    }

    #[test]
    fn ascii_quad_is_fanned_into_two_triangles() {
        let m = parse(ASCII.as_bytes()).unwrap().mesh;
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.indices, vec![0, 1, 2, 0, 2, 3]);
        // red alone (no green, blue) is no colour.
        assert!(m.colors.is_empty());
    }

    #[test]
    fn binary_triangle() {
        let o = parse(&binary()).unwrap();
        assert_eq!(world(&o), vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        assert_eq!(o.mesh.indices, vec![0, 1, 2]);
    }

    #[test]
    fn big_endian_doubles_far_from_the_origin_keep_their_precision() {
        // 1e9 out, corners a millimetre and a quarter apart: f32 world coordinates (spacing 64)
        // would make this one point.
        let c = [[1e9 + 0.001, 2e9, -3e9], [1e9 + 0.251, 2e9, -3e9], [1e9 + 0.001, 2e9 + 0.25, -3e9]];
        let o = parse(&big_endian_double(c)).unwrap();
        assert_eq!(o.mesh.indices, vec![0, 1, 2]);
        assert_eq!(o.mesh.colors, vec![[200, 100, 50, 255]; 3]);
        for (w, c) in world(&o).iter().zip(&c) {
            for k in 0..3 {
                assert!((w[k] - c[k]).abs() < 1e-7, "{w:?} vs {c:?}");
            }
        }
        // And the same bytes little-endian are refused as garbage or read differently, never
        // silently equal: the byte order is honoured.
        let mut le = big_endian_double(c);
        let at = find(&le, b"binary_big_endian").unwrap();
        le.splice(at..at + 17, b"binary_little_endian".iter().copied());
        assert!(parse(&le).map(|o| world(&o) != world(&parse(&big_endian_double(c)).unwrap())).unwrap_or(true));
    }

    #[test]
    fn every_truncation_is_an_error_not_a_panic() {
        for b in [binary(), big_endian_double([[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])] {
            for n in 0..b.len() {
                assert!(parse(&b[..n]).is_err(), "prefix {n} parsed");
            }
        }
        for n in 0..ASCII.len() - 2 {
            assert!(parse(&ASCII.as_bytes()[..n]).is_err(), "ascii prefix {n} parsed");
        }
    }

    #[test]
    fn bad_headers_are_named() {
        assert!(parse(b"ply\nformat binary_middle_endian 1.0\nend_header\n").unwrap_err().to_string().contains("binary_middle_endian"));
        assert!(parse(b"plx\nend_header\n").unwrap_err().to_string().contains("ply"));
        let bad_index = ASCII.replace("4 0 1 2 3", "3 0 1 -2");
        assert!(parse(bad_index.as_bytes()).unwrap_err().to_string().contains("bad vertex index"));
    }
}
