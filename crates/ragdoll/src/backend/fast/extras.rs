//! Bodies' extra shapes ([`crate::backend::BodyDesc::extra_shapes`]) in the whole world's
//! solver.
//!
//! An island's solver keeps shapes apart from bodies already (a compound carries its
//! parts' shapes, `freeze.rs`), so an extra shape is one more shape there, carried by its
//! body at its place. The whole world's solver keeps one shape per body in its per-body
//! arrays; its extra shapes are listed here, and its broad phase numbers every shape of
//! the world: body `i`'s own is shape `i`, extra `e` is shape `bodies + e`.
//!
//! Extra shapes meet the ground and other ragdolls, never their own ragdoll's bodies:
//! the bodies' own shapes keep a ragdoll from passing through itself, and a dragon's
//! skin pieces of two spine bodies met as it curled while dragged by its head, wedged
//! each other into the floor 6 cm deep, and pulled its joints 30 cm apart.

use std::ops::Range;

use glam::{Quat, Vec3};

use super::FastBackend;
use super::narrow::reach;
use crate::math::Transform;
use crate::spec::Shape;

/// The world's extra shapes.
#[derive(Clone, Debug, Default)]
pub(super) struct Extras {
    /// The body that carries each, its shape and its place in that body's frame.
    pub owner: Vec<u32>,
    pub shape: Vec<Shape>,
    pub attach: Vec<Transform>,
    /// Each body's extras, as a range of the lists above.
    pub of: Vec<Range<u32>>,
}

impl FastBackend {
    /// Adds body `i`'s extra shapes (in its frame), the last body added.
    pub(super) fn add_extras(&mut self, i: usize, extras: &[(Shape, Transform)]) {
        let start = self.extras.shape.len() as u32;
        for (shape, at) in extras {
            self.extras.owner.push(i as u32);
            self.extras.shape.push(*shape);
            self.extras.attach.push(*at);
        }
        self.extras.of.push(start..self.extras.shape.len() as u32);
    }

    /// How many shapes the whole world's broad phase sees: the bodies' own, then the
    /// extra ones.
    pub(super) fn world_shapes(&self) -> usize {
        self.pos.len() + self.extras.shape.len()
    }

    /// The body that carries world shape `k`.
    #[inline]
    pub(super) fn body_of_shape(&self, k: usize) -> usize {
        match k.checked_sub(self.pos.len()) {
            None => k,
            Some(e) => self.extras.owner[e] as usize,
        }
    }

    /// World shape `k`: its shape and its place in its body's frame (`None`: at the
    /// body's centre, the body's own shape).
    #[inline]
    pub(super) fn world_shape(&self, k: usize) -> (Shape, Option<Transform>) {
        match k.checked_sub(self.pos.len()) {
            None => (self.shape[k], None),
            Some(e) => (self.extras.shape[e], Some(self.extras.attach[e])),
        }
    }

    /// Where world shape `k` is now.
    pub(super) fn world_shape_pose(&self, k: usize) -> (Vec3, Quat) {
        let o = self.body_of_shape(k);
        match self.world_shape(k).1 {
            None => (self.pos[o], self.rot[o]),
            Some(t) => (
                self.pos[o] + self.rot[o] * t.translation,
                self.rot[o] * t.rotation,
            ),
        }
    }

    /// Farthest any shape of body `i` (its own and its extras) reaches from its centre,
    /// metres.
    pub(super) fn body_reach(&self, i: usize) -> f32 {
        let own = reach(&self.shape[i]);
        match self.extras.of.get(i) {
            Some(r) => r.clone().fold(own, |m, e| {
                let e = e as usize;
                m.max(self.extras.attach[e].translation.length() + reach(&self.extras.shape[e]))
            }),
            None => own,
        }
    }

    /// Adds body `i`'s extra shapes to the island solver `sub`, carried by its body
    /// `body` there, where body `i`'s own frame is at `part` in that body's frame (`None`:
    /// the same frame); records in `local` the shape each became.
    pub(super) fn push_extras_of(
        &self,
        i: usize,
        sub: &mut FastBackend,
        body: usize,
        part: Option<Transform>,
        local: &mut [u32],
    ) {
        let Some(range) = self.extras.of.get(i) else {
            return;
        };
        let bodies = self.pos.len();
        for e in range.clone() {
            let e = e as usize;
            let at = self.extras.attach[e];
            local[bodies + e] = sub.shape.len() as u32;
            sub.shape.push(self.extras.shape[e]);
            sub.owner.push(body as u32);
            sub.attach.push(Some(part.map_or(at, |p| p.mul(&at))));
            sub.holder.push(super::contact::NOTHING);
        }
    }
}
