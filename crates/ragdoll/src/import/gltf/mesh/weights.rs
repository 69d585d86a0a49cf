//! Skin influences as a file gives them, repaired rather than refused.
//!
//! Exporters leave NaN, infinite or negative weights, weights that do not sum to 1, joint
//! indices past the skin, and vertices with no weight at all (12 NaN weights are a common
//! defect). Viewers draw such vertices somewhere arbitrary or not at all, and refusing the
//! whole character for a handful of them helps nobody, so each is mended the way a user
//! would mend it by hand, and the importer says so in one warning per primitive
//! ([`WeightRepair::sentence`]). The exporter reads through the same code, so the file it
//! writes carries the repaired weights the ragdoll was built from.

use std::collections::VecDeque;

use gltf::accessor::Dimensions;
use gltf::mesh::{Mode, Semantic};

use super::super::data::{AccessorReader, format_err};
use crate::error::Result;

/// Per vertex, its (skin joint slot, weight) pairs.
pub(crate) type Influences = Vec<Vec<(usize, f32)>>;

/// Most `JOINTS_n`/`WEIGHTS_n` sets a primitive may have: 16, 64 influences per vertex.
/// Exporters write one or two; the limit keeps merging a vertex's influences cheap.
pub const MAX_INFLUENCE_SETS: usize = 16;

/// How far a vertex's weights may sum from 1 before renormalising them counts as a
/// repair worth a warning: 1 %. Weights stored as normalised bytes are off by up to 2/255
/// (0.8 %) from rounding alone, and floats by far less; renormalising those is silent,
/// since it changes nothing a user could see.
pub const WEIGHT_SUM_TOLERANCE: f32 = 0.01;

/// The skin a primitive's `JOINTS_n` index into.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SkinSlots {
    /// Number of joints in the skin: a joint index at or past it names nothing.
    pub count: usize,
    /// The slot of the skin's root joint, which carries parts with no weight at all.
    pub root: usize,
}

/// What was mended in one primitive's influences, counted in vertices.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct WeightRepair {
    /// Vertices with a NaN, infinite or negative weight (each such weight set to 0).
    pub not_finite_or_negative: usize,
    /// Vertices weighted to a joint index past the skin (each such weight set to 0).
    pub joint_out_of_range: usize,
    /// Vertices whose usable weights summed further than [`WEIGHT_SUM_TOLERANCE`] from 1.
    pub unnormalised: usize,
    /// Vertices left with no usable weight, given their nearest weighted neighbour's.
    pub from_neighbour: usize,
    /// Vertices left with no usable weight and no weighted vertex on their part of the
    /// mesh, bound to the skin's root joint.
    pub to_root: usize,
    /// Distinct vertices changed by any of the above.
    pub vertices: usize,
}

impl WeightRepair {
    /// Whether nothing needed mending.
    pub fn is_empty(&self) -> bool {
        self.vertices == 0
    }

    /// One sentence for the user: `place` names the primitive and its accessors, `root`
    /// the root joint.
    pub fn sentence(&self, place: &str, vertex_count: usize, joints: usize, root: &str) -> String {
        let mut parts = Vec::new();
        let mut part = |n: usize, what: String| {
            if n > 0 {
                parts.push(format!("{n} {what}"));
            }
        };
        part(
            self.not_finite_or_negative,
            "had a NaN, infinite or negative weight, set to 0".into(),
        );
        part(
            self.joint_out_of_range,
            format!("named a joint past the skin's {joints}, whose weight was set to 0"),
        );
        part(
            self.unnormalised,
            "had weights that did not sum to 1, renormalised".into(),
        );
        part(
            self.from_neighbour,
            "were left with no weight and now follow their nearest weighted neighbour".into(),
        );
        part(
            self.to_root,
            format!(
                "were on a part with no weight at all and now follow the root joint \"{root}\""
            ),
        );
        format!(
            "{place}: repaired the skin weights of {} of {vertex_count} vertices ({})",
            self.vertices,
            parts.join("; ")
        )
    }
}

