//! PLY reader (ASCII and binary little-endian, as the Stanford models ship): the `vertex`
//! element's x, y, z and the `face` element's vertex index list; polygons are fanned into
//! triangles; every other element and property is skipped.

use super::ImportError;
use crate::mesh::Mesh;
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
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
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

/// A source of values: ASCII tokens or little-endian bytes.
enum Body<'a> {
    Ascii(std::str::SplitAsciiWhitespace<'a>),
    Binary(&'a [u8]),
}

impl Body<'_> {
    fn value(&mut self, ty: Scalar) -> Result<f64, String> {
        match self {
            Body::Ascii(tokens) => {
                let t = tokens.next().ok_or("unexpected end of data")?;
                t.parse::<f64>().map_err(|_| format!("bad number {t:?}"))
            }
            Body::Binary(bytes) => {
                let n = ty.size();
                if bytes.len() < n {
                    return Err("unexpected end of data (file truncated?)".into());
                }
                let (v, rest) = bytes.split_at(n);
                *bytes = rest;
                let a = |k: usize| -> [u8; 8] {
                    let mut b = [0u8; 8];
                    b[..k].copy_from_slice(&v[..k]);
                    b
                };
                Ok(match ty {
                    Scalar::I8 => v[0] as i8 as f64,
                    Scalar::U8 => v[0] as f64,
                    Scalar::I16 => i16::from_le_bytes([v[0], v[1]]) as f64,
                    Scalar::U16 => u16::from_le_bytes([v[0], v[1]]) as f64,
                    Scalar::I32 => i32::from_le_bytes(a(4)[..4].try_into().expect("4 bytes")) as f64,
                    Scalar::U32 => u32::from_le_bytes(a(4)[..4].try_into().expect("4 bytes")) as f64,
                    Scalar::F32 => f32::from_le_bytes(a(4)[..4].try_into().expect("4 bytes")) as f64,
                    Scalar::F64 => f64::from_le_bytes(a(8)),
                })
            }
        }
    }
}

/// Reads the PLY file at `path`.
pub fn read(path: &Path) -> Result<Mesh, ImportError> {
    let bytes = std::fs::read(path).map_err(|source| ImportError::Io { path: path.to_owned(), source })?;
    parse(&bytes).map_err(|what| ImportError::Malformed { path: path.to_owned(), what })
}

