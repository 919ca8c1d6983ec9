//! The one nonlinear least-squares problem of the host's fits (the memo's models, a taxel's
//! element, the applicator's model): a model's residuals at a parameter vector, a
//! forward-difference Jacobian, and Levenberg–Marquardt from the `levenberg-marquardt` crate.

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{storage::Owned, DMatrix, DVector, Dyn};

/// What a fit minimises: the residuals of a parameter vector.
pub trait Residuals {
    /// The residuals at `theta`; `None` where they cannot be computed (the model is not one).
    fn residuals(&self, theta: &[f64]) -> Option<Vec<f64>>;
    /// The forward-difference step of parameter `c` at `theta`: large enough to move the
    /// residuals above their rounding, small enough to stay on the slope.
    fn step(&self, _theta: &[f64], _c: usize) -> f64 {
        1e-6
    }
}

impl<R: Residuals + ?Sized> Residuals for &R {
    fn residuals(&self, theta: &[f64]) -> Option<Vec<f64>> {
        (**self).residuals(theta)
    }
    fn step(&self, theta: &[f64], c: usize) -> f64 {
        (**self).step(theta, c)
    }
}

/// A model's residuals at a parameter vector, kept, with their Jacobian on demand.
pub struct Problem<R> {
    model: R,
    theta: DVector<f64>,
    residuals: Option<Vec<f64>>,
}

impl<R: Residuals> Problem<R> {
    /// `model` set at `theta`.
    pub fn new(model: R, theta: &[f64]) -> Self {
        let residuals = model.residuals(theta);
        Self::with_residuals(model, theta, residuals)
    }
    /// `model` set at `theta`, where its residuals there are already known.
    pub fn with_residuals(model: R, theta: &[f64], residuals: Option<Vec<f64>>) -> Self {
        Problem {
            model,
            theta: DVector::from_column_slice(theta),
            residuals,
        }
    }
    pub fn model(&self) -> &R {
        &self.model
    }
    pub fn theta(&self) -> &[f64] {
        self.theta.as_slice()
    }
    /// The residuals at the parameters, `None` where the model cannot be computed there.
    pub fn residuals_here(&self) -> Option<&[f64]> {
        self.residuals.as_deref()
    }
    /// The forward-difference Jacobian at the parameters (one row per residual).
    pub fn jacobian_here(&self) -> Option<DMatrix<f64>> {
        let base = self.residuals.as_ref()?;
        let theta = self.theta.as_slice();
        let mut j = DMatrix::zeros(base.len(), theta.len());
        let mut t = theta.to_vec();
        for c in 0..theta.len() {
            let h = self.model.step(theta, c);
            t[c] = theta[c] + h;
            let moved = self.model.residuals(&t)?;
            t[c] = theta[c];
            for (r, (a, b)) in moved.iter().zip(base).enumerate() {
                j[(r, c)] = (a - b) / h;
            }
        }
        Some(j)
    }
}

impl<R: Residuals> LeastSquaresProblem<f64, Dyn, Dyn> for Problem<R> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.theta.copy_from(x);
        self.residuals = self.model.residuals(x.as_slice());
    }
    fn params(&self) -> DVector<f64> {
        self.theta.clone()
    }
    fn residuals(&self) -> Option<DVector<f64>> {
        self.residuals
            .as_ref()
            .map(|r| DVector::from_column_slice(r))
    }
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        self.jacobian_here()
    }
}

/// Where Levenberg–Marquardt ended.
#[derive(Clone, Debug)]
pub struct Solution {
    pub theta: Vec<f64>,
    /// Half the sum of squared residuals there (not finite where the model failed).
    pub objective: f64,
    /// Residual evaluations spent.
    pub evaluations: usize,
}

/// Levenberg–Marquardt on `model` from `start`, with `patience` evaluations per parameter;
/// `None` where the model cannot be computed at `start`.
pub fn minimize<R: Residuals>(model: R, start: &[f64], patience: usize) -> Option<Solution> {
    let problem = Problem::new(model, start);
    problem.residuals_here()?;
    let (solved, report) = LevenbergMarquardt::new()
        .with_patience(patience)
        .minimize(problem);
    Some(Solution {
        theta: solved.theta.as_slice().to_vec(),
        objective: report.objective_function,
        evaluations: report.number_of_evaluations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y = a·exp(−b·x) sampled without noise.
    struct Decay {
        x: Vec<f64>,
        y: Vec<f64>,
    }

    impl Residuals for Decay {
        fn residuals(&self, theta: &[f64]) -> Option<Vec<f64>> {
            let [a, b] = theta else { return None };
            Some(
                self.x
                    .iter()
                    .zip(&self.y)
                    .map(|(x, y)| a * (-b * x).exp() - y)
                    .collect(),
            )
        }
    }

    #[test]
    fn an_exact_decay_is_found_from_a_distant_start() {
        let x: Vec<f64> = (0..40).map(|i| f64::from(i) * 0.1).collect();
        let y = x.iter().map(|x| 3.0 * (-0.7 * x).exp()).collect();
        let s = minimize(Decay { x, y }, &[1.0, 2.0], 100).unwrap();
        assert!((s.theta[0] - 3.0).abs() < 1e-6, "{:?}", s.theta);
        assert!((s.theta[1] - 0.7).abs() < 1e-6, "{:?}", s.theta);
        assert!(s.objective < 1e-12);
    }

    /// The decay at x = 1, to be zero.
    fn one_point() -> Decay {
        Decay {
            x: vec![1.0],
            y: vec![0.0],
        }
    }

    #[test]
    fn the_jacobian_is_the_derivative_to_the_steps_order() {
        // d/da = exp(−b x), d/db = −a x exp(−b x) at a = 2, b = 0.5, x = 1.
        let p = Problem::new(one_point(), &[2.0, 0.5]);
        let j = p.jacobian_here().unwrap();
        let e = (-0.5f64).exp();
        assert!((j[(0, 0)] - e).abs() < 1e-5, "{j}");
        assert!((j[(0, 1)] + 2.0 * e).abs() < 1e-5, "{j}");
    }

    #[test]
    fn a_model_that_cannot_be_computed_has_no_residuals_and_no_jacobian() {
        let p = Problem::new(one_point(), &[1.0]);
        assert!(p.residuals_here().is_none());
        assert!(p.jacobian_here().is_none());
        assert!(minimize(one_point(), &[1.0], 10).is_none());
    }
}