/// A primitive's `JOINTS_n`/`WEIGHTS_n` accessor pairs, `n` from 0 up to the first gap.
pub(crate) fn influence_sets<'a>(
    prim: &gltf::Primitive<'a>,
) -> Vec<(gltf::Accessor<'a>, gltf::Accessor<'a>)> {
    let mut sets = Vec::new();
    for k in 0.. {
        match (
            prim.get(&Semantic::Joints(k)),
            prim.get(&Semantic::Weights(k)),
        ) {
            // One past the limit, so that the caller can tell it was passed.
            (Some(j), Some(w)) if sets.len() <= MAX_INFLUENCE_SETS => sets.push((j, w)),
            _ => break,
        }
    }
    sets
}

/// The (skin slot, weight) pairs of every vertex of a primitive, over all its
/// `JOINTS_n`/`WEIGHTS_n` sets, repaired and renormalised to sum 1, with what was
/// repaired. `None` when the primitive is not skinned. `charge` is called with every
/// accessor before it is read (the importer's read budget).
///
/// A weight that is NaN, infinite or negative, or that names a joint past the skin, is set
/// to 0: it says nothing usable about where the vertex goes, and the vertex's other
/// weights usually do. A vertex left with no weight takes the influences of the nearest
/// weighted vertex along the mesh's edges (fewest edges; ties: the lowest vertex index),
/// so it moves with the surface around it and the mesh does not tear there; binding it to
/// one fixed joint instead would pull a spike out of the surface as soon as the limb
/// moved. A part of the mesh with no weighted vertex at all (a loose eye or button, or a
/// primitive whose weights are all bad) has no such neighbour and follows the skin's root
/// joint: it then moves with the character as a whole, which is what an unrigged prop
/// parented to the character would do.
pub(crate) fn read_influences(
    prim: &gltf::Primitive,
    vertex_count: usize,
    skin: SkinSlots,
    reader: &AccessorReader,
    charge: &dyn Fn(&gltf::Accessor) -> Result<()>,
) -> Result<Option<(Influences, WeightRepair)>> {
    let sets = influence_sets(prim);
    if sets.is_empty() {
        return Ok(None);
    }
    check_sets(&sets, vertex_count, reader)?;
    let (mut out, flags) = gather(&sets, vertex_count, skin, reader, charge)?;
    let (mut repair, unweighted) = normalise(&mut out, &flags);
    if !unweighted.is_empty() {
        let edges = edges(prim, vertex_count, reader, charge)?;
        let (near, far) = fill_from_neighbours(&mut out, &edges, skin.root);
        repair.from_neighbour = near;
        repair.to_root = far;
    }
    Ok(Some((out, repair)))
}

/// Every check of a primitive's influence sets that needs no data, so a count that does
/// not match the vertices is refused before anything is read or allocated for it.
fn check_sets(
    sets: &[(gltf::Accessor, gltf::Accessor)],
    vertex_count: usize,
    reader: &AccessorReader,
) -> Result<()> {
    if sets.len() > MAX_INFLUENCE_SETS {
        return Err(format_err(
            reader.path,
            format!("accessor {}", sets[MAX_INFLUENCE_SETS].0.index()),
            format!(
                "a primitive has more than {MAX_INFLUENCE_SETS} JOINTS_n/WEIGHTS_n sets; this importer reads at most that many"
            ),
        ));
    }
    for (ja, wa) in sets {
        reader.expect_dims(ja, &[Dimensions::Vec4], "JOINTS")?;
        reader.expect_dims(wa, &[Dimensions::Vec4], "WEIGHTS")?;
        for a in [ja, wa] {
            if a.count() != vertex_count {
                return Err(format_err(
                    reader.path,
                    format!("accessor {}", a.index()),
                    format!("has {} elements for {vertex_count} vertices", a.count()),
                ));
            }
        }
    }
    Ok(())
}

/// A bad weight (non-finite or negative) in a vertex's flags.
const BAD_WEIGHT: u8 = 1;
/// A joint index past the skin in a vertex's flags.
const JOINT_OUT_OF_RANGE: u8 = 2;

