//! Discrete-time state space realizations.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// Discrete realization `x[k+1] = A x[k] + B u[k]`, `y[k] = C x[k] + D u[k]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StateSpace {
    /// n x n state matrix.
    pub a: DMatrix<f64>,
    /// n x r input matrix.
    pub b: DMatrix<f64>,
    /// m x n output matrix.
    pub c: DMatrix<f64>,
    /// m x r direct transmission matrix.
    pub d: DMatrix<f64>,
    /// Sample interval in seconds.
    pub dt_s: f64,
}

impl StateSpace {
    /// Builds a realization. Panics if the shapes are inconsistent (a programming error).
    pub fn new(
        a: DMatrix<f64>,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
        d: DMatrix<f64>,
        dt_s: f64,
    ) -> Self {
        let ss = Self { a, b, c, d, dt_s };
        ss.assert_shapes();
        ss
    }

    /// Panics with a clear message if the matrix shapes are inconsistent.
    pub fn assert_shapes(&self) {
        let n = self.a.nrows();
        assert!(self.a.is_square(), "StateSpace: A must be square");
        assert_eq!(
            self.b.nrows(),
            n,
            "StateSpace: B must have as many rows as A"
        );
        assert_eq!(
            self.c.ncols(),
            n,
            "StateSpace: C must have as many columns as A"
        );
        assert_eq!(
            self.d.shape(),
            (self.c.nrows(), self.b.ncols()),
            "StateSpace: D must be outputs x inputs"
        );
    }

    /// State dimension n.
    pub fn order(&self) -> usize {
        self.a.nrows()
    }

    /// Number of inputs r.
    pub fn inputs(&self) -> usize {
        self.b.ncols()
    }

    /// Number of outputs m.
    pub fn outputs(&self) -> usize {
        self.c.nrows()
    }

    /// Markov parameters `Y_0 = D`, `Y_k = C A^(k-1) B`, for k = 0..count.
    pub fn markov(&self, count: usize) -> Vec<DMatrix<f64>> {
        let mut out = Vec::with_capacity(count);
        if count == 0 {
            return out;
        }
        out.push(self.d.clone());
        let mut ab = self.b.clone();
        for _ in 1..count {
            out.push(&self.c * &ab);
            ab = &self.a * ab;
        }
        out
    }

    /// Response to `inputs` (r x N) from rest; returns outputs m x N.
    ///
    /// Each product is summed column by column from zero, in the order of nalgebra's
    /// matrix-vector product, so the samples are those of `C x + D u` and `A x + B u`
    /// evaluated with nalgebra (see the tests). Orders up to 12 (with at least one input
    /// and one output) take a loop with the state in a fixed-size array.
    pub fn simulate(&self, inputs: &DMatrix<f64>) -> DMatrix<f64> {
        assert_eq!(inputs.nrows(), self.inputs(), "simulate: input count");
        macro_rules! fixed {
            ($($order:literal)*) => {
                match self.order() {
                    $($order => return self.simulate_order::<$order>(inputs),)*
                    _ => {}
                }
            };
        }
        if self.outputs() > 0 && self.inputs() > 0 {
            fixed!(1 2 3 4 5 6 7 8 9 10 11 12);
        }
        self.simulate_any(inputs)
    }

