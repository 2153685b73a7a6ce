//! The protocol's points file (methods/README.md, protocol 2): binary little-endian PLY, one
//! `vertex` element whose properties are `x y z` (double), `nx ny nz` (float) and, when the
//! dataset has them, `red green blue` (uchar) and `u v` (float). Only the positions and the
//! colours are read; every other property is skipped by its size.

use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use crate::error::{Error, Result, io};

/// The points pointsight sent: positions and, when the dataset has them, colours.
#[derive(Debug, Default)]
pub struct Points {
    /// Positions, point k at index k.
    pub positions: Vec<[f64; 3]>,
    /// 8-bit colours, when the file has `red green blue`.
    pub colors: Option<Vec<[u8; 3]>>,
}

/// Bytes of a PLY scalar type, `None` for a type PLY does not have.
fn type_size(name: &str) -> Option<usize> {
    Some(match name {
        "char" | "uchar" | "int8" | "uint8" => 1,
        "short" | "ushort" | "int16" | "uint16" => 2,
        "int" | "uint" | "float" | "int32" | "uint32" | "float32" => 4,
        "double" | "float64" => 8,
        _ => return None,
    })
}

/// Reads the points file at `path`.
pub fn read(path: &Path) -> Result<Points> {
    let bad = |what: String| Error::Ply {
        path: path.to_owned(),
        what,
    };
    let file = std::fs::File::open(path).map_err(io(path))?;
    let mut r = BufReader::new(file);
    let mut line = String::new();
    let mut n: Option<usize> = None;
    let mut in_vertex = false;
    let mut props: Vec<(String, String)> = Vec::new();
    let mut first = true;
    loop {
        line.clear();
        if r.read_line(&mut line).map_err(io(path))? == 0 {
            return Err(bad("the header has no end_header".into()));
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        if first {
            if words != ["ply"] {
                return Err(bad("it does not start with `ply`".into()));
            }
            first = false;
            continue;
        }
        match words.as_slice() {
            ["format", f, _] if *f != "binary_little_endian" => {
                return Err(bad(format!("format {f}, not binary_little_endian")));
            }
            ["element", name, count] => {
                in_vertex = *name == "vertex";
                if in_vertex {
                    n = Some(
                        count
                            .parse()
                            .map_err(|_| bad(format!("vertex count {count:?}")))?,
                    );
                } else if n.is_none() {
                    return Err(bad(format!("element {name} before vertex")));
                }
            }
            ["property", "list", ..] if in_vertex => {
                return Err(bad("a list property on vertex".into()));
            }
            ["property", ty, name] if in_vertex => {
                if type_size(ty).is_none() {
                    return Err(bad(format!("property {name} of type {ty}")));
                }
                props.push(((*ty).to_owned(), (*name).to_owned()));
            }
            ["end_header"] => break,
            _ => {}
        }
    }
    let n = n.ok_or_else(|| bad("no vertex element".into()))?;
    let mut offsets = Vec::with_capacity(props.len());
    let mut stride = 0;
    for (ty, _) in &props {
        offsets.push(stride);
        stride += type_size(ty).unwrap_or(0);
    }
    let at = |name: &str, ty: &str| -> Option<usize> {
        props
            .iter()
            .position(|(t, p)| p == name && t == ty)
            .map(|k| offsets[k])
    };
    let (x, y, z) = match (at("x", "double"), at("y", "double"), at("z", "double")) {
        (Some(x), Some(y), Some(z)) => (x, y, z),
        _ => return Err(bad("no double x y z".into())),
    };
    let rgb = match (
        at("red", "uchar"),
        at("green", "uchar"),
        at("blue", "uchar"),
    ) {
        (Some(r), Some(g), Some(b)) => Some((r, g, b)),
        _ => None,
    };
    let mut positions = Vec::with_capacity(n);
    let mut colors = rgb.map(|_| Vec::with_capacity(n));
    let f64_at = |rec: &[u8], o: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&rec[o..o + 8]);
        f64::from_le_bytes(b)
    };
    // Records in batches: the file may be larger than what one read should hold.
    let batch = (1 << 20) / stride.max(1) + 1;
    let mut buf = vec![0u8; batch * stride];
    let mut left = n;
    while left > 0 {
        let k = left.min(batch);
        let bytes = &mut buf[..k * stride];
        r.read_exact(bytes)
            .map_err(|e| bad(format!("{} of {n} points: {e}", n - left)))?;
        for rec in bytes.chunks_exact(stride) {
            positions.push([f64_at(rec, x), f64_at(rec, y), f64_at(rec, z)]);
            if let (Some(c), Some((r, g, b))) = (colors.as_mut(), rgb) {
                c.push([rec[r], rec[g], rec[b]]);
            }
        }
        left -= k;
    }
    if let Some(p) = positions
        .iter()
        .position(|p| p.iter().any(|c| !c.is_finite()))
    {
        return Err(bad(format!("point {p} is not finite")));
    }
    Ok(Points { positions, colors })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ply(body: &[u8], header: &str) -> tempdir::Dir {
        let d = tempdir::Dir::new();
        let mut bytes = header.as_bytes().to_vec();
        bytes.extend_from_slice(body);
        std::fs::write(d.path.join("p.ply"), bytes).expect("write");
        d
    }

    /// A temporary folder removed on drop (the crate keeps no test dependencies).
    mod tempdir {
        pub struct Dir {
            pub path: std::path::PathBuf,
        }
        impl Dir {
            pub fn new() -> Self {
                use std::sync::atomic::{AtomicUsize, Ordering};
                static K: AtomicUsize = AtomicUsize::new(0);
                let path = std::env::temp_dir().join(format!(
                    "copc-lod-test-{}-{}",
                    std::process::id(),
                    K.fetch_add(1, Ordering::Relaxed)
                ));
                std::fs::create_dir_all(&path).expect("temp dir");
                Self { path }
            }
        }
        impl Drop for Dir {
            fn drop(&mut self) {
                let _ = std::fs::remove_dir_all(&self.path);
            }
        }
    }

    #[test]
    fn positions_and_colours_are_read_and_other_properties_skipped() {
        let header = "ply\nformat binary_little_endian 1.0\nelement vertex 2\n\
                      property double x\nproperty double y\nproperty double z\n\
                      property float nx\nproperty float ny\nproperty float nz\n\
                      property uchar red\nproperty uchar green\nproperty uchar blue\n\
                      property float u\nproperty float v\nend_header\n";
        let mut body = Vec::new();
        for k in 0..2u8 {
            for c in 0..3 {
                body.extend_from_slice(&(f64::from(k) * 10.0 + f64::from(c)).to_le_bytes());
            }
            body.extend_from_slice(&[0u8; 12]);
            body.extend_from_slice(&[k, 2 * k, 3 * k]);
            body.extend_from_slice(&[0u8; 8]);
        }
        let d = ply(&body, header);
        let p = read(&d.path.join("p.ply")).expect("read");
        assert_eq!(p.positions, vec![[0.0, 1.0, 2.0], [10.0, 11.0, 12.0]]);
        assert_eq!(p.colors, Some(vec![[0, 0, 0], [1, 2, 3]]));
        // Truncated: an error naming the file and how far it got.
        let d = ply(&body[..body.len() - 1], header);
        let e = read(&d.path.join("p.ply"))
            .expect_err("truncated")
            .to_string();
        assert!(e.contains("p.ply") && e.contains("of 2 points"), "{e}");
    }
}
