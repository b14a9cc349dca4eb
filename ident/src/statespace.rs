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
    pub fn simulate(&self, inputs: &DMatrix<f64>) -> DMatrix<f64> {
        assert_eq!(inputs.nrows(), self.inputs(), "simulate: input count");
        let n = inputs.ncols();
        let mut y = DMatrix::zeros(self.outputs(), n);
        let mut x = nalgebra::DVector::zeros(self.order());
        for k in 0..n {
            let u = inputs.column(k);
            y.set_column(k, &(&self.c * &x + &self.d * u));
            x = &self.a * x + &self.b * u;
        }
        y
    }
}