    /// [`StateSpace::simulate`] for a state of `N` (at least one input and one output).
    fn simulate_order<const N: usize>(&self, inputs: &DMatrix<f64>) -> DMatrix<f64> {
        let (n, m, r) = (inputs.ncols(), self.outputs(), self.inputs());
        debug_assert!(self.order() == N && m > 0 && r > 0);
        // Column-major: `A` and `B` as columns of `N`, `D` as columns of `m`.
        let a = self.a.as_slice().as_chunks::<N>().0;
        let b = self.b.as_slice().as_chunks::<N>().0;
        // The rows of `C` (each output's sum over the state, in column order).
        let c_rows: Vec<[f64; N]> = (0..m)
            .map(|i| std::array::from_fn(|j| self.c[(i, j)]))
            .collect();
        let d = self.d.as_slice();
        let mut y = DMatrix::zeros(m, n);
        let mut x = [0.0; N];
        for (yk, uk) in y
            .as_mut_slice()
            .chunks_exact_mut(m)
            .zip(inputs.as_slice().chunks_exact(r))
        {
            for (i, (o, c_row)) in yk.iter_mut().zip(&c_rows).enumerate() {
                let mut cx = 0.0;
                for (&e, &xj) in c_row.iter().zip(&x) {
                    cx += e * xj;
                }
                let mut du = 0.0;
                for (l, &ul) in uk.iter().enumerate() {
                    du += d[i + l * m] * ul;
                }
                *o = cx + du;
            }
            let mut next = [0.0; N];
            for (column, &xj) in a.iter().zip(&x) {
                for (o, &e) in next.iter_mut().zip(column) {
                    *o += e * xj;
                }
            }
            let mut bu = [0.0; N];
            for (column, &ul) in b.iter().zip(uk) {
                for (o, &e) in bu.iter_mut().zip(column) {
                    *o += e * ul;
                }
            }
            for ((xi, p), q) in x.iter_mut().zip(next).zip(bu) {
                *xi = p + q;
            }
        }
        y
    }

