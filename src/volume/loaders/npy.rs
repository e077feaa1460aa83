//! NumPy `.npy` files (format versions 1.0, 2.0 and 3.0) holding a 3-D array of one of the
//! dtypes `u1 i1 u2 i2 u4 i4 f4 f8`, in either byte order (`<`, `>`, `|`, `=`).
//!
//! Axis order: the array's logical axes, whatever its memory order, as `occlux.Volume(array)`
//! reads an array in Python: shape `(nz, ny, nx)` maps to dims `[nx, ny, nz]`, so `np.save(f,
//! vol)` of an array indexed `vol[z, y, x]` loads as expected. A Fortran-order array
//! (`fortran_order: True`, `np.asfortranarray`) holds the same logical array with its first axis
//! fastest, and is reordered on loading (one pass over the voxels), so it loads exactly as the
//! C-order file of the same array. Spacing is 1 and the origin 0 (the format has no geometry).

use super::{finish, read_values, Frame, Layout, LoadOptions, Placement, ScalarType, SourceInfo};
use crate::error::{Error, Result};
use crate::volume::Volume;
use glam::Vec3;
use std::fs::File;
use std::io::{BufReader, ErrorKind, Read};
use std::path::Path;

const MAGIC: &[u8; 6] = b"\x93NUMPY";
/// numpy itself refuses larger headers by default; anything bigger is not a real array header.
const MAX_HEADER_BYTES: usize = 1 << 20;
const DTYPES: &str = "u1, i1, u2, i2, u4, i4, f4, f8 with byte order <, >, | or =";

pub(super) fn load(path: &Path, opts: &LoadOptions) -> Result<(Volume, SourceInfo)> {
    let mut reader = BufReader::new(File::open(path).map_err(|e| Error::io(path, e))?);
    let text = read_header(path, &mut reader)?;
    let header = Header::parse(&text).map_err(|message| {
        let shown: String = text.trim().chars().take(200).collect();
        Error::format(path, format!("bad .npy header {shown:?}: {message}"))
    })?;
    let (scalar, big_endian) = dtype(path, &header.descr)?;
    let dims = dims(path, &header.shape)?;
    let layout = Layout::checked(path, dims, scalar, big_endian, opts)?;
    let mut values = read_values(path, reader, "array data", &layout)?;
    if header.fortran_order {
        values = c_order(&values, dims);
    }
    let (volume, non_finite) = finish(
        path,
        dims,
        Placement::grid(Vec3::ONE, Vec3::ZERO),
        values,
        opts,
    )?;
    let info = SourceInfo {
        format: "npy",
        scalar: scalar.name().to_string(),
        grid: None,
        non_finite,
        frame: Frame::ALIGNED,
        hounsfield: None,
    };
    Ok((volume, info))
}

/// Reads the magic, version and header length, and returns the header dictionary's text.
fn read_header(path: &Path, reader: &mut impl Read) -> Result<String> {
    let short = |e: std::io::Error| {
        if e.kind() == ErrorKind::UnexpectedEof {
            Error::format(
                path,
                "file too short for a .npy header (empty or truncated)",
            )
        } else {
            Error::io(path, e)
        }
    };
    let mut prelude = [0u8; 8];
    reader.read_exact(&mut prelude).map_err(short)?;
    if &prelude[..6] != MAGIC {
        return Err(Error::format(
            path,
            "not a .npy file: it does not start with the magic \\x93NUMPY",
        ));
    }
    let length = match prelude[6] {
        1 => {
            let mut bytes = [0u8; 2];
            reader.read_exact(&mut bytes).map_err(short)?;
            usize::from(u16::from_le_bytes(bytes))
        }
        2 | 3 => {
            let mut bytes = [0u8; 4];
            reader.read_exact(&mut bytes).map_err(short)?;
            u32::from_le_bytes(bytes) as usize
        }
        major => {
            return Err(Error::format(
                path,
                format!(
                    "format version {major}.{} is not supported (1.0, 2.0, 3.0 are)",
                    prelude[7]
                ),
            ))
        }
    };
    if length > MAX_HEADER_BYTES {
        return Err(Error::format(
            path,
            format!(
                "header length {length} is over {MAX_HEADER_BYTES} bytes: not a .npy array header"
            ),
        ));
    }
    let mut text = vec![0u8; length];
    reader.read_exact(&mut text).map_err(short)?;
    String::from_utf8(text).map_err(|_| Error::format(path, "the .npy header is not text"))
}

/// The header dictionary's three keys.
#[derive(Debug, PartialEq)]
struct Header {
    descr: String,
    fortran_order: bool,
    shape: Vec<i64>,
}

/// A value in the header dictionary (a Python literal).
enum Literal {
    Str(String),
    Bool(bool),
    Tuple(Vec<i64>),
}

impl Header {
    /// Parses `{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3, 4), }`.
    fn parse(text: &str) -> Result<Self, String> {
        let mut parser = Parser { rest: text.trim() };
        let (mut descr, mut fortran_order, mut shape) = (None, None, None);
        parser.expect('{')?;
        while !parser.eat('}') {
            let key = parser.string()?;
            parser.expect(':')?;
            match (key.as_str(), parser.literal()?) {
                ("descr", Literal::Str(s)) => descr = Some(s),
                ("fortran_order", Literal::Bool(b)) => fortran_order = Some(b),
                ("shape", Literal::Tuple(t)) => shape = Some(t),
                (key, _) => return Err(format!("unexpected key or value for '{key}'")),
            }
            if !parser.eat(',') {
                parser.expect('}')?;
                break;
            }
        }
        Ok(Self {
            descr: descr.ok_or("missing 'descr'")?,
            fortran_order: fortran_order.ok_or("missing 'fortran_order'")?,
            shape: shape.ok_or("missing 'shape'")?,
        })
    }
}

