//! The coupled implicit step: one linearly implicit Euler step on every angle of a strand.
//!
//! Ward & Lin's Appendix A linearises only each angle's own spring. Here the whole generalised
//! torque is linearised: `I dw = h tau(q + h (w + dw), w + dw)` with
//! `tau(q + dq, w + dw) ~ tau + (J - K) dq - G dw`, which gives the dense system
//! `(I + h G + h^2 (K - J)) dw = h tau + h^2 (J - K) w` per strand (derivation in
//! `docs/dynamics.md`). `J` is the derivative of the load's torque with respect to every angle,
//! dense in angle coordinates. Strands of 20-32 points give systems of 38-62 unknowns: a
//! hand-written LU with partial pivoting solves them; faer's LU is the reference it is tested
//! against and can be selected.

use super::spring_of;
use crate::strand::{RootDyn, Scratch, StrandParams};
use nalgebra::RealField;

/// The dense solver of the coupled implicit step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum LinearSolver {
    /// Hand-written LU with partial pivoting, in place in the strand's scratch (no allocation).
    #[default]
    Hand,
    /// faer's partial-pivoting LU (the reference; allocates per solve).
    Faer,
}

pub(super) fn solve_step<T: RealField + Copy>(
    root: &RootDyn<T>,
    p: &StrandParams<'_, T>,
    q: &mut [T],
    w: &mut [T],
    h: T,
    solver: LinearSolver,
    sc: &mut Scratch<T>,
) {
    let m2 = q.len();
    let h2 = h * h;
    // A = diag(I + h g + h^2 k) - h^2 J ; b = h tau + h^2 (J w - k w)
    for l in 0..m2 {
        let i = l / 2 + 1;
        let k = spring_of(root, p, i, l);
        let row = l * m2;
        let mut jw = T::zero();
        for c in 0..m2 {
            let j = sc.jac[row + c];
            jw += j * w[c];
            sc.lu[row + c] = -h2 * j;
        }
        sc.lu[row + l] += sc.inertia[l] + h * p.damping[i] + h2 * k;
        sc.rhs[l] = h * sc.tau[l] + h2 * (jw - k * w[l]);
    }
    let ok = match solver {
        LinearSolver::Hand => lu_solve_in_place(
            &mut sc.lu[..m2 * m2],
            &mut sc.perm[..m2],
            &mut sc.rhs[..m2],
            m2,
        ),
        LinearSolver::Faer => faer_solve(&sc.lu[..m2 * m2], &mut sc.rhs[..m2], m2),
    };
    if !ok {
        // A singular system (an unstable equilibrium hit exactly) poisons the state on purpose:
        // the caller restores the strand and reports it rather than carrying a guess.
        sc.rhs[..m2]
            .iter_mut()
            .for_each(|x| *x = T::zero() / T::zero());
    }
    for c in 0..m2 {
        w[c] += sc.rhs[c];
        q[c] += h * w[c];
    }
}

/// Solves `A x = b` for a row-major `n x n` matrix in place (`b` becomes `x`). Returns `false`
/// when a pivot is exactly zero.
pub(crate) fn lu_solve_in_place<T: RealField + Copy>(
    a: &mut [T],
    perm: &mut [usize],
    b: &mut [T],
    n: usize,
) -> bool {
    for (i, p) in perm.iter_mut().enumerate().take(n) {
        *p = i;
    }
    for k in 0..n {
        // Pivot: the largest magnitude in column k at or below the diagonal.
        let mut piv = k;
        let mut best = a[k * n + k].abs();
        for r in k + 1..n {
            let v = a[r * n + k].abs();
            if v > best {
                best = v;
                piv = r;
            }
        }
        if best == T::zero() {
            return false;
        }
        if piv != k {
            for c in 0..n {
                a.swap(k * n + c, piv * n + c);
            }
            b.swap(k, piv);
            perm.swap(k, piv);
        }
        let inv = T::one() / a[k * n + k];
        for r in k + 1..n {
            let f = a[r * n + k] * inv;
            if f != T::zero() {
                a[r * n + k] = f;
                let (top, bottom) = a.split_at_mut(r * n);
                let pivot_row = &top[k * n + k + 1..k * n + n];
                let row = &mut bottom[k + 1..n];
                for (x, y) in row.iter_mut().zip(pivot_row) {
                    *x -= f * *y;
                }
                let bk = b[k];
                b[r] -= f * bk;
            }
        }
    }
    for k in (0..n).rev() {
        let mut s = b[k];
        for c in k + 1..n {
            s -= a[k * n + c] * b[c];
        }
        b[k] = s / a[k * n + k];
    }
    true
}

/// faer's LU as the reference solver (f32 and f64).
fn faer_solve<T: RealField + Copy>(a: &[T], b: &mut [T], n: usize) -> bool {
    // faer is generic over its own field trait; go through f64, which is exact for f32 input.
    let m = faer::Mat::<f64>::from_fn(n, n, |r, c| {
        nalgebra::try_convert::<T, f64>(a[r * n + c]).unwrap_or(f64::NAN)
    });
    let rhs = faer::Mat::<f64>::from_fn(n, 1, |r, _| {
        nalgebra::try_convert::<T, f64>(b[r]).unwrap_or(f64::NAN)
    });
    let lu = m.partial_piv_lu();
    let x = faer::linalg::solvers::Solve::solve(&lu, &rhs);
    let mut ok = true;
    for r in 0..n {
        let v = x[(r, 0)];
        ok &= v.is_finite();
        b[r] = T::from_f64(v).unwrap_or_else(T::zero);
    }
    ok
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_lu_matches_faer_on_random_systems() {
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 33) as f64 / (1u64 << 31) as f64) - 0.5
        };
        for n in [1usize, 2, 5, 38, 62] {
            let a: Vec<f64> = (0..n * n)
                .map(|i| rnd() + if i % (n + 1) == 0 { 0.1 } else { 0.0 })
                .collect();
            let b: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let mut x_hand = b.clone();
            let mut lu = a.clone();
            let mut perm = vec![0; n];
            assert!(lu_solve_in_place(&mut lu, &mut perm, &mut x_hand, n));
            let mut x_faer = b.clone();
            assert!(faer_solve(&a, &mut x_faer, n));
            for (h, f) in x_hand.iter().zip(&x_faer) {
                assert!((h - f).abs() <= 1e-9 * (1.0 + f.abs()), "n={n}: {h} vs {f}");
            }
        }
    }

    #[test]
    fn singular_matrix_is_reported() {
        let mut a = vec![1.0_f64, 2.0, 2.0, 4.0];
        let mut b = vec![1.0, 1.0];
        let mut perm = vec![0; 2];
        assert!(!lu_solve_in_place(&mut a, &mut perm, &mut b, 2));
    }
}
