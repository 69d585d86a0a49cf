//! The binary chunk a baked GLB is written into: the input's buffers merged into one, and
//! new buffer views and accessors appended to it.

use serde_json::{Map, Value, json};

use super::FLOAT;
use crate::error::Result;
use crate::import::gltf::{GltfSource, format_err};

/// The GLB binary chunk under construction, with the buffer views and accessors that
/// point into it.
#[derive(Default)]
pub(super) struct Bin {
    pub(super) data: Vec<u8>,
    pub(super) views: Vec<Value>,
    pub(super) accessors: Vec<Value>,
}

pub(super) fn pad_to_4(v: &mut Vec<u8>, fill: u8) {
    while v.len() % 4 != 0 {
        v.push(fill);
    }
}

pub(super) fn f32_bytes(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

impl Bin {
    /// Appends bytes as a new buffer view, 4-byte aligned (enough for every component type).
    pub(super) fn push_view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        pad_to_4(&mut self.data, 0);
        let mut v = json!({"buffer": 0, "byteOffset": self.data.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.data.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    pub(super) fn push_accessor(&mut self, accessor: Value) -> usize {
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// A float accessor in a view of its own.
    pub(super) fn floats(
        &mut self,
        values: &[f32],
        kind: &str,
        target: Option<u32>,
        with_bounds: bool,
    ) -> usize {
        let comps = components(kind);
        let view = self.push_view(&f32_bytes(values.iter().copied()), target);
        let mut a = json!({
            "bufferView": view,
            "componentType": FLOAT,
            "count": values.len() / comps,
            "type": kind,
        });
        if with_bounds {
            let (min, max) = bounds(values, comps);
            a["min"] = json!(min);
            a["max"] = json!(max);
        }
        self.push_accessor(a)
    }
}

pub(super) fn components(kind: &str) -> usize {
    match kind {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" => 4,
        "MAT4" => 16,
        _ => unreachable!("accessor type {kind} is not written here"),
    }
}

fn bounds(values: &[f32], comps: usize) -> (Vec<f32>, Vec<f32>) {
    let mut min = vec![f32::INFINITY; comps];
    let mut max = vec![f32::NEG_INFINITY; comps];
    for e in values.chunks_exact(comps) {
        for c in 0..comps {
            min[c] = min[c].min(e[c]);
            max[c] = max[c].max(e[c]);
        }
    }
    (min, max)
}

pub(super) fn take_array(obj: &mut Map<String, Value>, key: &str) -> Vec<Value> {
    match obj.remove(key) {
        Some(Value::Array(a)) => a,
        _ => Vec::new(),
    }
}

/// One buffer: the input's buffers back to back, their views taken out of `obj` and moved
/// along with them.
pub(super) fn merged_buffers(obj: &mut Map<String, Value>, src: &GltfSource) -> Result<Bin> {
    let path = src.path.as_path();
    let mut bin = Bin::default();
    let mut bases = Vec::with_capacity(src.buffers.len());
    for b in &src.buffers {
        pad_to_4(&mut bin.data, 0);
        bases.push(bin.data.len());
        bin.data.extend_from_slice(b);
    }
    bin.views = take_array(obj, "bufferViews");
    for (i, v) in bin.views.iter_mut().enumerate() {
        let buffer = v.get("buffer").and_then(Value::as_u64).unwrap_or(u64::MAX) as usize;
        let base = *bases.get(buffer).ok_or_else(|| {
            format_err(
                path,
                format!("bufferView {i}"),
                "refers to a missing buffer",
            )
        })?;
        let offset = v.get("byteOffset").and_then(Value::as_u64).unwrap_or(0);
        let moved = (base as u64).checked_add(offset).ok_or_else(|| {
            format_err(
                path,
                format!("bufferView {i}"),
                "byteOffset is past any buffer",
            )
        })?;
        v["buffer"] = json!(0);
        v["byteOffset"] = json!(moved);
    }
    Ok(bin)
}
