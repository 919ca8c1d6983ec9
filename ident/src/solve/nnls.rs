//! Least squares under sign constraints, from the normal equations.

use nalgebra::{DMatrix, DVector};

use super::Sign;

/// Least squares from the normal equations `g β = b` with the columns marked
/// [`Sign::NonNegative`] kept ≥ 0 (Lawson–Hanson active set, on the Jacobi-scaled Gram matrix
/// with a tiny ridge so nearly collinear grids stay solvable).
pub fn nnls(g: &DMatrix<f64>, b: &DVector<f64>, signs: &[Sign]) -> DVector<f64> {
    let p = b.len();
    if p == 0 {
        return DVector::zeros(0);
    }
    let d: Vec<f64> = (0..p)
        .map(|i| {
            let v = g[(i, i)];
            if v > 0.0 {
                1.0 / v.sqrt()
            } else {
                0.0
            }
        })
        .collect();
    let gs = DMatrix::from_fn(p, p, |i, j| g[(i, j)] * d[i] * d[j]);
    let bs = DVector::from_fn(p, |i, _| b[i] * d[i]);
    let usable: Vec<bool> = d.iter().map(|v| *v > 0.0).collect();
    let constrained = |i: usize| signs.get(i) == Some(&Sign::NonNegative);
    let solve = |set: &[usize]| -> DVector<f64> {
        let m = set.len();
        let mut a = DMatrix::from_fn(m, m, |i, j| gs[(set[i], set[j])]);
        for i in 0..m {
            a[(i, i)] += 1e-10;
        }
        let rhs = DVector::from_fn(m, |i, _| bs[set[i]]);
        let mut z = DVector::zeros(p);
        let sol = match a.clone().cholesky() {
            Some(c) => c.solve(&rhs),
            None => a
                .svd(true, true)
                .solve(&rhs, 1e-12)
                .unwrap_or_else(|_| DVector::zeros(m)),
        };
        for (i, &s) in set.iter().enumerate() {
            z[s] = sol[i];
        }
        z
    };
    let mut passive: Vec<usize> = (0..p).filter(|&i| usable[i] && !constrained(i)).collect();
    let mut x = if passive.is_empty() {
        DVector::zeros(p)
    } else {
        solve(&passive)
    };
    for _ in 0..3 * p + 10 {
        let w = &bs - &gs * &x;
        let next = (0..p)
            .filter(|&i| usable[i] && constrained(i) && !passive.contains(&i))
            .max_by(|&a, &b| w[a].total_cmp(&w[b]));
        match next {
            Some(j) if w[j] > 1e-12 => passive.push(j),
            _ => break,
        }
        for _ in 0..3 * p + 10 {
            let z = solve(&passive);
            let bad: Vec<usize> = passive
                .iter()
                .copied()
                .filter(|&i| constrained(i) && z[i] <= 0.0)
                .collect();
            if bad.is_empty() {
                x = z;
                break;
            }
            let alpha = bad
                .iter()
                .map(|&i| x[i] / (x[i] - z[i]))
                .fold(f64::INFINITY, f64::min)
                .clamp(0.0, 1.0);
            x = &x + (&z - &x) * alpha;
            passive.retain(|&i| !(constrained(i) && x[i] <= 1e-14));
            for i in 0..p {
                if constrained(i) && !passive.contains(&i) {
                    x[i] = 0.0;
                }
            }
        }
    }
    DVector::from_fn(p, |i, _| x[i] * d[i])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nnls_hand_example() {
        // min |A β − y|² with A = [[1,0],[0,1],[1,1]], y = [2, −1, 1], β ≥ 0:
        // unconstrained β = (2, −1); with β ≥ 0 the optimum is β = (1.5, 0).
        let a = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
        let y = DVector::from_row_slice(&[2.0, -1.0, 1.0]);
        let g = a.transpose() * &a;
        let b = a.transpose() * &y;
        let free = nnls(&g, &b, &[Sign::Free, Sign::Free]);
        assert!(
            (free[0] - 2.0).abs() < 1e-6 && (free[1] + 1.0).abs() < 1e-6,
            "{free}"
        );
        let x = nnls(&g, &b, &[Sign::NonNegative, Sign::NonNegative]);
        assert!((x[0] - 1.5).abs() < 1e-6 && x[1].abs() < 1e-9, "{x}");
    }
}