/// Every vertex's positive weights on joints of the skin, merged per joint over all sets,
/// and per vertex the flags of what was dropped ([`BAD_WEIGHT`], [`JOINT_OUT_OF_RANGE`]).
fn gather(
    sets: &[(gltf::Accessor, gltf::Accessor)],
    vertex_count: usize,
    skin: SkinSlots,
    reader: &AccessorReader,
    charge: &dyn Fn(&gltf::Accessor) -> Result<()>,
) -> Result<(Influences, Vec<u8>)> {
    let mut out: Influences = Vec::new();
    let mut flags: Vec<u8> = Vec::new();
    for (k, (ja, wa)) in sets.iter().enumerate() {
        charge(ja)?;
        charge(wa)?;
        let (js, _) = reader.uints(ja)?;
        let (ws, _) = reader.floats_as_stored(wa)?;
        if k == 0 {
            // Both accessors were read, so the vertex count is backed by data.
            out = vec![Vec::new(); vertex_count];
            flags = vec![0; vertex_count];
        }
        for (v, (jv, wv)) in js.chunks_exact(4).zip(ws.chunks_exact(4)).enumerate() {
            for c in 0..4 {
                let (slot, w) = (jv[c] as usize, wv[c]);
                if !w.is_finite() || w < 0.0 {
                    flags[v] |= BAD_WEIGHT;
                    continue;
                }
                if w == 0.0 {
                    continue;
                }
                if slot >= skin.count {
                    flags[v] |= JOINT_OUT_OF_RANGE;
                    continue;
                }
                match out[v].iter_mut().find(|(s, _)| *s == slot) {
                    Some((_, acc)) => *acc += w,
                    None => out[v].push((slot, w)),
                }
            }
        }
    }
    Ok((out, flags))
}

/// Scales each vertex's weights to sum to 1 and counts what was repaired; returns the
/// count and the vertices left with no weight at all (for their neighbours to fill).
fn normalise(out: &mut Influences, flags: &[u8]) -> (WeightRepair, Vec<usize>) {
    let mut repair = WeightRepair::default();
    let mut unweighted = Vec::new();
    for (v, infl) in out.iter_mut().enumerate() {
        // In f64: finite f32 weights can still overflow an f32 sum.
        let sum: f64 = infl.iter().map(|&(_, w)| w as f64).sum();
        let mut changed = flags[v] != 0;
        repair.not_finite_or_negative += (flags[v] & BAD_WEIGHT != 0) as usize;
        repair.joint_out_of_range += (flags[v] & JOINT_OUT_OF_RANGE != 0) as usize;
        if sum > 0.0 {
            if (sum - 1.0).abs() > WEIGHT_SUM_TOLERANCE as f64 {
                repair.unnormalised += 1;
                changed = true;
            }
            infl.iter_mut()
                .for_each(|(_, w)| *w = (*w as f64 / sum) as f32);
        } else {
            infl.clear();
            unweighted.push(v);
            changed = true;
        }
        repair.vertices += changed as usize;
    }
    (repair, unweighted)
}

/// Each vertex's neighbours along the primitive's triangle edges, as offsets into one
/// list (compressed rows), so a million-vertex mesh costs a few arrays, not a million
/// vectors. Empty rows for a primitive that is not a triangle list.
struct Edges {
    start: Vec<usize>,
    to: Vec<u32>,
}

fn edges(
    prim: &gltf::Primitive,
    n: usize,
    reader: &AccessorReader,
    charge: &dyn Fn(&gltf::Accessor) -> Result<()>,
) -> Result<Edges> {
    let indices: Vec<u32> = if prim.mode() != Mode::Triangles {
        Vec::new()
    } else if let Some(a) = prim.indices() {
        reader.expect_dims(&a, &[Dimensions::Scalar], "indices")?;
        charge(&a)?;
        let (ix, _) = reader.uints(&a)?;
        if let Some(bad) = ix.iter().find(|&&i| i as usize >= n) {
            return Err(format_err(
                reader.path,
                format!("accessor {}", a.index()),
                format!("index {bad} is not below the vertex count {n}"),
            ));
        }
        ix
    } else {
        (0..n as u32).collect()
    };
    let tris = &indices[..indices.len() / 3 * 3];
    let mut degree = vec![0usize; n + 1];
    for t in tris.chunks_exact(3) {
        for &i in t {
            degree[i as usize] += 2;
        }
    }
    let mut start = vec![0usize; n + 1];
    for v in 0..n {
        start[v + 1] = start[v] + degree[v];
    }
    let mut fill = start.clone();
    let mut to = vec![0u32; start[n]];
    for t in tris.chunks_exact(3) {
        for c in 0..3 {
            let a = t[c] as usize;
            for d in [1, 2] {
                to[fill[a]] = t[(c + d) % 3];
                fill[a] += 1;
            }
        }
    }
    Ok(Edges { start, to })
}