    /// [`StateSpace::simulate`] for any shape.
    fn simulate_any(&self, inputs: &DMatrix<f64>) -> DMatrix<f64> {
        let (n, order, m, r) = (inputs.ncols(), self.order(), self.outputs(), self.inputs());
        let mut y = DMatrix::zeros(m, n);
        let mut x = vec![0.0; order];
        let mut next = vec![0.0; order];
        // Without the four allocations per sample of nalgebra's products.
        let times = |mat: &DMatrix<f64>, v: &[f64], out: &mut [f64]| {
            out.fill(0.0);
            let rows = out.len();
            if rows == 0 {
                return;
            }
            // Column-major storage: column j is the j-th chunk of `rows` values.
            for (column, &vj) in mat.as_slice().chunks_exact(rows).zip(v) {
                for (o, &a) in out.iter_mut().zip(column) {
                    *o += a * vj;
                }
            }
        };
        let mut cx = vec![0.0; m];
        let mut du = vec![0.0; m];
        let mut bu = vec![0.0; order];
        let mut u = vec![0.0; r];
        for k in 0..n {
            for (ul, &v) in u.iter_mut().zip(inputs.column(k).iter()) {
                *ul = v;
            }
            times(&self.c, &x, &mut cx);
            times(&self.d, &u, &mut du);
            for ((yi, &a), &b) in y.column_mut(k).iter_mut().zip(&cx).zip(&du) {
                *yi = a + b;
            }
            times(&self.a, &x, &mut next);
            times(&self.b, &u, &mut bu);
            for ((xi, &a), &b) in x.iter_mut().zip(&next).zip(&bu) {
                *xi = a + b;
            }
        }
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simulation_equals_the_nalgebra_recursion_bit_for_bit() {
        // Oracle: the recursion written with nalgebra's products. The fast
        // loops sum in the same order, so the samples agree exactly (up to
        // the sign of zeros, which `==` ignores). Orders 1 to 12 take the
        // fixed-size loop, 13 and the shapes without inputs or outputs the
        // general one.
        for (order, m, r) in [
            (1, 1, 1),
            (2, 2, 1),
            (4, 2, 1),
            (5, 3, 2),
            (6, 3, 1),
            (12, 4, 2),
            (13, 3, 1),
            (4, 0, 1),
            (4, 2, 0),
        ] {
            simulation_matches_nalgebra(order, m, r);
        }
    }

    fn simulation_matches_nalgebra(order: usize, m: usize, r: usize) {
        let n = 300;
        let f = |i: usize, j: usize, s: f64| ((i * 7 + j * 3) as f64 * s).sin() * 0.4;
        let sys = StateSpace {
            a: DMatrix::from_fn(order, order, |i, j| f(i, j, 0.31)),
            b: DMatrix::from_fn(order, r, |i, j| f(i, j, 0.17)),
            c: DMatrix::from_fn(m, order, |i, j| f(i, j, 0.23)),
            d: DMatrix::from_fn(m, r, |i, j| f(i, j, 0.11)),
            dt_s: 0.01,
        };
        let u = DMatrix::from_fn(r, n, |i, k| ((i + 1) as f64 * k as f64 * 0.05).cos());
        let mut expected = DMatrix::zeros(m, n);
        let mut x = nalgebra::DVector::zeros(order);
        for k in 0..n {
            let uk = u.column(k);
            expected.set_column(k, &(&sys.c * &x + &sys.d * uk));
            x = &sys.a * x + &sys.b * uk;
        }
        assert_eq!(sys.simulate(&u), expected, "order {order}, {m} x {r}");
    }

    /// Against the convolution with the Markov parameters, `y[k] = sum_j Y_j u[k - j]`
    /// (an oracle that shares no code with either loop): the orders on both sides of the
    /// fixed-size limit (11, 12, 13, 14), order 0 (`y = D u`), one and two samples, and
    /// no samples at all for every shape, including those without inputs or outputs.
    #[test]
    fn simulation_equals_the_markov_convolution_at_the_path_boundaries() {
        use crate::testutil::{normal, random_stable_system};
        use rand::SeedableRng;
        use rand::rngs::ChaCha8Rng;
        let mut rng = ChaCha8Rng::seed_from_u64(91);
        let mut worst = 0.0f64;
        for &(order, m, r) in &[
            (11usize, 2usize, 3usize),
            (12, 1, 1),
            (12, 3, 2),
            (13, 1, 1),
            (13, 2, 3),
            (14, 4, 1),
            (1, 1, 1),
        ] {
            let sys = random_stable_system(&mut rng, order, m, r, 0.9);
            for len in [0usize, 1, 2, 60] {
                let u = DMatrix::from_fn(r, len, |_, _| normal(&mut rng));
                let y = sys.simulate(&u);
                assert_eq!(y.shape(), (m, len));
                let markov = sys.markov(len);
                let mut scale = f64::MIN_POSITIVE;
                let want = DMatrix::from_fn(m, len, |i, k| {
                    let mut sum = 0.0;
                    for (j, yj) in markov.iter().enumerate().take(k + 1) {
                        for l in 0..r {
                            sum += yj[(i, l)] * u[(l, k - j)];
                            scale = scale.max((yj[(i, l)] * u[(l, k - j)]).abs());
                        }
                    }
                    sum
                });
                if len == 0 {
                    continue;
                }
                let e = (&y - &want).amax() / scale;
                worst = worst.max(e);
                // The same sums in another order (the recursion keeps partial sums in the
                // state): round-off of up to 60 r terms relative to the largest (measured
                // 2.1e-14: the state's partial sums exceed the largest single term); one
                // sample misplaced, or a state component dropped, is of order one.
                assert!(e < 1e-12, "order {order} {m} x {r}, {len} samples: {e:e}");
                if len <= 2 {
                    // The first sample is D u[0] exactly (the state starts at zero).
                    let d_u0 = &sys.d * u.column(0);
                    assert_eq!(y.column(0), d_u0.column(0), "order {order}");
                }
            }
        }
        eprintln!("worst relative difference: {worst:e}");
        // Order 0 (no state; the general loop): the direct feedthrough only.
        let sys = StateSpace::new(
            DMatrix::zeros(0, 0),
            DMatrix::zeros(0, 2),
            DMatrix::zeros(3, 0),
            DMatrix::from_fn(3, 2, |_, _| normal(&mut rng)),
            1.0,
        );
        let u = DMatrix::from_fn(2, 5, |_, _| normal(&mut rng));
        assert_eq!(sys.simulate(&u), &sys.d * &u);
        // No samples, for shapes without inputs or outputs too.
        for &(order, m, r) in &[(3usize, 0usize, 2usize), (3, 2, 0), (0, 0, 0), (13, 1, 0)] {
            let sys = StateSpace::new(
                DMatrix::from_fn(order, order, |_, _| 0.1 * normal(&mut rng)),
                DMatrix::from_fn(order, r, |_, _| normal(&mut rng)),
                DMatrix::from_fn(m, order, |_, _| normal(&mut rng)),
                DMatrix::from_fn(m, r, |_, _| normal(&mut rng)),
                1.0,
            );
            assert_eq!(sys.simulate(&DMatrix::zeros(r, 0)).shape(), (m, 0));
            // Without inputs the state stays at rest: the outputs are zero.
            assert_eq!(sys.simulate(&DMatrix::zeros(r, 4)), DMatrix::zeros(m, 4));
        }
    }
}
