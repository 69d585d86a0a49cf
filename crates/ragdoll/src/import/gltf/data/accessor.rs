//! Accessor reads, bounds checked against the resolved buffers and charged to one
//! import's budget.

use std::path::Path;

use glam::Mat4;
use gltf::accessor::{DataType, Dimensions};

use super::{format_err, u32_at};
use crate::error::{Error, Result};

/// Most accessor components (a `VEC3` has three) read from one glTF file in all: 64 Mi,
/// about 512 MB while being decoded. A million-vertex skinned mesh with normals and
/// triangles needs about 20 Mi; the limit stops a small file from naming one large accessor
/// many times (a mesh instanced by thousands of nodes) or asking for a huge accessor that
/// has no data at all (one without a buffer view is all zeros).
pub const MAX_ACCESSOR_COMPONENTS: usize = 64 << 20;

/// What is left of [`MAX_ACCESSOR_COMPONENTS`] for one import; every read is charged
/// before it allocates anything.
pub(crate) struct ReadBudget {
    left: std::cell::Cell<usize>,
}

impl ReadBudget {
    pub fn new() -> Self {
        ReadBudget {
            left: std::cell::Cell::new(MAX_ACCESSOR_COMPONENTS),
        }
    }

    /// Takes `a`'s components from the budget, or says which accessor went past it.
    pub fn charge(&self, reader: &AccessorReader, a: &gltf::Accessor) -> Result<()> {
        let (cols, rows, _) = layout(a.dimensions(), 1);
        let want = a.count().saturating_mul(cols * rows);
        match self.left.get().checked_sub(want) {
            Some(rest) => {
                self.left.set(rest);
                Ok(())
            }
            None => Err(reader.err(
                a,
                format!(
                    "{want} more components would pass the {MAX_ACCESSOR_COMPONENTS} that one import reads in all (every use of an accessor counts)"
                ),
            )),
        }
    }
}

/// Reads accessors with bounds checks against the resolved buffers.
pub(crate) struct AccessorReader<'a> {
    /// Resolved buffers, each cut to its declared length.
    pub buffers: &'a [Vec<u8>],
    /// The file, for error messages.
    pub path: &'a Path,
}

fn layout(dims: Dimensions, component_size: usize) -> (usize, usize, usize) {
    let (cols, rows) = match dims {
        Dimensions::Scalar => (1, 1),
        Dimensions::Vec2 => (1, 2),
        Dimensions::Vec3 => (1, 3),
        Dimensions::Vec4 => (1, 4),
        Dimensions::Mat2 => (2, 2),
        Dimensions::Mat3 => (3, 3),
        Dimensions::Mat4 => (4, 4),
    };
    // Matrix columns start on 4-byte boundaries (glTF 2.0 §3.6.2.4).
    let col_stride = if cols > 1 {
        (rows * component_size).next_multiple_of(4)
    } else {
        rows * component_size
    };
    (cols, rows, col_stride)
}

fn component_size(dt: DataType) -> usize {
    match dt {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

fn component(bytes: &[u8], at: usize, dt: DataType) -> f64 {
    match dt {
        DataType::I8 => bytes[at] as i8 as f64,
        DataType::U8 => bytes[at] as f64,
        DataType::I16 => i16::from_le_bytes([bytes[at], bytes[at + 1]]) as f64,
        DataType::U16 => u16::from_le_bytes([bytes[at], bytes[at + 1]]) as f64,
        DataType::U32 => u32_at(bytes, at) as f64,
        DataType::F32 => {
            f32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]) as f64
        }
    }
}