/// Gives every vertex without influences those of its nearest weighted vertex along
/// `edges` (a breadth-first search from all weighted vertices at once, so the cost is
/// linear in the mesh), and the root slot alone where none is reachable. Returns how many
/// vertices got a neighbour's and how many the root's.
fn fill_from_neighbours(infl: &mut Influences, edges: &Edges, root: usize) -> (usize, usize) {
    let n = infl.len();
    // The weighted vertex each vertex takes its influences from.
    let mut source: Vec<Option<u32>> = (0..n)
        .map(|v| (!infl[v].is_empty()).then_some(v as u32))
        .collect();
    let mut queue: VecDeque<usize> = (0..n).filter(|&v| source[v].is_some()).collect();
    while let Some(v) = queue.pop_front() {
        let from = source[v];
        let row = edges.start.get(v..v + 2).map_or(0..0, |r| r[0]..r[1]);
        for &u in &edges.to[row] {
            let u = u as usize;
            if source[u].is_none() {
                source[u] = from;
                queue.push_back(u);
            }
        }
    }
    let (mut near, mut far) = (0, 0);
    for v in 0..n {
        if !infl[v].is_empty() {
            continue;
        }
        match source[v] {
            Some(s) => {
                infl[v] = infl[s as usize].clone();
                near += 1;
            }
            None => {
                infl[v] = vec![(root, 1.0)];
                far += 1;
            }
        }
    }
    (near, far)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A chain 0-1-2-…: each vertex's neighbours are the ones beside it.
    fn chain(n: usize) -> Edges {
        let mut start = vec![0];
        let mut to = Vec::new();
        for v in 0..n {
            if v > 0 {
                to.push(v as u32 - 1);
            }
            if v + 1 < n {
                to.push(v as u32 + 1);
            }
            start.push(to.len());
        }
        Edges { start, to }
    }

    #[test]
    fn an_unweighted_vertex_takes_its_nearest_weighted_neighbours_influences() {
        let mut infl: Influences = vec![
            vec![(3, 1.0)],
            vec![],
            vec![],
            vec![],
            vec![(5, 0.5), (6, 0.5)],
        ];
        let (near, far) = fill_from_neighbours(&mut infl, &chain(5), 0);
        assert_eq!((near, far), (3, 0));
        assert_eq!(infl[1], vec![(3, 1.0)]);
        // Two edges from both ends: the tie goes to the lower vertex, found first.
        assert_eq!(infl[2], vec![(3, 1.0)]);
        assert_eq!(infl[3], vec![(5, 0.5), (6, 0.5)]);
    }

    #[test]
    fn a_part_with_no_weight_at_all_follows_the_root() {
        let mut infl: Influences = vec![vec![(2, 1.0)], vec![], vec![]];
        let none = Edges {
            start: vec![0; 4],
            to: Vec::new(),
        };
        let (near, far) = fill_from_neighbours(&mut infl, &none, 7);
        assert_eq!((near, far), (0, 2));
        assert_eq!(infl[1], vec![(7, 1.0)]);
        assert_eq!(infl[0], vec![(2, 1.0)]);
    }

    #[test]
    fn the_sentence_names_each_kind_of_repair_once() {
        let r = WeightRepair {
            not_finite_or_negative: 12,
            joint_out_of_range: 0,
            unnormalised: 0,
            from_neighbour: 2,
            to_root: 0,
            vertices: 12,
        };
        let s = r.sentence(
            "mesh \"body\" primitive 0, WEIGHTS_0 accessor 4",
            300,
            19,
            "hips",
        );
        assert_eq!(
            s,
            "mesh \"body\" primitive 0, WEIGHTS_0 accessor 4: repaired the skin weights of 12 of 300 vertices \
             (12 had a NaN, infinite or negative weight, set to 0; 2 were left with no weight and now follow \
             their nearest weighted neighbour)"
        );
    }
}