/// A minimal reader of the Python literals that appear in .npy headers.
struct Parser<'a> {
    rest: &'a str,
}

impl Parser<'_> {
    /// Consumes `c` (after whitespace) if it comes next.
    fn eat(&mut self, c: char) -> bool {
        self.rest = self.rest.trim_start();
        match self.rest.strip_prefix(c) {
            Some(rest) => {
                self.rest = rest;
                true
            }
            None => false,
        }
    }

    fn expect(&mut self, c: char) -> Result<(), String> {
        if self.eat(c) {
            Ok(())
        } else {
            Err(format!("expected '{c}' at {:?}", self.context()))
        }
    }

    fn context(&self) -> String {
        self.rest.chars().take(20).collect()
    }

    fn string(&mut self) -> Result<String, String> {
        self.rest = self.rest.trim_start();
        let quote = match self.rest.chars().next() {
            Some(q @ ('\'' | '"')) => q,
            _ => return Err(format!("expected a quoted string at {:?}", self.context())),
        };
        let body = &self.rest[1..];
        let end = body
            .find(quote)
            .ok_or_else(|| format!("unterminated string at {:?}", self.context()))?;
        self.rest = &body[end + 1..];
        Ok(body[..end].to_string())
    }

    fn literal(&mut self) -> Result<Literal, String> {
        self.rest = self.rest.trim_start();
        for (word, value) in [("True", true), ("False", false)] {
            if let Some(rest) = self.rest.strip_prefix(word) {
                self.rest = rest;
                return Ok(Literal::Bool(value));
            }
        }
        if self.eat('(') {
            return self.tuple().map(Literal::Tuple);
        }
        self.string().map(Literal::Str)
    }

    /// The integers of a tuple whose '(' has been consumed: `()`, `(5,)`, `(2, 3, 4)`.
    fn tuple(&mut self) -> Result<Vec<i64>, String> {
        let mut items = Vec::new();
        while !self.eat(')') {
            self.rest = self.rest.trim_start();
            let end = self
                .rest
                .find(|c: char| !(c.is_ascii_digit() || c == '-'))
                .unwrap_or(self.rest.len());
            let item = self.rest[..end]
                .parse()
                .map_err(|_| format!("expected an integer in the shape at {:?}", self.context()))?;
            items.push(item);
            self.rest = &self.rest[end..];
            if !self.eat(',') {
                self.expect(')')?;
                break;
            }
        }
        Ok(items)
    }
}

/// Maps a dtype string like `<f4` to a scalar type and byte order.
fn dtype(path: &Path, descr: &str) -> Result<(ScalarType, bool)> {
    let unsupported = || {
        Error::format(
            path,
            format!("dtype '{descr}' is not supported (supported: {DTYPES})"),
        )
    };
    let mut chars = descr.chars();
    let big_endian = match chars.next() {
        Some('<' | '|') => false,
        Some('>') => true,
        Some('=') => cfg!(target_endian = "big"),
        _ => return Err(unsupported()),
    };
    let scalar = match chars.as_str() {
        "u1" => ScalarType::U8,
        "i1" => ScalarType::I8,
        "u2" => ScalarType::U16,
        "i2" => ScalarType::I16,
        "u4" => ScalarType::U32,
        "i4" => ScalarType::I32,
        "f4" => ScalarType::F32,
        "f8" => ScalarType::F64,
        _ => return Err(unsupported()),
    };
    Ok((scalar, big_endian))
}

/// The voxels of a Fortran-order array (its first logical axis, z, fastest) in the volume's
/// order, x fastest; `dims` = [nx, ny, nz].
fn c_order(fortran: &[f32], [nx, ny, nz]: [usize; 3]) -> Vec<f32> {
    let mut values = Vec::with_capacity(fortran.len());
    for z in 0..nz {
        for y in 0..ny {
            values.extend((0..nx).map(|x| fortran[z + nz * (y + ny * x)]));
        }
    }
    values
}

/// The volume's dims (x fastest) for an array of `shape` (its logical axes z, y, x); see the
/// module docs for the axis order.
fn dims(path: &Path, shape: &[i64]) -> Result<[usize; 3]> {
    let sizes: Option<Vec<usize>> = shape
        .iter()
        .map(|&s| usize::try_from(s).ok().filter(|&s| s > 0))
        .collect();
    match sizes.as_deref() {
        Some(&[a, b, c]) => Ok([c, b, a]),
        _ => Err(Error::format(
            path,
            format!("shape {shape:?}: only 3-D arrays with positive sizes are supported"),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_numpy_headers() {
        let h =
            Header::parse("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3, 4), }    \n")
                .unwrap();
        assert_eq!(
            h,
            Header {
                descr: "<f4".into(),
                fortran_order: false,
                shape: vec![2, 3, 4]
            }
        );
        let h = Header::parse("{\"shape\":(5,),\"fortran_order\":True,\"descr\":\"|u1\"}").unwrap();
        assert_eq!(h.shape, vec![5]);
        assert!(h.fortran_order);
        assert!(
            Header::parse("{'descr': [('a', '<f4')], 'fortran_order': False, 'shape': (2,)}")
                .is_err()
        );
        assert!(Header::parse("{'descr': '<f4', 'shape': (2,)}")
            .unwrap_err()
            .contains("fortran_order"));
        assert!(Header::parse("{'descr': '<f4'").is_err());
    }
}
