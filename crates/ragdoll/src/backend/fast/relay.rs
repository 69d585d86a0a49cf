//! Two workers sharing the step of an island cut in two (`split.rs`).

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use super::FastBackend;
use super::solve::substep_fractions;
use super::split::Seam;

/// The phases of one step of an island cut in two: each half runs a phase, and once both
/// have, the seam runs its share of it.
pub(super) struct Plan {
    pub substeps: usize,
    pub passes: usize,
    pub dt: f32,
}

pub(super) enum Phase {
    Begin,
    /// A pass of a substep ending `frac` of the way through the step.
    Pass {
        pass: usize,
        frac0: f32,
        frac: f32,
    },
    Velocities,
    End,
}

impl Plan {
    fn phases(&self) -> usize {
        2 + self.substeps * (self.passes + 1)
    }

    pub(super) fn phase(&self, k: usize) -> Phase {
        if k == 0 {
            return Phase::Begin;
        }
        if k + 1 >= self.phases() {
            return Phase::End;
        }
        let (substep, pass) = ((k - 1) / (self.passes + 1), (k - 1) % (self.passes + 1));
        if pass == self.passes {
            return Phase::Velocities;
        }
        let (frac0, frac) = substep_fractions(substep, self.substeps);
        Phase::Pass { pass, frac0, frac }
    }

    /// Phase `k` on one half.
    fn run(&self, part: &mut FastBackend, k: usize) {
        let h = self.dt / self.substeps as f32;
        match self.phase(k) {
            Phase::Begin => {
                part.begin_solve(self.dt);
            }
            Phase::Pass { pass, frac0, frac } => {
                if pass == 0 {
                    part.begin_substep(h, frac, self.dt);
                }
                part.solve_pass(pass, h, frac0, frac);
            }
            Phase::Velocities => part.end_substep(h),
            Phase::End => part.end_solve(self.dt),
        }
    }
}

/// Two workers sharing one step of an island cut in two, a few hundred phases of tens of
/// microseconds each: each takes the next half-phase there is, waits (spinning) until
/// the phase before it is through, runs it, and the second to finish a phase runs the
/// seam's share. A fork and join per phase instead (`rayon::join`) cost 33 µs a phase in
/// waking the other thread, a fifth of the step. Where the pool has no second thread
/// free, one worker takes every half-phase in turn and the other finds nothing left.
pub(super) struct Relay<'a, 'b> {
    halves: [Mutex<&'a mut FastBackend>; 2],
    seam: Mutex<&'b mut Seam>,
    /// The next half-phase to take (phase `k`'s halves are `2k` and `2k + 1`), the
    /// half-phases finished, and the phases the seam is through.
    next: AtomicUsize,
    finished: AtomicUsize,
    ready: AtomicUsize,
    /// Set when a worker panicked, so the other stops waiting for it.
    failed: AtomicBool,
}

impl Relay<'_, '_> {
    /// One step of the island whose halves are `a` and `b`, cut by `seam`.
    pub(super) fn run(a: &mut FastBackend, b: &mut FastBackend, seam: &mut Seam, plan: &Plan) {
        let relay = Relay {
            halves: [Mutex::new(a), Mutex::new(b)],
            seam: Mutex::new(seam),
            next: AtomicUsize::new(0),
            finished: AtomicUsize::new(0),
            ready: AtomicUsize::new(0),
            failed: AtomicBool::new(false),
        };
        rayon::join(|| relay.work(plan), || relay.work(plan));
    }

    fn work(&self, plan: &Plan) {
        let _alarm = Alarm(&self.failed);
        let tasks = 2 * plan.phases();
        loop {
            let t = self.next.fetch_add(1, Ordering::Relaxed);
            if t >= tasks {
                break;
            }
            let (phase, half) = (t / 2, t % 2);
            let mut spins = 0u32;
            while self.ready.load(Ordering::Acquire) < phase {
                if self.failed.load(Ordering::Relaxed) {
                    return;
                }
                spins += 1;
                if spins < 1 << 12 {
                    std::hint::spin_loop();
                } else {
                    std::thread::yield_now();
                }
            }
            plan.run(&mut lock(&self.halves[half]), phase);
            if self.finished.fetch_add(1, Ordering::AcqRel) % 2 == 1 {
                let (mut a, mut b) = (lock(&self.halves[0]), lock(&self.halves[1]));
                lock(&self.seam).after(&mut [&mut **a, &mut **b], plan, phase);
                self.ready.store(phase + 1, Ordering::Release);
            }
        }
    }
}

/// Raises its flag if dropped while its thread unwinds from a panic.
struct Alarm<'a>(&'a AtomicBool);

impl Drop for Alarm<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.store(true, Ordering::Relaxed);
        }
    }
}

/// A lock a panic elsewhere does not poison for good: the step is lost either way.
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}
