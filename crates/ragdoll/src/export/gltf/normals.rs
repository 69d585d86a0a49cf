//! Vertex normals rescaled to unit length on the way out. glTF requires unit normals and
//! the Khronos validator counts every other one as an error; exporters write slightly or
//! badly scaled ones (the three-vrm sample avatar: 1,984 of them), and a baked file should
//! open clean wherever the source did not.

use std::collections::HashMap;

use gltf::mesh::Semantic;
use serde_json::{Map, Value, json};

use super::{ARRAY_BUFFER, Bin};
use crate::error::Result;
use crate::import::gltf::{AccessorReader, GltfSource};

/// How far from unit length a normal may be before it is rewritten: the validator's own
/// threshold (it reports `ACCESSOR_VECTOR3_NON_UNIT` past 0.0005).
const UNIT_TOLERANCE: f32 = 4.0e-4;

/// Rewrites each primitive's `NORMAL` accessor that holds a vector off unit length as a new
/// float accessor of unit vectors (a zero or non-finite one becomes +Y, which a renderer
/// lights like an upward face), shared accessors once.
pub(super) fn renormalise_normals(
    obj: &mut Map<String, Value>,
    doc: &gltf::Document,
    bin: &mut Bin,
    src: &GltfSource,
) -> Result<()> {
    let reader = AccessorReader {
        buffers: &src.buffers,
        path: &src.path,
    };
    let mut rewritten: HashMap<usize, Option<usize>> = HashMap::new();
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            let Some(acc) = prim.get(&Semantic::Normals) else {
                continue;
            };
            let new = match rewritten.get(&acc.index()) {
                Some(&new) => new,
                None => {
                    let new = unit_copy(&acc, &reader, bin)?;
                    rewritten.insert(acc.index(), new);
                    new
                }
            };
            if let (Some(new), Some(attrs)) = (
                new,
                super::weights::primitive_attributes(obj, mesh.index(), prim.index()),
            ) {
                attrs.insert("NORMAL".into(), json!(new));
            }
        }
    }
    Ok(())
}

/// A new accessor holding `acc`'s normals at unit length, or `None` when they already are.
fn unit_copy(
    acc: &gltf::Accessor,
    reader: &AccessorReader,
    bin: &mut Bin,
) -> Result<Option<usize>> {
    let (values, comps) = reader.floats_as_stored(acc)?;
    if comps != 3 {
        return Ok(None);
    }
    let off_unit = |n: &[f32]| {
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        !len.is_finite() || (len - 1.0).abs() > UNIT_TOLERANCE
    };
    if !values.chunks_exact(3).any(off_unit) {
        return Ok(None);
    }
    let mut out = Vec::with_capacity(values.len());
    for n in values.chunks_exact(3) {
        let v = glam::Vec3::new(n[0], n[1], n[2]);
        let unit = v.try_normalize().unwrap_or(glam::Vec3::Y);
        out.extend_from_slice(&unit.to_array());
    }
    let view = bin.push_view(&super::f32_bytes(out.iter().copied()), Some(ARRAY_BUFFER));
    Ok(Some(bin.push_accessor(json!({
        "bufferView": view,
        "componentType": super::FLOAT,
        "count": acc.count(),
        "type": "VEC3",
    }))))
}
