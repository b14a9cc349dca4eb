//! Helpers shared by the unit tests: random systems and records. The analytic shear
//! frames come from the `testkit` crate.

use crate::record::Record;
use crate::statespace::StateSpace;
use nalgebra::DMatrix;
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use rand_distr::StandardNormal;

pub fn normal(rng: &mut ChaCha8Rng) -> f64 {
    rng.sample(StandardNormal)
}

/// Random stable discrete system of order `n`: eigenvalues with radii in
/// [0.5, `max_radius`] and angles in [0.1, 2.5] rad, in a random basis.
pub fn random_stable_system(
    rng: &mut ChaCha8Rng,
    n: usize,
    m: usize,
    r: usize,
    max_radius: f64,
) -> StateSpace {
    let mut a = DMatrix::<f64>::zeros(n, n);
    let mut i = 0;
    while i + 1 < n {
        let rho = 0.5 + (max_radius - 0.5) * rng.random::<f64>();
        let theta = 0.1 + 2.4 * rng.random::<f64>();
        let (c, s) = (rho * theta.cos(), rho * theta.sin());
        a[(i, i)] = c;
        a[(i, i + 1)] = -s;
        a[(i + 1, i)] = s;
        a[(i + 1, i + 1)] = c;
        i += 2;
    }
    if i < n {
        a[(i, i)] = 0.5 + (max_radius - 0.5) * rng.random::<f64>();
    }
    let t = DMatrix::<f64>::identity(n, n) + DMatrix::from_fn(n, n, |_, _| 0.3 * normal(rng));
    let ti = t.clone().try_inverse().expect("random basis is invertible");
    let a = &t * a * ti;
    let b = DMatrix::from_fn(n, r, |_, _| normal(rng));
    let c = DMatrix::from_fn(m, n, |_, _| normal(rng));
    let d = DMatrix::from_fn(m, r, |_, _| normal(rng));
    StateSpace::new(a, b, c, d, 1.0)
}

/// Records of white Gaussian input of the given lengths, response from rest.
pub fn white_noise_records(
    rng: &mut ChaCha8Rng,
    sys: &StateSpace,
    lengths: &[usize],
) -> Vec<Record> {
    lengths
        .iter()
        .map(|&len| {
            let u = DMatrix::from_fn(sys.inputs(), len, |_, _| normal(rng));
            let y = sys.simulate(&u);
            Record::new(u, y)
        })
        .collect()
}

/// Largest entry-wise difference between two sequences of matrices, relative to the
/// largest entry of `want`.
pub fn max_relative_difference(got: &[DMatrix<f64>], want: &[DMatrix<f64>]) -> f64 {
    assert!(got.len() >= want.len());
    let scale = want.iter().map(|w| w.amax()).fold(0.0, f64::max);
    got.iter()
        .zip(want)
        .map(|(g, w)| (g - w).amax())
        .fold(0.0, f64::max)
        / scale
}
