//! What every engine service keeps of the ragdolls it serves: each ragdoll's own data in
//! the order the engine added them, found by its first body (how the seam names a
//! ragdoll), and each joint by the engine's [`JointId`] (joints numbered in the order
//! added, every ragdoll's after the one before).

use std::ops::Deref;

use super::JointId;

/// One ragdoll a service holds.
#[derive(Clone, Debug)]
pub(crate) struct Held<T> {
    /// The engine's index of its first body.
    pub first_body: usize,
    /// Taken out of the engine: the service leaves it alone from then on.
    pub removed: bool,
    data: T,
}

impl<T> Deref for Held<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.data
    }
}

/// Every ragdoll a service holds, in the order added.
#[derive(Clone, Debug)]
pub(crate) struct Ragdolls<T> {
    list: Vec<Held<T>>,
    /// Each joint added: its ragdoll and its index there.
    joint_at: Vec<(usize, usize)>,
}

impl<T> Default for Ragdolls<T> {
    fn default() -> Self {
        Ragdolls {
            list: Vec::new(),
            joint_at: Vec::new(),
        }
    }
}

impl<T> Ragdolls<T> {
    /// Takes in a ragdoll whose first body is `first_body`, with `joints` joints.
    pub fn add(&mut self, first_body: usize, joints: usize, data: T) {
        let r = self.list.len();
        self.joint_at.extend((0..joints).map(|k| (r, k)));
        self.list.push(Held {
            first_body,
            removed: false,
            data,
        });
    }

    /// Marks the ragdoll whose first body is `first_body` as taken out.
    pub fn remove(&mut self, first_body: usize) {
        if let Some(r) = self.list.iter_mut().find(|r| r.first_body == first_body) {
            r.removed = true;
        }
    }

    /// The data of the ragdoll whose first body is `first_body`.
    pub fn get_mut(&mut self, first_body: usize) -> Option<&mut T> {
        let r = self.list.iter_mut().find(|r| r.first_body == first_body)?;
        Some(&mut r.data)
    }

    /// The data of `joint`'s ragdoll and the joint's index in it.
    pub fn joint_mut(&mut self, JointId(index): JointId) -> Option<(&mut T, usize)> {
        let &(r, k) = self.joint_at.get(index)?;
        Some((&mut self.list[r].data, k))
    }

    /// The ragdolls not taken out, in the order added.
    pub fn live(&self) -> impl Iterator<Item = &Held<T>> {
        self.list.iter().filter(|r| !r.removed)
    }
}