impl AccessorReader<'_> {
    fn err(&self, a: &gltf::Accessor, message: String) -> Error {
        format_err(self.path, format!("accessor {}", a.index()), message)
    }

    /// The bytes of a buffer view, checked against its buffer.
    fn view_bytes(&self, view: &gltf::buffer::View) -> Result<&[u8]> {
        let buf_index = view.buffer().index();
        let place = format!("bufferView {}", view.index());
        let buf = self.buffers.get(buf_index).ok_or_else(|| {
            format_err(
                self.path,
                &place,
                format!("buffer {buf_index} does not exist"),
            )
        })?;
        let start = view.offset();
        let end = start
            .checked_add(view.length())
            .filter(|&e| e <= buf.len())
            .ok_or_else(|| {
                format_err(
                    self.path,
                    &place,
                    format!(
                        "bytes {start}..{} run past the end of buffer {buf_index} ({} bytes)",
                        start.saturating_add(view.length()),
                        buf.len()
                    ),
                )
            })?;
        Ok(&buf[start..end])
    }

    /// Every component as `f64`, element by element, with sparse substitution applied but
    /// no normalisation; also returns the number of components per element.
    fn raw(&self, a: &gltf::Accessor) -> Result<(Vec<f64>, usize)> {
        let dt = a.data_type();
        let cs = component_size(dt);
        let (cols, rows, col_stride) = layout(a.dimensions(), cs);
        let shape = Elements {
            dt,
            cs,
            cols,
            rows,
            col_stride,
            elem: cols * col_stride,
            comps: cols * rows,
        };
        let count = a.count();
        let total = count
            .checked_mul(shape.comps)
            .filter(|&t| t <= MAX_ACCESSOR_COMPONENTS)
            .ok_or_else(|| {
                self.err(
                    a,
                    format!(
                        "count {count} is too large: more than the {MAX_ACCESSOR_COMPONENTS} components an import reads"
                    ),
                )
            })?;
        let mut out = vec![0.0; total];
        if let Some(view) = a.view() {
            self.read_dense(a, &view, &shape, &mut out)?;
        }
        if let Some(sparse) = a.sparse() {
            self.apply_sparse(a, &sparse, &shape, &mut out)?;
        }
        Ok((out, shape.comps))
    }

    /// Accessor `a`'s elements from its buffer `view` into `out`, checked to fit the view.
    fn read_dense(
        &self,
        a: &gltf::Accessor,
        view: &gltf::buffer::View,
        shape: &Elements,
        out: &mut [f64],
    ) -> Result<()> {
        let count = a.count();
        let data = self.view_bytes(view)?;
        let elem = shape.elem;
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(self.err(
                a,
                format!(
                    "bufferView {} has byteStride {stride}, less than one element ({elem} bytes)",
                    view.index()
                ),
            ));
        }
        if count > 0 {
            let need = (count - 1)
                .checked_mul(stride)
                .and_then(|n| n.checked_add(a.offset()))
                .and_then(|n| n.checked_add(elem));
            match need {
                Some(n) if n <= data.len() => {}
                _ => {
                    return Err(self.err(
                        a,
                        format!(
                            "{count} elements from byte {} need more than the {} bytes of bufferView {}",
                            a.offset(),
                            data.len(),
                            view.index()
                        ),
                    ));
                }
            }
        }
        let comps = shape.comps;
        for i in 0..count {
            shape.read_into(
                &mut out[i * comps..(i + 1) * comps],
                data,
                a.offset() + i * stride,
            );
        }
        Ok(())
    }

    /// Accessor `a`'s sparse substitutions written over `out`, indices and values checked.
    fn apply_sparse(
        &self,
        a: &gltf::Accessor,
        sparse: &gltf::accessor::sparse::Sparse,
        shape: &Elements,
        out: &mut [f64],
    ) -> Result<()> {
        let (count, comps, elem) = (a.count(), shape.comps, shape.elem);
        let n = sparse.count();
        let idx = sparse.indices();
        let (isize, idt) = match idx.index_type() {
            gltf::accessor::sparse::IndexType::U8 => (1, DataType::U8),
            gltf::accessor::sparse::IndexType::U16 => (2, DataType::U16),
            gltf::accessor::sparse::IndexType::U32 => (4, DataType::U32),
        };
        let idata = self.view_bytes(&idx.view())?;
        let vals = sparse.values();
        let vdata = self.view_bytes(&vals.view())?;
        let fits = |offset: usize, size: usize, len: usize| {
            n.checked_mul(size)
                .and_then(|b| b.checked_add(offset))
                .is_some_and(|end| end <= len)
        };
        if !fits(idx.offset(), isize, idata.len()) || !fits(vals.offset(), elem, vdata.len()) {
            return Err(self.err(
                a,
                format!("its {n} sparse entries run past the end of their buffer views"),
            ));
        }
        for k in 0..n {
            let i = component(idata, idx.offset() + k * isize, idt) as usize;
            if i >= count {
                return Err(self.err(
                    a,
                    format!("sparse index {i} is not below the count {count}"),
                ));
            }
            shape.read_into(
                &mut out[i * comps..(i + 1) * comps],
                vdata,
                vals.offset() + k * elem,
            );
        }
        Ok(())
    }

    /// Components as `f32`, normalised integers mapped to [0, 1] or [−1, 1]; also returns the
    /// number of components per element.
    pub fn floats(&self, a: &gltf::Accessor) -> Result<(Vec<f32>, usize)> {
        let (out, comps) = self.floats_as_stored(a)?;
        if out.iter().any(|v| !v.is_finite()) {
            return Err(self.err(a, "holds a value that is not a finite number".into()));
        }
        Ok((out, comps))
    }

    /// [`Self::floats`] with NaN and infinities kept, for data that can be repaired
    /// (skin weights) rather than refused.
    pub fn floats_as_stored(&self, a: &gltf::Accessor) -> Result<(Vec<f32>, usize)> {
        let (raw, comps) = self.raw(a)?;
        let scale = if a.normalized() {
            match a.data_type() {
                DataType::I8 => Some(127.0),
                DataType::U8 => Some(255.0),
                DataType::I16 => Some(32767.0),
                DataType::U16 => Some(65535.0),
                DataType::U32 => Some(4_294_967_295.0),
                DataType::F32 => None,
            }
        } else {
            None
        };
        let out: Vec<f32> = match scale {
            Some(s) => raw.iter().map(|v| (v / s).max(-1.0) as f32).collect(),
            None => raw.iter().map(|&v| v as f32).collect(),
        };
        Ok((out, comps))
    }

    /// Components of an integer accessor (indices, joint indices); also returns the number
    /// of components per element.
    pub fn uints(&self, a: &gltf::Accessor) -> Result<(Vec<u32>, usize)> {
        if a.data_type() == DataType::F32 || a.normalized() {
            return Err(self.err(
                a,
                "must hold unsigned integers (it holds floats or normalised values)".into(),
            ));
        }
        if matches!(a.data_type(), DataType::I8 | DataType::I16) {
            return Err(self.err(
                a,
                "must hold unsigned integers (it holds signed ones)".into(),
            ));
        }
        let (raw, comps) = self.raw(a)?;
        Ok((raw.into_iter().map(|v| v as u32).collect(), comps))
    }

    /// A `MAT4` float accessor as matrices.
    pub fn mat4s(&self, a: &gltf::Accessor) -> Result<Vec<Mat4>> {
        if a.dimensions() != Dimensions::Mat4 {
            return Err(self.err(a, "must be of type MAT4".into()));
        }
        let (f, _) = self.floats(a)?;
        Ok(f.chunks_exact(16).map(Mat4::from_cols_slice).collect())
    }

    /// Checks that an accessor has the element type a use needs, e.g. `VEC3` for positions.
    pub fn expect_dims(&self, a: &gltf::Accessor, dims: &[Dimensions], what: &str) -> Result<()> {
        if dims.contains(&a.dimensions()) {
            Ok(())
        } else {
            Err(self.err(
                a,
                format!("used as {what} but its type is {:?}", a.dimensions()),
            ))
        }
    }
}

/// How an accessor's elements lie in bytes: component type and size, columns and rows
/// (a matrix pads each column to 4 bytes), bytes per element, components per element.
struct Elements {
    dt: DataType,
    cs: usize,
    cols: usize,
    rows: usize,
    col_stride: usize,
    elem: usize,
    comps: usize,
}

impl Elements {
    /// One element at byte `base` of `data` into `out`, column by column.
    fn read_into(&self, out: &mut [f64], data: &[u8], base: usize) {
        for c in 0..self.cols {
            for r in 0..self.rows {
                out[c * self.rows + r] =
                    component(data, base + c * self.col_stride + r * self.cs, self.dt);
            }
        }
    }
}
