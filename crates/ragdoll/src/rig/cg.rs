//! A sparse symmetric positive-definite solve for bone heat: Jacobi-preconditioned
//! conjugate gradients on a compressed-row matrix, several right-hand sides at once.
//!
//! Hand-written rather than a crate: the heat system is symmetric positive definite (a
//! cotangent Laplacian with non-negative weights plus a positive diagonal), where plain
//! preconditioned CG converges, needs memory linear in the matrix (a direct factorisation
//! such as `sprs-ldl` fills in, and on a 300,000-vertex mesh that is gigabytes), and is
//! sixty lines without a dependency. Solving a few bones together reads the matrix once
//! per iteration for all of them.

/// A square sparse matrix in compressed-row form, both triangles stored.
pub(super) struct Csr {
    /// Row `r`'s entries are `start[r]..start[r + 1]`.
    pub start: Vec<usize>,
    pub col: Vec<u32>,
    pub val: Vec<f64>,
}

impl Csr {
    fn rows(&self) -> usize {
        self.start.len() - 1
    }

    /// `y = A x` for `k` interleaved vectors (`x[r * k + c]` is row `r` of vector `c`).
    fn mul(&self, x: &[f64], y: &mut [f64], k: usize) {
        for r in 0..self.rows() {
            let out = &mut y[r * k..(r + 1) * k];
            out.fill(0.0);
            for e in self.start[r]..self.start[r + 1] {
                let (c, v) = (self.col[e] as usize, self.val[e]);
                for (o, xi) in out.iter_mut().zip(&x[c * k..(c + 1) * k]) {
                    *o += v * xi;
                }
            }
        }
    }

    fn diagonal(&self) -> Vec<f64> {
        (0..self.rows())
            .map(|r| {
                (self.start[r]..self.start[r + 1])
                    .find(|&e| self.col[e] as usize == r)
                    .map_or(0.0, |e| self.val[e])
            })
            .collect()
    }
}

/// Solves `A X = B` for `k` interleaved right-hand sides, each to a residual of at most
/// `tol` times its own norm, in at most `max_iter` iterations; returns the solution and the
/// iterations spent. `Err` holds the iterations spent when some column did not converge
/// (or the matrix proved not positive definite).
pub(super) fn solve(
    a: &Csr,
    b: &[f64],
    k: usize,
    tol: f64,
    max_iter: usize,
) -> Result<(Vec<f64>, usize), usize> {
    let n = a.rows();
    let inv_diag: Vec<f64> = a
        .diagonal()
        .iter()
        .map(|&d| if d > 0.0 { 1.0 / d } else { 1.0 })
        .collect();
    let dot = |u: &[f64], v: &[f64], c: usize| -> f64 {
        (0..n).map(|r| u[r * k + c] * v[r * k + c]).sum::<f64>()
    };
    let mut x = vec![0.0; n * k];
    let mut r = b.to_vec();
    let mut z: Vec<f64> = (0..n * k).map(|i| r[i] * inv_diag[i / k]).collect();
    let mut p = z.clone();
    let mut ap = vec![0.0; n * k];
    let goal: Vec<f64> = (0..k).map(|c| tol * dot(b, b, c).sqrt()).collect();
    let mut rz: Vec<f64> = (0..k).map(|c| dot(&r, &z, c)).collect();
    let mut done: Vec<bool> = (0..k).map(|c| dot(&r, &r, c).sqrt() <= goal[c]).collect();
    for it in 0..max_iter {
        if done.iter().all(|&d| d) {
            return Ok((x, it));
        }
        a.mul(&p, &mut ap, k);
        for c in 0..k {
            if done[c] {
                continue;
            }
            let pap = dot(&p, &ap, c);
            if !(pap > 0.0 && pap.is_finite()) {
                return Err(it);
            }
            let alpha = rz[c] / pap;
            for i in 0..n {
                x[i * k + c] += alpha * p[i * k + c];
                r[i * k + c] -= alpha * ap[i * k + c];
            }
            done[c] = dot(&r, &r, c).sqrt() <= goal[c];
        }
        for i in 0..n * k {
            z[i] = r[i] * inv_diag[i / k];
        }
        for c in 0..k {
            if done[c] {
                continue;
            }
            let rz_new = dot(&r, &z, c);
            let beta = rz_new / rz[c];
            rz[c] = rz_new;
            for i in 0..n {
                p[i * k + c] = z[i * k + c] + beta * p[i * k + c];
            }
        }
    }
    if done.iter().all(|&d| d) {
        Ok((x, max_iter))
    } else {
        Err(max_iter)
    }
}