/// Parses PLY bytes. Errors say what is wrong; the mesh is not cleaned up.
pub fn parse(bytes: &[u8]) -> Result<Mesh, String> {
    let end = find(bytes, b"end_header").ok_or("no end_header line: not a PLY file, or truncated")?;
    let header = std::str::from_utf8(&bytes[..end]).map_err(|_| "header is not text")?;
    let mut body = &bytes[end + b"end_header".len()..];
    body = match body {
        [b'\r', b'\n', rest @ ..] | [b'\n', rest @ ..] => rest,
        _ => body,
    };
    let mut lines = header.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with("comment") && !l.starts_with("obj_info"));
    if lines.next() != Some("ply") {
        return Err("does not start with \"ply\"".into());
    }
    let mut ascii = None;
    let mut elements: Vec<Element> = Vec::new();
    for line in lines {
        let w: Vec<&str> = line.split_ascii_whitespace().collect();
        match w.as_slice() {
            ["format", "ascii", _] => ascii = Some(true),
            ["format", "binary_little_endian", _] => ascii = Some(false),
            ["format", f, _] => return Err(format!("unsupported format {f} (ascii and binary_little_endian are)")),
            ["element", name, count] => {
                let count = count.parse().map_err(|_| format!("bad element count {count:?}"))?;
                elements.push(Element { name: name.to_string(), count, props: Vec::new() });
            }
            ["property", "list", c, t, name] => {
                let (list, ty) = (Scalar::parse(c).ok_or(format!("bad type {c}"))?, Scalar::parse(t).ok_or(format!("bad type {t}"))?);
                elements.last_mut().ok_or("property before any element")?.props.push(Property {
                    name: name.to_string(),
                    list: Some(list),
                    ty,
                });
            }
            ["property", t, name] => {
                let ty = Scalar::parse(t).ok_or(format!("bad type {t}"))?;
                elements.last_mut().ok_or("property before any element")?.props.push(Property { name: name.to_string(), list: None, ty });
            }
            _ => return Err(format!("bad header line {line:?}")),
        }
    }
    let ascii = ascii.ok_or("no format line")?;
    let text;
    let mut src = if ascii {
        text = std::str::from_utf8(body).map_err(|_| "ASCII body is not text")?;
        Body::Ascii(text.split_ascii_whitespace())
    } else {
        Body::Binary(body)
    };
    let mut mesh = Mesh::default();
    for el in &elements {
        let xyz = ["x", "y", "z"].map(|a| el.props.iter().position(|p| p.name == a && p.list.is_none()));
        let faces = el.props.iter().position(|p| (p.name == "vertex_indices" || p.name == "vertex_index") && p.list.is_some());
        if el.name == "vertex" && xyz.iter().any(Option::is_none) {
            return Err("vertex element without x, y, z".into());
        }
        // Guard the reservation against a lying count.
        if el.name == "vertex" {
            mesh.positions.reserve(el.count.min(bytes.len() / 12 + 1));
        }
        for i in 0..el.count {
            let mut p = [0f32; 3];
            for (k, prop) in el.props.iter().enumerate() {
                let at = |e: String| format!("element {} {i}, property {}: {e}", el.name, prop.name);
                match prop.list {
                    None => {
                        let v = src.value(prop.ty).map_err(at)?;
                        if let Some(axis) = xyz.iter().position(|&a| a == Some(k)) {
                            p[axis] = v as f32;
                        }
                    }
                    Some(count_ty) => {
                        let n = src.value(count_ty).map_err(at)?;
                        if !(0.0..=1e6).contains(&n) {
                            return Err(at(format!("bad list length {n}")));
                        }
                        let items = (0..n as usize).map(|_| src.value(prop.ty)).collect::<Result<Vec<f64>, String>>().map_err(at)?;
                        if el.name == "face" && faces == Some(k) {
                            if items.iter().any(|&v| v < 0.0 || v > u32::MAX as f64 || v.fract() != 0.0) {
                                return Err(at(format!("bad vertex index in {items:?}")));
                            }
                            for j in 1..items.len().saturating_sub(1) {
                                mesh.indices.extend([items[0] as u32, items[j] as u32, items[j + 1] as u32]);
                            }
                        }
                    }
                }
            }
            if el.name == "vertex" {
                mesh.positions.push(p);
            }
        }
    }
    Ok(mesh)
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

    #[test]
    fn ascii_quad_is_fanned_into_two_triangles() {
        let m = parse(ASCII.as_bytes()).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.indices, vec![0, 1, 2, 0, 2, 3]);
    }

    #[test]
    fn binary_triangle() {
        let m = parse(&binary()).unwrap();
        assert_eq!(m.positions, vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        assert_eq!(m.indices, vec![0, 1, 2]);
    }

    #[test]
    fn every_truncation_is_an_error_not_a_panic() {
        let b = binary();
        for n in 0..b.len() {
            assert!(parse(&b[..n]).is_err(), "prefix {n} parsed");
        }
        for n in 0..ASCII.len() - 2 {
            assert!(parse(&ASCII.as_bytes()[..n]).is_err(), "ascii prefix {n} parsed");
        }
    }

    #[test]
    fn bad_headers_are_named() {
        assert!(parse(b"ply\nformat binary_big_endian 1.0\nend_header\n").unwrap_err().contains("binary_big_endian"));
        assert!(parse(b"plx\nend_header\n").unwrap_err().contains("ply"));
        let bad_index = ASCII.replace("4 0 1 2 3", "3 0 1 -2");
        assert!(parse(bad_index.as_bytes()).unwrap_err().contains("bad vertex index"));
    }
}
